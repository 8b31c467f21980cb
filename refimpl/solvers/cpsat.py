"""The abduction model as a CP-SAT model (OR-Tools), optimised lexicographically.

The hypothesis space and the cost vector are those of docs/model-spec.md, the same contract the
ASP encoding (model/*.lp) implements; the event calculus and the events' preconditions come from
refimpl/events.py instead of ASP rules.

Model (``build_model``): one Boolean per *candidate* action and per *candidate* event.  A
candidate action passes its integrity constraint (spec section 1) and, if it needs an
explanation, has at least one possible one; a candidate event is possible (``poss``, spec
section 4).  Actions and events that can never hold are simply not created.  Constraints:
exactly one action per track and per detection, and every explanation rule as a linear equality
"sum of the action's explaining events == the action" (which also forbids events without their
action).

Solving (``solve_lexicographic``): the five objectives priority by priority (10, 3, 2, 1, 0):
solve, fix the level at its optimum (as the bound ``objective <= optimum``, equivalent to the
equality), hint the solution to the next level.  A level is
proven only if CP-SAT answers OPTIMAL; anything less is reported as ``optimal=False``.

Fast exact path (``solve_fast``, on by default: ``CpSatSolver(fast_path=True)``): the model above
is a bipartite matching with lexicographic costs, solved exactly in Python component by
component, and only when its optimum is unique; otherwise (ties, inadmissible tracks, huge
components) the full CP-SAT model above answers.  See the section "The fast exact path" below
and docs/benchmarks.md for why this gives the identical hypothesis.
"""

from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np

from ortools.sat.python import cp_model

from ..constants import resolve_constants
from ..events import EVENT_TABLE, EventState, EventType, explaining, fluent_key
from ..hypothesis import EVENT_LEVEL, PRIORITIES, TIEBREAK_LEVEL, Hypothesis, action_cost
from ..relations import area
from ..spec import Detection, FrameProblem, TrackPrediction
from . import NoAdmissibleHypothesis, SolveTimeout, check_time_limit
from .common import intersection_matrix, tiebreak_level, tiebreak_weights
from .decompose import DEFAULT_PART_NODES, Part, own_atoms, split
from .fallback import obvious_hypothesis

_EVENT_AT = PRIORITIES.index(EVENT_LEVEL)
_TIE_AT = PRIORITIES.index(TIEBREAK_LEVEL)


def _cost(action: str, likelihood: int = 0, event: int = 0, tiebreak: int = 0) -> tuple[int, ...]:
    """An action's cost vector in PRIORITIES order, with its explaining event's cost and tie-break."""
    out = list(action_cost(action, likelihood))
    out[_EVENT_AT] += event
    out[_TIE_AT] += tiebreak
    return tuple(out)


def _pair_candidates(spec: EventType, i: int, tracks: Sequence[TrackPrediction], top: np.ndarray,
                     state: EventState) -> Sequence[TrackPrediction]:
    """The second tracks worth testing poss for a pair event of tracks[i]: every other track, narrowed
    (as a speed-up only, same answers) by what the precondition needs first: hides_behind needs
    overlapping_top (the top matrix), unhides_from_behind needs the track not_visible."""
    if spec.name == "hides_behind":
        return [tracks[j] for j in np.flatnonzero(top[i]).tolist()]
    if spec.name == "unhides_from_behind" and not _hidden(state, tracks[i].id):
        return ()
    return [t2 for t2 in tracks if t2.id != tracks[i].id]


def _explanations(action: str, i: int, tracks: Sequence[TrackPrediction], top: np.ndarray,
                  state: EventState, constants: Mapping[str, int],
                  by_id: Mapping[str, TrackPrediction]) -> list[tuple[EventType, tuple[str, ...]]]:
    """The possible events explaining ``action`` of tracks[i]: (event type, argument ids), in
    event-table order, pair events by their candidate order."""
    t = tracks[i]
    out: list[tuple[EventType, tuple[str, ...]]] = []
    for spec in explaining(action):
        if spec.arity == 1:
            if spec.poss(state, constants, t, tracks=by_id):
                out.append((spec, (t.id,)))
        else:
            out.extend((spec, (t.id, t2.id)) for t2 in _pair_candidates(spec, i, tracks, top, state)
                       if spec.poss(state, constants, t, t2, tracks=by_id))
    return out


EXPLANATION = -1
"""AbductionModel.objectives key of the tie-break's explanation part (solved after the pair part)."""

TIEBREAK_WORD_BITS = 60
"""CP-SAT's sums are 64-bit: the tie-break's pair part is solved in chunks that keep every sum
below 2^59 (common.py, solve_lexicographic)."""


class CpSatFailure(RuntimeError):
    """CP-SAT ended without any solution for a reason other than infeasibility (e.g. UNKNOWN at a
    time limit with no fallback answer, or MODEL_INVALID)."""


