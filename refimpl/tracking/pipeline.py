"""One pipeline: a sequence and a Setup in, result rows and events out.

Every way of tracking goes through here: ``refimpl track`` with one input (streamed to its
files) or many (``--out-dir``, serial or on Dask), ``benchmark``, ``calibrate``, ``sweep``,
``table6``, the peer comparison, ``detectors``, ``diff`` and the library's ``refimpl.Tracker``
(which builds its tracker with :func:`new_tracker`).  So what a user's command writes is what the
published tables measured.

* :class:`Setup` is what a sequence is tracked with: the tracker (``baseline`` or an abduction
  backend), the model constants beyond ``model/constants.lp``, the tracker options, the per-frame
  time limit, and the name of the preset they came from;
* :func:`setup_for` is the one rule that picks it: the preset of (format, class) (refimpl.tracking.presets;
  the robust default where that pair has none), unless asked for none or for another by name, then
  the caller's constants and options on top;
* :func:`run_sequence` tracks one sequence with a Setup, optionally streaming to a sink (a
  Setup of one's own, without a preset: ``Setup("cpsat", options=TrackerOptions(...))``).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from time import process_time
from typing import Callable, Mapping

import numpy as np

from ..solvers import BASELINE, DEFAULT_BACKEND, REAL_TIME, get_solver
from .baseline import stream_sequence
from .options import TrackerOptions
from .presets import merge_constants, merge_options, preset_named, resolve_preset
from .camera import (DURATIONS, FRAME_OPTIONS, RATE_OPTIONS, frames_at, image_in_use, sequence_constants, sequence_scale,
                     warn_if_outside)
from .tracker import AbductionTracker, DEFAULT_MIN_HITS, TrackingResult, check_frame_budget

AUTO = "auto"
"""Pick the preset by (format, class), falling back to the robust default."""
NONE = "none"
"""No preset: model/constants.lp and the tracker's default options."""
DEFAULT_FRAME_BUDGET_MS = 25.0
"""The frame budget a real-time backend (refimpl.solvers.REAL_TIME: ``cpsat``) gets unless told
otherwise: a 30 fps camera's 33 ms less room for applying the answer and a garbage collection.  On
the 81 shared sequences no frame reaches it (the fast path answers every frame in a few ms), so the
answers are those without a budget (docs/benchmarks.md, "The frame budget")."""


@dataclass(frozen=True)
class Setup:
    """What a sequence is tracked with (picklable: a task carries it to a worker)."""

    backend: str = DEFAULT_BACKEND
    constants: tuple[tuple[str, int], ...] = ()
    """Model constants beyond model/constants.lp (the preset's, then overrides)."""
    options: TrackerOptions = field(default_factory=TrackerOptions)
    time_limit: float | None = None
    preset: str = NONE
    """The preset the constants and options came from ("kitti/car", "default", or "none")."""
    tuned_fps: float | None = None
    """The frame rate the preset's durations were tuned at (refimpl.tracking.presets.Preset.fps): a
    sequence of another frame rate gets them converted (refimpl.tracking.camera.frames_at)."""
    in_frames: tuple[str, ...] = ()
    """The durations the caller gave (constants of DURATIONS, options of FRAME_OPTIONS), and the
    per-frame rates (RATE_OPTIONS): frames as given."""
    frame_budget: float | None = None
    """Milliseconds a frame may take (refimpl.tracking.tracker.AbductionTracker), None: no budget.
    setup_for gives a real-time backend DEFAULT_FRAME_BUDGET_MS unless told otherwise."""

    @property
    def baseline(self) -> bool:
        return self.backend == BASELINE

    def describe(self) -> str:
        """One line for a user: which tracker and preset ran."""
        if self.baseline:
            return "baseline (SORT)"
        budget = "" if self.frame_budget is None else f", frame budget {self.frame_budget:g} ms"
        if self.preset == NONE:
            return f"{self.backend}, no preset (model/constants.lp, default tracker options){budget}"
        return f"{self.backend}, preset {self.preset}{budget}"


def setup_for(fmt: str, object_class: str | None, backend: str = DEFAULT_BACKEND,
              constants: Mapping[str, int] | None = None, options: Mapping[str, object] | None = None,
              preset: str | None = AUTO, time_limit: float | None = None,
              frame_budget: float | None | str = AUTO) -> Setup:
    """The Setup for a sequence of this format and class.

    ``preset``: AUTO (the preset of (format, class), or the robust default where there is none),
    NONE or None (no preset), or a preset's name (``kitti/car``, ``default``).  ``constants`` and
    ``options`` ({name: value}) override the preset's.  ``frame_budget``: milliseconds per frame,
    None (no budget) or AUTO (DEFAULT_FRAME_BUDGET_MS for a real-time backend,
    refimpl.solvers.REAL_TIME, none for the oracles).  ValueError (one sentence) for an unknown
    preset, constant or option, a bad budget, or for constants/options given to the baseline."""
    if backend == BASELINE:
        if constants or options:
            raise ValueError("model constants and tracker options need an abduction backend; the baseline is SORT")
        return Setup(BASELINE, preset=NONE)
    if preset is None or preset == NONE:
        chosen = None
    elif preset == AUTO:
        chosen = resolve_preset(fmt, object_class or "pedestrian")
    else:
        chosen = preset_named(preset)
    merged = merge_constants(chosen, constants)
    opts = merge_options(chosen, options)
    if isinstance(frame_budget, str) and frame_budget == AUTO:
        frame_budget = DEFAULT_FRAME_BUDGET_MS if backend in REAL_TIME else None
    given = set(constants or {}) | set(options or {})
    return Setup(backend, tuple(merged.items()), opts, time_limit, chosen.name if chosen else NONE,
                 chosen.fps if chosen else None,
                 tuple(sorted(given & {*DURATIONS, *FRAME_OPTIONS, *RATE_OPTIONS})),
                 check_frame_budget(frame_budget))


