"""The exact fast path of the CP-SAT backend ``cpsat`` (refimpl.solvers.cpsat): ``solve_fast``.

The model of refimpl.solvers.cpsat_model is a bipartite matching with lexicographic costs; it is
solved exactly in Python component by component, and answered only when the optimum is unique
(otherwise FastPathDeclined, and the full CP-SAT model answers).  The event state both paths
query is refimpl.solvers.trackwise_state's.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from ..knowledge.events import EventState
from ..knowledge.event_table import EVENT_TABLE, EventType, explaining, reexplained
from ..core.hypothesis import EVENT_LEVEL, PRIORITIES, TIEBREAK_LEVEL
from ..core.spec import FrameProblem, halved_likelihood, pair_likelihood
from .common import DisjointSets, LazyTiebreak, disjoint_pairs as _disjoint
from .admissibility import Claimed, assignment_constraints, occupied, resume_constraints, start_constraints
from .cpsat_model import _cost, _explanations, _has_explanation

# ---------------------------------------------------------------------------------------
# The fast exact path
# ---------------------------------------------------------------------------------------
#
# Why the model of cpsat_model.py is a bipartite matching (docs/benchmarks.md, "The fast exact path"):
#
# * Every event variable occurs in exactly one explanation constraint, that of one action (halt(T),
#   end(T), the resumes of T, start(D)), and whether it is possible depends on the history only,
#   never on another choice of this frame.  So once the actions are fixed, each chosen action
#   independently takes its cheapest explanation: an action is an option with a fixed cost vector.
# * Every action belongs to one track, one detection, or (assign, resume) one track and one
#   detection, and each of those takes exactly one action.  With the pair actions as edges, an
#   answer is a matching of tracks to detections; every unmatched track or detection takes its
#   best "solo" action (halt / end / ignore_trk; start / ignore_det).
# * All the levels (PRIORITIES), the tie-break level 0 included, are sums over the chosen variables, so the
#   cost of an answer is a sum of per-option vectors, and minimising the levels one after another
#   is minimising that vector sum lexicographically.  Integer vectors are mapped into one Python
#   integer (base B larger than twice any level's range), which keeps the lexicographic order
#   exact; then it is a maximum-weight bipartite matching, solved per connected component.
#
# The answer is returned only when the optimum is unique: no other matching of equal weight (no
# zero-weight cycle in the residual graph), no tie between a chosen action's explanations, and
# none between an unmatched node's solo options.  A unique optimum is the answer of every exact
# solver, the full CP-SAT model included, so the fast path gives the identical Hypothesis; in
# every other case (a tie, a track with no solo action, a component larger than max_component)
# it declines and the full model answers.

FAST_PATH_MAX_COMPONENT = 400
"""Largest component (tracks + detections) the fast path solves in Python; larger: the full model."""


class FastPathDeclined(Exception):
    """The fast path cannot vouch for the full model's answer; ``reason`` says why."""

    def __init__(self, reason: str):
        super().__init__(reason)
        self.reason = reason


@dataclass
class _Option:
    """One way for a node (or a pair of nodes) to take its action: the action atom, its explaining
    event (None when it needs none), its cost vector in PRIORITIES order, and whether another
    explanation is equally cheap (then the full model may pick either)."""

    action: str
    event: str | None
    cost: tuple[int, int, int, int, int]
    tie: bool = False


def _cheapest(explanations: list[tuple[tuple[int, int], str]]) -> tuple[tuple[int, int], str, bool]:
    """The (level-1, level-0) cheapest explanation, and whether another one costs the same."""
    if len(explanations) == 1:
        return explanations[0][0], explanations[0][1], False
    best = min(explanations)
    return best[0], best[1], sum(1 for c, _ in explanations if c == best[0]) > 1


def _best_solo(options: list[_Option]) -> _Option:
    """The cheapest solo option; marked tied when another solo option has the same cost vector."""
    if len(options) == 1:
        return options[0]
    best = min(options, key=lambda o: o.cost)
    if sum(1 for o in options if o.cost == best.cost) > 1:
        return _Option(best.action, best.event, best.cost, True)
    return best


