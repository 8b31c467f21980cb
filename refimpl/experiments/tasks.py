"""The units of work of the many-sequence commands, as picklable jobs and module-level functions.

Each job carries its input data (a DetectionSequence, a GroundTruth), not file paths, so a
worker on another machine needs no shared file system.  Each function's result depends on its
job only; refimpl.experiments.scaleout runs them serially or on a Dask cluster and returns results in input
order, and the commands write from those results only, so outputs are the same bytes either way.

* ``track_job``: one sequence tracked (``refimpl track`` with several ``--dets``);
* ``benchmark_job``: one sequence tracked and scored (``benchmark``, ``table6``, ``sweep``);
* ``diff_job``: one sequence tracked with one backend and re-solved with the other (``diff``).
"""

from __future__ import annotations

import os
import time
from collections import Counter
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable, Mapping, Sequence

import numpy as np

from ..io import DetectionSequence, GroundTruth
from ..tracking.options import TrackerOptions
from ..tracking.pipeline import NONE, Setup, run_sequence
from ..solvers import BASELINE
from ..solvers.asp_model import AspModel


# ---------------------------------------------------------------------------------------
# track


@dataclass(frozen=True)
class TrackJob:
    seq: DetectionSequence
    setup: Setup
    check: bool = False
    scene: bool = False


@dataclass(frozen=True)
class TrackOutput:
    name: str
    rows: np.ndarray
    """(n, 6) MOT rows frame, id, x, y, w, h."""
    events: tuple
    frames: int
    not_optimal_frames: int = 0
    checked: int = 0
    violations: tuple[str, ...] = ()
    """One line per frame whose answer broke a rule (with --check)."""
    scene: object | None = None


class AnswerCheck:
    """The independent checker on every frame's answer (``--check``): counts and one line per
    frame whose answer breaks a rule or whose cost vector differs (refimpl.solvers.check)."""

    def __init__(self, report: Callable[[str], None] | None = None) -> None:
        self.checked = 0
        self.violations: list[str] = []
        self.report = report

    def __call__(self, problem, hyp) -> None:
        from ..solvers.check import check_answer
        found = check_answer(problem, hyp)
        self.checked += 1
        if found.violations or found.cost != hyp.cost:
            line = f"frame {problem.time}: {'; '.join(found.messages) or 'the cost vector differs'}"
            self.violations.append(line)
            if self.report is not None:
                self.report(line)


def track_job(job: TrackJob, on_frame: Callable[[], None] | None = None) -> TrackOutput:
    """Track one sequence through the pipeline (optionally checking each answer)."""
    check = AnswerCheck() if job.check and not job.setup.baseline else None
    result = run_sequence(job.seq, job.setup, observer=check, on_frame=on_frame)
    scene = None
    if job.scene and not job.setup.baseline:
        from ..scene import scene_from_result
        scene = scene_from_result(job.seq, result)
    return TrackOutput(job.seq.name, result.rows, result.events, result.frames, result.not_optimal_frames,
                       check.checked if check else 0, tuple(check.violations) if check else (), scene)


# ---------------------------------------------------------------------------------------
# benchmark / table6 / sweep


@dataclass(frozen=True)
class BenchmarkJob:
    """One sequence of a RunRequest: tracked as the request says, then scored."""

    name: str
    dets: DetectionSequence
    gt: GroundTruth
    request: RunRequest
    """Its request without the sequences (what a worker needs to know, nothing more)."""


@dataclass(frozen=True)
class BenchmarkOutput:
    metrics: dict
    events: dict
    """Event name -> count, in order of first occurrence."""
    frames: int
    seconds: float
    rows: np.ndarray | None = None
    """The results rows scored (only when the request keeps them: ``benchmark --results-dir``)."""


def benchmark_job(job: BenchmarkJob, on_frame: Callable[[], None] | None = None) -> BenchmarkOutput:
    """Track one sequence with job.tracker and score it against its ground truth (``on_frame``:
    called once per frame, progress)."""
    from ..evaluation.evaluate import evaluate_sequence
    start = time.perf_counter()
    result = run_sequence(job.dets, job.request.setup, on_frame=on_frame)
    rows, events = result.rows, result.events
    seconds = time.perf_counter() - start  # tracking only: scoring is not the tracker's time
    metrics = evaluate_sequence(job.gt, rows)
    return BenchmarkOutput(metrics, dict(Counter(e.event.name for e in events)), len(job.dets.frames), seconds,
                           rows if job.request.keep_rows else None)


