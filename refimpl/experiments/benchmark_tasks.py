"""The scored units of work: one sequence of a RunRequest tracked and scored against its ground
truth (``benchmark``, ``table6``, ``sweep``, ``calibrate``), as picklable jobs and a module-level
function, and the requests' scores regrouped from the tasks' results.

Apart from refimpl.runs.tasks (the track and diff jobs) because scoring needs the scorer
and scipy: a worker of ``refimpl track --workers N`` never imports them.  As there, a job carries
its data (detections, ground truth), and its result depends on the job only.
"""

from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass, field, replace
from typing import Callable, Sequence

import numpy as np

from ..evaluation.evaluate import combine, evaluate_sequence
from ..io import DetectionSequence, GroundTruth
from ..solvers import BASELINE
from ..tracking.options import TrackerOptions
from ..tracking.pipeline import NONE, Setup, run_sequence
from ..runs.scaleout import run_tasks
from ..runs.tasks import pack_sequence, unpack_sequence


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

    def __reduce__(self):
        # its detections packed, as a TrackJob's (refimpl.runs.tasks.pack_sequence); the
        # ground truth is a few arrays already
        return _unpack_benchmark_job, (self.name, pack_sequence(self.dets), self.gt, self.request)


def _unpack_benchmark_job(name: str, dets, gt: GroundTruth, request: RunRequest) -> BenchmarkJob:
    return BenchmarkJob(name, unpack_sequence(dets), gt, request)


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
    tuned_fps: float | None = None
    """The frame rate of the preset's durations (refimpl.tracking.pipeline.Setup.tuned_fps)."""
    in_frames: tuple[str, ...] = ()
    keep_rows: bool = False
    """Hand every sequence's results rows back (RunSummary.rows)."""

    @property
    def setup(self) -> Setup:
        """What each sequence is tracked with (refimpl.tracking.pipeline)."""
        if self.tracker == BASELINE:
            return Setup(BASELINE)
        return Setup(self.tracker, tuple(self.constants), self.options, None, self.preset, self.tuned_fps,
                     tuple(self.in_frames))


@dataclass(frozen=True)
class RunSummary:
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
    jobs = [BenchmarkJob(name, dets, gt, replace(r, sequences=()))
            for r in requests for name, dets, gt in r.sequences]
    outs = run_tasks(benchmark_job, jobs, plan, label=label, quiet=quiet,
                     describe=lambda j: f"{j.request.dataset}/{j.request.tracker}/{j.name}",
                     steps=lambda j: len(j.dets.frames))
    summaries, k = [], 0
    for r in requests:
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
        summaries.append(RunSummary(per_seq, combine(per_seq.values()), dict(events),
                                    sum(o.frames for o in mine), sum(o.seconds for o in mine), rows))
    return summaries