_HIGH = PRIORITIES.index(EVENT_LEVEL)
"""The levels above the event level are the first _HIGH of a cost vector; an explaining event adds
to the event level and the tie-break only (cpsat_model._cost), so above them an option's cost
does not depend on its explanation."""
assert PRIORITIES[_HIGH:] == (EVENT_LEVEL, TIEBREAK_LEVEL)
_HALT_HIGH = _cost("halt")[:_HIGH]
_IGNORE_DET_HIGH = _cost("ignore_det")[:_HIGH]
_START_HIGH = _cost("start")[:_HIGH]


def _lex_sign(a: Sequence[int], b: Sequence[int], c: Sequence[int]) -> int:
    """The sign of a + b - c (vectors, elementwise) in lexicographic order: of its first nonzero entry."""
    for x, y, z in zip(a, b, c):
        g = x + y - z
        if g:
            return 1 if g > 0 else -1
    return 0


def _matching(nl: int, nr: int, solo_l: list[tuple[int, ...]], solo_r: list[tuple[int, ...]],
              edges: list[tuple[int, int, tuple[int, ...]]]) -> list[int]:
    """The matching of least total cost vector (lexicographic) of one component, as mate[l] (-1:
    unmatched): left node l alone costs solo_l[l], right node r alone solo_r[r], edge (l, r, c)
    costs c instead of both; FastPathDeclined("tie") when it is not unique.

    One integer per cost vector, in the lexicographic order: base B larger than twice any level's
    range over this component's options (the matching compares sums within it); an edge's gain
    is what it saves over its two solos.

    A star (one node on one side, so every edge shares it: most components of a tracker's frame
    that have more than one pair) has the empty matching and one matching per edge: the optimum
    is the edge of greatest gain vector if that gain is > 0 and no other edge's equals it, none if
    every gain is < 0, else a tie; compared as vectors, lexicographically, with no integer encoding."""
    if nl == 1 or nr == 1:
        gains = [tuple(a + b - x for a, b, x in zip(solo_l[l], solo_r[r], c)) for l, r, c in edges]
        best = max(gains)
        zero = (0,) * len(best)
        if best < zero:
            return [-1] * nl
        if best == zero or gains.count(best) > 1:
            raise FastPathDeclined("tie")
        l, r, _ = edges[gains.index(best)]
        mate = [-1] * nl
        mate[l] = r
        return mate
    bound = sum(sum(map(abs, v)) for v in solo_l) + sum(sum(map(abs, v)) for v in solo_r) + \
        sum(sum(map(abs, c)) for _, _, c in edges)
    base = 2 * bound + 1

    def scalar(v: tuple[int, ...]) -> int:
        out = 0
        for c in v:
            out = out * base + c
        return out

    return _max_weight_matching(nl, nr, [(l, r, scalar(solo_l[l]) + scalar(solo_r[r]) - scalar(c))
                                         for l, r, c in edges])