@dataclass(frozen=True)
class RunRequest:
    """One (dataset, tracker, constants, tracker options) whose every sequence is a task."""

    dataset: str
    sequences: Sequence[tuple[str, DetectionSequence, GroundTruth]]
    tracker: str
    constants: tuple[tuple[str, int], ...] = ()
    options: TrackerOptions = TrackerOptions()
    preset: str = NONE
    keep_rows: bool = False
    """Hand every sequence's results rows back (RunSummary.rows)."""

    @property
    def setup(self) -> Setup:
        """What each sequence is tracked with (refimpl.tracking.pipeline)."""
        if self.tracker == BASELINE:
            return Setup(BASELINE)
        return Setup(self.tracker, tuple(self.constants), self.options, None, self.preset)


@dataclass(frozen=True)
class RunSummary:
    request_index: int
    per_sequence: dict = field(default_factory=dict)
    overall: dict = field(default_factory=dict)
    events: dict = field(default_factory=dict)
    frames: int = 0
    seconds: float = 0.0
    """Summed tracking seconds of the tasks (not wall time, not scoring)."""
    rows: dict = field(default_factory=dict)
    """Sequence name -> its results rows, when the request keeps them."""


def run_requests(requests: Sequence[RunRequest], plan, label: str = "benchmark",
                 quiet: bool = False) -> list[RunSummary]:
    """Every sequence of every request as one task; per-request scores combined in input order."""
    from ..evaluation.evaluate import combine
    from .scaleout import run_tasks
    jobs = [BenchmarkJob(name, dets, gt, replace(r, sequences=()))
            for r in requests for name, dets, gt in r.sequences]
    outs = run_tasks(benchmark_job, jobs, plan, label=label, quiet=quiet,
                     describe=lambda j: f"{j.request.dataset}/{j.request.tracker}/{j.name}",
                     steps=lambda j: len(j.dets.frames))
    summaries, k = [], 0
    for i, r in enumerate(requests):
        mine = outs[k:k + len(r.sequences)]
        k += len(r.sequences)
        per_seq: dict[str, dict] = {}
        events: Counter = Counter()
        for (name, _, _), out in zip(r.sequences, mine):
            if name in per_seq:
                raise ValueError(f"sequence name {name!r} given twice")
            per_seq[name] = out.metrics
            events.update(out.events)
        rows = {name: out.rows for (name, _, _), out in zip(r.sequences, mine) if out.rows is not None}
        summaries.append(RunSummary(i, per_seq, combine(per_seq.values()), dict(events),
                                    sum(o.frames for o in mine), sum(o.seconds for o in mine), rows))
    return summaries


# ---------------------------------------------------------------------------------------
# diff


@dataclass(frozen=True)
class DiffJob:
    seq: DetectionSequence
    backends: tuple[str, ...]
    time_limit: float | None = 20.0
    """Per-frame limit of every backend (refimpl.experiments.diff)."""
    asp_model: AspModel | None = None
    """A user's encoding for the clingo backend (refimpl.solvers.asp_model.AspModel), or None."""


def diff_job(job: DiffJob):
    """refimpl.experiments.diff.diff_sequence of one sequence (a DiffReport)."""
    from .diff import diff_sequence
    return diff_sequence(job.seq, job.backends, time_limit=job.time_limit, asp_model=job.asp_model)


def constants_tuple(constants: Mapping[str, int] | None) -> tuple[tuple[str, int], ...]:
    return tuple((str(k), int(v)) for k, v in (constants or {}).items())


def results_file_name(path) -> str:
    """The results file of one input among many: its MOTChallenge sequence folder
    (``.../TUD-Campus/det/det.txt`` -> ``TUD-Campus.txt``) or its file stem (``.../Car/0011.txt``
    -> ``0011.txt``)."""
    p = Path(os.path.abspath(path))  # absolute (a relative det/det.txt), symlinks kept as named
    if p.parent.name == "det" and p.parent.parent.name:
        return f"{p.parent.parent.name}.txt"
    return f"{p.stem}.txt"
