"""Solver backends: one frame problem (with its event history) in, one Hypothesis out.

The registry ``BACKENDS`` names every backend; ``get_solver(name)`` builds one.  Every command
that takes ``--backend`` / ``--backends`` reads this registry, nowhere else lists them.

* ``cpsat``      the exact fast path (refimpl.solvers.cpsat.solve_fast: a lexicographic
                 bipartite matching in Python) where it applies, the full CP-SAT model where it
                 declines
* ``cpsat-full`` the full CP-SAT model on every frame (the oracle)
* ``clingo``     the paper's answer set program (model/*.lp) with clingo

The full CP-SAT model and the ASP program are solved per independent component of the frame
(refimpl.solvers.decompose), with the same answers; under the canonical tie-break
(refimpl.solvers.common) the optimum is unique, so every backend returns the identical answer.

The time-out contract (every backend)
-------------------------------------
``solve(problem, time_limit=None)``: ``time_limit`` is None (no limit) or a finite number of
seconds >= 0 (anything else: ValueError).  It bounds the whole call: building the problem, the
fast path, CP-SAT's model, clingo's grounding (counted: grounding cannot be stopped half-way
inside a process, so the in-process clingo checks the clock after it, a large part under a limit
goes to clingo's worker process, refimpl.solvers.clingo_worker, and the worker is killed when it
overruns its limit by a second, less under a short limit: clingo_process.grace) and the search;
a call ends within 10 % of its limit + 1 s (tests/test_time_limit.py).  A frame solved in
parts (refimpl.solvers.decompose) gives each part all the time that is left.  Out of time, a backend returns the best answer it
has, flagged ``optimal=False``: the best solution found so far, or, when it found none, the
obvious answer (every detection ignored, every halted track ignored, every active track halted
by missing_detections; refimpl.solvers.fallback).  When not even that answer is admissible it
raises ``SolveTimeout`` (one exception; the CLI prints one line and exits 2).  A frame without
any admissible answer raises ``NoAdmissibleHypothesis``.  ``time_limit=0`` therefore returns the
obvious answer at once.

The frame budget (``solve(problem, time_limit=None, budget=None)``): ``budget`` is None or the
seconds of a frame's budget still left (>= 0; the tracker's ``frame_budget``, refimpl.tracking.tracker):
a soft limit.  The search stops there as at a time limit (CP-SAT's and clingo's: their best answer
so far, flagged ``optimal=False``, or the obvious answer), but an answer the backend has already
*proven* is kept however late it comes: the fast path's (exact, and not interrupted: it returns
or declines), so a frame the fast path answers gets the same answer with any budget.  A time
limit stays hard: a fast answer after it is replaced by the obvious answer (above).  A solver
without a ``budget`` argument is never passed one unless the tracker is given a budget.

Interrupts: a SIGINT during a solve raises KeyboardInterrupt in the caller within a second:
CP-SAT runs with ``catch_sigint_signal=False`` (it does not swallow the signal), clingo's search
runs asynchronously and is polled every 0.1 s, then cancelled.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Protocol

from ..core.errors import UserFacingError
from ..core.hypothesis import Hypothesis
from ..core.loader import load
from ..core.spec import FrameProblem

CPSAT, CPSAT_FULL, CLINGO = "cpsat", "cpsat-full", "clingo"
"""The backend names; the only place they are spelled (``get_solver`` tells a solver its entry's name)."""


@dataclass(frozen=True)
class BackendEntry:
    """One row of the registry: where the solver class lives, its options and how it is shown."""

    name: str
    module: str
    cls: str
    options: Mapping[str, object]
    description: str
    colour: str
    """Its colour in benchmark plots."""
    library: str
    """The Python module it needs (``SolverUnavailable`` without it)."""
    real_time: bool = False
    """Whether a tracker built without a frame budget of its own gets the default one
    (refimpl.tracking.pipeline.DEFAULT_FRAME_BUDGET_MS): the default backend, whose fast path answers
    within it; the oracles are there to prove every frame, however long it takes."""


_REGISTRY: dict[str, BackendEntry] = {e.name: e for e in (
    BackendEntry(CPSAT, "refimpl.solvers.cpsat", "CpSatSolver", {},
                 "exact fast path, the full CP-SAT model where it declines", "tab:blue", "ortools", real_time=True),
    BackendEntry(CPSAT_FULL, "refimpl.solvers.cpsat", "CpSatSolver", {"fast_path": False},
                 "the full CP-SAT model on every frame", "tab:green", "ortools"),
    BackendEntry(CLINGO, "refimpl.solvers.clingo_backend", "ClingoSolver", {},
                 "the ASP program model/*.lp with clingo", "tab:red", "clingo"),
)}

BACKENDS: tuple[str, ...] = tuple(_REGISTRY)
"""Every backend name, in the order the CLI lists them."""

COLOURS: dict[str, str] = {name: entry.colour for name, entry in _REGISTRY.items()}
LIBRARIES: dict[str, str] = {name: entry.library for name, entry in _REGISTRY.items()}
REAL_TIME: frozenset[str] = frozenset(name for name, entry in _REGISTRY.items() if entry.real_time)
"""The backends a default frame budget applies to (BackendEntry.real_time)."""

DEFAULT_BACKEND = CPSAT
"""The backend a tracker runs with unless told otherwise."""
ORACLE_PAIR: tuple[str, str] = (CPSAT_FULL, CLINGO)
"""The two encodings ``refimpl diff`` compares by default: the CP-SAT model on every frame and the ASP program."""
REFERENCE_BACKEND = CLINGO
"""The paper's own encoding: benchmarks give every other backend's speed as a ratio to it."""

BASELINE = "baseline"
"""The paper's baseline tracker (SORT, refimpl.tracking.baseline): a tracker without a solver."""
TRACKERS: tuple[str, ...] = (BASELINE,) + BACKENDS
"""What a tracking command's ``--backend`` accepts: the baseline, or abduction with a backend."""


class SolverUnavailable(RuntimeError, UserFacingError):
    """The backend's solver library is not installed (e.g. clingo without the 'asp' extra)."""


class NoAdmissibleHypothesis(RuntimeError, UserFacingError):
    """The frame problem has no answer that satisfies every rule of the model."""


class SolveTimeout(RuntimeError, UserFacingError):
    """Out of time without any admissible answer (see the time-out contract above)."""


class Solver(Protocol):
    name: str

    def solve(self, problem: FrameProblem, time_limit: float | None = None) -> Hypothesis:
        """The best hypothesis for the problem; ``optimal`` says whether every level was proven
        optimal.  refimpl's backends also take ``budget=`` (the frame budget, above)."""
        ...


def check_time_limit(time_limit: float | None) -> float | None:
    """None, or a finite number of seconds >= 0 (the contract above); ValueError otherwise."""
    if time_limit is None:
        return None
    value = float(time_limit)
    if not math.isfinite(value) or value < 0:
        raise ValueError(f"a time limit must be a finite number of seconds >= 0, got {time_limit!r}")
    return value


def effective_limit(time_limit: float | None, budget: float | None) -> float | None:
    """The sooner of a time limit and a frame budget's time left (both checked: check_time_limit)."""
    time_limit, budget = check_time_limit(time_limit), check_time_limit(budget)
    if budget is None:
        return time_limit
    return budget if time_limit is None else min(time_limit, budget)


def get_solver(backend: str, /, **options) -> Solver:
    """A backend by name (one of BACKENDS); ``options`` go to its constructor, and so does the
    entry's name: the solver answers under the name it was asked by, so an entry wrapping another
    entry's class is told its own (``name=`` in options overrides it: a user's encoding's label)."""
    if backend not in _REGISTRY:
        raise ValueError(f"unknown backend {backend!r} (choose from {', '.join(BACKENDS)})")
    entry = _REGISTRY[backend]
    return load(f"{entry.module}:{entry.cls}")(**{"name": entry.name, **entry.options, **options})
