"""The ASP backend: the paper's answer set program (model/*.lp) solved with clingo.

One frame problem in, one Hypothesis out.  clingo is imported when a ClingoSolver is
constructed, never when refimpl is imported, so refimpl works without the 'asp' extra.

clingo options (fixed, so that a run is reproducible):

* ``--opt-mode=opt``          lexicographic optimisation: find improving models until one is
                              proven optimal (clingo's default for optimisation problems)
* ``--models=0``              no limit on the number of improving models
* ``--configuration=tweety``  one fixed search configuration (instead of 'auto')
* ``--seed=1``                the fixed random seed (clingo's default, written out)
* ``--parallel-mode=N``       N solver threads (default 1: single-threaded, deterministic; with
                              N > 1 clingo races N configurations and the optimal answer found
                              first may differ among equally good ones)
* ``-c name=value``           every model constant (refimpl.constants.resolve_constants), so
                              model/constants.lp gives only the defaults and the problem's
                              ``#const`` lines are not passed in the fact text
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Sequence

from ..constants import model_dir, resolve_constants
from ..hypothesis import PRIORITIES, Hypothesis
from ..spec import FrameProblem
from . import NoAdmissibleHypothesis, SolverUnavailable
from .fallback import obvious_hypothesis
from .common import tiebreak_facts

"""The cost levels of the model (docs/model-spec.md section 5), highest first."""

_INSTALL_HINT = "the clingo backend needs clingo: pip install 'refimpl[asp]'"


def default_model_files() -> tuple[Path, ...]:
    """Every model/*.lp file, constants.lp included (it holds the defaults), in name order."""
    return tuple(sorted(model_dir().glob("*.lp")))


def problem_facts(problem: FrameProblem) -> str:
    """The problem's facts without its #const lines, followed by the tie-break facts."""
    lines = [ln for ln in problem.to_facts().splitlines() if not ln.lstrip().startswith("#const")]
    return "\n".join(lines) + "\n" + tiebreak_facts(problem)


def clingo_arguments(problem: FrameProblem, threads: int = 1) -> list[str]:
    """The clingo command-line options for this problem (see the module docstring)."""
    args = [
        "--opt-mode=opt",
        "--models=0",
        "--configuration=tweety",
        "--seed=1",
        f"--parallel-mode={threads}",
    ]
    for name, value in resolve_constants(problem).items():
        args += ["-c", f"{name}={value}"]
    return args


class _Best:
    """Keeps a copy of the last model clingo reports (the best so far); called from clingo's thread."""

    def __init__(self) -> None:
        self.atoms: list[str] | None = None
        self.cost: dict[int, int] = {}
        self.proven = False
        self.count = 0

    def on_model(self, model) -> None:
        self.atoms = [str(sym) for sym in model.symbols(shown=True)]
        self.cost = dict(zip(model.priority, model.cost))
        self.proven = model.optimality_proven
        self.count += 1


class ClingoSolver:
    """Solves a FrameProblem with clingo and the ASP model in model/*.lp."""

    name = "clingo"

    def __init__(self, threads: int = 1, model_files: Sequence[str | Path] | None = None):
        try:
            import clingo
        except ImportError:
            raise SolverUnavailable(_INSTALL_HINT) from None
        if int(threads) < 1:
            raise ValueError(f"threads must be >= 1, got {threads}")
        self._clingo = clingo
        self.threads = int(threads)
        self.model_files = (
            tuple(Path(p) for p in model_files) if model_files is not None else default_model_files()
        )

    # ------------------------------------------------------------------------------------
    def control(self, problem: FrameProblem, extra: str = ""):
        """A clingo Control with the model and the problem loaded, not yet grounded.

        ``extra`` is more ASP text for the same program (tests use it to force atoms).
        """
        return self._control(problem, extra)[0]

    def _control(self, problem: FrameProblem, extra: str = ""):
        messages: list[str] = []

        def logger(code, message: str) -> None:
            messages.append(" ".join(message.split()))

        ctl = self._clingo.Control(clingo_arguments(problem, self.threads), logger=logger, message_limit=20)
        try:
            for path in self.model_files:
                ctl.load(str(path))
            ctl.add("base", [], problem_facts(problem) + extra)
        except RuntimeError as exc:
            raise RuntimeError(f"clingo could not parse the model: {'; '.join(messages) or exc}") from None
        return ctl, messages

    def solve(self, problem: FrameProblem, time_limit: float | None = None) -> Hypothesis:
        """The optimal hypothesis, or with ``time_limit`` (seconds) the best found in time."""
        started = time.perf_counter()
        deadline = None if time_limit is None else started + max(0.0, float(time_limit))
        ctl, messages = self._control(problem)

        t0 = time.perf_counter()
        try:
            ctl.ground([("base", [])])
        except RuntimeError as exc:
            msgs = "; ".join(messages) or str(exc)
            raise RuntimeError(f"clingo could not ground the model: {msgs}") from None

        best = _Best()
        timed_out = False
        with ctl.solve(on_model=best.on_model, async_=True) as handle:
            if deadline is None:
                handle.wait()
            else:
                finished = False
                while not finished:
                    remaining = deadline - time.perf_counter()
                    if remaining <= 0:
                        break
                    finished = handle.wait(remaining)
                if not finished:
                    handle.cancel()
                    timed_out = True
            result = handle.get()
        solve_ms = (time.perf_counter() - t0) * 1000.0

        if best.atoms is None:
            # an interrupted search says nothing about satisfiability: use the fallback answer
            fallback = obvious_hypothesis(problem, self.name, solve_ms) if timed_out else None
            if fallback is not None:
                return fallback
            if result.unsatisfiable and not timed_out:
                raise NoAdmissibleHypothesis(
                    f"no admissible hypothesis at t={problem.time}: every candidate answer breaks a rule of the model")
            limit = f"{time_limit:g} s" if time_limit is not None else "none"
            raise NoAdmissibleHypothesis(
                f"no hypothesis found at t={problem.time} within the time limit ({limit})")

        optimal = (bool(result.exhausted) and not timed_out) or best.proven
        actions = [a for a in best.atoms if not a.startswith("occurs_at(")]
        events = [a for a in best.atoms if a.startswith("occurs_at(")]
        cost = tuple((p, best.cost.get(p, 0)) for p in PRIORITIES)
        return Hypothesis(
            time=problem.time,
            actions=tuple(actions),
            events=tuple(events),
            cost=cost,
            optimal=optimal,
            backend=self.name,
            solve_ms=solve_ms,
        )