def _max_weight_matching(nl: int, nr: int, edges: list[tuple[int, int, int]]) -> list[int]:
    """The maximum-weight matching of a bipartite graph (left 0..nl-1, right 0..nr-1, edges
    (l, r, gain), gains any integers, not every node matched) as mate[l] (-1: unmatched).

    Successive longest augmenting paths (Bellman-Ford over the alternating residual graph): the
    matching after k augmentations has the greatest weight among matchings of size k, and the
    weight is concave in k, so it stops at the first augmenting path of negative gain.  Raises
    FastPathDeclined("tie") when the maximum is not unique (an augmenting path of gain 0, or a
    zero-weight cycle found by _unique_optimum)."""
    adj: list[list[tuple[int, int]]] = [[] for _ in range(nl)]
    gain: dict[tuple[int, int], int] = {}
    for l, r, g in edges:
        adj[l].append((r, g))
        gain[(l, r)] = g
    mate_l, mate_r = [-1] * nl, [-1] * nr
    while True:
        dl: list[int | None] = [0 if m < 0 else None for m in mate_l]
        dr: list[int | None] = [None] * nr
        pred: list[int] = [-1] * nr
        for _ in range(nl + nr + 2):
            changed = False
            for l in range(nl):
                d = dl[l]
                if d is None:
                    continue
                for r, g in adj[l]:
                    if mate_l[l] != r and (dr[r] is None or d + g > dr[r]):
                        dr[r], pred[r], changed = d + g, l, True
            for r in range(nr):
                l2 = mate_r[r]
                if l2 >= 0 and dr[r] is not None:
                    v = dr[r] - gain[(l2, r)]
                    if dl[l2] is None or v > dl[l2]:
                        dl[l2], changed = v, True
            if not changed:
                break
        else:
            raise FastPathDeclined("internal: positive alternating cycle")
        best = -1
        for r in range(nr):
            if mate_r[r] < 0 and dr[r] is not None and (best < 0 or dr[r] > dr[best]):
                best = r
        if best < 0 or dr[best] < 0:
            break
        if dr[best] == 0:
            raise FastPathDeclined("tie")
        r, steps = best, 0
        while True:  # augment: flip the path back to its free left end
            l = pred[r]
            nxt = mate_l[l]
            mate_l[l], mate_r[r] = r, l
            steps += 1
            if nxt < 0:
                break
            if steps > nl + nr:
                raise FastPathDeclined("internal: augmenting path")
            r = nxt
    if not _unique_optimum(nl, nr, edges, mate_l, mate_r):
        raise FastPathDeclined("tie")
    return mate_l


def _unique_optimum(nl: int, nr: int, edges: list[tuple[int, int, int]], mate_l: list[int],
                    mate_r: list[int]) -> bool:
    """Whether the matching is the only one of maximum weight.

    Residual graph H on left nodes, right nodes and an end node z, arc costs = weight lost:
    l -> r adds an unmatched edge (-gain), r -> l removes a matched one (+gain), z -> l for a free l,
    l -> z for a matched l, z -> r for a matched r, r -> z for a free r.  Every alternating path
    (through z) or cycle is a cycle of H and the other way round; the matching is of maximum
    weight iff H has no negative cycle, and the only one iff H also has no zero-cost cycle, i.e.
    iff the arcs of zero reduced cost under shortest-path potentials form no cycle."""
    z = nl + nr
    arcs: list[tuple[int, int, int]] = []
    for l, r, g in edges:
        arcs.append((nl + r, l, g) if mate_l[l] == r else (l, nl + r, -g))
    arcs += [(z, l, 0) if mate_l[l] < 0 else (l, z, 0) for l in range(nl)]
    arcs += [(nl + r, z, 0) if mate_r[r] < 0 else (z, nl + r, 0) for r in range(nr)]
    n = z + 1
    dist = [0] * n
    for _ in range(n + 1):
        changed = False
        for u, v, c in arcs:
            if dist[u] + c < dist[v]:
                dist[v], changed = dist[u] + c, True
        if not changed:
            break
    else:
        raise FastPathDeclined("internal: the matching is not of maximum weight")
    out: list[list[int]] = [[] for _ in range(n)]
    indeg = [0] * n
    for u, v, c in arcs:
        if dist[u] + c == dist[v]:
            out[u].append(v)
            indeg[v] += 1
    stack = [x for x in range(n) if indeg[x] == 0]
    seen = 0
    while stack:
        x = stack.pop()
        seen += 1
        for y in out[x]:
            indeg[y] -= 1
            if indeg[y] == 0:
                stack.append(y)
    return seen == n


def _rows(top: "np.ndarray") -> list[list[int]]:
    """The column indices of each row's True entries (np.flatnonzero(top[i]).tolist() per row i),
    from one np.nonzero of the whole matrix (row-major, so each row's in increasing order)."""
    out: list[list[int]] = [[] for _ in range(top.shape[0])]
    ii, jj = np.nonzero(top)
    for i, j in zip(ii.tolist(), jj.tolist()):
        out[i].append(j)
    return out


