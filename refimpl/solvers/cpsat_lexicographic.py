"""The lexicographic solve of the CP-SAT abduction model (refimpl.solvers.cpsat_model builds it).

``solve_lexicographic`` minimises one objective per level of PRIORITIES, highest first, each
level fixed at its optimum before the next: levels packed into one objective only within
OBJECTIVE_BITS, the tie-break's pair part cut into chunks that fit it, a level too large for
CP-SAT's doubles certified in exact integer arithmetic, a level without time answered by the
fallback (``_trivial_solution``).  The contract is in refimpl/solvers/cpsat.py.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Mapping, Sequence

# OR-Tools is imported where a model is solved (solve_lexicographic's helpers), not here: see
# refimpl.solvers.cpsat_model.
if TYPE_CHECKING:
    from ortools.sat.python import cp_model

from ..core.hypothesis import PRIORITIES, TIEBREAK_LEVEL
from ..core.spec import FrameProblem, parse_atom
from . import NoAdmissibleHypothesis, SolveTimeout
from .cpsat_matching import UPPER, PairStructure, lexmin_pairs, pair_structure
from .cpsat_model import EXPLANATION, OBJECTIVE_BITS, PAIR_ORDER, AbductionModel, CpSatFailure
from .fallback import obvious_answer

@dataclass(frozen=True)
class LexResult:
    values: dict[str, int]
    """atom (action or event) -> 0/1 in the final solution."""
    cost: tuple[tuple[int, int], ...]
    optimal: bool
    statuses: tuple[str, ...]
    """CP-SAT's status name per level; SKIPPED: the level has no terms; NO_TIME: the time limit
    was used up before the level; BOUND: the solution so far already has the level's lower bound 0 (all coefficients > 0);
    CERTIFIED / UNCERTIFIED: a level too large for CP-SAT's doubles whose OPTIMAL was (or, out of
    time, was not) confirmed in exact arithmetic (_certify); UNIQUE: a chunk of the tie-break's
    pair part not solved because no other set of pair actions is optimal at levels 10..1
    (_only_pair_set); MATCHED: one whose pairs the alternating cycles of cpsat_matching decided
    (proven as the chunk's solve would be)."""


def _solution(solver: cp_model.CpSolver, indices: list[int]) -> dict[int, int]:
    """var index -> value of the solver's last solution (read from the response in one go)."""
    values = solver.response_proto.solution
    return {i: int(values[i]) for i in indices}


def _level_value(terms: list[tuple[int, cp_model.IntVar]], values: Mapping[int, int]) -> int:
    return sum(c * values[v.index] for c, v in terms)


def _trivial_solution(am: AbductionModel, problem: FrameProblem) -> dict[int, int] | None:
    """The obvious answer (fallback.obvious_answer: everything ignored or halted) as a solution of
    the model, found without search; None if the model has no variable for one of its atoms (some
    active track cannot be halted)."""
    actions, events = obvious_answer(problem)
    if am.witness:  # its tracks assigned, not halted; its detections assigned, not ignored
        taken = {x for pair in am.witness for x in pair}
        actions = tuple(a for a in actions if parse_atom(a).arg_names[0] not in taken) + tuple(
            f"assign({t},{d})" for t, d in am.witness)
        events = tuple(e for e in events if parse_atom(e).arg_names[0] not in taken)
    if not all(a in am.actions for a in actions) or not all(e in am.events for e in events):
        return None
    chosen = set(actions) | set(events)
    return {v.index: int(atom in chosen) for atom, v in list(am.actions.items()) + list(am.events.items())}


LevelTerms = list[tuple[int, "cp_model.IntVar"]]

def _range(terms: LevelTerms) -> int:
    """max - min + 1 of a level's sum over 0/1 variables."""
    return sum(abs(c) for c, _ in terms) + 1


def _pack_levels(levels: list[tuple[int, LevelTerms]],
                 bits: int = OBJECTIVE_BITS) -> list[list[tuple[int, LevelTerms]]]:
    """Consecutive levels grouped so that each group's scalarised objective (below) spans at most
    2^bits values: one CP-SAT solve per group instead of per level.  A level whose own range
    exceeds 2^bits is a group of its own (solved, then certified: ``_certify``)."""
    groups: list[list[tuple[int, LevelTerms]]] = []
    span = 0
    for prio, terms in levels:
        r = _range(terms)
        if groups and span * r <= (1 << bits):
            groups[-1].append((prio, terms))
            span *= r
        else:
            groups.append([(prio, terms)])
            span = r
    return groups


def _span(group: list[tuple[int, LevelTerms]]) -> int:
    """The product of the group's ranges: |scalarised objective| < this (telescoping sum)."""
    out = 1
    for _, terms in group:
        out *= _range(terms)
    return out


def _scalarised(group: list[tuple[int, LevelTerms]]) -> LevelTerms:
    """One objective whose order is the group's lexicographic order: level i is weighted by the
    product of the ranges of the levels after it, which exceeds any difference those can make."""
    out: LevelTerms = []
    weight = 1
    for _, terms in reversed(group):
        out += [(c * weight, v) for c, v in terms]
        weight *= _range(terms)
    return out


def _chunk_pairs(pair_terms: LevelTerms, bits: int = OBJECTIVE_BITS) -> list[LevelTerms]:
    """The tie-break's pair part (coefficients 2^q) as levels, most significant first: 2^q goes to
    chunk q // width with coefficient 2^(q % width).  With n terms and width = bits - bitlength(n),
    a chunk's range is below n * 2^width < 2^bits.  Comparing the chunks one after another finds
    the same optimum as comparing the integers (docs/model.md 2.7: within a component the powers
    are distinct, so no chunk carries; components add up independently)."""
    width = max(1, bits - max(len(pair_terms), 1).bit_length())
    chunked: dict[int, LevelTerms] = {}
    for c, v in pair_terms:
        q = c.bit_length() - 1
        chunked.setdefault(q // width, []).append((1 << (q % width), v))
    return [chunked[j] for j in sorted(chunked, reverse=True)]


def _new_solver(workers: int, seed: int, seconds: float | None) -> cp_model.CpSolver:
    from ortools.sat.python import cp_model  # heavy: only when the full model is solved (see the imports)
    solver = cp_model.CpSolver()
    solver.parameters.num_workers = workers
    solver.parameters.random_seed = seed
    solver.parameters.catch_sigint_signal = False  # Ctrl-C interrupts refimpl, not just this level
    if seconds is not None:
        solver.parameters.max_time_in_seconds = seconds
    return solver


def _hint(model: cp_model.CpModel, indices: list[int], solution: Mapping[int, int]) -> None:
    """The solution as a complete hint (the same as add_hint per variable, in one go)."""
    model.clear_hints()
    hint = model.proto.solution_hint
    hint.vars.extend(indices)
    hint.values.extend(solution[i] for i in indices)


def _certify(model: cp_model.CpModel, terms: LevelTerms, solution: dict[int, int], indices: list[int],
             workers: int, seed: int, deadline: float | None) -> tuple[bool, dict[int, int]]:
    """(proven, best solution) for an objective too large for CP-SAT's doubles after CP-SAT
    reported ``solution`` OPTIMAL: ask, without any objective, for a solution strictly below it
    (a pure integer feasibility question, exact in 64 bits) until there is none.  The constraint
    added last is relaxed to ``<= best`` afterwards, so the model keeps only valid bounds."""
    from ortools.sat.python import cp_model  # heavy: only when the full model is solved (see the imports)
    model.clear_objective()
    expr = sum(c * v for c, v in terms)
    while True:
        best = _level_value(terms, solution)
        model.add(expr <= best - 1)
        bound = model.proto.constraints[len(model.proto.constraints) - 1].linear.domain
        left = None if deadline is None else deadline - time.perf_counter()
        status = cp_model.UNKNOWN
        if left is None or left > 0:
            _hint(model, indices, solution)
            solver = _new_solver(workers, seed, left)
            status = solver.solve(model)
        bound[len(bound) - 1] = best
        if status == cp_model.INFEASIBLE:
            return True, solution
        if status not in (cp_model.OPTIMAL, cp_model.FEASIBLE):
            return False, solution
        solution = _solution(solver, indices)


def _fix_levels(model: cp_model.CpModel, group: list[tuple[int, LevelTerms]], solution: Mapping[int, int]) -> None:
    """Every level of a group solved to optimality, fixed at its value (as ``<=``, see below)."""
    for _, terms in group:
        if terms:
            model.add(sum(c * v for c, v in terms) <= _level_value(terms, solution))


UNIQUE_CHECK_CHUNKS = 2
"""The pair part must need at least this many objectives of its own before solve_lexicographic
asks _only_pair_set instead (a question costs one to a few solves; below this, all levels are
packed in one sequence as they always were: a small component keeps its 1-3 solves)."""


def objective_plan(am: AbductionModel, bits: int = OBJECTIVE_BITS,
                   unique_pairs: bool = True) -> tuple[list[list[tuple[int, LevelTerms]]], ...]:
    """(levels 10..1, the tie-break's pair part in chunks (_chunk_pairs), its explanation part),
    each packed on its own (_pack_levels), so that no objective straddles two of them, when the
    chunks need UNIQUE_CHECK_CHUNKS objectives or more (and ``unique_pairs``); otherwise
    (everything packed in one sequence, [], []): no question is asked."""
    upper = [(p, am.objectives[p]) for p in PRIORITIES if p != TIEBREAK_LEVEL]
    pairs = am.objectives.get(PAIR_ORDER) or am.objectives[TIEBREAK_LEVEL]
    chunks = [(TIEBREAK_LEVEL, chunk) for chunk in _chunk_pairs(pairs, bits)]
    lower = [(TIEBREAK_LEVEL, am.objectives.get(EXPLANATION, []))]
    packed = _pack_levels(chunks, bits) if chunks else []
    if not unique_pairs or len(packed) < UNIQUE_CHECK_CHUNKS:
        return _pack_levels(upper + chunks + lower, bits), [], []
    return _pack_levels(upper, bits), packed, [lower]


def _only_pair_set(fresh: cp_model.CpModel, upper: list[list[tuple[int, LevelTerms]]],
                   pair_vars: Sequence[cp_model.IntVar], solution: Mapping[int, int], workers: int,
                   seed: int, deadline: float | None, bits: int) -> bool:
    """Whether ``solution``'s pair actions are the only set among the optima of levels 10..1 (then
    every chunk of the pair part is optimal as it stands; docs/model.md 2.7, step 4).  ``fresh``,
    the model before any level was fixed, gets the clause "some pair action differs"; levels 10..1
    are minimised on it group by group, each fixed at ``solution``'s value while it ties.  A
    minimum above it, or no solution, proves uniqueness; False: a tie on every level, or no time."""
    from ortools.sat.python import cp_model  # heavy: only when the full model is solved (see the imports)
    var = fresh.get_bool_var_from_proto_index
    fresh.add_bool_or([var(v.index).Not() if solution[v.index] else var(v.index) for v in pair_vars])
    for group in upper:
        terms = [(c, var(v.index)) for c, v in _scalarised(group)]
        if not terms:
            continue
        if _span(group) > (1 << bits):  # CP-SAT's minimum is not exact there: conclude nothing
            return False
        best = _level_value(terms, solution)
        left = None if deadline is None else deadline - time.perf_counter()
        if left is not None and left <= 0:
            return False
        fresh.clear_objective()
        expr = sum(c * v for c, v in terms)
        fresh.minimize(expr)
        solver = _new_solver(workers, seed, left)
        status = solver.solve(fresh)
        if status == cp_model.INFEASIBLE:
            return True
        if status != cp_model.OPTIMAL:
            return False
        if _level_value(terms, _solution(solver, [v.index for _, v in terms])) > best:
            return True
        fresh.add(expr <= best)
    return False


class _Levels:
    """One lexicographic solve under way: the model with every level solved so far fixed, the best
    solution so far (var index -> value), whether each level so far was proven optimal, and the
    status of each (LexResult.statuses)."""

    def __init__(self, am: AbductionModel, problem: FrameProblem, deadline: float | None, workers: int,
                 seed: int, bits: int):
        self.am, self.problem, self.model = am, problem, am.model
        self.deadline, self.workers, self.seed, self.bits = deadline, workers, seed, bits
        self.indices = [v.index for v in am.all_vars()]
        self.solution: dict[int, int] | None = None
        self.optimal = True
        self.statuses: list[str] = []

    def pairs_unique(self, fresh: cp_model.CpModel, upper: list[list[tuple[int, LevelTerms]]],
                     pair_terms: LevelTerms, after: int) -> bool:
        """Whether the solution's pair actions are the only optimal set of levels 10..1
        (_only_pair_set, given its even share of the time left with the ``after`` objectives
        after the chunks); if so they are fixed."""
        assert self.solution is not None
        now = time.perf_counter()
        until = None if self.deadline is None else now + (self.deadline - now) / (1 + after)
        if not _only_pair_set(fresh, upper, [v for _, v in pair_terms], self.solution, self.workers, self.seed,
                              until, self.bits):
            return False
        for _, v in pair_terms:
            self.model.add(v == self.solution[v.index])
        return True

    def pairs_matched(self, st: PairStructure, pair_terms: LevelTerms, chunks: int) -> bool:
        """The pair part's minimum among the optima of levels 10..1 by cpsat_matching (instead of
        ``chunks`` solves), fixed, with the whole answer it gives as the solution; out of time, the
        solution's pairs fixed, not proven (NO_TIME).  False: the matching does not apply (the
        chunks are solved)."""
        assert self.solution is not None
        choice = lexmin_pairs(st, self.solution, self.deadline)
        if choice is None:
            return False
        values, status = choice.values, "MATCHED"
        if values is None:
            self.optimal = False
            values, status = self.solution, "NO_TIME"
        elif any(_level_value(self.am.objectives[p], values) != _level_value(self.am.objectives[p], self.solution)
                 for p in UPPER):
            return False  # not the levels CP-SAT proved: never the case if the structure holds
        for _, v in pair_terms:
            self.model.add(v == values[v.index])
        self.solution = values
        self.statuses += [status] * chunks
        return True

    def minimise(self, group: list[tuple[int, LevelTerms]], left: int) -> None:
        """Solve one group's objective with the time left shared over the ``left`` objectives
        still to solve (this one included), then fix it (``_settle``)."""
        from ortools.sat.python import cp_model  # heavy: only when the full model is needed (see the imports)
        terms = _scalarised(group)
        expr = sum(c * v for c, v in terms) if terms else 0
        if not terms and self.solution is not None:
            self.statuses.append("SKIPPED")
            return
        if self.solution is not None and all(c > 0 for c, _ in terms) and _level_value(terms, self.solution) == 0:
            self.model.add(expr == 0)
            self.statuses.append("BOUND")
            return
        status = None
        share = None
        if self.deadline is not None:
            share = (self.deadline - time.perf_counter()) / left
            if share <= 0:
                status = cp_model.UNKNOWN  # no time left for this level
        if status is None:
            status, name = self._solve(group, terms, expr, share)
        else:
            name = "NO_TIME"
        self.statuses.append(name)
        self._settle(group, terms, expr, status, name)

    def _solve(self, group: list[tuple[int, LevelTerms]], terms: LevelTerms, expr,
               share: float | None) -> tuple[int, str]:
        """CP-SAT's status of one objective and its name (CERTIFIED / UNCERTIFIED for an objective
        too large for its doubles: _certify), the solution kept when there is one."""
        from ortools.sat.python import cp_model  # heavy: only when the full model is needed (see the imports)
        model = self.model
        solver = _new_solver(self.workers, self.seed, share)
        model.clear_objective()
        if terms:
            model.minimize(expr)
        if self.solution is not None:
            _hint(model, self.indices, self.solution)
        else:
            model.clear_hints()
        status = solver.solve(model)
        name = solver.status_name(status)
        if status == cp_model.OPTIMAL:
            self.solution = _solution(solver, self.indices)
            if _span(group) > (1 << self.bits):  # CP-SAT's OPTIMAL is not exact here
                proven, self.solution = _certify(model, terms, self.solution, self.indices, self.workers,
                                                 self.seed, self.deadline)
                status, name = (cp_model.OPTIMAL, "CERTIFIED") if proven else (cp_model.FEASIBLE, "UNCERTIFIED")
        elif status == cp_model.FEASIBLE:
            self.solution = _solution(solver, self.indices)
        return status, name

    def _settle(self, group: list[tuple[int, LevelTerms]], terms: LevelTerms, expr, status: int,
                name: str) -> None:
        """A level proven optimal fixed at its value; one not proven bounded by the best solution
        so far (the obvious hypothesis standing in when there is none yet); INFEASIBLE and
        MODEL_INVALID raised."""
        from ortools.sat.python import cp_model  # heavy: only when the full model is needed (see the imports)
        am, model, prio = self.am, self.model, group[0][0]
        if status == cp_model.OPTIMAL:
            assert self.solution is not None
            _fix_levels(model, group, self.solution)
        elif status in (cp_model.FEASIBLE, cp_model.UNKNOWN):
            self.optimal = False
            if self.solution is None:
                self.solution = _trivial_solution(am, self.problem)
            if self.solution is not None and terms:
                model.add(expr <= _level_value(terms, self.solution))
        elif status == cp_model.INFEASIBLE:
            if self.solution is None:
                raise NoAdmissibleHypothesis(
                    f"no hypothesis satisfies the model at time {am.time} (CP-SAT: INFEASIBLE)")
            raise CpSatFailure(f"level {prio} became INFEASIBLE after a solution was fixed (time {am.time})")
        else:  # MODEL_INVALID
            raise CpSatFailure(f"CP-SAT status {name} at level {prio} "
                               f"(time {am.time}): {model.validate()}")

    def result(self, time_limit: float | None) -> LexResult:
        """The answer: every atom's value, the cost vector (level 0 from its two parts)."""
        am, solution = self.am, self.solution
        if solution is None:
            raise SolveTimeout(f"no answer at t={am.time} within the time limit "
                               f"({'none' if time_limit is None else f'{time_limit:g} s'})")
        level0 = (_level_value(am.objectives[TIEBREAK_LEVEL], solution) << am.tiebreak_shift) + _level_value(
            am.objectives.get(EXPLANATION, []), solution)
        cost = tuple((p, level0 if p == TIEBREAK_LEVEL else _level_value(am.objectives[p], solution))
                     for p in PRIORITIES)
        values = {atom: solution[v.index] for atom, v in list(am.actions.items()) + list(am.events.items())}
        return LexResult(values, cost, self.optimal, tuple(self.statuses))


def solve_lexicographic(am: AbductionModel, problem: FrameProblem, time_limit: float | None = None,
                        workers: int = 1, seed: int = 0, objective_bits: int = OBJECTIVE_BITS,
                        unique_pairs: bool = True, matching: bool = True) -> LexResult:
    """Minimise the objectives of PRIORITIES one after another (see the module docstring).

    Each level is solved with the previous level's solution as a complete hint.  A level proven
    OPTIMAL at value V is fixed with ``expr <= V``: since nothing below V is feasible this is the
    equality ``expr == V`` on every solution, and CP-SAT propagates it far better (an equality
    over IoU-sized coefficients is a subset-sum constraint: on a 100-track frame the next levels
    took 1.8 s with ``==`` and 0.09 s with ``<=``).  A level whose coefficients are all positive and whose
    value in the solution so far is 0 is optimal without a solve (0 is its lower bound).

    Every objective CP-SAT minimises spans at most 2^objective_bits values (OBJECTIVE_BITS: exact
    in CP-SAT's doubles); a level larger on its own is certified exactly after CP-SAT's OPTIMAL
    (``_certify``).  ``objective_bits`` exists for tests of that path.

    The pair chunks are not solved (UNIQUE) when ``_only_pair_set`` proves the optima of levels
    10..1 share one pair set; ``unique_pairs=False`` solves them all (tests: same answers).
    Before that, where the model is a matching (cpsat_matching.pair_structure) and ``matching``,
    the chunks are decided by alternating cycles (MATCHED) and the question is not asked.

    With a time limit, the remaining budget is split evenly over the levels still to solve.  A
    level that ends FEASIBLE, or UNKNOWN (no solution in its share), makes the answer not optimal
    and is bounded by "no worse than the best solution so far" (an inequality), so lower levels
    never make a higher one worse.  If the first level finds no solution in time, the obvious
    hypothesis (everything ignored or halted, see _trivial_solution) stands in when it exists.
    """
    deadline = None if time_limit is None else time.perf_counter() + max(0.0, time_limit)
    run = _Levels(am, problem, deadline, workers, seed, objective_bits)
    upper, chunks, lower = objective_plan(am, objective_bits, unique_pairs)
    groups = upper + chunks + lower
    first_chunk, after_chunks = len(upper), len(upper) + len(chunks)
    structure = pair_structure(am) if chunks and matching else None
    # before any level is fixed: _only_pair_set's model
    fresh = am.model.clone() if chunks and structure is None else None
    i = -1
    while i + 1 < len(groups):
        i += 1
        if i == first_chunk and structure is not None and run.optimal and run.solution is not None:
            if run.pairs_matched(structure, am.objectives[TIEBREAK_LEVEL], len(chunks)):
                i = after_chunks - 1
                continue
        if i == first_chunk and fresh is not None and run.optimal and run.solution is not None:
            if run.pairs_unique(fresh, upper, am.objectives[TIEBREAK_LEVEL], len(lower)):
                run.statuses += ["UNIQUE"] * len(chunks)
                i = after_chunks - 1
                continue
        # the objectives left, the pair chunks counted as the one question of _only_pair_set
        # until it was asked
        left = len(groups) - i if i >= first_chunk else first_chunk - i + bool(chunks) + len(lower)
        run.minimise(groups[i], left)
    return run.result(time_limit)
