"""The tie-break's pair part of the CP-SAT model, once levels 10..1 are solved: its minimum by
alternating cycles of zero cost instead of one CP-SAT solve per chunk (docs/model.md 2.7, step 4).

The model build_model makes is a bipartite matching with lexicographic costs (the argument is
refimpl/solvers/fast_path.py's): every constraint is "exactly one action per track / per
detection" or an explanation rule "sum(events) == sum(actions)" whose actions all belong to one
node; a pair action (assign, resume) belongs to one track and one detection, every other action to
one node.  So once the actions are fixed each explained action takes its cheapest explanation, an
unmatched node its cheapest solo action, and levels 10..1 of an answer are those of its matching M
of pair actions: sum of the pairs' cost vectors plus the solos' of the nodes M leaves out.
``pair_structure`` reads this structure from the AbductionModel (the lists build_model records)
and checks it, or returns None (then solve_lexicographic solves the chunks as before).

Given a solution optimal at levels 10..1 (CP-SAT's), with matching M, the others are found in the
residual graph H (fast_path._unique_optimum's): tracks, detections and an end node z; an unmatched
pair is an arc track -> detection costing what it adds, a matched one detection -> track; z -> a
free track, a matched track -> z (only with a solo action), z -> a matched detection (only with
one), a free detection -> z.  Alternating paths and cycles are the cycles of H.  Another matching
M' is optimal iff M xor M' is a union of cycles of H of cost 0 (each has cost >= 0, as M is
optimal, and they add up to 0).  With potentials d (shortest distances in H, which exist as M is
optimal: ``_potentials`` fails otherwise) every arc has reduced cost >= 0, so a cycle of cost 0
uses only *tight* arcs (reduced cost 0); flipping one keeps the potentials valid (a tight arc
reversed is tight).

The tie-break weighs the pairs 2^q, distinct within a component (checked), and components are
independent (a cycle of H stays within one component, z aside).  So its minimum is the greedy in
decreasing q (``_greedy``): a pair not in M is left out for good; a pair in M is left out iff a
cycle of tight arcs through its arc avoids every pair decided before (a path of tight arcs from
its track to its detection: one breadth-first search), else it is kept for good.  The result is
the same set of pairs as comparing every chunk with CP-SAT, proven by the potentials; the answer
it gives (``PairChoice.values``: every action and event of the model) is checked to have the
solution's values on levels 10..1.
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass
from typing import Mapping, Sequence

from ..core.hypothesis import PRIORITIES, TIEBREAK_LEVEL
from .cpsat_model import EXPLANATION, PAIR_ORDER

UPPER = tuple(p for p in PRIORITIES if p != TIEBREAK_LEVEL)
"""Levels 10..1: the ones fixed before the pair part."""

Vector = tuple[int, ...]


@dataclass
class PairStructure:
    """The model as a matching (module docstring); nodes are track l (0..nl-1), detection r (0..nr-1)."""

    nl: int
    nr: int
    edges: list[tuple[int, int, int, int, Vector]]
    """Pair actions that can be in an optimum: (track, detection, var index, tie-break weight 2^q,
    cost vector on levels 10..1 with the cheapest explanation)."""
    solo_l: list[tuple[int, Vector] | None]
    """Per track: its cheapest solo action (var index, cost vector), None if it has none."""
    solo_r: list[tuple[int, Vector] | None]
    explanation: dict[int, list[tuple[Vector, int]]]
    """Explained action var index -> [(cost vector, event var index)] of its possible events."""
    pair_vars: list[int]
    """Every pair action's var index (those the certificate fixed to 0 too)."""
    all_vars: list[int]


def _vector(costs: Mapping[int, list[int]], index: int) -> Vector:
    return tuple(costs[index]) if index in costs else (0,) * len(UPPER)


def _add(a: Vector, b: Vector) -> Vector:
    return tuple(x + y for x, y in zip(a, b))


def _upper_costs(am) -> dict[int, list[int]] | None:
    """var index -> its coefficients on levels 10..1; None if an objective other than those, the
    tie-break's two parts and PAIR_ORDER has terms."""
    if set(am.objectives) - set(UPPER) - {TIEBREAK_LEVEL, EXPLANATION, PAIR_ORDER}:
        return None
    costs: dict[int, list[int]] = {}
    for k, p in enumerate(UPPER):
        for c, v in am.objectives.get(p, []):
            costs.setdefault(v.index, [0] * len(UPPER))[k] += c
    return costs