def _inter_and_top(tracks, hide_overlap: int) -> tuple[np.ndarray, np.ndarray]:
    """(common.intersection_matrix, cpsat_model._overlapping_top_matrix) of the tracks' integer
    boxes, from one array of them, x and y taken together: the same integer arithmetic, exact."""
    b = np.asarray([t.box for t in tracks], dtype=np.int64).reshape(-1, 4)
    lo = b[:, :2]
    hi = lo + b[:, 2:]
    side = np.maximum(np.minimum(hi[:, None], hi[None]) - np.maximum(lo[:, None], lo[None]), 0)
    inter = side[..., 0] * side[..., 1]
    bottom = hi[:, 1]
    top = (100 * inter > hide_overlap * (b[:, 2] * b[:, 3])[:, None]) & (bottom[None, :] >= bottom[:, None])
    np.fill_diagonal(top, False)
    return inter, top


@dataclass
class FastAnswer:
    """What solve_fast found: the answer and how the frame fell apart."""

    actions: list[str]
    events: list[str]
    cost: tuple[tuple[int, int], ...]
    components: int
    largest: int
    """Nodes (tracks + detections) of the largest component."""


def _candidate_pairs(problem: FrameProblem, state: EventState, constants: Mapping[str, int],
                     t_index: Mapping[str, int], d_index: Mapping[str, int],
                     by_id: Mapping, iou: Mapping[tuple[str, str], int] | None = None) -> list[tuple[int, int]]:
    """The candidate pairs (common.candidate_pairs: an iou/3 fact and the pair action's integrity
    constraint) as (track index, detection index) in iou/3 order: they rank the pair actions of the
    tie-break, and an edge of the matching is one of them.  A pair at or below its action's IoU
    threshold (iou_thresh for an active track, iou_thresh_resume for a halted one, which both
    resume rules ask) fails the constraint without asking it: most overlaps in a crowd.  ``iou``:
    problem.iou_map, where the caller has made it."""
    tracks, dets = problem.tracks, problem.detections
    iou = problem.iou_map if iou is None else iou
    above = {"active": constants["iou_thresh"], "halted": constants["iou_thresh_resume"]}
    lowest = min(above.values())
    claims = Claimed(problem, constants, iou)  # [resume_claimed], computed if a resume asks
    pairs: list[tuple[int, int]] = []
    for (tid, did), v in iou.items():
        if v <= lowest:
            continue
        i, j = t_index.get(tid), d_index.get(did)
        if i is None or j is None:
            continue
        t, d = tracks[i], dets[j]
        limit = above.get(t.state)
        if limit is None or v <= limit:
            continue
        if (assignment_constraints(problem, constants, iou, t, d) if t.state == "active"
                else resume_constraints(problem, constants, iou, t, d, state, by_id, claims)):
            pairs.append((i, j))
    return pairs


