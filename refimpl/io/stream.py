"""Detections read from a text stream as its lines arrive: a detector writing rows into a pipe
(``refimpl track --dets -``).

A :class:`DetectionStream` yields the same DetectionFrames as a format's file reader gives for the
same text (each line goes through the same row checks, ``_mot_rows`` / ``_kitti_rows`` of
refimpl.io.formats.mot / .kitti, which also make their streams, and each frame through the same
confidence rule), one frame at a
time: a frame is complete when a line of a later frame arrives, or at the end of the stream.  Its
memory is one frame's rows (at most MAX_DETECTIONS_PER_FRAME), plus a few floats per detection under an online rule
(evidence, rank: their state is the last refimpl.core.confidence.SCORE_WINDOW scores) and the line numbers of
dropped KITTI boxes (a handful per sequence).  A stream has no last frame (a file has MAX_FRAME); a gap of
more than MAX_FRAME frames between two rows is refused as a typo.

What differs from a file, because a stream cannot be read twice:

* rows come frame by frame: a line whose frame is smaller than a previous line's is an error
  naming its line (a file's rows are sorted);
* frames are numbered as in the format (MOTChallenge from 1, KITTI from 0); frames missing
  before the first row or between two rows are empty frames; the stream ends at its last row's
  frame (MOTChallenge: at seqLength of a given seqinfo.ini).  There is no side file: the image
  size and frame rate come from ``seqinfo`` (MOTChallenge) or the format (KITTI), or ``image_size``;
* KITTI's dropped degenerate boxes are warned about once, at the end, as the file reader does.
"""

from __future__ import annotations

from typing import IO, Callable, Iterator, Sequence

import numpy as np

from ..core.confidence import online_rule
from .detections import DetectionFrame, _Rows, _warn_dropped, resolve_rule, scale_confidences
from .errors import InputFormatError
from .lines import MAX_DETECTIONS_PER_FRAME, MAX_FRAME, _data_lines, _line_numbers, too_many_detections

STDIN_NAME = "<stdin>"
"""How errors and the summary name standard input (``<stdin>:12: ...``)."""


class _Scores:
    """A confidence rule applied frame by frame, in order (an online rule keeps its state here;
    empty frames go through it too, as in a file); ``auto``: the format's rule for ``auto``."""

    def __init__(self, path: str, rule: str, auto: str):
        self.path, self.rule = path, resolve_rule(rule, auto)
        self.state = online_rule(self.rule)

    def __call__(self, linenos: Sequence[int], boxes: np.ndarray, scores: np.ndarray,
                 types: tuple[str, ...]) -> np.ndarray:
        if self.state is not None:
            return self.state.confidences(boxes, scores, types)
        return scale_confidences(self.path, linenos, scores, self.rule)

    def empty(self) -> None:
        if self.state is not None:
            self.state.confidences(np.zeros((0, 4)), np.zeros(0), ())


class DetectionStream:
    """The frames of one sequence read from a text stream as they arrive (module doc).

    ``frames`` is an iterator of DetectionFrame, first frame to last, read once; a user mistake
    raises InputFormatError ``<stdin>:<line>: <reason>`` when its line is read.  ``num_frames``,
    ``num_detections``, ``confidence_range`` and ``dropped`` count what has been read so far."""

    def __init__(self, fh: IO[str], path: str, table: tuple, rows: Callable[[Sequence[int], np.ndarray], _Rows],
                 scores: _Scores, object_type: str, first_frame: int, last_frame: int | None, name: str,
                 image_size: tuple[int, int] | None, fps: float | None):
        self.path, self.name, self.first_frame = path, name, first_frame
        self.image_size, self.fps = image_size, fps
        self.num_frames = 0
        self.num_detections = 0
        self.confidence_range: tuple[int, int] | None = None
        self.dropped: list[tuple[int, str]] = []
        self._table, self._rows, self._scores, self._type = table, rows, scores, object_type
        self._last = last_frame
        self.frames: Iterator[DetectionFrame] = self._read(fh)

    def _read(self, fh: IO[str]) -> Iterator[DetectionFrame]:
        current, value, block, previous = None, None, [], 0
        for lineno, text in _data_lines(fh, self.path):
            a = _line_numbers(self.path, lineno, text, *self._table)
            if a[0, 0] != value:  # a new frame: the previous one is complete, its rows are checked first
                done = self._frame(current, block) if current is not None else None
                self._rows([lineno], a)  # then this row, so its frame is integral and in range before any step
                frame = int(a[0, 0])
                if current is not None and frame < current:
                    raise InputFormatError(f"frame {frame} after frame {current} (line {previous}): a stream is "
                                           "read frame by frame, so its frame numbers must not decrease",
                                           self.path, lineno)
                before = self.first_frame - 1 if current is None else current
                if frame - before > MAX_FRAME:  # a stream has no last frame, but a typo must not make a
                    # billion empty frames: the gap is bounded as a file's frame numbers are
                    raise InputFormatError(f"frame {frame} after frame {before}: more than {MAX_FRAME} frames "
                                           "without a row (a typo?)", self.path, lineno)
                if done is not None:
                    yield done
                yield from self._empty(self.first_frame if current is None else current + 1, frame)
                current, value, block = frame, a[0, 0], []
            if len(block) == MAX_DETECTIONS_PER_FRAME:  # before the frame's rows outgrow the cap in memory
                raise InputFormatError(too_many_detections(current), self.path, lineno)
            block.append((lineno, a))
            previous = lineno
        if current is None:
            raise InputFormatError("empty input (no data lines)", self.path)
        yield self._frame(current, block)
        if self._last is not None:
            yield from self._empty(current + 1, self._last + 1)
        if self.dropped:
            _warn_dropped(self.path, self.dropped, stacklevel=2)

    def _empty(self, start: int, stop: int) -> Iterator[DetectionFrame]:
        for number in range(start, stop):
            yield self._blank(number)

    def _blank(self, number: int) -> DetectionFrame:
        self.num_frames += 1
        self._scores.empty()
        return DetectionFrame(number, np.zeros((0, 4)), np.zeros(0), np.zeros(0, dtype=np.int64), ())

    def _frame(self, number: int, block: list[tuple[int, np.ndarray]]) -> DetectionFrame:
        """One frame from its lines: every row check of the format, the rows kept, in line order,
        and the confidence rule."""
        kept = self._rows([n for n, _ in block], np.vstack([a for _, a in block]))
        self.dropped.extend(kept.dropped)
        if not len(kept.scores):  # KITTI: every row of another class, or dropped
            return self._blank(number)
        conf = self._scores(kept.linenos, np.array(kept.boxes), kept.scores, (self._type,) * len(kept.scores))
        self.num_frames += 1
        self.num_detections += len(conf)
        lo, hi = int(conf.min()), int(conf.max())
        if self.confidence_range is not None:
            lo, hi = min(lo, self.confidence_range[0]), max(hi, self.confidence_range[1])
        self.confidence_range = (lo, hi)
        return DetectionFrame(number, np.array(kept.boxes), kept.scores, conf, (self._type,) * len(conf))


