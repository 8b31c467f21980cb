"""The units of work of the many-sequence commands, as picklable jobs and module-level functions.

Each job carries its input data (a DetectionSequence), not file paths, so a
worker on another machine needs no shared file system.  Each function's result depends on its
job only; refimpl.runs.scaleout runs them serially or on a Dask cluster and returns results in input
order, and the commands write from those results only, so outputs are the same bytes either way.

* ``track_job``: one sequence tracked (``refimpl track`` with several ``--dets``).

``diff``'s job (``DiffJob``, ``diff_job``) is in refimpl.runs.diff, beside what it runs, and the
scored jobs (``benchmark``, ``table6``, ``sweep``) are in refimpl.experiments.benchmark_tasks:
they need the scorer (scipy), which a worker that only tracks never imports.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from ..core.loader import load
from ..io import DetectionFrame, DetectionSequence, results_formatter
from ..solvers.check import check_answer
from ..tracking.pipeline import Setup, run_sequence

SCENE_FROM_RESULT = "refimpl.scene:scene_from_result"
SCENE_TO_JSON = "refimpl.scene:scene_to_json"
"""The scene a job builds when asked (``track --scene``, one input or many), named for
refimpl.core.loader: the scene package (eight modules and the standard library's statistics) is
~0.1 s of a start-up that issue 27 bounds at 0.5 s, and only ``--scene`` needs it."""


# ---------------------------------------------------------------------------------------
# track


@dataclass(frozen=True)
class TrackJob:
    seq: DetectionSequence
    setup: Setup
    check: bool = False
    scene: bool = False
    events: bool = False
    """Hand the sequence's events back (TrackOutput.events).  Off by default: the many-sequence
    ``track`` writes results rows only, and on a cluster every result is unpickled in the command's
    process, where 1,175 events (KITTI Car 0001) cost 0.07 s against 0.001 s for its rows."""
    out_format: str | None = None
    """Also hand the rows back as the text of a results file in this format (TrackOutput.text), for
    ``object_class``: the many-sequence ``track`` writes that text as it is, so on a cluster the
    workers format their sequences in parallel (12 KITTI Car sequences: 0.07 s of the command's
    own time otherwise, after the last task)."""
    object_class: str | None = None

    def __reduce__(self):
        # pickled with its sequence packed (pack_sequence): a job travels pickled to a worker
        # (scaleout.call_pickled; before it, the scheduler unpickled and pickled it again too), and
        # 12 KITTI sequences as 4,500 frames of small arrays cost the command's process 1.7 CPU-s unpacked
        return _unpack_track_job, (pack_sequence(self.seq), self.setup, self.check, self.scene, self.events,
                                   self.out_format, self.object_class)


def _unpack_track_job(seq, setup: Setup, check: bool, scene: bool, events: bool, out_format: str | None,
                      object_class: str | None) -> TrackJob:
    return TrackJob(unpack_sequence(seq), setup, check, scene, events, out_format, object_class)


@dataclass(frozen=True)
class PackedSequence:
    """A DetectionSequence as a few arrays (what pickles quickly): every frame's boxes, scores and
    confidences one after another, the number of detections per frame, and the types as indices
    into ``type_names``.  unpack_sequence gives the sequence back, equal array by array (values,
    dtypes, shapes)."""

    name: str
    first_frame: int
    image_size: tuple[int, int] | None
    fps: float | None
    dropped: tuple[tuple[int, str], ...]
    numbers: np.ndarray
    counts: np.ndarray
    boxes: np.ndarray
    scores: np.ndarray
    confidences: np.ndarray
    type_names: tuple[str, ...]
    types: np.ndarray


def _packable(frames) -> bool:
    """Whether every frame's arrays stack into one of each kind with nothing lost: boxes (k, w),
    scores and confidences (k,), each kind of one dtype (and one w), C-ordered (as a copy of a
    slice of the stack is)."""
    if not frames or frames[0].boxes.ndim != 2:
        return False
    first = frames[0]
    width = first.boxes.shape[1]
    for f in frames:
        k = len(f.types)
        if f.boxes.shape != (k, width) or f.scores.shape != (k,) or f.confidences.shape != (k,):
            return False
        if (f.boxes.dtype != first.boxes.dtype or f.scores.dtype != first.scores.dtype
                or f.confidences.dtype != first.confidences.dtype):
            return False
        if not (f.boxes.flags.c_contiguous and f.scores.flags.c_contiguous and f.confidences.flags.c_contiguous):
            return False
    return True


def pack_sequence(seq: DetectionSequence) -> PackedSequence | DetectionSequence:
    """The sequence packed for pickling, or the sequence itself when its frames do not stack
    (:func:`_packable`): then it pickles as it is."""
    frames = seq.frames
    if not _packable(frames):
        return seq
    names = tuple(sorted({t for f in frames for t in f.types}))
    code = {name: i for i, name in enumerate(names)}
    return PackedSequence(seq.name, seq.first_frame, seq.image_size, seq.fps, seq.dropped,
                          np.array([f.frame for f in frames], dtype=np.int64),
                          np.array([len(f.types) for f in frames], dtype=np.int64),
                          np.concatenate([f.boxes for f in frames]), np.concatenate([f.scores for f in frames]),
                          np.concatenate([f.confidences for f in frames]), names,
                          np.array([code[t] for f in frames for t in f.types], dtype=np.int64))


def unpack_sequence(packed: PackedSequence | DetectionSequence) -> DetectionSequence:
    if isinstance(packed, DetectionSequence):
        return packed
    ends = np.cumsum(packed.counts).tolist()
    starts = [0, *ends[:-1]]
    names, types = packed.type_names, packed.types.tolist()
    frames = tuple(DetectionFrame(int(number), packed.boxes[a:b].copy(), packed.scores[a:b].copy(),
                                  packed.confidences[a:b].copy(), tuple(names[t] for t in types[a:b]))
                   for number, a, b in zip(packed.numbers.tolist(), starts, ends))
    return DetectionSequence(packed.name, frames, packed.first_frame, packed.image_size, packed.fps, packed.dropped)


@dataclass(frozen=True)
class TrackOutput:
    name: str
    rows: np.ndarray
    """(n, 6) MOT rows frame, id, x, y, w, h."""
    events: tuple
    """The sequence's events when the job asked for them (TrackJob.events), else ()."""
    frames: int
    not_optimal_frames: int = 0
    checked: int = 0
    violations: tuple[str, ...] = ()
    """One line per frame whose answer broke a rule (with --check)."""
    scene: object | None = None
    text: str | None = None
    """The rows as a results file's text, when the job gave an ``out_format``."""
    budget_hits: int = 0
    """Frames the frame budget stopped (refimpl.tracking.tracker.TrackingResult)."""
    over_budget: int = 0
    """Frames that took longer than the frame budget."""
    said: tuple[str, ...] = ()
    """The warnings tracking the sequence gave (refimpl.tracking.camera.warn_if_outside), for the
    caller to say in input order: a worker process's stderr is not the user's."""


class AnswerCheck:
    """The independent checker on every frame's answer (``--check``): counts and one line per
    frame whose answer breaks a rule or whose cost vector differs (refimpl.solvers.check)."""

    def __init__(self, report: Callable[[str], None] | None = None) -> None:
        self.checked = 0
        self.violations: list[str] = []
        self.report = report

    def __call__(self, problem, hyp) -> None:
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
    with warnings.catch_warnings(record=True) as said:  # restored after the job
        warnings.simplefilter("always")
        result = run_sequence(job.seq, job.setup, observer=check, on_frame=on_frame)
    scene = None
    if job.scene and not job.setup.baseline:
        scene = load(SCENE_FROM_RESULT)(job.seq, result)
    text = None
    if job.out_format is not None:
        text = results_formatter(job.out_format, job.seq.first_frame, job.object_class)(result.rows)
    return TrackOutput(job.seq.name, result.rows, result.events if job.events else (), result.frames,
                       result.not_optimal_frames,
                       check.checked if check else 0, tuple(check.violations) if check else (), scene, text,
                       result.budget_hits, result.over_budget, tuple(str(w.message) for w in said))


def results_file_name(path) -> str:
    """The results file of one input among many: its MOTChallenge sequence folder
    (``.../TUD-Campus/det/det.txt`` -> ``TUD-Campus.txt``) or its file stem (``.../Car/0011.txt``
    -> ``0011.txt``)."""
    p = Path(os.path.abspath(path))  # absolute (a relative det/det.txt), symlinks kept as named
    if p.parent.name == "det" and p.parent.parent.name:
        return f"{p.parent.parent.name}.txt"
    return f"{p.stem}.txt"