# ---------------------------------------------------------------------------------------
# Integrity constraints of the actions (docs/model-spec.md section 1)
# ---------------------------------------------------------------------------------------

def match_type(problem: FrameProblem, trk_type: str, det_type: str) -> bool:
    """match_type(TrkType, DetType): equal types or a match_type/2 fact of the problem."""
    return trk_type == det_type or (trk_type, det_type) in problem.match_types


def assignment_constraints(problem: FrameProblem, constants: Mapping[str, int], iou: Mapping[tuple[str, str], int],
                           trk: TrackPrediction, det: Detection) -> bool:
    """Appendix A assignment_constraints(Trk, Det)."""
    v = iou.get((trk.id, det.id))
    return (
        trk.state == "active"
        and match_type(problem, trk.type, det.type)
        and det.conf > constants["conf_thresh_assign"]
        and v is not None and v > constants["iou_thresh"]
    )


def resume_constraints(problem: FrameProblem, constants: Mapping[str, int], iou: Mapping[tuple[str, str], int],
                       trk: TrackPrediction, det: Detection) -> bool:
    """Appendix A resume_constraints(Trk, Det) plus refimpl's IoU condition (docs/model-spec.md)."""
    v = iou.get((trk.id, det.id))
    return (
        trk.state == "halted"
        and match_type(problem, trk.type, det.type)
        and det.conf > constants["conf_thresh_resume"]
        and v is not None and v > constants["iou_thresh_resume"]
    )


def start_constraints(constants: Mapping[str, int], det: Detection) -> bool:
    """Appendix A start_constraints(Det): confidence and size(bigger, Det, size_threshold) as area."""
    return det.conf > constants["conf_thresh_new_track"] and area(det.box) > constants["size_threshold"]


# ---------------------------------------------------------------------------------------
# Model building
# ---------------------------------------------------------------------------------------

@dataclass
class AbductionModel:
    """A built CP-SAT model with its variables by atom string and its five objectives."""

    model: cp_model.CpModel
    time: int
    actions: dict[str, cp_model.IntVar] = field(default_factory=dict)
    """action atom ('assign(trk_1,det_0)') -> Boolean."""
    events: dict[str, cp_model.IntVar] = field(default_factory=dict)
    """event ('hides_behind(trk_13,trk_12)', 'enters_fov(det_3)') -> Boolean."""
    objectives: dict[int, list[tuple[int, cp_model.IntVar]]] = field(default_factory=dict)
    """priority -> [(coefficient, Boolean)], minimised.  TIEBREAK_LEVEL holds the tie-break's pair
    part (coefficients 2^q, Python integers of any size); EXPLANATION its explanation part."""
    tiebreak_shift: int = 0
    """E of the tie-break (common.py): level 0 = pair part * 2^E + explanation part."""

    def all_vars(self) -> list[cp_model.IntVar]:
        return list(self.actions.values()) + list(self.events.values())


def _overlapping_top_matrix(tracks: Sequence[TrackPrediction], inter: np.ndarray, hide_overlap: int) -> np.ndarray:
    """top[i, j] = relations.overlapping_top(tracks[i].box, tracks[j].box, hide_overlap) and i != j,
    for all pairs at once (exact integer arithmetic on the intersection matrix)."""
    b = np.asarray([t.box for t in tracks], dtype=np.int64).reshape(-1, 4)
    bottom = b[:, 1] + b[:, 3]
    top = (100 * inter > hide_overlap * (b[:, 2] * b[:, 3])[:, None]) & (bottom[None, :] >= bottom[:, None])
    np.fill_diagonal(top, False)
    return top


def _hidden(state: EventState, trk: str) -> bool:
    return state.holds_at(("visibility", trk), "not_visible")


