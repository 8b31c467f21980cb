"""What every backend takes from one place: the frame's independent components and the
canonical tie-break (docs/model.md, "The canonical tie-break").

Independent components
----------------------
Only a pair action (assign(T, D), resume(T, D)) ties the choice of a track to the choice of a
detection, and a pair action needs an iou/3 fact and its integrity constraint (candidate_pairs).  Every other rule concerns one track or one
detection: "exactly one action" is per node, an event explains exactly one action of its first
argument, and every event's precondition reads the history and the (fixed) boxes only, never
another choice of this frame (refimpl's [start_occupied] reads a detection's iou/3 facts with the
tracks: facts, not choices; refimpl.solvers.decompose keeps such a detection and track in one
sub-problem; refimpl's [resume_claimed] reads an active track's iou/3 facts with the detections it
may be assigned, all of them in that track's component).  So the connected components of the
bipartite graph of candidate pairs (tracks and detections as nodes; a node without a pair is a
component of its own) are
independent: the answers of the frame are exactly the unions of one answer per component, and
every cost level is a sum over the components.  The lexicographic optimum of the frame is the
union of the components' optima.

The canonical tie-break (level 0)
---------------------------------
Levels 10..1 leave ties.  Level 0 makes the optimum unique on every frame:

* pair part: within each component the candidate pairs (T, D) are ranked in natural
  (T, D) order, rank 0, 1, 2, ...; a chosen assign/resume of the pair of rank q weighs 2^(E+q).
  Powers of two never collide: two different sets of pairs of one component always have
  different sums, so among the answers optimal at levels 10..1 the set of pair actions is unique.
  Given the pairs, every other track and detection takes its cheapest solo action, and the solo
  options of one node always differ at level 3 (ignore costs 10@3, end/start/halt 0@3; an active
  track has no other solo action than halt), so the actions are unique.
* explanation part: every event a track (or detection) can explain an action with has an index
  idx >= 0 among the events of its first argument: the arity-1 events in refimpl.knowledge.event_table.EVENT_NAMES
  order, then for each arity-2 event the other tracks that overlap the track's box (decreasing
  overlap, then natural order) or that its history names (natural order).  A chosen event weighs
  idx.  The events of one action have distinct indices and, given the actions, each action's
  explanation is chosen independently; so the cheapest explanation is unique.  E is the bit
  length of the largest possible sum of indices, so the explanation part never reaches the pair
  part.

Level 0 = sum of the chosen atoms' weights; it separates every two answers that tie at levels
10..1 (above).  The weights are exact Python integers; a large component can need more bits than a
solver's integers have, so a solver splits them into chunks (``chunks``): 30-bit chunks under clingo's
32-bit sums, 60-bit ones under CP-SAT's 64-bit ones, each chunk a lexicographic level of its own,
most significant first; comparing the chunks one after another is comparing the integers.  A chunk
holds at most one component's distinct powers of two per component plus the small index sums, and
the chunk width is lowered by the bit length of the number of components solved together, so no
chunk's sum can overflow.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Iterable, NamedTuple, Sequence

import numpy as np

from ..core.constants import resolve_constants
from ..knowledge.events import EventState
from ..knowledge.event_table import EFFECTS, EVENT_NAMES
from ..core.ranges import EXPLANATION_LIMIT
from ..core.spec import Box, FrameProblem, event_of, natural_key, parse_atom
from .admissibility import Claimed, assignment_constraints, resume_constraints


def intersection_matrix(boxes: Sequence[Box]) -> np.ndarray:
    """inter[i, j] = refimpl.core.geometry.intersection_area(boxes[i], boxes[j]) for integer boxes,
    all pairs at once (int64, exact: the same integer arithmetic, vectorised)."""
    b = np.asarray(boxes, dtype=np.int64).reshape(-1, 4)
    x1, y1 = b[:, 0], b[:, 1]
    x2, y2 = x1 + b[:, 2], y1 + b[:, 3]
    iw = np.minimum(x2[:, None], x2[None, :]) - np.maximum(x1[:, None], x1[None, :])
    ih = np.minimum(y2[:, None], y2[None, :]) - np.maximum(y1[:, None], y1[None, :])
    return np.maximum(iw, 0) * np.maximum(ih, 0)


@lru_cache(maxsize=1 << 16)
def _natural_key(ident: str) -> tuple:
    """spec.natural_key, memoised: the same ids come back frame after frame."""
    return natural_key(ident)


# ---------------------------------------------------------------------------------------
# Components
# ---------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Component:
    tracks: tuple[str, ...]
    """Track ids in problem order."""
    detections: tuple[str, ...]
    """Detection ids in problem order."""
    pairs: tuple[tuple[str, str], ...]
    """The iou/3 pairs inside, in natural (trk, det) order."""


def candidate_pairs(problem: FrameProblem, state: EventState | None = None) -> list[tuple[str, str]]:
    """The (trk, det) pairs that can take a pair action: an iou/3 fact and the assign or resume
    integrity constraint (whether a resume can be explained is not asked: a superset is safe).
    ``state``: the event state the resumes read (default: the problem's history)."""
    constants = resolve_constants(problem)
    iou = problem.iou_map
    tracks = {t.id: t for t in problem.tracks}
    dets = {d.id: d for d in problem.detections}
    out = []
    claims = Claimed(problem, constants, iou)  # [resume_claimed], computed if a resume asks
    for t, d, v in problem.iou:
        trk, det = tracks.get(t), dets.get(d)
        if trk is None or det is None:
            continue
        if trk.state == "active":
            ok = assignment_constraints(problem, constants, iou, trk, det)
        else:
            if state is None and v > constants["iou_thresh_resume"]:
                # the event state, built once where a resume may need it (anticipated_unhide, halted_at)
                state = EventState.from_problem(problem)
            ok = resume_constraints(problem, constants, iou, trk, det, state, tracks, claims)
        if ok:
            out.append((t, d))
    return out


def disjoint_pairs(pairs) -> bool:
    """Whether no two of the (left, right, ...) pairs share their left or their right node: then
    every pair is a component of the pair graph on its own (the usual frame of a tracker)."""
    lefts = {p[0] for p in pairs}
    return len(lefts) == len(pairs) and len({p[1] for p in pairs}) == len(pairs)


class DisjointSets:
    """Union-find over 0..n-1 (path halving); the root of a set is its smallest member."""

    def __init__(self, n: int):
        self.parent = list(range(n))

    def find(self, x: int) -> int:
        parent = self.parent
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    def union(self, a: int, b: int) -> None:
        a, b = self.find(a), self.find(b)
        if a != b:
            self.parent[max(a, b)] = min(a, b)

    def union_pairs(self, pairs, offset: int) -> None:
        """``union(p[0], offset + p[1])`` for every pair p, in order (the same sets and roots), the
        finds written out in one loop (a tracker's frame has a few dozen pairs, a crowd's thousands)."""
        parent = self.parent
        for p in pairs:
            a, b = p[0], offset + p[1]
            while parent[a] != a:
                parent[a] = parent[parent[a]]
                a = parent[a]
            while parent[b] != b:
                parent[b] = parent[parent[b]]
                b = parent[b]
            if a < b:
                parent[b] = a
            elif b < a:
                parent[a] = b


def components(problem: FrameProblem, state: EventState | None = None) -> list[Component]:
    """The independent components of the frame (module docstring), in the order of their first
    node (tracks before detections, problem order); ``state`` as candidate_pairs'."""
    tracks, dets = problem.tracks, problem.detections
    nt = len(tracks)
    t_index = {t.id: i for i, t in enumerate(tracks)}
    d_index = {d.id: nt + j for j, d in enumerate(dets)}
    sets = DisjointSets(nt + len(dets))
    find = sets.find

    pairs = candidate_pairs(problem, state)
    for t, d in pairs:
        sets.union(t_index[t], d_index[d])
    groups: dict[int, list[int]] = {}
    for x in range(nt + len(dets)):
        groups.setdefault(find(x), []).append(x)
    by_root: dict[int, list[tuple[str, str]]] = {}
    for t, d in pairs:
        by_root.setdefault(find(t_index[t]), []).append((t, d))
    nat = _natural_key
    out = []
    for root in sorted(groups):
        members = groups[root]
        out.append(Component(
            tuple(tracks[x].id for x in members if x < nt),
            tuple(dets[x - nt].id for x in members if x >= nt),
            tuple(sorted(by_root.get(root, ()), key=lambda p: (nat(p[0]), nat(p[1])))),
        ))
    return out


# ---------------------------------------------------------------------------------------
# Tie-break weights
# ---------------------------------------------------------------------------------------

class TiebreakWeights(NamedTuple):
    pair: dict[tuple[str, str], int]
    """2^q for the pair (trk, det) of rank q in its component (assign or resume)."""
    event: dict[str, int]
    """idx of an event term ('hides_behind(trk_1,trk_2)') among its first argument's events."""
    component: dict[str, int]
    """node id (track or detection) -> index of its component in ``components(problem)``."""
    shift: int
    """E: level 0 = (sum of chosen pair weights) * 2^E + (sum of chosen event indices)."""


def _event_candidates(problem: FrameProblem, inter: np.ndarray | None = None) -> dict[str, list[str]]:
    """first argument -> its weighted events in idx order (module docstring)."""
    tracks = problem.tracks
    nat = _natural_key
    ids = {t.id for t in tracks}
    unary = [n for n in EVENT_NAMES if EFFECTS[n][0] == 1]
    binary = [n for n in EVENT_NAMES if EFFECTS[n][0] == 2]
    named: dict[str, set[str]] = {}
    for h in problem.history:
        args = [str(a) for a in h.event.args]
        if len(args) >= 2 and args[0] in ids:
            named.setdefault(args[0], set()).update(a for a in args[1:] if a in ids and a != args[0])
    if inter is None:
        inter = intersection_matrix([t.box for t in tracks])
    out: dict[str, list[str]] = {}
    for i, t in enumerate(tracks):
        over = [j for j in np.flatnonzero(inter[i]).tolist() if j != i]
        over.sort(key=lambda j: (-int(inter[i, j]), nat(tracks[j].id)))
        others = [tracks[j].id for j in over]
        seen = set(others)
        others += sorted((x for x in named.get(t.id, ()) if x not in seen), key=nat)
        out[t.id] = [f"{n}({t.id})" for n in unary] + [f"{n}({t.id},{o})" for n in binary for o in others]
    for d in problem.detections:
        out[d.id] = [f"{n}({d.id})" for n in unary]
    return out


def tiebreak_weights(problem: FrameProblem, inter: np.ndarray | None = None,
                     state: EventState | None = None) -> TiebreakWeights:
    """The level-0 weights of every pair and event of the frame (module docstring).

    ``inter`` optionally passes ``intersection_matrix`` of the track boxes (in problem.tracks
    order) when the caller has it already.  Without it the weights of the last two problems are
    memoised (read them, never change them): one solve prices its problem's tie-break several
    times (clingo's range check, the fallback's check, the answer's level 0), 0.44 s each on a
    400-track crowd, time its time limit must cover.  ``state``: the event state the candidate
    pairs' resumes read, where a solver is given one (default: the problem's history)."""
    if inter is None and state is None:
        return _tiebreak_weights(problem)
    return _compute_tiebreak_weights(problem, inter, state)


@lru_cache(maxsize=2)
def _tiebreak_weights(problem: FrameProblem) -> TiebreakWeights:
    return _compute_tiebreak_weights(problem, None)


def _compute_tiebreak_weights(problem: FrameProblem, inter: np.ndarray | None,
                              state: EventState | None = None) -> TiebreakWeights:
    comps = components(problem, state)
    cands = _event_candidates(problem, inter)
    event = {e: idx for evs in cands.values() for idx, e in enumerate(evs)}
    # the largest possible index sum: a track or detection takes one action, explained by at
    # most one event, so at most its largest index
    bound = sum(len(evs) - 1 for evs in cands.values() if evs)
    pair: dict[tuple[str, str], int] = {}
    component: dict[str, int] = {}
    for c, comp in enumerate(comps):
        for q, p in enumerate(comp.pairs):
            pair[p] = 1 << q
        for x in comp.tracks + comp.detections:
            component[x] = c
    return TiebreakWeights(pair, event, component, max(bound, 0).bit_length())


_UNARY_AT = {n: k for k, n in enumerate(n for n in EVENT_NAMES if EFFECTS[n][0] == 1)}
_BINARY_AT = {n: k for k, n in enumerate(n for n in EVENT_NAMES if EFFECTS[n][0] == 2)}


class LazyTiebreak:
    """The numbers of :func:`tiebreak_weights` that the fast path reads, computed where asked: the
    index of one event (``index``, ``TiebreakWeights.event.get(term, 0)``), E (``shift``) and the
    pair weights (``pair``), without spelling out every possible event of the frame.

    The same definitions (module docstring): an event's index is its position in its first
    argument's list, the arity-1 events in EVENT_NAMES order and then each arity-2 event with the
    other tracks in ``_event_candidates``' order; E counts len(list) - 1 per track and detection.
    ``pairs``: the candidate pairs (:func:`candidate_pairs`) as (track index, detection index)
    in problem order, which the caller has computed already; their weights are 2^rank in their
    component of the candidate-pair graph, as in ``components``."""

    def __init__(self, problem: FrameProblem, inter: np.ndarray, pairs: Sequence[tuple[int, int]],
                 t_index: dict[str, int] | None = None, d_index: dict[str, int] | None = None):
        """``t_index``, ``d_index``: {id: position} of the problem's tracks and detections, where the
        caller has them already."""
        tracks, dets = problem.tracks, problem.detections
        self._tracks, self._inter = tracks, inter
        self._t_index = {t.id: i for i, t in enumerate(tracks)} if t_index is None else t_index
        self._d_ids = {d.id for d in dets} if d_index is None else d_index  # only ``in`` is asked
        ids = self._t_index
        named: dict[str, set[str]] = {}
        for h in problem.history:
            event_args = h.event.args
            if len(event_args) < 2:  # only pair events name another track
                continue
            args = [a.name if not a.args else str(a) for a in event_args]  # str(Term) of a constant is its name
            if args[0] in ids:
                named.setdefault(args[0], set()).update(a for a in args[1:] if a in ids and a != args[0])
        self._named = named
        self._others: dict[int, list[str]] = {}
        nu, nb = len(_UNARY_AT), len(_BINARY_AT)
        # E = sum over detections of (nu - 1) and over tracks of (nu + nb * others - 1), others the
        # overlapping other tracks (inter[i, i] is the box's own area, > 0) and those named in the
        # history and not overlapping now: integers, summed in any order
        nt = len(tracks)
        nonzero = inter != 0
        others = int(nonzero.sum()) - int(nonzero.trace()) if nt else 0
        value = inter.item  # inter[i, j] as a Python int (of the few pairs named in the history)
        for trk, extra in named.items():
            i = ids[trk]
            others += sum(1 for x in extra if not value(i, ids[x]))
        bound = len(dets) * (nu - 1) + nt * (nu - 1) + nb * others
        self.shift = max(bound, 0).bit_length()
        self.pair: dict[tuple[str, str], int] = {}
        if disjoint_pairs(pairs):  # every pair alone in its component: rank 0, weight 1
            for i, j in pairs:
                self.pair[(tracks[i].id, dets[j].id)] = 1
            return
        sets = DisjointSets(nt + len(dets))
        sets.union_pairs(pairs, nt)
        groups: dict[int, list[tuple[str, str]]] = {}
        for i, j in pairs:
            groups.setdefault(sets.find(i), []).append((tracks[i].id, dets[j].id))
        nat = _natural_key
        for group in groups.values():
            group.sort(key=lambda p: (nat(p[0]), nat(p[1])))
            for q, p in enumerate(group):
                self.pair[p] = 1 << q

    def _others_of(self, i: int) -> list[str]:
        got = self._others.get(i)
        if got is None:  # _event_candidates' order
            tracks, nat = self._tracks, _natural_key
            row = self._inter[i].tolist()  # Python ints: the same values as int(inter[i, j])
            over = [j for j, v in enumerate(row) if v and j != i]
            over.sort(key=lambda j: (-row[j], nat(tracks[j].id)))
            got = [tracks[j].id for j in over]
            seen = set(got)
            got += sorted((x for x in self._named.get(tracks[i].id, ()) if x not in seen), key=nat)
            self._others[i] = got
        return got

    def index(self, name: str, args: Sequence[str]) -> int:
        """The index of the event name(args), 0 where tiebreak_weights has no such event."""
        if len(args) == 1:
            k = _UNARY_AT.get(name)
            return k if k is not None and (args[0] in self._t_index or args[0] in self._d_ids) else 0
        if len(args) == 2:
            b, i = _BINARY_AT.get(name), self._t_index.get(args[0])
            if b is None or i is None:
                return 0
            others = self._others_of(i)
            try:
                return len(_UNARY_AT) + b * len(others) + others.index(args[1])
            except ValueError:
                return 0
        return 0


def pair_atom(atom: str) -> tuple[str, str] | None:
    """(trk, det) of an assign/resume atom, else None."""
    term = parse_atom(atom)
    if term.name in ("assign", "resume") and len(term.args) == 2:
        t, d = term.arg_names
        return t, d
    return None


def event_term(atom: str) -> str:
    """The event of 'occurs_at(E,T)' (or E itself), as text."""
    return str(event_of(atom))


def tiebreak_level(problem: FrameProblem, actions: Iterable[str], events: Iterable[str],
                   weights: TiebreakWeights | None = None) -> int:
    """Level 0 of an answer: (sum of its pairs' weights) * 2^E + (sum of its events' indices)."""
    w = weights or tiebreak_weights(problem)
    pairs = sum(w.pair.get(p, 0) for p in map(pair_atom, actions) if p is not None)
    return (pairs << w.shift) + sum(w.event.get(event_term(a), 0) for a in events)




def tiebreak_levels(w: TiebreakWeights, word_bits: int) -> tuple[list[dict[tuple[str, str], int]], dict[str, int]]:
    """The tie-break as solver levels, most significant first: the pair part split into chunks of
    ``chunk_width`` bits (one dict (trk, det) -> coefficient per chunk), then the explanation part
    (event -> index).  Each chunk holds distinct powers of two of each component, < 2^width per
    component, so a chunk's sum over all components stays below 2^(word_bits - 1)."""
    parts = len(set(w.component.values()))
    width = max(1, word_bits - 1 - max(parts, 1).bit_length())
    levels: dict[int, dict[tuple[str, str], int]] = {}
    for p, v in w.pair.items():
        q = v.bit_length() - 1
        levels.setdefault(q // width, {})[p] = 1 << (q % width)
    if (1 << w.shift) > EXPLANATION_LIMIT:
        raise OverflowError("the frame has too many possible events for the tie-break's explanation level")
    return [levels.get(j, {}) for j in range(max(levels, default=-1), -1, -1)], dict(w.event)


def tiebreak_facts(problem: FrameProblem) -> str:
    """The tie-break as ASP facts for the clingo backend (model/optimisation.lp): chunk levels of
    the pair part as tiebreak_pair(T, D, P, W) at priorities 0, -1, ... (most significant
    first), the explanation part as tiebreak_event(E, P, Idx) one priority below."""
    pair_levels, event = tiebreak_levels(tiebreak_weights(problem), 31)
    lines = [f"tiebreak_pair({t},{d},{-j},{c})." for j, lev in enumerate(pair_levels) for (t, d), c in lev.items()]
    low = -len(pair_levels)
    lines += [f"tiebreak_event({e},{low},{v})." for e, v in event.items() if v]
    return "\n".join(lines) + ("\n" if lines else "")
