"""The units of work of the many-sequence commands, as picklable jobs and module-level functions.

Each job carries its input data (a DetectionSequence, a GroundTruth), not file paths, so a
worker on another machine needs no shared file system.  Each function's result depends on its
job only; refimpl.scaleout runs them serially or on a Dask cluster and returns results in input
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

from .io import DetectionSequence, GroundTruth
from .solvers import BASELINE
from .options import TrackerOptions


# ---------------------------------------------------------------------------------------
# track


@dataclass(frozen=True)
class TrackJob:
    seq: DetectionSequence
    backend: str
    time_limit: float | None = None
    check: bool = False
    scene: bool = False
    constants: tuple[tuple[str, int], ...] = ()
    options: TrackerOptions = TrackerOptions()


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


def track_job(job: TrackJob, on_frame: Callable[[], None] | None = None) -> TrackOutput:
    """Track one sequence with the baseline or an abduction backend (optionally checking each answer)."""
    if job.backend == BASELINE:
        from .baseline import track_sequence as sort_track
        return TrackOutput(job.seq.name, sort_track(job.seq), (), len(job.seq.frames))
    from .tracker import track_sequence
    checked = 0
    violations: list[str] = []

    def observe(problem, hyp) -> None:
        nonlocal checked
        if job.check:
            from .check import check_answer
            report = check_answer(problem, hyp)
            checked += 1
            if report.violations or report.cost != hyp.cost:
                found = "; ".join(report.messages) or "the cost vector differs"
                violations.append(f"frame {problem.time}: {found}")
        if on_frame is not None:
            on_frame()

    result = track_sequence(job.seq, backend=job.backend, constants=dict(job.constants) or None,
                            time_limit=job.time_limit, **job.options.kwargs(),
                            observer=observe if (job.check or on_frame is not None) else None)
    scene = None
    if job.scene:
        from .scene import scene_from_result
        scene = scene_from_result(job.seq, result)
    return TrackOutput(job.seq.name, result.rows, result.events, result.frames, result.not_optimal_frames,
                       checked, tuple(violations), scene)


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


def benchmark_job(job: BenchmarkJob) -> BenchmarkOutput:
    """Track one sequence with job.tracker and score it against its ground truth."""
    from .evaluate import evaluate_sequence
    start = time.perf_counter()
    how = job.request
    if how.tracker == BASELINE:
        from .baseline import track_sequence as sort_track
        rows, events = sort_track(job.dets), ()
    else:
        from .tracker import track_sequence
        result = track_sequence(job.dets, backend=how.tracker, constants=dict(how.constants) or None,
                                **how.options.kwargs())
        rows, events = result.rows, result.events
    seconds = time.perf_counter() - start  # tracking only: scoring is not the tracker's time
    metrics = evaluate_sequence(job.gt, rows)
    return BenchmarkOutput(metrics, dict(Counter(e.event.name for e in events)), len(job.dets.frames), seconds)


@dataclass(frozen=True)
class RunRequest:
    """One (dataset, tracker, constants, tracker options) whose every sequence is a task."""

    dataset: str
    sequences: Sequence[tuple[str, DetectionSequence, GroundTruth]]
    tracker: str
    constants: tuple[tuple[str, int], ...] = ()
    options: TrackerOptions = TrackerOptions()


@dataclass(frozen=True)
class RunSummary:
    request_index: int
    per_sequence: dict = field(default_factory=dict)
    overall: dict = field(default_factory=dict)
    events: dict = field(default_factory=dict)
    frames: int = 0
    seconds: float = 0.0
    """Summed tracking seconds of the tasks (not wall time, not scoring)."""


def run_requests(requests: Sequence[RunRequest], plan, label: str = "benchmark",
                 quiet: bool = False) -> list[RunSummary]:
    """Every sequence of every request as one task; per-request scores combined in input order."""
    from .evaluate import combine
    from .scaleout import run_tasks
    jobs = [BenchmarkJob(name, dets, gt, replace(r, sequences=()))
            for r in requests for name, dets, gt in r.sequences]
    outs = run_tasks(benchmark_job, jobs, plan, label=label, quiet=quiet,
                     describe=lambda j: f"{j.request.dataset}/{j.request.tracker}/{j.name}")
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
        summaries.append(RunSummary(i, per_seq, combine(per_seq.values()), dict(events),
                                    sum(o.frames for o in mine), sum(o.seconds for o in mine)))
    return summaries


# ---------------------------------------------------------------------------------------
# diff


@dataclass(frozen=True)
class DiffJob:
    seq: DetectionSequence
    backends: tuple[str, ...]
    time_limit: float | None = 20.0
    """Per-frame limit of every backend (refimpl.diff)."""


def diff_job(job: DiffJob):
    """refimpl.diff.diff_sequence of one sequence (a DiffReport)."""
    from .diff import diff_sequence
    return diff_sequence(job.seq, job.backends, time_limit=job.time_limit)


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
