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

With a user's own ASP encoding (``asp_model``, refimpl.solvers.asp_model) the clingo backend
runs that encoding instead of model/*.lp, on the whole frame (no decomposition: that rests on
properties of refimpl's model a user's encoding need not have), with the constants its files
define, and with the checker's cost vector (refimpl's constants: the reference's).  An encoding
without refimpl's level-0 tie-break is compared on levels 10..1 only: a frame where its valid
answer differs from the others' with equal costs there is a *tie* (an equal-cost choice the
tie-break would decide), counted, not a disagreement.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable, Sequence

from ..solvers.check import check_answer
from ..solvers.check_optimum import FrameOptimum
from ..core.bigint import int_text
from ..core.hypothesis import PRIORITIES, TIEBREAK_LEVEL, Cost, Hypothesis, cost_list_text
from ..core.ranges import OutOfClingoRange
from ..solvers import CLINGO, ORACLE_PAIR, NoAdmissibleHypothesis, Solver, get_solver
from ..solvers.asp_model import AspModel
from ..core.spec import FrameProblem
from ..io import DetectionSequence
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
            lines.append(f"  {h.backend}: cost {cost_list_text(h.cost)} optimal={h.optimal}")
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
    """Proven frames whose answers differ with equal costs, every answer valid: a tie-break failure,
    or, comparing an encoding without the tie-break (levels 10..1), the choice it would decide."""
    disagreements: int = 0
    """Proven frames whose costs differ, or whose answers differ other than by such a tie."""
    levels: tuple[int, ...] = PRIORITIES
    """The cost levels compared (10..1 for a user's encoding without the tie-break)."""
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
    enumerated: int = 0
    """Frames whose every component the checker enumerated (refimpl.solvers.check_optimum)."""
    false_optima: int = 0
    """Answers flagged optimal, rule-abiding, that the checker's enumeration beats (a cheaper
    admissible answer on some component of at most check_optimum.MAX_NODES nodes)."""
    first_divergence: Divergence | None = None
    divergences: list[int] = field(default_factory=list)
    unproven_frames: list[tuple[int, tuple[str, ...]]] = field(default_factory=list)
    """(frame, the backends that did not prove it optimal in time)."""
    out_of_range_frames: list[int] = field(default_factory=list)
    disagreement_frames: list[int] = field(default_factory=list)
    tie_frames: list[int] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.disagreements == 0 and self.violations == 0 and self.false_optima == 0

    def add(self, other: "DiffReport") -> None:
        for name in ("frames", "proven", "cost_equal", "answer_equal", "ties", "disagreements", "not_proven",
                     "out_of_range",
                     "out_of_range_parts", "violations", "checked", "enumerated",
                     "false_optima"):
            setattr(self, name, getattr(self, name) + getattr(other, name))
        self.divergences += other.divergences
        self.unproven_frames += other.unproven_frames
        self.out_of_range_frames += other.out_of_range_frames
        self.disagreement_frames += other.disagreement_frames
        self.tie_frames += other.tie_frames
        self.first_divergence = self.first_divergence or other.first_divergence

    def summary(self) -> str:
        tied = ("different answers, equal cost, all valid" if TIEBREAK_LEVEL in self.levels else
                "different answers, equal cost on levels 10..1, all valid: the tie-break the encoding lacks "
                "would decide, not disagreements")
        on = "" if self.levels == PRIORITIES else f" on levels {self.levels[0]}..{self.levels[-1]}"
        return (f"{' vs '.join(self.backends)}: {self.frames} frames, {self.proven} proven optimal by every "
                f"backend: {self.cost_equal} equal cost vectors{on}, {self.answer_equal} equal answers, "
                f"{self.ties} ties ({tied}); {self.disagreements} disagreements{_frames(self.disagreement_frames)}; "
                f"{self.not_proven} not proven "
                f"optimal within the time limit{self._unproven()};{self._out_of_range()} {self.violations} "
                f"rule violations in {self.checked} checked answers; {self.false_optima} answers flagged optimal that "
                f"the checker's enumeration beats ({self.enumerated} frames enumerated)")

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


def _frames(frames: Sequence[int]) -> str:
    if not frames:
        return ""
    return f" (frame {', '.join(str(t) for t in frames[:8])}{', ...' if len(frames) > 8 else ''})"


def _on(cost: Cost, levels: Sequence[int]) -> Cost:
    return tuple((p, v) for p, v in cost if p in levels)


def _explain(answers: Sequence[Hypothesis], levels: Sequence[int] = PRIORITIES) -> str:
    first = answers[0]
    for other in answers[1:]:
        for (p, v1), (_, v2) in zip(_on(first.cost, levels), _on(other.cost, levels)):
            if v1 != v2:
                worse = first if v1 > v2 else other
                return (f"{worse.backend}'s answer is worse at priority {p} ({int_text(max(v1, v2))} vs "
                        f"{int_text(min(v1, v2))}) although proven optimal")
    return "equal costs, different answers: a tie the canonical tie-break did not separate"


def _answers(problem: FrameProblem, hyp: Hypothesis, others: Sequence[Solver], time_limit: float | None
             ) -> tuple[tuple[Hypothesis, ...], list[OutOfClingoRange], list[str]]:
    """The first backend's answer and every other's on the same frame problem; the refusals of a
    frame beyond clingo's range; the backends that find no admissible answer where the first found one."""
    answers: tuple[Hypothesis, ...] = (hyp,)
    refused = []
    unanswered = []
    for s in others:
        try:
            answers += (s.solve(problem, time_limit=time_limit),)
        except OutOfClingoRange as exc:
            refused.append(exc)
        except NoAdmissibleHypothesis:
            unanswered.append(s.name)
    return answers, refused, unanswered


def _checked(report: DiffReport, problem: FrameProblem, answers: tuple[Hypothesis, ...],
             levels: tuple[int, ...]) -> list[str]:
    """Every answer checked (the rules, its cost vector, and where the components are small enough
    the checker's own optimum against a claim of optimality): what each answer breaks, counted in
    the report."""
    checks = [check_answer(problem, h) for h in answers]
    report.checked += len(answers)
    bad = [f"{h.backend} breaks {', '.join(sorted({v.rule for v in c.violations}) or ['cost_vector'])}"
           for c, h in zip(checks, answers) if c.violations or c.cost != h.cost]
    report.violations += sum(len(c.violations) + (c.cost != h.cost) for c, h in zip(checks, answers))
    claimed = [h for c, h in zip(checks, answers) if h.optimal and c.ok and c.cost == h.cost]
    if claimed:  # the checker's own optimum where the components are small enough
        optimum = FrameOptimum.of(problem)
        report.enumerated += not optimum.skipped
        for h in claimed:
            verdict = optimum.verdict(h, len(levels))
            if verdict.better is not None:
                report.false_optima += 1
                bad.append(f"{h.backend} claims optimal, but {verdict.detail}")
    return bad


def _compared(report: DiffReport, problem: FrameProblem, hyp: Hypothesis, answers: tuple[Hypothesis, ...],
              levels: tuple[int, ...], broken: bool, explanation: str | None) -> str | None:
    """A frame every backend proved optimal: equal costs and answers counted, a tie or a
    disagreement recorded; the explanation of the divergence (that of a broken rule first)."""
    report.proven += 1
    same_cost = all(_on(h.cost, levels) == _on(hyp.cost, levels) for h in answers)
    same_answer = all(h.answer == hyp.answer for h in answers)
    report.cost_equal += same_cost
    report.answer_equal += same_answer
    tie = same_cost and not same_answer and not broken
    report.ties += tie
    if tie:
        report.tie_frames.append(problem.time)
    agree = same_cost and (same_answer or (tie and TIEBREAK_LEVEL not in levels))
    if not agree:
        report.disagreements += 1
        report.disagreement_frames.append(problem.time)
    if not agree and explanation is None:
        explanation = _explain(answers, levels)
    return explanation


def diff_sequence(seq, backends: Sequence[str] = DEFAULT_BACKENDS, constants=None,
                  solvers: Sequence[Solver] | None = None,
                  time_limit: float | None = DEFAULT_TIME_LIMIT, asp_model: AspModel | None = None,
                  on_frame: Callable[[], None] | None = None, setup: Setup | None = None) -> DiffReport:
    """Track seq with backends[0], re-solving each frame with the other backends; with
    ``asp_model`` the clingo backend runs that encoding (module docstring); ``on_frame()`` once
    per frame, when every backend has answered it (progress).  ``setup``: track with a preset's
    setup (its constants and tracker options, e.g. ``setup_for("mot", "pedestrian")``) instead of
    the plain tracker with ``constants``; its backend and time limit are the diff's."""
    backends = tuple(backends)
    levels = PRIORITIES
    if asp_model is not None:
        if CLINGO not in backends:
            raise ValueError(f"a user's encoding runs on the {CLINGO} backend, which is not among {backends}")
        if not asp_model.tiebreak:
            levels = tuple(p for p in PRIORITIES if p != TIEBREAK_LEVEL)
    if solvers is None:
        solvers = tuple(user_solver(asp_model) if asp_model is not None and b == CLINGO else get_solver(b)
                        for b in backends)
    solvers = tuple(solvers)
    report = DiffReport(tuple(s.name for s in solvers) if asp_model is not None else backends, levels=levels)

    def observe(problem: FrameProblem, hyp: Hypothesis) -> None:
        answers, refused, unanswered = _answers(problem, hyp, solvers[1:], time_limit)
        report.frames += 1
        if unanswered:
            report.disagreements += 1
            report.disagreement_frames.append(problem.time)
            report.divergences.append(problem.time)
            if report.first_divergence is None:
                report.first_divergence = Divergence(problem.time, problem, answers,
                                                     f"{', '.join(unanswered)} finds no admissible answer, "
                                                     f"{hyp.backend} does")
        bad = _checked(report, problem, answers, levels)
        explanation = "; ".join(bad) if bad else None
        if refused:
            report.out_of_range += 1
            report.out_of_range_parts += sum(exc.components for exc in refused)
            report.out_of_range_frames.append(problem.time)
        elif unanswered:
            pass  # a disagreement already (above), not compared further
        elif not all(h.optimal for h in answers):
            report.not_proven += 1
            report.unproven_frames.append((problem.time, tuple(h.backend for h in answers if not h.optimal)))
        else:
            explanation = _compared(report, problem, hyp, answers, levels, bool(bad), explanation)
        if explanation is not None:
            report.divergences.append(problem.time)
            if report.first_divergence is None:
                report.first_divergence = Divergence(problem.time, problem, answers, explanation)

    if setup is None:
        setup = Setup(backends[0], tuple((constants or {}).items()), time_limit=time_limit)
    else:
        setup = replace(setup, backend=backends[0], time_limit=time_limit, frame_budget=None)
    run_sequence(seq, setup, observer=observe, solver=solvers[0], on_frame=on_frame)
    return report


def user_solver(asp_model: AspModel) -> Solver:
    """The clingo backend on a user's encoding: the whole frame, the checker's costs, its own label,
    its own constants (refimpl.solvers.asp_model); every solve in clingo's worker process
    (``inline_solves=0``), which is killed at the time limit: grounding cannot be stopped in this
    process, and a user's rule may ground without end on a frame's facts."""
    return get_solver(CLINGO, model_files=asp_model.files, decompose=False, checked_costs=True,
                      name=asp_model.label, own_constants=asp_model.defined, inline_solves=0)


# ---------------------------------------------------------------------------------------
# diff's job for refimpl.runs.scaleout (one sequence, picklable: it carries its data)


@dataclass(frozen=True)
class DiffJob:
    seq: DetectionSequence
    backends: tuple[str, ...]
    time_limit: float | None = 20.0
    """Per-frame limit of every backend (refimpl.runs.diff)."""
    asp_model: AspModel | None = None
    """A user's encoding for the clingo backend (refimpl.solvers.asp_model.AspModel), or None."""
    constants: tuple[tuple[str, int], ...] = ()
    """Model constants on top of model/constants.lp (``refimpl diff --const``)."""


def diff_job(job: DiffJob, on_frame: Callable[[], None] | None = None):
    """diff_sequence of one sequence (a DiffReport); ``on_frame()`` once per frame (progress)."""
    return diff_sequence(job.seq, job.backends, constants=dict(job.constants), time_limit=job.time_limit,
                         asp_model=job.asp_model, on_frame=on_frame)