FrameCallback = Callable[[], None]


def new_tracker(setup: Setup, image_size: tuple[int, int] | None = None, fps: float | None = None,
                min_hits: int | None = None, solver=None, sink=None, keep_records: bool = True, compact_history: bool = True):
    """The abduction tracker (refimpl.tracking.tracker.AbductionTracker) of a Setup for a sequence of this
    image size and frame rate, exactly as :func:`run_sequence` builds it (the library's
    refimpl.Tracker steps it frame by frame)."""
    if setup.baseline:
        raise ValueError("the baseline is SORT (refimpl.tracking.baseline), not an abduction tracker")
    options = setup.options
    if fps and setup.tuned_fps:
        options = replace(options, **{name: frames_at(getattr(options, name), fps, setup.tuned_fps)
                                      for name in FRAME_OPTIONS if name not in setup.in_frames})
        options = replace(options, **{name: at(options, fps, setup.tuned_fps)
                                      for name, at in RATE_OPTIONS.items() if name not in setup.in_frames})
    return AbductionTracker(solver or get_solver(setup.backend),
                            sequence_constants(dict(setup.constants), image_size, fps, setup.tuned_fps,
                                               setup.in_frames),
                            DEFAULT_MIN_HITS if min_hits is None else min_hits, setup.time_limit,
                            compact_history,
                            sink=sink, keep_records=keep_records, frame_budget=setup.frame_budget,
                            options=options, pixel_scale=sequence_scale(dict(setup.constants), image_size))


def run_sequence(seq, setup: Setup, *, observer=None, sink=None, keep_records: bool = True,
                 solver=None, on_frame: FrameCallback | None = None, frame_times: list | None = None,
                 min_hits: int | None = None, compact_history: bool = True):
    """Track one DetectionSequence (or a refimpl.io.DetectionStream: its frames are read once, as
    they arrive) with ``setup``: a refimpl.tracking.tracker.TrackingResult.  The sequence's image
    size feeds the field-of-view border and its frame rate the safety bound on halts
    (refimpl.tracking.camera.sequence_constants).

    ``observer(problem, hypothesis)`` sees every frame's answer (abduction only); ``on_frame()`` is
    called once per frame (progress); with a ``sink`` (refimpl.tracking.tracker.ResultSink) rows
    and events are handed over as they become final and the result's rows are empty (its events
    and tracks too unless ``keep_records``); ``solver``: a solver instance to use instead of the
    backend's; ``frame_times``: a list that receives each frame's CPU seconds of tracking
    (time.process_time around the frame's update, plus what the solver's worker process spent
    in it: latency, issue 27); ``min_hits``,
    ``compact_history``: the abduction tracker's own
    (refimpl.tracking.tracker.AbductionTracker; None: its defaults)."""
    if setup.baseline:
        kept, frames = [], 0
        for rows in _timed(stream_sequence(seq), frame_times):  # seq.frames may be a stream, read once
            frames += 1
            if sink is not None:
                sink.rows(rows)
            elif len(rows):
                kept.append(rows)
            if on_frame is not None:
                on_frame()
        rows = np.vstack(kept) if kept else np.zeros((0, 6))
        return TrackingResult(rows, (), (), frames, 0, 0.0)

    def observe(problem, hyp) -> None:
        if observer is not None:
            observer(problem, hyp)
        if on_frame is not None:
            on_frame()

    tracker = new_tracker(setup, seq.image_size, getattr(seq, "fps", None), min_hits, solver=solver,
                          sink=sink, keep_records=keep_records, compact_history=compact_history)
    watch = observe if (observer is not None or on_frame is not None) else None
    image = image_in_use(dict(setup.constants), seq.image_size)  # None: nothing to test against
    for fr in seq.frames:
        if image is not None and len(fr.boxes) and warn_if_outside(fr.frame, fr.boxes, image):
            image = None  # said once
        start = _cpu(tracker.solver) if frame_times is not None else 0.0
        tracker.step(fr.frame, fr.boxes, fr.confidences, fr.types, watch, scores=fr.scores)
        if frame_times is not None:
            frame_times.append(_cpu(tracker.solver) - start)
    tracker.finish()
    if sink is None:
        return tracker.result()
    return TrackingResult(np.zeros((0, 6)), tuple(tracker.events) if keep_records else (),
                          tracker.track_records() if keep_records else (), tracker.frames, tracker.not_optimal,
                          tracker.solve_ms, tracker.budget_hits, tracker.over_budget)


def _cpu(solver) -> float:
    """CPU seconds of this process and of the solver's worker processes (clingo's, which solves
    past its first solves in a child: refimpl.solvers.clingo_backend.INLINE_SOLVES)."""
    return process_time() + getattr(solver, "child_cpu_seconds", 0.0)


def _timed(frames, frame_times: list | None):
    """The items of an iterator, each one's CPU seconds of computing appended to frame_times."""
    it = iter(frames)
    while True:
        start = process_time()
        try:
            item = next(it)
        except StopIteration:
            return
        if frame_times is not None:
            frame_times.append(process_time() - start)
        yield item

