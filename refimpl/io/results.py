"""Results files: MOTChallenge and KITTI tracking results read and written (atomically), and the
streaming ``ResultWriter``; which format is which lives in :mod:`.formats`."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .errors import InputFormatError
from .event_logs import event_json_line, event_line
from .ground_truth import _KITTI_LABEL_TYPES
from .lines import (_check_coordinates, _check_frame_sizes, _check_integral, _check_min_frame, _check_positive_size,
                    _check_unique, _first_bad, _numbers, _object_type, _read_lines, _split, _table)
from .outputs import write_atomic


_KITTI_RESULT_TYPE = {"car": "Car", "pedestrian": "Pedestrian", "cyclist": "Cyclist"}


def _results_array(path: Path, lines: list[tuple[int, str]], first_frame: int) -> np.ndarray:
    a = _table(path, lines, ",", 6, 10, "frame,id,x,y,w,h,...", range(6), ("frame", "id", "x", "y", "w", "h"))
    linenos = [n for n, _ in lines]
    frames = _check_integral(path, linenos, a[:, 0], "frame")
    ids = _check_integral(path, linenos, a[:, 1], "id")
    _check_min_frame(path, linenos, frames, first_frame)
    _check_coordinates(path, linenos, a[:, 2:6], ("x", "y", "w", "h"))
    _check_positive_size(path, linenos, a[:, 2:6])
    _check_unique(path, linenos, frames, ids)
    _check_frame_sizes(path, linenos, frames)
    return a


def _result_lines(path: Path, allow_empty: bool):
    """The numbered lines of a results file, or None for an empty file when that is allowed."""
    try:
        return _read_lines(path)
    except InputFormatError as exc:
        if allow_empty and exc.reason.startswith("empty file"):
            return None
        raise


def read_mot_results(path: str | os.PathLike, allow_empty: bool = False, first_frame: int = 1) -> np.ndarray:
    """A MOTChallenge results file as an (n, 6) float array ``frame, id, x, y, w, h`` in file order.

    An empty file is an error (usually a crashed tracker) unless ``allow_empty``.  Frames before
    ``first_frame`` are errors: 1 for MOTChallenge, 0 for KITTI results kept 0-based.
    """
    path = Path(path)
    lines = _result_lines(path, allow_empty)
    if lines is None:
        return np.zeros((0, 6))
    return _results_array(path, lines, first_frame)


def _fmt2(v: float) -> str:
    return f"{round(float(v), 2) + 0.0:.2f}"  # + 0.0 turns -0.0 into 0.0


def write_text_atomic(path, text: str) -> None:
    """Write text atomically through refimpl.io.outputs (never a partial file; symlinks, device
    nodes, modes and the umask handled as its module doc says)."""
    write_atomic(path, text)


def _sorted_result_rows(rows, first_frame: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validated (n, 6) ``frame, id, x, y, w, h`` rows sorted by (frame, id), and their int frames / ids."""
    a = np.asarray(rows, dtype=float)
    if a.size == 0:
        a = a.reshape(0, 6)
    if a.ndim != 2 or a.shape[1] != 6:
        raise ValueError(f"results must be an (n, 6) array frame,id,x,y,w,h; got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError("results contain NaN or inf")
    if np.any(a[:, :2] != np.floor(a[:, :2])):
        raise ValueError("frame and id must be integers")
    if np.any(a[:, 0] < first_frame):
        raise ValueError(f"frame {int(a[:, 0].min())} is before the first frame {first_frame} "
                         "(pass first_frame=0 for 0-based KITTI frames)")
    if np.any(np.round(a[:, 4:6], 2) <= 0):
        raise ValueError("box width and height must be > 0 (after rounding to 2 decimals)")
    frames, ids = a[:, 0].astype(np.int64), a[:, 1].astype(np.int64)
    order = np.lexsort((ids, frames))
    a, frames, ids = a[order], frames[order], ids[order]
    if len(a) > 1 and np.any((frames[1:] == frames[:-1]) & (ids[1:] == ids[:-1])):
        k = int(np.flatnonzero((frames[1:] == frames[:-1]) & (ids[1:] == ids[:-1]))[0])
        raise ValueError(f"duplicate (frame {frames[k]}, id {ids[k]}) in results")
    return a, frames, ids


def format_mot_results(rows, first_frame: int = 1) -> str:
    """(n, 6) ``frame, id, x, y, w, h`` rows as MOTChallenge results lines, sorted by (frame, id).

    Bad rows raise ValueError.  Frames are written as given; ``first_frame`` (1 MOT, 0 KITTI) is
    the smallest allowed.  Rows given in whole frames can be formatted chunk by chunk (streaming):
    the concatenation is the text of all rows at once.
    """
    a, frames, ids = _sorted_result_rows(rows, first_frame)
    return "".join(
        f"{f},{i},{_fmt2(r[2])},{_fmt2(r[3])},{_fmt2(r[4])},{_fmt2(r[5])},1,-1,-1,-1\n"
        for f, i, r in zip(frames, ids, a))


def write_mot_results(path: str | os.PathLike, rows, first_frame: int = 1) -> None:
    """Write (n, 6) ``frame, id, x, y, w, h`` rows as MOTChallenge results, sorted, atomically.

    The lines go to a temporary file in the target folder which then replaces the target, so a
    crash never leaves a partial results file.  Bad rows raise ValueError before anything is
    written (see :func:`format_mot_results`).
    """
    write_text_atomic(path, format_mot_results(rows, first_frame))


def write_kitti_results(path: str | os.PathLike, rows, object_class: str) -> None:
    """Write (n, 6) ``frame, id, x, y, w, h`` rows (0-based frames) as KITTI tracking results.

    One space-separated line per box, ``frame id type truncated occluded alpha x1 y1 x2 y2 h w l
    x y z ry score`` (the layout of KITTI's label_02 plus a score, what TrackEval's Kitti2DBox
    reads), sorted by (frame, id), written atomically.  ``type`` is the KITTI spelling of the
    class (Car, Pedestrian, Cyclist); what a 2D tracker does not know is written with KITTI's
    "unknown" values: truncated and occluded -1, alpha and ry -10, h w l -1, x y z -1000; the
    score is 1 (results rows carry none).  x1 and y1 are x and y rounded to two decimals, and
    x2 = x1 + w, y2 = y1 + h with w and h rounded to two decimals, so the file holds exactly the
    boxes of the MOTChallenge results file of the same rows.
    """
    write_text_atomic(path, format_kitti_results(rows, object_class, path))


def format_kitti_results(rows, object_class: str, path: str | os.PathLike = "<results>") -> str:
    """The lines of :func:`write_kitti_results` (chunks of whole frames concatenate, as for MOT)."""
    name = _KITTI_RESULT_TYPE[_object_type(object_class, path)]
    a, frames, ids = _sorted_result_rows(rows, 0)
    # the MOTChallenge writer's rounding (Python's round of each value, _fmt2), so both files hold
    # the same boxes: np.round scales by 100 first and can land 0.01 off (e.g. 184.355 -> 184.36)
    r = [[round(float(v), 2) for v in row] for row in a[:, 2:6]]
    lines = []
    for f, i, (x, y, w, h) in zip(frames, ids, r):
        lines.append(f"{f} {i} {name} -1 -1 -10 {_fmt2(x)} {_fmt2(y)} {_fmt2(x + w)} {_fmt2(y + h)} "
                     "-1 -1 -1 -1000 -1000 -1000 -10 1\n")
    return "".join(lines)


def read_kitti_results(path: str | os.PathLike, object_class: str, allow_empty: bool = False) -> np.ndarray:
    """KITTI tracking results of one class as an (n, 6) array ``frame, id, x, y, w, h`` (0-based frames).

    17 or 18 space-separated fields (``write_kitti_results``; label_02 without a score works too).
    Rows of other KITTI types are skipped (a KITTI submission holds Car and Pedestrian in one
    file; as in TrackEval only the evaluated class is read); a type outside the KITTI vocabulary,
    a negative id, x2 <= x1 or y2 <= y1 are errors.  An empty file is an error unless ``allow_empty``.
    """
    path = Path(path)
    otype = _object_type(object_class, path)
    lines = _result_lines(path, allow_empty)
    if lines is None:
        return np.zeros((0, 6))
    rows = _split(path, lines, None, 17, 18, "frame id type truncated occluded alpha x1 y1 x2 y2 h w l x y z ry [score]")
    linenos = [n for n, _ in lines]
    for fields, lineno in zip(rows, linenos):
        if fields[2] not in _KITTI_LABEL_TYPES:
            raise InputFormatError(f"unknown object type {fields[2]!r} (KITTI types: {', '.join(_KITTI_LABEL_TYPES)})",
                                   path, lineno)
    keep = [k for k, fields in enumerate(rows) if fields[2] == _KITTI_RESULT_TYPE[otype]]
    rows, linenos = [rows[k] for k in keep], [linenos[k] for k in keep]
    if not rows:
        return np.zeros((0, 6))
    a = _numbers(path, linenos, rows, [0, 1, 6, 7, 8, 9], ("frame", "id", "x1", "y1", "x2", "y2"))
    frames = _check_integral(path, linenos, a[:, 0], "frame")
    ids = _check_integral(path, linenos, a[:, 1], "id")
    _check_min_frame(path, linenos, frames, 0)
    bad = _first_bad(ids < 0)
    if bad is not None:
        raise InputFormatError(f"negative track id {ids[bad]}", path, linenos[bad])
    _check_coordinates(path, linenos, a[:, 2:6], ("x1", "y1", "x2", "y2"))
    boxes = np.column_stack([a[:, 2], a[:, 3], a[:, 4] - a[:, 2], a[:, 5] - a[:, 3]])
    _check_positive_size(path, linenos, boxes)
    _check_unique(path, linenos, frames, ids)
    _check_frame_sizes(path, linenos, frames)
    return np.column_stack([frames.astype(float), ids.astype(float), boxes])


class ResultWriter:
    """Writes results rows and event logs to open (staged) files as a streaming tracker decides
    them: a ``refimpl.tracking.tracker.ResultSink`` (rows of whole frames, then each frame's events).

    ``results_format``: a function formatting (n, 6) rows as text (default MOTChallenge lines,
    :func:`format_mot_results`); chunks of whole frames concatenate to the text of all rows."""

    def __init__(self, results=None, events=None, events_json=None, first_frame: int = 1, results_format=None):
        self.results, self.events_lp, self.events_json = results, events, events_json
        self.format = results_format or (lambda rows: format_mot_results(rows, first_frame))
        self.track_ids: set[int] = set()  # distinct ids written (for the summary line)

    def rows(self, rows: np.ndarray) -> None:
        if len(rows):
            self.track_ids.update(int(i) for i in set(rows[:, 1].tolist()))
            if self.results is not None:
                self.results.write(self.format(rows))

    def events(self, events) -> None:
        if self.events_lp is not None:
            self.events_lp.write("".join(event_line(e) for e in events))
        if self.events_json is not None:
            self.events_json.write("".join(event_json_line(e) for e in events))