def _nodes(am) -> tuple[dict[int, int], dict[int, int]] | None:
    """var index -> its track, -> its detection; None if an action is in two groups of one side."""
    of_l: dict[int, int] = {}
    of_r: dict[int, int] = {}
    for side, groups in ((of_l, am.track_actions), (of_r, am.det_actions)):
        for node, group in enumerate(groups):
            for v in group:
                if v.index in side:
                    return None
                side[v.index] = node
    return of_l, of_r


def _explanations(am, costs, of_l, of_r) -> dict[int, list[tuple[Vector, int]]] | None:
    """Explained action -> its priced events; None unless every rule's actions are one node's (a
    pair action is its track's), no action or event is in two rules and every rule has events."""
    out: dict[int, list[tuple[Vector, int]]] = {}
    seen: set[int] = set()
    for actions, events in am.explained:
        owners = {("l", of_l[v.index]) if v.index in of_l else ("r", of_r.get(v.index)) for v in actions}
        if len(owners) != 1 or None in {o[1] for o in owners} or not events or any(v.index in out for v in actions):
            return None
        priced = [(_vector(costs, e.index), e.index) for e in events]
        if any(e in seen for _, e in priced):
            return None
        seen.update(e for _, e in priced)
        for v in actions:
            out[v.index] = priced
    return out


def pair_structure(am) -> PairStructure | None:
    """The model's matching structure (module docstring), or None where the model is not one."""
    if am.built_constraints != len(am.track_actions) + len(am.det_actions) + len(am.explained):
        return None  # build_model added a constraint these lists do not describe
    costs = _upper_costs(am)
    found = _nodes(am)
    if costs is None or found is None:
        return None
    of_l, of_r = found
    actions = {v.index for v in am.actions.values()}
    events = {v.index for v in am.events.values()}
    if set(of_l) | set(of_r) != actions or set(costs) - actions - events:
        return None
    expl = _explanations(am, costs, of_l, of_r)
    if expl is None or {e for pr in expl.values() for _, e in pr} != events:
        return None

    def option(index: int) -> Vector:
        own = _vector(costs, index)
        return _add(own, min(expl[index])[0]) if index in expl else own

    weight = {v.index: c for c, v in am.objectives.get(TIEBREAK_LEVEL, [])}
    pairs = sorted(set(of_l) & set(of_r))
    if len(weight) != len(am.objectives.get(TIEBREAK_LEVEL, [])) or set(weight) != set(pairs) or any(
            c <= 0 or c & (c - 1) for c in weight.values()):
        return None
    kept = {v.index for _, v in (am.objectives.get(PAIR_ORDER) or am.objectives.get(TIEBREAK_LEVEL, []))}
    edges = [(of_l[i], of_r[i], i, weight[i], option(i)) for i in pairs if i in kept]

    def solos(groups) -> list[tuple[int, Vector] | None]:
        out = []
        for group in groups:
            options = [(option(v.index), v.index) for v in group if v.index not in weight]
            out.append(None if not options else (min(options)[1], min(options)[0]))
        return out

    return PairStructure(len(am.track_actions), len(am.det_actions), edges, solos(am.track_actions),
                         solos(am.det_actions), expl, pairs, sorted(actions | events))


@dataclass
class PairChoice:
    values: dict[int, int] | None
    """Every var index of the model -> 0/1: the minimum of the pair part with the cheapest solo
    actions and explanations; None when out of time."""