class _FrameOptions:
    """Every option of one frame: each track's and detection's solo option and each candidate
    pair's (an edge).  Their costs above the event level are known at once; an option's whole cost
    vector (its explanation, the event level, the tie-break) is priced where first needed, and kept.

    Candidates are those of build_model (same rules: cpsat_model's constraint functions and the
    poss functions of refimpl.knowledge.event_table), costs those of build_model's objectives."""

    def __init__(self, problem: FrameProblem, state: EventState, constants: Mapping[str, int]):
        self.tracks, self.dets, self.iou = problem.tracks, problem.detections, problem.iou_map
        self.state, self.constants = state, constants
        inter, top = _inter_and_top(self.tracks, constants["hide_overlap"])
        t_index = {t.id: i for i, t in enumerate(self.tracks)}
        d_index = {d.id: j for j, d in enumerate(self.dets)}
        self.by_id = {t.id: t for t in self.tracks}
        self.pairs = _candidate_pairs(problem, state, constants, t_index, d_index, self.by_id, self.iou)
        tb = LazyTiebreak(problem, inter, self.pairs, t_index, d_index)  # = tiebreak_weights' numbers, computed where asked
        self.ev = tb.index  # level 0 of an explaining event: its index (common.py)
        self.w = {p: v << tb.shift for p, v in tb.pair.items()}  # level 0 of a pair action
        self.cost = {name: constants[e.cost_constant] for name, e in EVENT_TABLE.items()}
        self.top_rows = _rows(top)
        self._track_solos()
        self._detection_solos(occupied(problem, constants, state))  # [start_occupied]
        self._edges()

    def priced(self, found: list[tuple[EventType, tuple[str, ...]]]) -> list[tuple[tuple[int, int], str]]:
        return [((self.cost[spec.name], self.ev(spec.name, args)), f"{spec.name}({','.join(args)})")
                for spec, args in found]

    def explanations(self, action: str, i: int) -> list[tuple[tuple[int, int], str]]:
        """Track i's possible explanations of action, priced."""
        return self.priced(_explanations(action, i, self.tracks, self.top_rows, self.state, self.constants,
                                         self.by_id))

    # -- solo options of the tracks, and each halted track's cheapest resume explanation --------
    # An active track's halt is priced only where it is needed (``track_solo``): most tracks are
    # assigned in a one-pair component decided above the event level, where neither the
    # explanation nor its cost can change the answer (see _HIGH).  Until then every active track
    # is taken to have a halt: a relaxation of the model.  A unique optimum of the relaxation that
    # halts only tracks with an explanation is admissible in the model, so it is the model's
    # unique optimum; where it would halt a track without one, track_solo declines (the full model
    # answers: assign it, or no admissible hypothesis).
    def _track_solos(self) -> None:
        paired = {tid for tid, _ in self.iou}
        self.solo_t: list[_Option | None] = []
        self.resumable: set[int] = set()  # halted tracks with an iou/3 pair and a possible resume explanation
        self.resume_expl: dict[int, tuple[tuple[int, int], str, bool]] = {}
        for i, t in enumerate(self.tracks):
            if t.state == "active":
                self.solo_t.append(None)  # its halt, priced where needed (track_solo)
                continue
            again = self.explanations("ignore_trk", i) if reexplained(self.state, t.id) else []
            if again:  # explain_ignore: the ignore of a missing track carries its re-explanation
                (c1, c0), event, tie = _cheapest(again)
                options = [_Option(f"ignore_trk({t.id})", event, _cost("ignore_trk", event=c1, tiebreak=c0), tie)]
            else:
                options = [_Option(f"ignore_trk({t.id})", None, _cost("ignore_trk"))]
            ends = self.explanations("end", i)
            if ends:
                (c1, c0), event, tie = _cheapest(ends)
                options.append(_Option(f"end({t.id})", event, _cost("end", event=c1, tiebreak=c0), tie))
            self.solo_t.append(_best_solo(options))
            if t.id in paired and _has_explanation("resume", i, self.tracks, self.top_rows, self.state,
                                                   self.constants, self.by_id):
                self.resumable.add(i)  # priced where needed (``resume_of``), as the halts

    def track_solo(self, i: int) -> _Option:
        """Track i's solo option: a halted track's, or an active track's halt, priced now."""
        o = self.solo_t[i]
        if o is None:
            t = self.tracks[i]
            found = self.explanations("halt", i)
            if not found:
                raise FastPathDeclined("track without a solo action")  # full model: assign or nothing
            (c1, c0), event, tie = _cheapest(found)
            o = self.solo_t[i] = _Option(f"halt({t.id})", event, _cost("halt", event=c1, tiebreak=c0), tie)
        return o

    def solo_high_t(self, i: int) -> tuple[int, ...]:
        """Track i's solo cost above the event level (an active track's: its halt's)."""
        o = self.solo_t[i]
        return _HALT_HIGH if o is None else o.cost[:_HIGH]

    def resume_of(self, i: int) -> tuple[tuple[int, int], str, bool]:
        """The cheapest resume explanation of halted track i (one of ``resumable``)."""
        got = self.resume_expl.get(i)
        if got is None:
            got = self.resume_expl[i] = _cheapest(self.explanations("resume", i))
        return got

    # -- solo options of the detections (priced where needed, as the halts: ``det_of``) ----------
    def _detection_solos(self, taken) -> None:
        self.taken = taken
        self.solo_d: list[_Option | None] = []
        self.high_d: list[tuple[int, ...]] = []  # the solo's cost above the event level, known at once
        for d in self.dets:
            startable = start_constraints(self.constants, d, taken) and any(
                spec.poss(self.state, self.constants, d.id, tracks=None) for spec in explaining("start"))
            self.solo_d.append(None)
            self.high_d.append(min(_IGNORE_DET_HIGH, _START_HIGH) if startable else _IGNORE_DET_HIGH)

    def det_of(self, j: int) -> _Option:
        """Detection j's solo option, priced now."""
        o = self.solo_d[j]
        if o is None:
            d = self.dets[j]
            options = [_Option(f"ignore_det({d.id})", None, _cost("ignore_det"))]
            starts = [((self.cost[spec.name], self.ev(spec.name, (d.id,))), f"{spec.name}({d.id})")
                      for spec in explaining("start")
                      if spec.poss(self.state, self.constants, d.id, tracks=None)]
            if start_constraints(self.constants, d, self.taken) and starts:
                (c1, c0), event, tie = _cheapest(starts)
                options.append(_Option(f"start({d.id})", event, _cost("start", event=c1, tiebreak=c0), tie))
            o = self.solo_d[j] = _best_solo(options)
        return o

    # -- pair options (edges): assign for active tracks, resume for halted ones ------------------
    # Each edge's cost above the event level is known at once; a resume's explanation (its event,
    # its cost at the event level and the tie-break) is priced where needed (``edge_of``).
    def _edges(self) -> None:
        self.edges: list[tuple[int, int, tuple[int, ...]]] = []  # (track, detection, cost above the event level)
        self.edge_opt: list[_Option | None] = []
        self.ml: list[int] = []  # each edge's matching likelihood ([matching_likelihood])
        k, halving = self.constants["likelihood_conf"], self.constants["likelihood_halving"]
        for i, j in self.pairs:  # candidate pairs, in iou/3 order
            t, d = self.tracks[i], self.dets[j]
            active = t.state == "active"
            if not active and i not in self.resumable:
                continue
            tid, did = t.id, d.id
            ml = pair_likelihood(self.iou[(tid, did)], d.conf, k)
            if halving and not active:  # [stale_likelihood]
                halted = self.state.halted_at(tid)
                ml = halved_likelihood(ml, None if halted is None else self.constants["curr_time"] - halted, halving)
            self.ml.append(ml)
            if active:
                o = _Option(f"assign({tid},{did})", None, _cost("assign", ml, tiebreak=self.w[(tid, did)]))
                self.edges.append((i, j, o.cost[:_HIGH]))
                self.edge_opt.append(o)
            else:
                self.edges.append((i, j, _cost("resume", ml)[:_HIGH]))
                self.edge_opt.append(None)

    def edge_of(self, k: int) -> _Option:
        """Edge k's pair option, priced now."""
        o = self.edge_opt[k]
        if o is None:
            i, j, _ = self.edges[k]
            tid, did = self.tracks[i].id, self.dets[j].id
            (c1, c0), event, tie = self.resume_of(i)
            o = self.edge_opt[k] = _Option(
                f"resume({tid},{did})", event,
                _cost("resume", self.ml[k], event=c1, tiebreak=self.w[(tid, did)] + c0), tie)
        return o


