"""Property checks of the readers, the pipe and the library API on any input (issue 37): each input
is either tracked or refused with one line, never a traceback.

The strategies build what a hostile or careless user gives: detection rows whose fields are
numbers, NaN, infinities, huge or negative values, empty fields, words and control characters;
arrays of any shape and dtype with such values.  Each ``check_*`` function runs one input and
returns ``"tracked"`` or ``"refused"``; anything else (another exception, a refusal message of
more than one line, an output with non-finite or non-positive boxes) fails an assertion.

tests/test_property_based_inputs.py runs them under hypothesis with a bounded number of examples (CI);
tests/tools/properties.py runs them longer and counts the outcomes (docs/robustness.md).
"""

from __future__ import annotations

import io as stdio
import warnings
from pathlib import Path

import numpy as np
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from refimpl.api import Tracker
from refimpl.core.errors import UserFacingError
from refimpl.io import InputFormatWarning
from refimpl.io import read_kitti_detections, read_mot_detections
from refimpl.io import stream_mot_detections

_NUMBERS = st.one_of(
    st.integers(-5, 2000).map(str),
    st.floats(allow_nan=True, allow_infinity=True, width=64).map(repr),
    st.sampled_from(["nan", "inf", "-inf", "1e308", "-1e308", "1e400", "9" * 30, "0", "-0", "0.0", "1e-9"]),
)
_JUNK = st.one_of(st.just(""), st.sampled_from([" ", "x", "Car", "pedestrian", "\x1b[31m", "\x00", "é", ",", ";"]),
                  st.text(max_size=6))
FIELD = st.one_of(_NUMBERS, _NUMBERS, _NUMBERS, _JUNK)
"""One field of a row: mostly numbers of every kind, sometimes anything."""


def _plausible_mot_row(frame: int, x: float, y: float, w: float, h: float, score: float) -> str:
    return f"{frame},-1,{x:.2f},{y:.2f},{w:.2f},{h:.2f},{score:.3f},-1,-1,-1"


PLAUSIBLE_MOT = st.builds(_plausible_mot_row, st.integers(1, 6), st.floats(-50, 600), st.floats(-50, 400),
                          st.floats(0.5, 200), st.floats(0.5, 300), st.floats(-5, 120))
"""A MOTChallenge detection row that is well formed, with values anywhere near an image."""

MOT_LINE = st.one_of(PLAUSIBLE_MOT, PLAUSIBLE_MOT, st.lists(FIELD, min_size=0, max_size=12).map(",".join))
MOT_TEXT = st.lists(MOT_LINE, min_size=0, max_size=12).map(lambda lines: "\n".join(lines) + "\n")


def _plausible_kitti_row(frame: int, x: float, y: float, w: float, h: float, score: float) -> str:
    return (f"{frame},2,{x:.2f},{y:.2f},{x + w:.2f},{y + h:.2f},{score:.4f},"
            "1.5,1.6,3.9,1.0,1.7,20.0,0.1,0.9")


PLAUSIBLE_KITTI = st.builds(_plausible_kitti_row, st.integers(0, 5), st.floats(-50, 1200), st.floats(-50, 360),
                            st.floats(0.5, 300), st.floats(0.5, 200), st.floats(-20, 20))
KITTI_LINE = st.one_of(PLAUSIBLE_KITTI, PLAUSIBLE_KITTI, st.lists(FIELD, min_size=0, max_size=17).map(",".join))
KITTI_TEXT = st.lists(KITTI_LINE, min_size=0, max_size=12).map(lambda lines: "\n".join(lines) + "\n")

_VALUES = st.one_of(st.floats(-100, 1000), st.floats(allow_nan=True, allow_infinity=True), st.integers(-10, 10**6))
FRAME_ARRAY = st.one_of(
    hnp.arrays(np.float64, st.tuples(st.integers(0, 6), st.sampled_from([0, 4, 5, 6, 7])), elements=_VALUES),
    hnp.arrays(np.int64, st.tuples(st.integers(0, 6), st.sampled_from([5, 6])), elements=st.integers(-10, 10**6)),
    hnp.arrays(np.float64, st.integers(0, 6), elements=_VALUES),
    st.builds(lambda n: np.column_stack([np.arange(n) * 60.0, np.full(n, 50.0), np.arange(n) * 60.0 + 40,
                                         np.full(n, 130.0), np.full(n, 0.9)]), st.integers(0, 5)),
)
"""What ``Tracker.update`` may be given: arrays of any shape and dtype, values of every kind, and
well-formed frames among them (so that tracks start, run and stop between the bad ones)."""
FRAMES = st.lists(FRAME_ARRAY, min_size=1, max_size=8)


def _one_line(exc: BaseException) -> None:
    text = str(exc)
    assert text and "\n" not in text, f"a refusal must be one line: {text!r}"


def _boxes_ok(boxes: np.ndarray) -> None:
    boxes = np.asarray(boxes, dtype=float).reshape(-1, 4)
    assert np.isfinite(boxes).all() and (boxes[:, 2] > 0).all() and (boxes[:, 3] > 0).all(), boxes


def check_file(text: str, folder: Path, kind: str) -> str:
    """A detection file of ``kind`` ("mot" or "kitti"): read, or refused in one line."""
    path = folder / f"det_{kind}.txt"
    path.write_text(text, encoding="utf-8")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", InputFormatWarning)
            seq = read_mot_detections(path) if kind == "mot" else read_kitti_detections(path, "Car")
    except UserFacingError as exc:
        _one_line(exc)
        return "refused"
    for fr in seq.frames:
        _boxes_ok(fr.boxes)
        assert ((0 <= fr.confidences) & (fr.confidences <= 100)).all()
    return "tracked"


def check_pipe(text: str) -> str:
    """The same rows on a pipe (``refimpl track --dets -``): every frame read, or refused in one line."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", InputFormatWarning)
            stream = stream_mot_detections(stdio.StringIO(text))
            for fr in stream.frames:
                _boxes_ok(fr.boxes)
    except UserFacingError as exc:
        _one_line(exc)
        return "refused"
    return "tracked"


def check_api(frames: list[np.ndarray]) -> str:
    """``Tracker.update`` frame after frame: (M, 5) finite rows per frame, or a one-line ValueError
    or TypeError at the first bad frame, after which the tracker still takes a good frame."""
    tracker = Tracker("cpsat", img_size=(640, 480))
    good = np.array([[10.0, 10.0, 50.0, 90.0, 0.9]])
    for arr in frames:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                out = tracker.update(arr)
        except (ValueError, TypeError) as exc:
            _one_line(exc)
            tracker.update(good)  # a refused frame leaves the tracker usable
            return "refused"
        assert out.ndim == 2 and out.shape[1] in (5, 6) and np.isfinite(out).all()
    return "tracked"
