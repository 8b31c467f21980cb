"""Frame-by-frame cross-check of two or three backends on a tracked sequence.

The tracker runs with the first backend; on every frame the same problem (same event history)
is also solved by the others, each with the same per-frame time limit.  On a frame every backend
proved optimal, the cost vectors must be equal (the same model), and so must the answers: under
the canonical tie-break the optimum is unique (refimpl.solvers.common).  A frame some backend did
not prove optimal within the limit is counted as "not proven" and left out of the comparison,
never waited for.  A frame with a component clingo cannot represent (its 32-bit sums,
refimpl.core.ranges.clingo_overflow) is counted as "beyond clingo's range" and not compared either;
the other backends' answers are still checked.  Every answer passes through the independent
checker; where answers differ, the checker says which rule or which cost level separates them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

from ..solvers.check import check_answer
from ..core.hypothesis import Hypothesis
from ..core.ranges import OutOfClingoRange
from ..solvers import ORACLE_PAIR, Solver, get_solver
from ..core.spec import FrameProblem
from ..tracking.pipeline import Setup, run_sequence

DEFAULT_BACKENDS = ORACLE_PAIR
DEFAULT_TIME_LIMIT = 20.0


@dataclass
class Divergence:
    frame: int
    problem: FrameProblem
    answers: tuple[Hypothesis, ...]
    explanation: str

    @property
    def first(self) -> Hypothesis:
        return self.answers[0]

    @property
    def second(self) -> Hypothesis:
        return self.answers[1]

    def describe(self) -> str:
        lines = [f"first divergence at frame {self.frame}: {self.explanation}"]
        ref = set(self.answers[0].answer)
        for k, h in enumerate(self.answers):
            lines.append(f"  {h.backend}: cost {list(h.cost)} optimal={h.optimal}")
            if k:
                lines.append(f"    only in {self.answers[0].backend}: {' '.join(sorted(ref - set(h.answer))) or '-'}")
                lines.append(f"    only here: {' '.join(sorted(set(h.answer) - ref)) or '-'}")
        return "\n".join(lines)


@dataclass
class DiffReport:
    backends: tuple[str, ...]
    frames: int = 0
    proven: int = 0
    """Frames every backend proved optimal within the time limit (the compared frames)."""
    cost_equal: int = 0
    """Of the proven frames: all cost vectors equal."""
    answer_equal: int = 0
    """Of the proven frames: all answers equal."""
    ties: int = 0
    """Proven frames whose answers differ with equal costs, every answer valid (a tie-break failure)."""
    not_proven: int = 0
    """Frames some backend did not prove optimal within the limit (not compared)."""
    out_of_range: int = 0
    """Frames a backend refused because some component is beyond clingo's 32-bit sums (not compared)."""
    out_of_range_parts: int = 0
    """The sub-problems of those frames clingo cannot represent."""
    violations: int = 0
    """Rule violations (or cost vectors the checker does not confirm) in any backend's answers."""
    checked: int = 0
    """Answers passed through the checker."""
    first_divergence: Divergence | None = None
    divergences: list[int] = field(default_factory=list)
    unproven_frames: list[tuple[int, tuple[str, ...]]] = field(default_factory=list)
    """(frame, the backends that did not prove it optimal in time)."""
    out_of_range_frames: list[int] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.cost_equal == self.proven and self.answer_equal == self.proven and self.violations == 0

    def add(self, other: "DiffReport") -> None:
        for name in ("frames", "proven", "cost_equal", "answer_equal", "ties", "not_proven", "out_of_range",
                     "out_of_range_parts", "violations", "checked"):
            setattr(self, name, getattr(self, name) + getattr(other, name))
        self.divergences += other.divergences
        self.unproven_frames += other.unproven_frames
        self.out_of_range_frames += other.out_of_range_frames
        self.first_divergence = self.first_divergence or other.first_divergence

    def summary(self) -> str:
        return (f"{' vs '.join(self.backends)}: {self.frames} frames, {self.proven} proven optimal by every "
                f"backend: {self.cost_equal} equal cost vectors, {self.answer_equal} equal answers, "
                f"{self.ties} ties (different answers, equal cost, all valid); {self.not_proven} not proven "
                f"optimal within the time limit{self._unproven()};{self._out_of_range()} {self.violations} "
                f"rule violations in {self.checked} checked answers")

    def _out_of_range(self) -> str:
        if not self.out_of_range:
            return ""
        shown = ", ".join(str(t) for t in self.out_of_range_frames[:5])
        more = ", ..." if len(self.out_of_range_frames) > 5 else ""
        return (f" {self.out_of_range} beyond clingo's 32-bit range, not compared ({self.out_of_range_parts} "
                f"sub-problems; frame {shown}{more});")

    def _unproven(self) -> str:
        if not self.unproven_frames:
            return ""
        shown = ", ".join(f"{t} ({'+'.join(b)})" for t, b in self.unproven_frames[:5])
        return f" (frame {shown}{', ...' if len(self.unproven_frames) > 5 else ''})"