class _Residual:
    """H (module docstring) with integer costs: each cost vector as one integer whose order is the
    lexicographic one (base larger than twice any sum that is compared)."""

    def __init__(self, st: PairStructure, mate_l: list[int], mate_r: list[int], edge_at: dict[tuple[int, int], int]):
        self.st, self.mate_l, self.mate_r, self.edge_at = st, mate_l, mate_r, edge_at
        zero = (0,) * len(UPPER)
        sl = [zero if s is None else s[1] for s in st.solo_l]
        sr = [zero if s is None else s[1] for s in st.solo_r]
        bound = [1] * len(UPPER)
        gains = []
        for l, r, _, _, c in st.edges:
            g = tuple(a + b - x for a, b, x in zip(sl[l], sr[r], c))
            gains.append(g)
            bound = [b + abs(x) for b, x in zip(bound, g)]
        base = 8 * max(bound) + 1

        def scalar(v: Vector) -> int:
            out = 0
            for x in v:
                out = out * base + x
            return out

        self.gain = [scalar(g) for g in gains]
        self.z = st.nl + st.nr

    def arcs(self) -> list[tuple[int, int, int]]:
        """Every arc of H as (tail, head, cost); detections at nl + r."""
        st, nl, z = self.st, self.st.nl, self.z
        out = []
        for k, (l, r, _, _, _) in enumerate(st.edges):
            g = self.gain[k]
            out.append((nl + r, l, g) if self.mate_l[l] == r else (l, nl + r, -g))
        for l in range(nl):
            if self.mate_l[l] < 0:
                out.append((z, l, 0))
            elif st.solo_l[l] is not None:
                out.append((l, z, 0))
        for r in range(st.nr):
            if self.mate_r[r] < 0:
                out.append((nl + r, z, 0))
            elif st.solo_r[r] is not None:
                out.append((z, nl + r, 0))
        return out


def _potentials(h: _Residual) -> list[int] | None:
    """Shortest distances in H from a virtual source to every node (queue-based Bellman-Ford);
    None if H has a negative cycle (the matching was not optimal)."""
    n = h.z + 1
    adj: list[list[tuple[int, int]]] = [[] for _ in range(n)]
    for u, v, c in h.arcs():
        adj[u].append((v, c))
    dist = [0] * n
    queued = [True] * n
    count = [0] * n
    queue = deque(range(n))
    while queue:
        u = queue.popleft()
        queued[u] = False
        du = dist[u]
        for v, c in adj[u]:
            if du + c < dist[v]:
                dist[v] = du + c
                if not queued[v]:
                    count[v] += 1
                    if count[v] > n:
                        return None
                    queued[v] = True
                    queue.append(v)
    return dist


def _answer(st: PairStructure, mate_l: list[int], edge_at: dict[tuple[int, int], int]) -> dict[int, int] | None:
    """Every var of the model for the matching: its pairs, every other node's cheapest solo action,
    each taken action's cheapest explanation; None if a node left out has no solo action."""
    values = dict.fromkeys(st.all_vars, 0)
    taken = [st.edges[edge_at[(l, r)]][2] for l, r in enumerate(mate_l) if r >= 0]
    matched_r = set(r for r in mate_l if r >= 0)
    for solos, free in ((st.solo_l, [l for l, r in enumerate(mate_l) if r < 0]),
                        (st.solo_r, [r for r in range(st.nr) if r not in matched_r])):
        for node in free:
            if solos[node] is None:
                return None
            taken.append(solos[node][0])
    for i in taken:
        values[i] = 1
        if i in st.explanation:
            values[min(st.explanation[i])[1]] = 1
    return values


def lexmin_pairs(st: PairStructure, solution: Mapping[int, int], deadline: float | None) -> PairChoice | None:
    """The minimum of the pair part among the optima of levels 10..1, from ``solution`` (one of
    them), as a whole answer (module docstring); PairChoice(None) when the deadline passes first;
    None where the solution is not a matching of the structure's pairs or not optimal (then the
    caller solves the chunks)."""
    mate_l, mate_r = [-1] * st.nl, [-1] * st.nr
    edge_at: dict[tuple[int, int], int] = {}
    kept = set()
    for k, (l, r, i, _, _) in enumerate(st.edges):
        if (l, r) in edge_at:
            return None
        edge_at[(l, r)] = k
        kept.add(i)
        if solution[i]:
            if mate_l[l] >= 0 or mate_r[r] >= 0:
                return None
            mate_l[l], mate_r[r] = r, l
    if any(solution[i] for i in st.pair_vars if i not in kept) or not _distinct_in_components(st):
        return None
    h = _Residual(st, mate_l, mate_r, edge_at)
    dist = _potentials(h)
    if dist is None:
        return None
    if not _Greedy(h, dist).run(deadline):
        return PairChoice(None)
    values = _answer(st, mate_l, edge_at)
    return None if values is None else PairChoice(values)


