"""Solver backends: one frame problem (with its event history) in, one Hypothesis out.

Every backend implements ``solve(problem, time_limit=None) -> Hypothesis`` and answers the
same model (docs/model.md).  ``get_solver(name)`` picks one by name.
"""

from __future__ import annotations

from typing import Protocol

from ..hypothesis import Hypothesis
from ..spec import FrameProblem

BACKENDS = ("cpsat", "clingo")


class SolverUnavailable(RuntimeError):
    """The backend's solver library is not installed (e.g. clingo without the 'asp' extra)."""


class NoAdmissibleHypothesis(RuntimeError):
    """The frame problem has no answer that satisfies every rule of the model."""


class Solver(Protocol):
    name: str

    def solve(self, problem: FrameProblem, time_limit: float | None = None) -> Hypothesis:
        """The best hypothesis for the problem; ``optimal`` says whether every level was proven optimal."""
        ...


def get_solver(name: str, **options) -> Solver:
    """A backend by name ('cpsat' or 'clingo')."""
    if name == "cpsat":
        from .cpsat import CpSatSolver
        return CpSatSolver(**options)
    if name == "clingo":
        from .clingo_backend import ClingoSolver
        return ClingoSolver(**options)
    raise ValueError(f"unknown backend {name!r} (choose from {', '.join(BACKENDS)})")