def build_model(problem: FrameProblem, state: EventState, constants: Mapping[str, int]) -> AbductionModel:
    """The CP-SAT model of one frame problem (see the module docstring).

    Raises NoAdmissibleHypothesis when some track has no candidate action at all.
    """
    model = cp_model.CpModel()
    am = AbductionModel(model, problem.time, objectives={p: [] for p in PRIORITIES + (EXPLANATION,)})
    iou = problem.iou_map
    inter = intersection_matrix([t.box for t in problem.tracks])
    tb = tiebreak_weights(problem, inter)
    w = tb.pair  # 2^q per pair; events: tb.event (common.py)
    am.tiebreak_shift = tb.shift
    # Only pairs with an iou/3 fact can be assigned or resumed, and hides_behind(T, T2) needs
    # overlapping_top(T, T2): the loops below skip everything else before calling the rules
    # (same candidates, same variable order as testing every pair, without n^2 Python calls).
    paired = {t for t, _, _ in problem.iou}
    by_id = {t.id: t for t in problem.tracks}
    top = _overlapping_top_matrix(problem.tracks, inter, constants["hide_overlap"])
    obj = am.objectives
    cost = {name: constants[e.cost_constant] for name, e in EVENT_TABLE.items()}

    def action(atom: str, name: str, likelihood: int = 0) -> cp_model.IntVar:
        v = model.new_bool_var(atom)
        am.actions[atom] = v
        for p, c in zip(PRIORITIES, action_cost(name, likelihood)):
            if c:
                obj[p].append((c, v))
        return v

    def event(spec: EventType, args: tuple[str, ...]) -> cp_model.IntVar:
        v = model.new_bool_var(f"{spec.name}({','.join(args)})")
        am.events[f"{spec.name}({','.join(args)})"] = v
        if cost[spec.name]:
            obj[EVENT_LEVEL].append((cost[spec.name], v))
        tie = tb.event.get(f"{spec.name}({','.join(args)})", 0)
        if tie:
            obj[EXPLANATION].append((tie, v))
        return v

    per_trk: dict[str, list[cp_model.IntVar]] = {t.id: [] for t in problem.tracks}
    per_det: dict[str, list[cp_model.IntVar]] = {d.id: [] for d in problem.detections}

    for i, t in enumerate(problem.tracks):
        if t.state == "active":
            # assign(T, D): assignment_constraints
            for d in (problem.detections if t.id in paired else ()):
                if assignment_constraints(problem, constants, iou, t, d):
                    a = action(f"assign({t.id},{d.id})", "assign", iou[(t.id, d.id)])
                    per_trk[t.id].append(a)
                    per_det[d.id].append(a)
                    obj[TIEBREAK_LEVEL].append((w[(t.id, d.id)], a))
            # halt(T) <=> exactly one of its possible explanations   (explain_halt)
            halts = _explanations("halt", i, problem.tracks, top, state, constants, by_id)
            if halts:
                h = action(f"halt({t.id})", "halt")
                per_trk[t.id].append(h)
                model.add(sum(event(spec, args) for spec, args in halts) == h)
        else:  # halted
            # end(T) <=> exactly one of its possible explanations   (explain_end)
            ends = _explanations("end", i, problem.tracks, top, state, constants, by_id)
            if ends:
                en = action(f"end({t.id})", "end")
                per_trk[t.id].append(en)
                model.add(sum(event(spec, args) for spec, args in ends) == en)
            per_trk[t.id].append(action(f"ignore_trk({t.id})", "ignore_trk"))
            # resume(T, D) <=> exactly one of its possible explanations   (explain_resume)
            resumable = [d for d in (problem.detections if t.id in paired else ())
                         if resume_constraints(problem, constants, iou, t, d)]
            expl = _explanations("resume", i, problem.tracks, top, state, constants, by_id) if resumable else []
            if resumable and expl:
                res = []
                for d in resumable:
                    a = action(f"resume({t.id},{d.id})", "resume", iou[(t.id, d.id)])
                    res.append(a)
                    per_trk[t.id].append(a)
                    per_det[d.id].append(a)
                    obj[TIEBREAK_LEVEL].append((w[(t.id, d.id)], a))
                model.add(sum(event(spec, args) for spec, args in expl) == sum(res))

    for d in problem.detections:
        # start(D) <=> exactly one of its possible explanations (enters_fov)   (explain_start)
        starts = [spec for spec in explaining("start") if spec.poss(state, constants, d.id, tracks=None)]
        if start_constraints(constants, d) and starts:
            s = action(f"start({d.id})", "start")
            per_det[d.id].append(s)
            model.add(sum(event(spec, (d.id,)) for spec in starts) == s)
        per_det[d.id].append(action(f"ignore_det({d.id})", "ignore_det"))

    for t in problem.tracks:
        if not per_trk[t.id]:
            raise NoAdmissibleHypothesis(
                f"track {t.id} ({t.state}) has no admissible action at time {problem.time}")
        model.add_exactly_one(per_trk[t.id])
    for d in problem.detections:
        model.add_exactly_one(per_det[d.id])
    return am


# ---------------------------------------------------------------------------------------
# Solving
# ---------------------------------------------------------------------------------------

@dataclass(frozen=True)
class LexResult:
    values: dict[str, int]
    """atom (action or event) -> 0/1 in the final solution."""
    cost: tuple[tuple[int, int], ...]
    optimal: bool
    statuses: tuple[str, ...]
    """CP-SAT's status name per level; SKIPPED: the level has no terms; NO_TIME: the time limit
    was used up before the level; BOUND: the solution so far already has the level's lower bound 0 (all coefficients > 0)."""


def _solution(solver: cp_model.CpSolver, indices: list[int]) -> dict[int, int]:
    """var index -> value of the solver's last solution (read from the response in one go)."""
    values = solver.response_proto.solution
    return {i: int(values[i]) for i in indices}