def _explain(answers: Sequence[Hypothesis]) -> str:
    first = answers[0]
    for other in answers[1:]:
        for (p, v1), (_, v2) in zip(first.cost, other.cost):
            if v1 != v2:
                worse = first if v1 > v2 else other
                return (f"{worse.backend}'s answer is worse at priority {p} ({max(v1, v2)} vs "
                        f"{min(v1, v2)}) although proven optimal")
    return "equal costs, different answers: a tie the canonical tie-break did not separate"


def diff_sequence(seq, backends: Sequence[str] = DEFAULT_BACKENDS, constants=None,
                  solvers: Sequence[Solver] | None = None,
                  time_limit: float | None = DEFAULT_TIME_LIMIT) -> DiffReport:
    """Track seq with backends[0], re-solving each frame with the other backends."""
    backends = tuple(backends)
    solvers = tuple(solvers) if solvers is not None else tuple(get_solver(b) for b in backends)
    report = DiffReport(backends)

    def observe(problem: FrameProblem, hyp: Hypothesis) -> None:
        answers: tuple[Hypothesis, ...] = (hyp,)
        refused = []
        for s in solvers[1:]:
            try:
                answers += (s.solve(problem, time_limit=time_limit),)
            except OutOfClingoRange as exc:
                refused.append(exc)
        report.frames += 1
        checks = [check_answer(problem, h) for h in answers]
        report.checked += len(answers)
        bad = [f"{h.backend} breaks {', '.join(sorted({v.rule for v in c.violations}) or ['cost_vector'])}"
               for c, h in zip(checks, answers) if c.violations or c.cost != h.cost]
        report.violations += sum(len(c.violations) + (c.cost != h.cost) for c, h in zip(checks, answers))
        explanation = "; ".join(bad) if bad else None
        if refused:
            report.out_of_range += 1
            report.out_of_range_parts += sum(exc.components for exc in refused)
            report.out_of_range_frames.append(problem.time)
        elif not all(h.optimal for h in answers):
            report.not_proven += 1
            report.unproven_frames.append((problem.time, tuple(h.backend for h in answers if not h.optimal)))
        else:
            report.proven += 1
            same_cost = all(h.cost == hyp.cost for h in answers)
            same_answer = all(h.answer == hyp.answer for h in answers)
            report.cost_equal += same_cost
            report.answer_equal += same_answer
            if same_cost and not same_answer and not bad:
                report.ties += 1
            if not (same_cost and same_answer) and explanation is None:
                explanation = _explain(answers)
        if explanation is not None:
            report.divergences.append(problem.time)
            if report.first_divergence is None:
                report.first_divergence = Divergence(problem.time, problem, answers, explanation)

    setup = Setup(backends[0], tuple((constants or {}).items()), time_limit=time_limit)
    run_sequence(seq, setup, observer=observe, solver=solvers[0])
    return report
