"""A dual certificate of level 10, proposed here and checked by clingo (model/certificate.lp).

Only the pair actions have terms at level 10 (optimisation.lp [level10_likelihood],
[level10_count]: assigns and, since docs/model.md 3.15, resumes), and no other action or event
does: an answer's level 10 is the weight w(T, D) = IoU + 1 summed over its assigns and resumes,
and these pairs are a matching of the pairs with ``assignment_constraints`` (an active track) or
``resume_constraints`` (a halted one): one action per track and per detection.  clingo's branch
and bound cannot bound such a sum on a dense crowd; LP duality can (docs/model.md 2.10):

* potentials u(T) >= 0, v(D) >= 0 with u(T) + v(D) >= w(T, D) on every such pair bound every
  matching's weight by sum u + sum v;
* a witness matching M that an answer can complete (every track outside M has a solo action,
  every resume of M can be explained), each of its pairs tight (u + v = w) and every node of
  positive potential in M, reaches that bound, so the bound is the level-10 optimum;
* then every level-10 optimum, and so every lexicographic optimum, takes only tight pairs and
  covers every node of positive potential: the pruning model/certificate.lp adds.

This module only proposes the numbers (``certificate``: the witness by scipy's
linear_sum_assignment, the potentials as the rounded-down midpoint of the greatest and the least
solution of the dual's difference constraints, all integers) and writes them as facts
(``certificate_facts``); clingo checks every condition above itself and prunes only when all
hold, so a wrong certificate costs time, never an answer.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.assignment import linear_sum_assignment
from ..core.spec import FrameProblem
from ..knowledge.event_table import explaining
from ..core.constants import resolve_constants
from ..knowledge.events import EventState
from .common import candidate_pairs
from .cpsat_model import _has_explanation


_AGAIN = "|".join(e.name for e in explaining("ignore_trk"))
"""The event that re-explains an ignored missing track (the event table's role; model/events.lp
[explain_ignore] names it)."""

CERTIFIED_STATEMENTS = frozenset({
    # [actions_per_track], [actions_per_detection]: every track may take ignore_trk and every
    # detection ignore_det (the solo actions the witness's extension takes)
    "1 <= { assign(Trk,Det): assignment_constraints(Trk,Det); end(Trk); ignore_trk(Trk); halt(Trk); "
    "resume(Trk,Det): resume_candidate(Trk,Det) } <= 1 :- trk(Trk,_).",
    "1 <= { assign(Trk,Det): assignment_constraints(Trk,Det); start(Det); ignore_det(Det); "
    "resume(Trk,Det): resume_candidate(Trk,Det) } <= 1 :- det(Det,_,_).",
    # ... and as they were before the pair actions were offered only for admissible pairs (issue 38:
    # the same solo actions, so the argument holds for an encoding copied from an earlier refimpl)
    "1 <= { assign(Trk,Det): det(Det,_,_); end(Trk); ignore_trk(Trk); halt(Trk); "
    "resume(Trk,Det): det(Det,_,_) } <= 1 :- trk(Trk,_).",
    "1 <= { assign(Trk,Det): trk(Trk,_); start(Det); ignore_det(Det); resume(Trk,Det): trk(Trk,_) } <= 1 "
    ":- det(Det,_,_).",
    # [ignore_trk_constraints]: only a halted track is ignored (the argument's "a halted track")
    "#false :- ignore_trk(Trk); not trk_state(Trk,halted).",
    # [explain_ignore] (docs/model.md 3.16): the re-explanation is always possible where required
    # (every possible one is offered: poss(hides_behind(T, T2)) implies can_occur, events.lp), and
    # the choice as it was before it offered only can_occur's (issue 38)
    f"0 <= {{ occurs_at({_AGAIN}(Trk,Trk2),curr_time): can_occur({_AGAIN}(Trk,Trk2)) }} <= 1 :- ignore_trk(Trk).",
    f"0 <= {{ occurs_at({_AGAIN}(Trk,Trk2),curr_time): event({_AGAIN}(Trk,Trk2)) }} <= 1 :- ignore_trk(Trk).",
    f"reexplained(Trk) :- ignore_trk(Trk); occurs_at({_AGAIN}(Trk,_),curr_time).",
    f"#false :- ignore_trk(Trk); holds_at(clipped(Trk),true,curr_time); poss({_AGAIN}(Trk,_)); "
    "not reexplained(Trk).",
    # level 3: ignoring costs, below the levels the certificate prunes
    ":~ ignore_det(Det). [10@3,Det,ignore_det]",
    ":~ ignore_trk(Trk). [10@3,Trk,ignore_trk]",
    # level 10: the pair actions only ([level10_likelihood], [level10_count]); level 5 empty; the
    # empty statements that declare the levels
    ":~ . [0@10]",
    ":~ . [0@5]",
    ":~ assign(Trk,Det); matching_likelihood(Trk,Det,ML). [-ML@10,Trk,Det]",
    ":~ resume(Trk,Det); matching_likelihood(Trk,Det,ML). [-ML@10,Trk,Det]",
    ":~ assign(Trk,Det). [-1@10,Trk,Det,count]",
    ":~ resume(Trk,Det). [-1@10,Trk,Det,count]",
    # [level0_tiebreak]: priorities from refimpl's tie-break facts, all below level 1
    ":~ assign(Trk,Det); tiebreak_pair(Trk,Det,P,W). [W@P,Trk,Det,assign]",
    ":~ resume(Trk,Det); tiebreak_pair(Trk,Det,P,W). [W@P,Trk,Det,resume]",
    ":~ occurs_at(E,curr_time); tiebreak_event(E,P,W). [W@P,E,event]",
})
"""The preconditions of the certificate, as clingo prints the statements of model/ they rest on
(docs/model.md 2.10, "Preconditions").  The argument needs ignore_det always admissible, ignore_trk
admissible for every halted track, and only assigns and resumes at level 10 and nothing at 5.  An
encoding in which a statement outside this set mentions ``ignore_det`` or ``ignore_trk``, or
weighs at priority 5 or more (or at a priority not written as a number), is not offered the
certificate (refimpl.solvers.asp_model.certificate_preconditions, checked when a ClingoSolver is
built): such a statement may forbid the solo actions or add terms the certificate does not bound,
and its pruning could then cut an optimum.  A change to one of these statements withdraws it too,
until the argument is made again for the new text and the text is written here."""


@dataclass(frozen=True)
class Certificate:
    """Potentials of the tracks and detections (every one of the problem), and the witness
    matching, as (trk, det) pairs."""

    trk: tuple[tuple[str, int], ...]
    det: tuple[tuple[str, int], ...]
    matching: tuple[tuple[str, str], ...]


def pair_weights(problem: FrameProblem) -> dict[tuple[str, str], int]:
    """w(T, D) = ML + 1 for every pair an assign or a resume may take (common.candidate_pairs:
    assignment_constraints for an active track, resume_constraints for a halted one whose resume
    has a possible explanation, model/certificate.lp [cert_pairs]): its level-10 weight (ML: the
    matching likelihood, model/optimisation.lp [matching_likelihood])."""
    c = resolve_constants(problem)
    ml = problem.likelihood_map(c["likelihood_conf"], c["likelihood_halving"],  # [stale_likelihood]
                                EventState.from_problem(problem).halted_at if c["likelihood_halving"] else None)
    pairs = candidate_pairs(problem)
    halted = {t for t, _ in pairs} & {t.id for t in problem.tracks if t.state == "halted"}
    explained = _resume_explainable(problem, halted) if halted else set()
    return {(t, d): ml[(t, d)] + 1 for t, d in pairs if t not in halted or t in explained}


def _resume_explainable(problem: FrameProblem, halted: set[str]) -> set[str]:
    """The tracks of ``halted`` whose resume some event can explain (model/events.lp
    [resume_explainable]; the CP-SAT model's test, cpsat_model._has_explanation)."""
    tracks = list(problem.tracks)
    state = EventState.from_problem(problem)
    constants = resolve_constants(problem)
    by_id = {t.id: t for t in tracks}
    return {t.id for i, t in enumerate(tracks) if t.id in halted
            and _has_explanation("resume", i, tracks, None, state, constants, by_id)}


def _max_matching(tracks: list[str], dets: list[str], w: dict[tuple[str, str], int]) -> list[tuple[str, str]]:
    """A maximum-weight matching of the pairs ``w`` (weights > 0; a node may stay unmatched)."""
    if not w:
        return []
    ti = {t: i for i, t in enumerate(tracks)}
    di = {d: j for j, d in enumerate(dets)}
    gain = np.zeros((len(tracks), len(dets)), dtype=np.int64)
    for (t, d), v in w.items():
        gain[ti[t], di[d]] = v
    rows, cols = linear_sum_assignment(gain, maximize=True)
    return [(tracks[i], dets[j]) for i, j in zip(rows, cols) if gain[i, j] > 0]


def _potentials(tracks: list[str], dets: list[str], w: dict[tuple[str, str], int],
                matching: list[tuple[str, str]]) -> tuple[dict[str, int], dict[str, int]] | None:
    """Optimal dual potentials for ``matching`` (None if it is not a maximum-weight matching).

    With x(T) = u(T), x(D) = -v(D) and x(z) = 0 for a reference node z, dual feasibility and
    complementary slackness with the matching are difference constraints x(b) <= x(a) + c, i.e.
    arcs a -> b of length c: T -> D (-w) per pair, z -> D and T -> z (0) for v >= 0 and u >= 0,
    D -> T (+w) per matched pair (tight), z -> T per unmatched track and D -> z per unmatched
    detection (potential 0).  Every node is reachable from z; the shortest distances from z
    satisfy every constraint unless a negative cycle shows the matching is not optimal."""
    nodes = [("z", "")] + [("t", t) for t in tracks] + [("d", d) for d in dets]
    index = {n: k for k, n in enumerate(nodes)}
    arcs: list[tuple[int, int, int]] = []
    z = 0
    mt = {t: d for t, d in matching}
    md = {d: t for t, d in matching}
    for (t, d), v in w.items():
        arcs.append((index[("t", t)], index[("d", d)], -v))
    for t, d in matching:
        arcs.append((index[("d", d)], index[("t", t)], w[(t, d)]))
    for t in tracks:
        arcs.append((index[("t", t)], z, 0))
        if t not in mt:
            arcs.append((z, index[("t", t)], 0))
    for d in dets:
        arcs.append((z, index[("d", d)], 0))
        if d not in md:
            arcs.append((index[("d", d)], z, 0))
    near = _shortest(len(nodes), arcs, z)  # the greatest solution: x(b) <= x(z) + d(z, b)
    if near is None:
        return None  # a negative cycle: the matching is not a maximum
    far = _shortest(len(nodes), [(b, a, c) for a, b, c in arcs], z)  # the least: x(a) >= -d(a, z)
    # the midpoint of the two, rounded down, satisfies every constraint too (floor((a + b) / 2) is
    # monotone and commutes with adding an integer); it is strictly inside wherever they differ,
    # so fewer pairs are tight than at either end
    dist = [(a - b) // 2 for a, b in zip(near, far)]
    u = {t: int(dist[index[("t", t)]]) for t in tracks}
    v = {d: -int(dist[index[("d", d)]]) for d in dets}
    return u, v


def _shortest(n: int, arcs: list[tuple[int, int, int]], source: int) -> list[int] | None:
    """Shortest distances from ``source`` (Bellman-Ford; every node reachable), or None on a
    negative cycle."""
    dist: list[int | None] = [None] * n
    dist[source] = 0
    for _ in range(n):
        changed = False
        for a, b, c in arcs:
            da = dist[a]
            if da is not None and (dist[b] is None or da + c < dist[b]):
                dist[b] = da + c
                changed = True
        if not changed:
            return [int(d) for d in dist]
    return None


def certificate(problem: FrameProblem, weights: dict[tuple[str, str], int] | None = None) -> Certificate | None:
    """The proposed certificate of the problem's level 10 (module docstring), or None when no
    pair can be taken (nothing to prune).  ``weights``: pair_weights(problem), if the caller has them."""
    w = pair_weights(problem) if weights is None else weights
    if not w:
        return None
    tracks = [t.id for t in problem.tracks]
    dets = [d.id for d in problem.detections]
    matching = _max_matching(tracks, dets, w)
    pot = _potentials(tracks, dets, w, matching)
    if pot is None:
        return None
    u, v = pot
    return Certificate(tuple((t, u[t]) for t in tracks), tuple((d, v[d]) for d in dets), tuple(matching))


def certificate_facts(cert: Certificate | None) -> str:
    """cert_trk(T, U), cert_det(D, V), cert_match(T, D) facts (empty for None)."""
    if cert is None:
        return ""
    lines = [f"cert_trk({t},{u})." for t, u in cert.trk]
    lines += [f"cert_det({d},{v})." for d, v in cert.det]
    lines += [f"cert_match({t},{d})." for t, d in cert.matching]
    return "\n".join(lines) + "\n"
