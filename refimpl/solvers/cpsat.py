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
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Mapping

from ortools.sat.python import cp_model

from ..constants import resolve_constants
from ..events import (
    COST_CONSTANT,
    EventState,
    poss_enters_fov,
    poss_hides_behind,
    poss_leaves_fov,
    poss_lost,
    poss_missing_detections,
    poss_noise,
    poss_recover,
    poss_unhides_from_behind,
)
from ..hypothesis import Hypothesis
from ..relations import area
from ..spec import Detection, FrameProblem, TrackPrediction
from . import NoAdmissibleHypothesis
from .common import tiebreak_weights

PRIORITIES = (10, 3, 2, 1, 0)
"""The cost levels, highest priority first (docs/model-spec.md section 5)."""


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
    """priority -> [(coefficient, Boolean)], minimised."""

    def all_vars(self) -> list[cp_model.IntVar]:
        return list(self.actions.values()) + list(self.events.values())


def build_model(problem: FrameProblem, state: EventState, constants: Mapping[str, int]) -> AbductionModel:
    """The CP-SAT model of one frame problem (see the module docstring).

    Raises NoAdmissibleHypothesis when some track has no candidate action at all.
    """
    model = cp_model.CpModel()
    am = AbductionModel(model, problem.time, objectives={p: [] for p in PRIORITIES})
    iou = problem.iou_map
    w, r, k = tiebreak_weights(problem)
    obj = am.objectives
    cost = {name: constants[c] for name, c in COST_CONSTANT.items()}

    def action(atom: str) -> cp_model.IntVar:
        v = model.new_bool_var(atom)
        am.actions[atom] = v
        return v

    def event(atom: str, name: str) -> cp_model.IntVar:
        v = model.new_bool_var(atom)
        am.events[atom] = v
        if cost[name]:
            obj[1].append((cost[name], v))
        return v

    per_trk: dict[str, list[cp_model.IntVar]] = {t.id: [] for t in problem.tracks}
    per_det: dict[str, list[cp_model.IntVar]] = {d.id: [] for d in problem.detections}

    for t in problem.tracks:
        if t.state == "active":
            # assign(T, D): assignment_constraints
            for d in problem.detections:
                if assignment_constraints(problem, constants, iou, t, d):
                    a = action(f"assign({t.id},{d.id})")
                    per_trk[t.id].append(a)
                    per_det[d.id].append(a)
                    obj[10].append((-(iou[(t.id, d.id)] + 1), a))
                    obj[0].append((w[(t.id, d.id)], a))
            # halt(T) <=> exactly one of hides_behind(T, T2), missing_detections(T)   (explain_halt)
            hides = [t2 for t2 in problem.tracks if poss_hides_behind(state, constants, t, t2)]
            missing = poss_missing_detections(state, constants, t)
            if hides or missing:
                h = action(f"halt({t.id})")
                per_trk[t.id].append(h)
                expl = []
                for t2 in hides:
                    e = event(f"hides_behind({t.id},{t2.id})", "hides_behind")
                    expl.append(e)
                    if r.get((t.id, t2.id)):
                        obj[0].append((r[(t.id, t2.id)], e))
                if missing:
                    expl.append(event(f"missing_detections({t.id})", "missing_detections"))
                model.add(sum(expl) == h)
        else:  # halted
            # end(T) <=> exactly one of leaves_fov(T), lost(T), noise(T)   (explain_end)
            ends = [(name, fn) for name, fn in (("leaves_fov", poss_leaves_fov), ("lost", poss_lost),
                                                ("noise", poss_noise)) if fn(state, constants, t)]
            if ends:
                en = action(f"end({t.id})")
                per_trk[t.id].append(en)
                obj[2].append((5, en))
                model.add(sum(event(f"{name}({t.id})", name) for name, _ in ends) == en)
            ig = action(f"ignore_trk({t.id})")
            per_trk[t.id].append(ig)
            obj[3].append((10, ig))
            # resume(T, D) <=> exactly one of unhides_from_behind(T, T2), recover(T)   (explain_resume)
            resumable = [d for d in problem.detections if resume_constraints(problem, constants, iou, t, d)]
            unhides = [t2 for t2 in problem.tracks if poss_unhides_from_behind(state, constants, t, t2)]
            recover = poss_recover(state, constants, t)
            if resumable and (unhides or recover):
                res = []
                for d in resumable:
                    a = action(f"resume({t.id},{d.id})")
                    res.append(a)
                    per_trk[t.id].append(a)
                    per_det[d.id].append(a)
                    obj[2].append((1, a))
                    obj[0].append((w[(t.id, d.id)], a))
                expl = [event(f"unhides_from_behind({t.id},{t2.id})", "unhides_from_behind") for t2 in unhides]
                obj[0].extend((k[t2.id], e) for t2, e in zip(unhides, expl) if k[t2.id])
                if recover:
                    expl.append(event(f"recover({t.id})", "recover"))
                model.add(sum(expl) == sum(res))

    for d in problem.detections:
        # start(D) <=> enters_fov(D)   (explain_start)
        if start_constraints(constants, d) and poss_enters_fov(state, constants, d.id):
            s = action(f"start({d.id})")
            per_det[d.id].append(s)
            obj[2].append((5, s))
            model.add(event(f"enters_fov({d.id})", "enters_fov") == s)
        ig = action(f"ignore_det({d.id})")
        per_det[d.id].append(ig)
        obj[3].append((10, ig))

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
    solution: dict[int, int] | None = None  # var index -> value
    optimal = True
    statuses: list[str] = []

    for i, prio in enumerate(PRIORITIES):
        terms = am.objectives[prio]
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
        status = None
        if deadline is not None:
            share = (deadline - time.perf_counter()) / (len(PRIORITIES) - i)
            if share > 0:
                solver.parameters.max_time_in_seconds = share
            else:
                status = cp_model.UNKNOWN  # no time left for this level
        if status is None:
            model.clear_objective()
            if terms:
                model.minimize(expr)
            model.clear_hints()
            if solution is not None:
                for v in variables:
                    model.add_hint(v, solution[v.index])
            status = solver.solve(model)
            statuses.append(solver.status_name(status))
        else:
            statuses.append("NO_TIME")

        if status == cp_model.OPTIMAL:
            solution = {v.index: int(solver.value(v)) for v in variables}
            if terms:
                model.add(expr <= _level_value(terms, solution))
        elif status in (cp_model.FEASIBLE, cp_model.UNKNOWN):
            optimal = False
            if status == cp_model.FEASIBLE:
                solution = {v.index: int(solver.value(v)) for v in variables}
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
        raise CpSatFailure(f"CP-SAT found no solution within the time limit of {time_limit} s and the "
                           f"obvious hypothesis is not admissible (time {am.time}; statuses "
                           f"{', '.join(statuses)})")
    cost = tuple((p, _level_value(am.objectives[p], solution)) for p in PRIORITIES)
    values = {atom: solution[v.index] for atom, v in list(am.actions.items()) + list(am.events.items())}
    return LexResult(values, cost, optimal, tuple(statuses))