# -- components (union-find over the edges) and their matchings ----------------------------------
def _components(frame: _FrameOptions) -> tuple[dict[int, list[int]], dict[int, int]]:
    """The frame's components: each root's edges (indices into ``frame.edges``), and each root's
    number of nodes (tracks + detections, an edgeless node a component of its own)."""
    nt, nodes = len(frame.tracks), len(frame.tracks) + len(frame.dets)
    if _disjoint(frame.edges):  # every edge a component of its own, rooted at its track (the smaller node)
        comp_edges = {e[0]: [k] for k, e in enumerate(frame.edges)}
        paired = {nt + e[1] for e in frame.edges}
        return comp_edges, {x: 2 if x in comp_edges else 1 for x in range(nodes) if x not in paired}
    sets = DisjointSets(nodes)
    sets.union_pairs(frame.edges, nt)
    # every node's root in one pass: a parent is never larger than its node (roots are the smallest
    # members), so a node's parent has its root already
    parent, root = sets.parent, list(range(nodes))
    for x in range(nodes):
        p = parent[x]
        if p != x:
            root[x] = root[p]
    comp_edges: dict[int, list[int]] = {}
    for k, e in enumerate(frame.edges):
        comp_edges.setdefault(root[e[0]], []).append(k)
    sizes: dict[int, int] = {}
    for r in root:
        sizes[r] = sizes.get(r, 0) + 1
    return comp_edges, sizes