def _level_value(terms: list[tuple[int, cp_model.IntVar]], values: Mapping[int, int]) -> int:
    return sum(c * values[v.index] for c, v in terms)


def _trivial_solution(am: AbductionModel, problem: FrameProblem) -> dict[int, int] | None:
    """A solution found without search, if the obvious one exists: every detection ignored, every
    halted track ignored, every active track halted (missing_detections, else the first possible
    hides_behind); None if some active track cannot be halted."""
    chosen = {f"ignore_det({d.id})" for d in problem.detections}
    for t in problem.tracks:
        if f"ignore_trk({t.id})" in am.actions:
            chosen.add(f"ignore_trk({t.id})")
            continue
        if f"halt({t.id})" not in am.actions:
            return None
        chosen.add(f"halt({t.id})")
        expl = [e for e in am.events if e == f"missing_detections({t.id})"]
        expl += [e for e in am.events if e.startswith(f"hides_behind({t.id},")]
        chosen.add(expl[0])
    return {v.index: int(atom in chosen) for atom, v in list(am.actions.items()) + list(am.events.items())}


LevelTerms = list[tuple[int, cp_model.IntVar]]

SCALAR_BITS = 62
"""A group of consecutive levels is minimised as one weighted sum when its range fits in this many bits."""


def _range(terms: LevelTerms) -> int:
    """max - min + 1 of a level's sum over 0/1 variables."""
    return sum(abs(c) for c, _ in terms) + 1


def _pack_levels(levels: list[tuple[int, LevelTerms]]) -> list[list[tuple[int, LevelTerms]]]:
    """Consecutive levels grouped so that each group's scalarised objective (below) fits in
    SCALAR_BITS: one CP-SAT solve per group instead of per level."""
    groups: list[list[tuple[int, LevelTerms]]] = []
    span = 0
    for prio, terms in levels:
        r = _range(terms)
        if groups and span * r < (1 << SCALAR_BITS):
            groups[-1].append((prio, terms))
            span *= r
        else:
            groups.append([(prio, terms)])
            span = r
    return groups


def _scalarised(group: list[tuple[int, LevelTerms]]) -> LevelTerms:
    """One objective whose order is the group's lexicographic order: level i is weighted by the
    product of the ranges of the levels after it, which exceeds any difference those can make."""
    out: LevelTerms = []
    weight = 1
    for _, terms in reversed(group):
        out += [(c * weight, v) for c, v in terms]
        weight *= _range(terms)
    return out


def _fix_levels(model: cp_model.CpModel, group: list[tuple[int, LevelTerms]], solution: Mapping[int, int]) -> None:
    """Every level of a group solved to optimality, fixed at its value (as ``<=``, see below)."""
    for _, terms in group:
        if terms:
            model.add(sum(c * v for c, v in terms) <= _level_value(terms, solution))