class CpSatSolver:
    """The CP-SAT backend: ``solve(problem, time_limit=None) -> Hypothesis``.

    Options: ``workers`` (CP-SAT num_workers; 1 for reference runs), ``seed`` (random_seed),
    ``fast_path`` (reserved for later; currently has no effect).
    """

    name = "cpsat"

    def __init__(self, workers: int = 1, seed: int = 0, fast_path: bool = False):
        if workers < 1:
            raise ValueError(f"workers must be >= 1, got {workers}")
        self.workers = workers
        self.seed = seed
        self.fast_path = fast_path

    def solve(self, problem: FrameProblem, time_limit: float | None = None,
              state: EventState | None = None) -> Hypothesis:
        """The best hypothesis; ``state`` (optional) replaces folding problem.history."""
        start = time.perf_counter()
        constants = resolve_constants(problem)
        if state is None:
            state = EventState.from_problem(problem)
        am = build_model(problem, state, constants)
        remaining = None if time_limit is None else time_limit - (time.perf_counter() - start)
        res = solve_lexicographic(am, problem, remaining, self.workers, self.seed)
        t = problem.time
        actions = [a for a, v in res.values.items() if v and a in am.actions]
        events = [f"occurs_at({e},{t})" for e, v in res.values.items() if v and e in am.events]
        return Hypothesis(time=t, actions=tuple(actions), events=tuple(events), cost=res.cost,
                          optimal=res.optimal, backend=self.name,
                          solve_ms=(time.perf_counter() - start) * 1000.0)