def _one_pair(frame: _FrameOptions, k: int) -> list[int]:
    """A component of one track, one detection and one pair option, in closed form: [k] when the
    pair is taken, [] when both take their solos.

    The pair wins iff the solos' cost vector minus its own is lexicographically > 0; above the
    event level the solos' costs are known without their explanations."""
    i, j, high = frame.edges[k]
    gain = _lex_sign(frame.solo_high_t(i), frame.high_d[j], high)
    if gain == 0:
        gain = _lex_sign(frame.track_solo(i).cost, frame.det_of(j).cost, frame.edge_of(k).cost)
    if gain == 0:
        raise FastPathDeclined("tie")
    return [k] if gain > 0 else []


def _matched_edges(frame: _FrameOptions, ces: list[int]) -> list[int]:
    """The edges (indices into ``frame.edges``) of the unique optimal matching of one component.

    First above the event level, where every cost is known without an explanation: a unique
    optimum there is the unique optimum of the whole vector (every other matching is worse
    already above the event level).  Otherwise all the costs, every explanation priced."""
    edges = frame.edges
    ls = sorted({edges[k][0] for k in ces})
    rs = sorted({edges[k][1] for k in ces})
    lpos = {i: a for a, i in enumerate(ls)}
    rpos = {j: b for b, j in enumerate(rs)}
    by_pair = {(lpos[edges[k][0]], rpos[edges[k][1]]): k for k in ces}
    try:
        mate = _matching(len(ls), len(rs), [frame.solo_high_t(i) for i in ls], [frame.high_d[j] for j in rs],
                         [(lpos[edges[k][0]], rpos[edges[k][1]], edges[k][2]) for k in ces])
    except FastPathDeclined as exc:
        if exc.reason != "tie":
            raise
        mate = _matching(len(ls), len(rs), [frame.track_solo(i).cost for i in ls],
                         [frame.det_of(j).cost for j in rs],
                         [(lpos[edges[k][0]], rpos[edges[k][1]], frame.edge_of(k).cost) for k in ces])
    return [by_pair[(a, b)] for a, b in enumerate(mate) if b >= 0]


def solve_fast(problem: FrameProblem, state: EventState, constants: Mapping[str, int],
               max_component: int = FAST_PATH_MAX_COMPONENT) -> FastAnswer:
    """The unique lexicographic optimum of the model, without CP-SAT, or FastPathDeclined.

    The frame's options (``_FrameOptions``), its components, each component's matching, and
    every unmatched track and detection with its solo option."""
    frame = _FrameOptions(problem, state, constants)
    comp_edges, sizes = _components(frame)
    chosen: list[_Option] = []
    matched_t: set[int] = set()
    matched_d: set[int] = set()
    for root, ces in comp_edges.items():
        if sizes[root] > max_component:
            raise FastPathDeclined("component too large")
        for k in (_one_pair(frame, ces[0]) if len(ces) == 1 else _matched_edges(frame, ces)):
            i, j, _ = frame.edges[k]
            chosen.append(frame.edge_of(k))
            matched_t.add(i)
            matched_d.add(j)
    chosen += [frame.track_solo(i) for i in range(len(frame.tracks)) if i not in matched_t]
    chosen += [frame.det_of(j) for j in range(len(frame.dets)) if j not in matched_d]
    if any(o.tie for o in chosen):
        raise FastPathDeclined("tie")
    t = problem.time
    total = [sum(o.cost[p] for o in chosen) for p in range(len(PRIORITIES))]
    return FastAnswer(
        actions=[o.action for o in chosen],
        events=[f"occurs_at({o.event},{t})" for o in chosen if o.event is not None],
        cost=tuple(zip(PRIORITIES, total)),
        components=len(sizes),
        largest=max(sizes.values(), default=0),
    )
