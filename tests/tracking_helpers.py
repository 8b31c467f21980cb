"""The Setup of a test that tracks with a few tracker options (refimpl.tracking.pipeline.run_sequence).

A test says ``run_sequence(seq, setup_with("cpsat", written_box="detection"))``: the backend, the
model constants beyond model/constants.lp, no preset, and the tracker options by name, so the test
reads as the options it varies.
"""

from __future__ import annotations

from typing import Mapping

from refimpl.solvers import BASELINE, DEFAULT_BACKEND
from refimpl.tracking.options import TrackerOptions
from refimpl.tracking.pipeline import Setup


def setup_with(backend: str = DEFAULT_BACKEND, constants: Mapping[str, int] | None = None, *,
               time_limit: float | None = None, frame_budget: float | None = None, **options: object) -> Setup:
    """The Setup of an abduction ``backend`` without a preset: ``constants`` as given, the tracker
    options by name (refimpl.tracking.options.TRACKER_OPTIONS; ValueError for an unknown name or a
    bad value), ``time_limit`` and ``frame_budget`` (None: no budget).  The baseline takes no
    options: ``Setup(BASELINE)``."""
    if backend == BASELINE:
        raise ValueError("setup_with is for an abduction backend; the baseline is Setup(BASELINE)")
    return Setup(backend=backend, constants=tuple((constants or {}).items()),
                 options=TrackerOptions.from_mapping(options), time_limit=time_limit, frame_budget=frame_budget)
