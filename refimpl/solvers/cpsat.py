"""The abduction model as a CP-SAT model (OR-Tools), optimised lexicographically.

The hypothesis space and the cost vector are those of docs/model-spec.md, the same contract the
ASP encoding (model/*.lp) implements; the event calculus and the events' preconditions come from
refimpl/knowledge/events.py instead of ASP rules.

Model (``build_model``): one Boolean per *candidate* action and per *candidate* event.  A
candidate action passes its integrity constraint (spec section 1) and, if it needs an
explanation, has at least one possible one; a candidate event is possible (``poss``, spec
section 4).  Actions and events that can never hold are simply not created.  Constraints:
exactly one action per track and per detection, and every explanation rule as a linear equality
"sum of the action's explaining events == the action" (which also forbids events without their
action).

Solving (``solve_lexicographic``): one objective per level of ``PRIORITIES``, priority by priority (10, 5, 3, 2, 1, 0):
solve, fix the level at its optimum (as the bound ``objective <= optimum``, equivalent to the
equality), hint the solution to the next level.  A level is
proven only if CP-SAT answers OPTIMAL; anything less is reported as ``optimal=False``.

Fast exact path (``solve_fast``, on by default: ``CpSatSolver(fast_path=True)``): the model above
is a bipartite matching with lexicographic costs, solved exactly in Python component by
component, and only when its optimum is unique; otherwise (ties, inadmissible tracks, huge
components) the full CP-SAT model above answers.  See the section "The fast exact path" in
refimpl/solvers/fast_path.py and docs/benchmarks.md for why this gives the identical hypothesis.

Modules: this one holds the backend class ``CpSatSolver``; refimpl/solvers/cpsat_model.py
``build_model`` (the admissibility functions it reads are refimpl/solvers/admissibility.py);
refimpl/solvers/cpsat_lexicographic.py ``solve_lexicographic``; refimpl/solvers/fast_path.py
``solve_fast``; refimpl/solvers/trackwise_state.py ``TrackwiseState``.  Every name of these is
importable from here.
"""

from __future__ import annotations

import time
from collections import Counter

from ..core.constants import resolve_constants
from ..knowledge.events import EventState
from ..core.hypothesis import PRIORITIES, TIEBREAK_LEVEL, Hypothesis
from ..core.spec import FrameProblem
from . import CPSAT, CPSAT_FULL, NoAdmissibleHypothesis, SolveTimeout, Solver, check_time_limit, effective_limit  # noqa: F401
from .common import tiebreak_level
from .cpsat_model import (  # noqa: F401  (re-exported: refimpl.solvers.cpsat is the public name)
    _EVENT_AT,
    _TIE_AT,
    EXPLANATION,
    OBJECTIVE_BITS,
    AbductionModel,
    CpSatFailure,
    _cost,
    _explanations,
    _hidden,
    _overlapping_top_matrix,
    _pair_candidates,
    build_model,
)
from .cpsat_lexicographic import (  # noqa: F401  (re-exported)
    LevelTerms,
    LexResult,
    _certify,
    _chunk_pairs,
    _fix_levels,
    _level_value,
    _pack_levels,
    _range,
    _scalarised,
    _span,
    _solution,
    _trivial_solution,
    solve_lexicographic,
)
from .admissibility import (  # noqa: F401  (re-exported)
    assignment_constraints,
    match_type,
    resume_constraints,
    start_constraints,
)
from .cpsat_certificate import prune
from .decompose import DEFAULT_PART_NODES, Part, own_atoms, split
from .fallback import obvious_hypothesis
from .fast_path import (  # noqa: F401  (re-exported)
    FAST_PATH_MAX_COMPONENT,
    FastAnswer,
    FastPathDeclined,
    _best_solo,
    _cheapest,
    _max_weight_matching,
    _Option,
    _unique_optimum,
    solve_fast,
)
from .trackwise_state import TrackwiseState  # noqa: F401  (re-exported)

class CpSatSolver(Solver):
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
                 part_nodes: int = DEFAULT_PART_NODES, name: str | None = None):
        if workers < 1:
            raise ValueError(f"workers must be >= 1, got {workers}")
        self.workers = workers
        self.seed = seed
        self.fast_path = fast_path
        self.decompose = decompose
        self.part_nodes = int(part_nodes)
        self.name = name if name is not None else (CPSAT if fast_path else CPSAT_FULL)
        """The registry name it answers under (``get_solver`` passes its entry's; built directly,
        the name of the entry with these options)."""
        if not fast_path:
            # the full model needs OR-Tools on every frame: import it now, with the backend, not in
            # the middle of a run (a Ctrl-C landing inside a C extension's import becomes an
            # ImportError, not the KeyboardInterrupt that ends a command cleanly)
            from ortools.sat.python import cp_model  # noqa: F401
        self.stats: Counter[str] = Counter()
        self._state_cache: dict[str, tuple[tuple, tuple[EventState, dict]]] = {}

    def _fallback(self, problem: FrameProblem, start: float, time_limit: float | None) -> Hypothesis:
        self.stats["timeout"] += 1
        h = obvious_hypothesis(problem, self.name, (time.perf_counter() - start) * 1000.0)
        if h is None:
            raise SolveTimeout(f"no answer at t={problem.time} within the time limit ({time_limit:g} s)")
        return h

    def solve(self, problem: FrameProblem, time_limit: float | None = None,
              state: EventState | None = None, budget: float | None = None) -> Hypothesis:
        """The best hypothesis; ``state`` (optional) replaces folding problem.history; ``budget``:
        the frame budget's seconds left (refimpl.solvers: the full model stops there, the fast
        path's answer is kept however late)."""
        start = time.perf_counter()
        time_limit = check_time_limit(time_limit)
        limit = effective_limit(time_limit, budget)
        hard = None if time_limit is None else start + time_limit  # a fast answer after it is not used
        deadline = None if limit is None else start + limit  # where the search stops
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
                if hard is not None and time.perf_counter() > hard:
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
                return self._fallback(problem, start, limit)
            am = build_model(part.problem, state, constants)
            prune(am, part.problem)  # the level-10 certificate where it checks (cpsat_certificate)
            # all that is left after building the model (a dense crowd's takes seconds, and it
            # counts): most parts are trivial
            share = None if deadline is None else max(0.0, deadline - time.perf_counter())
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
        # one part: the model's own level 0, from the same weights (tiebreak_weights of the problem)
        level0 = totals[TIEBREAK_LEVEL] if whole else tiebreak_level(problem, actions, events)
        cost = tuple((p, level0 if p == TIEBREAK_LEVEL else totals[p]) for p in PRIORITIES)
        return Hypothesis(time=t, actions=tuple(actions), events=tuple(events), cost=cost,
                          optimal=optimal, backend=self.name,
                          solve_ms=(time.perf_counter() - start) * 1000.0)
