"""Frame-by-frame cross-check of two backends on a tracked sequence.

The tracker runs with the first backend; on every frame the same problem (same event
history) is also solved by the second.  Cost vectors must be equal (both are proven optimal
for the same model); answers should be equal too, since ties are broken canonically.  Where
they differ, the independent checker says which rule separates them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .check import check_answer
from .hypothesis import Hypothesis
from .solvers import Solver, get_solver
from .spec import FrameProblem
from .tracker import track_sequence


@dataclass
class Divergence:
    frame: int
    problem: FrameProblem
    first: Hypothesis
    second: Hypothesis
    explanation: str

    def describe(self) -> str:
        lines = [f"first divergence at frame {self.frame}: {self.explanation}"]
        for h in (self.first, self.second):
            lines.append(f"  {h.backend}: cost {list(h.cost)} optimal={h.optimal}")
            only = sorted(set(h.answer) - set((self.second if h is self.first else self.first).answer))
            lines.append(f"    only here: {' '.join(only) or '-'}")
        return "\n".join(lines)


@dataclass
class DiffReport:
    backends: tuple[str, str]
    frames: int = 0
    cost_equal: int = 0
    answer_equal: int = 0
    ties: int = 0
    """Frames whose answers differ but have equal costs and both pass the checker."""
    not_optimal: int = 0
    violations: int = 0
    """Rule violations the independent checker finds in either backend's answers (every frame)."""
    checked: int = 0
    """Answers passed through the checker (two per frame)."""
    first_divergence: Divergence | None = None
    divergences: list[int] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.cost_equal == self.frames and self.violations == 0

    def add(self, other: "DiffReport") -> None:
        for name in ("frames", "cost_equal", "answer_equal", "ties", "not_optimal", "violations", "checked"):
            setattr(self, name, getattr(self, name) + getattr(other, name))
        self.divergences += other.divergences
        self.first_divergence = self.first_divergence or other.first_divergence

    def summary(self) -> str:
        a, b = self.backends
        return (f"{a} vs {b}: {self.frames} frames compared, {self.cost_equal} equal cost vectors, "
                f"{self.answer_equal} equal answers, {self.ties} ties (different answers, equal cost, "
                f"both valid), {self.violations} rule violations in {self.checked} checked answers, "
                f"{self.not_optimal} not proven optimal")


def _explain(problem: FrameProblem, first: Hypothesis, second: Hypothesis) -> tuple[str, int]:
    reports = [check_answer(problem, h) for h in (first, second)]
    broken = [f"{h.backend} breaks {', '.join(sorted({v.rule for v in r.violations}))}"
              for h, r in zip((first, second), reports) if r.violations]
    if broken:
        return "; ".join(broken), sum(len(r.violations) for r in reports)
    for (p, v1), (_, v2) in zip(first.cost, second.cost):
        if v1 != v2:
            worse = first if v1 > v2 else second
            return (f"both answers pass every rule; {worse.backend}'s is worse at priority {p} "
                    f"({max(v1, v2)} vs {min(v1, v2)}), so it is not optimal"), 0
    return "equal costs, both valid: a tie the canonical tie-break did not separate", 0


def diff_sequence(seq, backends: tuple[str, str] = ("cpsat", "clingo"), constants=None,
                  solvers: tuple[Solver, Solver] | None = None) -> DiffReport:
    """Track seq with backends[0], re-solving each frame with backends[1]."""
    first, second = solvers or (get_solver(backends[0]), get_solver(backends[1]))
    report = DiffReport(backends)

    def observe(problem: FrameProblem, hyp: Hypothesis) -> None:
        other = second.solve(problem)
        report.frames += 1
        report.not_optimal += (not hyp.optimal) + (not other.optimal)
        same_cost = hyp.cost == other.cost
        same_answer = hyp.answer == other.answer
        report.cost_equal += same_cost
        report.answer_equal += same_answer
        checks = [check_answer(problem, h) for h in (hyp, other)]
        report.checked += 2
        violations = sum(len(c.violations) + (c.cost != h.cost) for c, h in zip(checks, (hyp, other)))
        report.violations += violations
        if same_answer and not violations:
            return
        explanation, _ = _explain(problem, hyp, other)
        if same_cost and not violations:
            report.ties += 1
        report.divergences.append(problem.time)
        if report.first_divergence is None:
            report.first_divergence = Divergence(problem.time, problem, hyp, other, explanation)

    track_sequence(seq, backends[0], constants=constants, observer=observe, solver=first)
    return report