def solve_lexicographic(am: AbductionModel, problem: FrameProblem, time_limit: float | None = None,
                        workers: int = 1, seed: int = 0) -> LexResult:
    """Minimise the objectives of PRIORITIES one after another (see the module docstring).

    Each level is solved with the previous level's solution as a complete hint.  A level proven
    OPTIMAL at value V is fixed with ``expr <= V``: since nothing below V is feasible this is the
    equality ``expr == V`` on every solution, and CP-SAT propagates it far better (an equality
    over IoU-sized coefficients is a subset-sum constraint: on a 100-track frame the next levels
    took 1.8 s with ``==`` and 0.09 s with ``<=``).  A level whose coefficients are all positive and whose
    value in the solution so far is 0 is optimal without a solve (0 is its lower bound).

    With a time limit, the remaining budget is split evenly over the levels still to solve.  A
    level that ends FEASIBLE, or UNKNOWN (no solution in its share), makes the answer not optimal
    and is bounded by "no worse than the best solution so far" (an inequality), so lower levels
    never make a higher one worse.  If the first level finds no solution in time, the obvious
    hypothesis (everything ignored or halted, see _trivial_solution) stands in when it exists.
    """
    model = am.model
    deadline = None if time_limit is None else time.perf_counter() + max(0.0, time_limit)
    variables = am.all_vars()
    indices = [v.index for v in variables]
    solution: dict[int, int] | None = None  # var index -> value
    optimal = True
    statuses: list[str] = []

    # levels 10..1, then the tie-break: its pair part in chunks small enough for 64-bit sums
    # (powers of two 2^q -> chunk q // width, coefficient 2^(q % width); comparing the chunks
    # most significant first compares the integers), then its explanation part
    levels: list[tuple[int, list[tuple[int, cp_model.IntVar]]]] = [
        (p, am.objectives[p]) for p in PRIORITIES if p != TIEBREAK_LEVEL]
    pair_terms = am.objectives[TIEBREAK_LEVEL]
    width = max(1, TIEBREAK_WORD_BITS - 1 - max(len(pair_terms), 1).bit_length())
    chunked: dict[int, list[tuple[int, cp_model.IntVar]]] = {}
    for c, v in pair_terms:
        q = c.bit_length() - 1
        chunked.setdefault(q // width, []).append((1 << (q % width), v))
    levels += [(TIEBREAK_LEVEL, chunked[j]) for j in sorted(chunked, reverse=True)]
    levels.append((TIEBREAK_LEVEL, am.objectives.get(EXPLANATION, [])))
    groups = _pack_levels(levels)

    for i, group in enumerate(groups):
        prio = group[0][0]
        terms = _scalarised(group)
        expr = sum(c * v for c, v in terms) if terms else 0
        if not terms and solution is not None:
            statuses.append("SKIPPED")
            continue
        if solution is not None and all(c > 0 for c, _ in terms) and _level_value(terms, solution) == 0:
            model.add(expr == 0)
            statuses.append("BOUND")
            continue
        solver = cp_model.CpSolver()
        solver.parameters.num_workers = workers
        solver.parameters.random_seed = seed
        solver.parameters.catch_sigint_signal = False  # Ctrl-C interrupts refimpl, not just this level
        status = None
        if deadline is not None:
            share = (deadline - time.perf_counter()) / (len(groups) - i)
            if share > 0:
                solver.parameters.max_time_in_seconds = share
            else:
                status = cp_model.UNKNOWN  # no time left for this level
        if status is None:
            model.clear_objective()
            if terms:
                model.minimize(expr)
            model.clear_hints()
            if solution is not None:  # the same hints as add_hint per variable, in one go
                hint = model.proto.solution_hint
                hint.vars.extend(indices)
                hint.values.extend(solution[i] for i in indices)
            status = solver.solve(model)
            statuses.append(solver.status_name(status))
        else:
            statuses.append("NO_TIME")

        if status == cp_model.OPTIMAL:
            solution = _solution(solver, indices)
            _fix_levels(model, group, solution)
        elif status in (cp_model.FEASIBLE, cp_model.UNKNOWN):
            optimal = False
            if status == cp_model.FEASIBLE:
                solution = _solution(solver, indices)
            elif solution is None:
                solution = _trivial_solution(am, problem)
            if solution is not None and terms:
                model.add(expr <= _level_value(terms, solution))
        elif status == cp_model.INFEASIBLE:
            if solution is None:
                raise NoAdmissibleHypothesis(
                    f"no hypothesis satisfies the model at time {am.time} (CP-SAT: INFEASIBLE)")
            raise CpSatFailure(f"level {prio} became INFEASIBLE after a solution was fixed (time {am.time})")
        else:  # MODEL_INVALID
            raise CpSatFailure(f"CP-SAT status {solver.status_name(status)} at level {prio} "
                               f"(time {am.time}): {model.validate()}")

    if solution is None:
        raise SolveTimeout(f"no answer at t={am.time} within the time limit "
                           f"({'none' if time_limit is None else f'{time_limit:g} s'})")
    level0 = (_level_value(pair_terms, solution) << am.tiebreak_shift) + _level_value(
        am.objectives.get(EXPLANATION, []), solution)
    cost = tuple((p, level0 if p == TIEBREAK_LEVEL else _level_value(am.objectives[p], solution))
                 for p in PRIORITIES)
    values = {atom: solution[v.index] for atom, v in list(am.actions.items()) + list(am.events.items())}
    return LexResult(values, cost, optimal, tuple(statuses))


# ---------------------------------------------------------------------------------------
# The fast exact path
# ---------------------------------------------------------------------------------------
#
# Why the model above is a bipartite matching (docs/benchmarks.md, "The fast exact path"):
#
# * Every event variable occurs in exactly one explanation constraint, that of one action (halt(T),
#   end(T), the resumes of T, start(D)), and whether it is possible depends on the history only,
#   never on another choice of this frame.  So once the actions are fixed, each chosen action
#   independently takes its cheapest explanation: an action is an option with a fixed cost vector.
# * Every action belongs to one track, one detection, or (assign, resume) one track and one
#   detection, and each of those takes exactly one action.  With the pair actions as edges, an
#   answer is a matching of tracks to detections; every unmatched track or detection takes its
#   best "solo" action (halt / end / ignore_trk; start / ignore_det).
# * All five levels, the tie-break level 0 included, are sums over the chosen variables, so the
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
    best = min(explanations)
    return best[0], best[1], sum(1 for c, _ in explanations if c == best[0]) > 1


def _best_solo(options: list[_Option]) -> _Option:
    """The cheapest solo option; marked tied when another solo option has the same cost vector."""
    best = min(options, key=lambda o: o.cost)
    if sum(1 for o in options if o.cost == best.cost) > 1:
        return _Option(best.action, best.event, best.cost, True)
    return best


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


class TrackwiseState:
    """The queries of an EventState (values, holds_at, started_at, halted_at) answered from one
    EventState per track, each folded from that track's own events only, and memoised.

    Exact because every effect, start and halt time of an event concerns its first argument only
    (refimpl.events.EFFECTS: each effect's fluent has the event's first argument as its own first
    argument; recover's "hidden_by(T, X) for every X" too), and the set-valued grouping of one
    time point is per fluent; folding a track's events in time order (stable, as EventState does)
    gives that track's fluents exactly.  Per-track states are reused across frames while the
    track's events are unchanged (``cache``), so a tracker's frame folds only new events;
    ``used`` holds the entries this frame needed, the cache to pass to the next frame."""

    _EMPTY = EventState()

    def __init__(self, history: Sequence, tracks: Sequence[str],
                 cache: dict[tuple[str, tuple], EventState] | None = None):
        groups: dict[str, list] = {}
        for h in history:
            args = h.event.args
            if args:  # events without arguments have no effect (no EFFECTS entry of arity 0)
                groups.setdefault(str(args[0]), []).append(h)
        cache = {} if cache is None else cache
        self.used: dict[tuple[str, tuple], EventState] = {}
        self._per: dict[str, EventState] = {}
        for trk in tracks:
            events = groups.get(trk)
            if not events:
                continue
            key = (trk, tuple(events))
            st = cache.get(key)
            if st is None:
                st = EventState(events, (trk,))
            self.used[key] = self._per[trk] = st
        self._memo: dict = {}

    def _state(self, trk: str) -> EventState:
        return self._per.get(trk, self._EMPTY)

    def values(self, fluent) -> frozenset[str]:
        key = fluent_key(fluent)
        return self._state(key[1]).values(key)

    def holds_at(self, fluent, value: str) -> bool:
        memo_key = (fluent, value) if isinstance(fluent, tuple) else None
        if memo_key is not None:
            got = self._memo.get(memo_key)
            if got is not None:
                return got
        got = value in self.values(fluent)
        if memo_key is not None:
            self._memo[memo_key] = got
        return got

    def started_at(self, trk: str) -> int | None:
        return self._state(trk).started_at(trk)

    def halted_at(self, trk: str) -> int | None:
        return self._state(trk).halted_at(trk)


@dataclass
class FastAnswer:
    """What solve_fast found: the answer and how the frame fell apart."""

    actions: list[str]
    events: list[str]
    cost: tuple[tuple[int, int], ...]
    components: int
    largest: int
    """Nodes (tracks + detections) of the largest component."""


def solve_fast(problem: FrameProblem, state: EventState, constants: Mapping[str, int],
               max_component: int = FAST_PATH_MAX_COMPONENT) -> FastAnswer:
    """The unique lexicographic optimum of the model, without CP-SAT, or FastPathDeclined.

    Candidates are those of build_model (same rules: the constraint functions above and the
    poss functions of refimpl.events), costs those of build_model's objectives."""
    tracks, dets = problem.tracks, problem.detections
    iou = problem.iou_map
    inter = intersection_matrix([t.box for t in tracks])
    tb = tiebreak_weights(problem, inter)
    ev = tb.event  # level 0 of an explaining event: its index (common.py)
    w = {p: v << tb.shift for p, v in tb.pair.items()}  # level 0 of a pair action
    cost = {name: constants[e.cost_constant] for name, e in EVENT_TABLE.items()}
    top = _overlapping_top_matrix(tracks, inter, constants["hide_overlap"])
    t_index = {t.id: i for i, t in enumerate(tracks)}
    d_index = {d.id: j for j, d in enumerate(dets)}
    paired = {tid for tid, _ in iou}
    by_id = {t.id: t for t in tracks}

    def priced(found: list[tuple[EventType, tuple[str, ...]]]) -> list[tuple[tuple[int, int], str]]:
        return [((cost[spec.name], ev.get(f"{spec.name}({','.join(args)})", 0)), f"{spec.name}({','.join(args)})")
                for spec, args in found]

    # -- solo options of the tracks, and each halted track's cheapest resume explanation --------
    solo_t: list[_Option] = []
    resume_expl: dict[int, tuple[tuple[int, int], str, bool]] = {}
    for i, t in enumerate(tracks):
        if t.state == "active":
            expl = priced(_explanations("halt", i, tracks, top, state, constants, by_id))
            if not expl:
                raise FastPathDeclined("track without a solo action")  # full model: assign or nothing
            (c1, c0), event, tie = _cheapest(expl)
            solo_t.append(_Option(f"halt({t.id})", event, _cost("halt", event=c1, tiebreak=c0), tie))
        else:
            options = [_Option(f"ignore_trk({t.id})", None, _cost("ignore_trk"))]
            ends = priced(_explanations("end", i, tracks, top, state, constants, by_id))
            if ends:
                (c1, c0), event, tie = _cheapest(ends)
                options.append(_Option(f"end({t.id})", event, _cost("end", event=c1, tiebreak=c0), tie))
            solo_t.append(_best_solo(options))
            if t.id not in paired:
                continue  # no iou/3 pair: no resume, no explanation needed
            expl = priced(_explanations("resume", i, tracks, top, state, constants, by_id))
            if expl:
                resume_expl[i] = _cheapest(expl)

    # -- solo options of the detections ---------------------------------------------------------
    solo_d: list[_Option] = []
    for d in dets:
        options = [_Option(f"ignore_det({d.id})", None, _cost("ignore_det"))]
        starts = [((cost[spec.name], ev.get(f"{spec.name}({d.id})", 0)), f"{spec.name}({d.id})")
                  for spec in explaining("start")
                  if spec.poss(state, constants, d.id, tracks=None)]
        if start_constraints(constants, d) and starts:
            (c1, c0), event, tie = _cheapest(starts)
            options.append(_Option(f"start({d.id})", event, _cost("start", event=c1, tiebreak=c0), tie))
        solo_d.append(_best_solo(options))

    # -- pair options (edges): assign for active tracks, resume for halted ones ------------------
    edges: list[tuple[int, int, _Option]] = []
    for (tid, did), v in iou.items():
        i, j = t_index.get(tid), d_index.get(did)
        if i is None or j is None:
            continue
        t, d = tracks[i], dets[j]
        if t.state == "active":
            if assignment_constraints(problem, constants, iou, t, d):
                edges.append((i, j, _Option(f"assign({tid},{did})", None,
                                            _cost("assign", iou[(tid, did)], tiebreak=w[(tid, did)]))))
        elif i in resume_expl and resume_constraints(problem, constants, iou, t, d):
            (c1, c0), event, tie = resume_expl[i]
            edges.append((i, j, _Option(f"resume({tid},{did})", event,
                                        _cost("resume", iou[(tid, did)], event=c1, tiebreak=w[(tid, did)] + c0),
                                        tie)))

    # -- one integer per cost vector, in the lexicographic order ---------------------------------
    bound = sum(abs(c) for o in solo_t + solo_d for c in o.cost) + sum(abs(c) for _, _, o in edges for c in o.cost)
    base = 2 * bound + 1

    def scalar(v: tuple[int, ...]) -> int:
        s = 0
        for c in v:
            s = s * base + c
        return s

    # -- components (union-find over the edges) and their matchings ------------------------------
    nt = len(tracks)
    parent = list(range(nt + len(dets)))

    def find(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for i, j, _ in edges:
        a, b = find(i), find(nt + j)
        if a != b:
            parent[a] = b
    comp_edges: dict[int, list[tuple[int, int, _Option]]] = {}
    for e in edges:
        comp_edges.setdefault(find(e[0]), []).append(e)
    sizes: dict[int, int] = {}
    for x in range(len(parent)):
        root = find(x)
        sizes[root] = sizes.get(root, 0) + 1
    chosen: list[_Option] = []
    matched_t: set[int] = set()
    matched_d: set[int] = set()
    for root, ces in comp_edges.items():
        if sizes[root] > max_component:
            raise FastPathDeclined("component too large")
        if len(ces) == 1:  # one track, one detection, one pair option: closed form
            i, j, o = ces[0]
            g = scalar(solo_t[i].cost) + scalar(solo_d[j].cost) - scalar(o.cost)
            if g == 0:
                raise FastPathDeclined("tie")
            if g > 0:
                chosen.append(o)
                matched_t.add(i)
                matched_d.add(j)
            continue
        ls = sorted({i for i, _, _ in ces})
        rs = sorted({j for _, j, _ in ces})
        lpos = {i: a for a, i in enumerate(ls)}
        rpos = {j: b for b, j in enumerate(rs)}
        by_pair = {(lpos[i], rpos[j]): o for i, j, o in ces}
        mate = _max_weight_matching(len(ls), len(rs), [
            (lpos[i], rpos[j], scalar(solo_t[i].cost) + scalar(solo_d[j].cost) - scalar(o.cost))
            for i, j, o in ces])
        for a, b in enumerate(mate):
            if b >= 0:
                chosen.append(by_pair[(a, b)])
                matched_t.add(ls[a])
                matched_d.add(rs[b])
    chosen += [o for i, o in enumerate(solo_t) if i not in matched_t]
    chosen += [o for j, o in enumerate(solo_d) if j not in matched_d]
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


class CpSatSolver:
    """The CP-SAT backends ``cpsat`` and ``cpsat-full``: ``solve(problem, time_limit=None) -> Hypothesis``.

    Options: ``workers`` (CP-SAT num_workers; 1 for reference runs), ``seed`` (random_seed),
    ``fast_path`` (default True, backend ``cpsat``): answer from ``solve_fast`` when it applies
    (a unique optimum, identical to the full model's answer), else from the full CP-SAT model;
    ``fast_path=False`` (backend ``cpsat-full``) always solves the full model.  ``decompose``
    (default True): the full model is built and solved per sub-problem of independent
    components (refimpl.solvers.decompose), which gives the same answer.  ``stats`` counts, per
    solve, how the answer was found: "fast", or "full" plus "declined: REASON", and "timeout".
    The time-out contract is that of refimpl.solvers.
    """

    def __init__(self, workers: int = 1, seed: int = 0, fast_path: bool = True, decompose: bool = True,
                 part_nodes: int = DEFAULT_PART_NODES):
        if workers < 1:
            raise ValueError(f"workers must be >= 1, got {workers}")
        self.workers = workers
        self.seed = seed
        self.fast_path = fast_path
        self.decompose = decompose
        self.part_nodes = int(part_nodes)
        self.name = "cpsat" if fast_path else "cpsat-full"
        self.stats: Counter[str] = Counter()
        self._state_cache: dict[tuple[str, tuple], EventState] = {}

    def _fallback(self, problem: FrameProblem, start: float, time_limit: float | None) -> Hypothesis:
        self.stats["timeout"] += 1
        h = obvious_hypothesis(problem, self.name, (time.perf_counter() - start) * 1000.0)
        if h is None:
            raise SolveTimeout(f"no answer at t={problem.time} within the time limit ({time_limit:g} s)")
        return h

    def solve(self, problem: FrameProblem, time_limit: float | None = None,
              state: EventState | None = None) -> Hypothesis:
        """The best hypothesis; ``state`` (optional) replaces folding problem.history."""
        start = time.perf_counter()
        time_limit = check_time_limit(time_limit)
        deadline = None if time_limit is None else start + time_limit
        if time_limit is not None and time_limit <= 0:
            return self._fallback(problem, start, time_limit)
        constants = resolve_constants(problem)
        t = problem.time
        if state is None:  # reuse the per-track folds of the previous frame
            state = TrackwiseState(problem.history, [x.id for x in problem.tracks], self._state_cache)
            self._state_cache = state.used  # type: ignore[attr-defined]
        if self.fast_path:
            try:
                fast = solve_fast(problem, state, constants)  # type: ignore[arg-type]
            except FastPathDeclined as exc:
                self.stats[f"declined: {exc.reason}"] += 1
            else:
                if deadline is not None and time.perf_counter() > deadline:
                    return self._fallback(problem, start, time_limit)
                self.stats["fast"] += 1
                return Hypothesis(time=t, actions=tuple(fast.actions), events=tuple(fast.events),
                                  cost=fast.cost, optimal=True, backend=self.name,
                                  solve_ms=(time.perf_counter() - start) * 1000.0)
        self.stats["full"] += 1
        parts = split(problem, self.part_nodes) if self.decompose else [Part(problem, frozenset())]
        whole = len(parts) == 1
        actions: list[str] = []
        events: list[str] = []
        totals = dict.fromkeys((p for p in PRIORITIES if p != TIEBREAK_LEVEL), 0)
        optimal = True
        for n, part in enumerate(parts):
            now = time.perf_counter()
            if deadline is not None and now >= deadline:
                return self._fallback(problem, start, time_limit)
            share = None if deadline is None else deadline - now  # all that is left: most parts are trivial
            am = build_model(part.problem, state, constants)
            res = solve_lexicographic(am, part.problem, share, self.workers, self.seed)
            optimal = optimal and res.optimal
            chosen = [a for a, v in res.values.items() if v]
            if whole:
                acts = [a for a in chosen if a in am.actions]
                evs = [e for e in chosen if e in am.events]
                totals = dict(res.cost)
            else:
                acts, evs = own_atoms(part, (a for a in chosen if a in am.actions),
                                      (e for e in chosen if e in am.events))
                own = set(acts) | set(evs)
                for p in totals:  # the part's own share of each level, from the model's objective
                    totals[p] += sum(c for c, v in am.objectives[p] if v.name in own and res.values[v.name])
            actions += acts
            events += [f"occurs_at({e},{t})" for e in evs]
        if not optimal and deadline is not None and time.perf_counter() > deadline:
            self.stats["timeout"] += 1
        level0 = tiebreak_level(problem, actions, events)
        cost = tuple((p, level0 if p == TIEBREAK_LEVEL else totals[p]) for p in PRIORITIES)
        return Hypothesis(time=t, actions=tuple(actions), events=tuple(events), cost=cost,
                          optimal=optimal, backend=self.name,
                          solve_ms=(time.perf_counter() - start) * 1000.0)