def _distinct_in_components(st: PairStructure) -> bool:
    """Whether the tie-break weights are distinct within every component of the pairs."""
    parent = list(range(st.nl + st.nr))

    def find(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for l, r, _, _, _ in st.edges:
        parent[find(l)] = find(st.nl + r)
    seen = {(find(l), w) for l, _, _, w, _ in st.edges}
    return len(seen) == len(st.edges)


class _Greedy:
    """The greedy of the module docstring over H's tight arcs; it changes h.mate_l / h.mate_r."""

    def __init__(self, h: _Residual, dist: list[int]):
        st, nl = h.st, h.st.nl
        self.h, self.nl, self.z = h, nl, h.z
        self.tight = [dist[l] - dist[nl + r] == h.gain[k] for k, (l, r, _, _, _) in enumerate(st.edges)]
        self.adj: list[list[tuple[int, int]]] = [[] for _ in range(nl)]
        for k, (l, r, _, _, _) in enumerate(st.edges):
            if self.tight[k]:
                self.adj[l].append((r, k))
        dz = dist[h.z]
        self.z_tracks = [l for l in range(nl) if dist[l] == dz]
        self.z_dets = [r for r in range(st.nr) if dist[nl + r] == dz]
        self.z_track_set, self.z_det_set = set(self.z_tracks), set(self.z_dets)
        self.state = [0] * len(st.edges)  # 0 open, 1 kept, 2 left out
        self.stamp = [0] * (h.z + 1)
        self.round = 0

    def run(self, deadline: float | None) -> bool:
        """Decide every pair, most significant first; False when the deadline passed first."""
        h, edges = self.h, self.h.st.edges
        for n, k in enumerate(sorted(range(len(edges)), key=lambda k: edges[k][3], reverse=True)):
            if deadline is not None and n % 64 == 0 and time.perf_counter() > deadline:
                return False
            l, r = edges[k][0], edges[k][1]
            if h.mate_l[l] != r:
                self.state[k] = 2
            elif self.tight[k] and self._leave_out(l, r, k):
                self.state[k] = 2
            else:
                self.state[k] = 1
        return True

    def _next(self, u: int, k0: int) -> list[tuple[int, int]]:
        """The open tight arcs out of node u, as (head, pair index or -1 for a z arc)."""
        h, nl, z = self.h, self.nl, self.z
        st = h.st
        if u < nl:
            out = [(nl + r, k) for r, k in self.adj[u] if self.state[k] == 0 and h.mate_l[u] != r]
            if h.mate_l[u] >= 0 and st.solo_l[u] is not None and u in self.z_track_set:
                out.append((z, -1))
            return out
        if u < z:
            r = u - nl
            l2 = h.mate_r[r]
            if l2 < 0:
                return [(z, -1)] if r in self.z_det_set else []
            k = h.edge_at[(l2, r)]
            return [(l2, k)] if k != k0 and self.tight[k] and self.state[k] == 0 else []
        return [(l, -1) for l in self.z_tracks if h.mate_l[l] < 0] + [
            (nl + r, -1) for r in self.z_dets if h.mate_r[r] >= 0 and st.solo_r[r] is not None]

    def _leave_out(self, l0: int, r0: int, k0: int) -> bool:
        """Whether a cycle of open tight arcs runs through matched pair k0 = (l0, r0); if so it is
        flipped (k0 leaves the matching)."""
        self.round += 1
        stamp, mark = self.stamp, self.round
        target = self.nl + r0
        prev: dict[int, tuple[int, int]] = {}
        stamp[l0] = mark
        queue = deque([l0])
        while queue:
            u = queue.popleft()
            for v, k in self._next(u, k0):
                if stamp[v] == mark:
                    continue
                stamp[v] = mark
                prev[v] = (u, k)
                if v == target:
                    self._flip(prev, l0, target, k0)
                    return True
                queue.append(v)
        return False

    def _flip(self, prev: dict[int, tuple[int, int]], l0: int, target: int, k0: int) -> None:
        """M xor the cycle: the path l0 -> ... -> target in ``prev``, then target -> l0 (pair k0)."""
        h, nl = self.h, self.nl
        edges = h.st.edges
        added, removed = [], [k0]
        v = target
        while v != l0:
            u, k = prev[v]
            if k >= 0:
                (added if u < nl else removed).append(k)
            v = u
        for k in removed:
            l, r = edges[k][0], edges[k][1]
            h.mate_l[l], h.mate_r[r] = -1, -1
        for k in added:
            l, r = edges[k][0], edges[k][1]
            h.mate_l[l], h.mate_r[r] = r, l
