"""Files in and out: MOTChallenge and KITTI tracking detections, ground truth and results.

Every reader turns a user mistake in a file into ``InputFormatError("<path>:<line>: <reason>")``
(never a numpy/pandas traceback, never a silently dropped row), because a benchmark number
computed from a half-read file is worse than no number.

Formats and the conventions implemented
---------------------------------------
MOTChallenge detections (``det/det.txt``): comma separated ``frame,id,x,y,w,h,score[,...]``,
7 to 10 fields, 1-based frames.  The sequence runs over frames ``1..seqLength`` of
``seqinfo.ini`` (or ``1..max frame`` without one); frames without detections are kept as
empty frames.  Confidence (the paper's integer 0..100): a file holds either probabilities or raw
detector scores, one rule for all its rows, chosen by ``scores=`` or, by default (``"auto"``),
by the share of its scores in [0, 1]:

* ``"probability"`` (e.g. SORT's Faster R-CNN ``det_sort_frcnn.txt``, 0.5..1.0): every score
  must be in [0, 1], else ``file:line`` is an error; ``conf = round(100 * score)``;
* ``"raw"`` (raw ACF scores of the official MOT15 ``det.txt``, about -0.8..139, of which at
  most 1.5 % fall in [0, 1]): ``conf = clip(round(score), 0, 100)``;
* ``"auto"``: probability if every score is in [0, 1], raw if at most half of them are; a file
  in between (more than half, but not all, in [0, 1]) is refused at the first score outside
  [0, 1].  So one stray value never switches the rule silently (a 1.01 among probabilities is
  an error naming its line; it used to turn every confidence of the file into 0 or 1).

``round`` is half up everywhere in this module (``floor(x + 0.5)``), as in ``geometry``.

KITTI PointRCNN detections (AB3DMOT's ``det_02_pointrcnn/<Class>/NNNN.txt``): comma separated
``frame,type,x1,y1,x2,y2,score,h,w,l,x,y,z,rot_y,alpha`` (15 fields, type 1 pedestrian, 2 car,
3 cyclist), 0-based frames.  Only rows of the requested class are kept (filtering by class,
not dropping).  The raw score is a logit (can be negative): ``conf = round(100*sigmoid(score))``.
The files contain a handful of zero-width boxes (``x1 == x2`` at the right image border: 1 in
Car/0000, 4 in Car/0019); by default these are dropped and *recorded* in
``DetectionSequence.dropped`` (with a warning), ``on_degenerate="error"`` raises instead.  A
negative width or height is always an error.  ``image_size`` is (1242, 375), the usual
image_02 size; individual KITTI sequences differ by a few pixels (e.g. 1224x370, 1238x374).
``fps`` is 10 (KITTI's recording rate).

MOTChallenge ground truth, following the MOTChallenge devkit:

* MOT15, 10 fields ``frame,id,x,y,w,h,flag,wx,wy,wz``: a row is a target iff ``flag != 0``;
  there are no distractors (as in the MOT15 evaluation).
* MOT16/17/20, 9 fields ``frame,id,x,y,w,h,flag,class,visibility``: a row is a target iff
  ``flag != 0`` and ``class == 1`` (pedestrian); classes 2 (person on vehicle), 7 (static
  person), 8 (distractor) and 12 (reflection) are distractors: a hypothesis matched to one
  (IoU >= 0.5, Hungarian per frame over all gt rows of the frame) is removed rather than
  counted.  The other classes (3..6, 9..11, 13) are kept as rows that are neither targets nor
  distractors (they take part in that matching, as in the devkit).  Class ids outside 1..13
  are an error.

KITTI tracking ground truth (``label_02/NNNN.txt``), space separated, 17 fields
``frame id type truncated occluded alpha x1 y1 x2 y2 h w l x y z ry``, 0-based frames:

* ``car``: ``Car`` rows are targets, ``Van`` rows distractors;
* ``pedestrian``: ``Pedestrian`` rows are targets, ``Person`` rows (KITTI *tracking* labels
  spell person-sitting ``Person``; ``Person_sitting`` is accepted too) distractors;
* ``cyclist``: ``Cyclist`` rows are targets, no distractors;
* ``DontCare`` rows become ignore regions (``GroundTruth.dontcare``); all other types are
  not loaded.  Type names outside the KITTI vocabulary are an error.
* Not implemented (unlike the official KITTI devkit): no minimum box height (25 px), no
  truncation/occlusion-based ignoring.  Scores are therefore close to, not identical with,
  the official devkit.

MOTChallenge results: ``frame,id,x,y,w,h,1,-1,-1,-1`` sorted by (frame, id), boxes with two
decimals, written atomically (temporary file in the same folder, then ``os.replace``).  Frame
numbers are written as the tracker numbered them, so KITTI results stay 0-based: pass
``first_frame=0`` to ``write_mot_results`` / ``read_mot_results`` for them.

KITTI tracking results (``write_kitti_results`` / ``read_kitti_results``): the label_02 layout
plus a score, ``frame id type truncated occluded alpha x1 y1 x2 y2 h w l x y z ry score``, space
separated, 0-based frames, what TrackEval's Kitti2DBox reads; unknown 3D fields are written as
KITTI's "unknown" values.  ``read_results`` reads either format for evaluation.

Frame numbers above ``MAX_FRAME`` (100 000) are rejected as typos everywhere, since a
sequence is materialised and tracked frame by frame (the longest MOTChallenge / KITTI
sequences have a few thousand frames; 100 000 empty frames already take about 10 s to track).
Box coordinates and sizes beyond ``MAX_COORD`` (1 000 000 pixels in magnitude) are rejected as
typos too: the solvers work on integer pixel boxes (32-bit integers in the fact format).  A
detection box narrower or lower than ``MIN_DET_SIZE`` (0.01 pixels, the precision of a results
file) is an error in MOTChallenge files and a degenerate box (dropped and recorded like a
zero-area box) in KITTI files: the trackers' boxes could not be written back.
"""

from __future__ import annotations

import configparser
import json
import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Mapping, Sequence

import numpy as np

OBJECT_TYPES = ("pedestrian", "car", "cyclist")
"""Object types in the paper's vocabulary."""

KITTI_IMAGE_SIZE = (1242, 375)
KITTI_FPS = 10.0

_KITTI_DET_TYPE = {"pedestrian": 1, "car": 2, "cyclist": 3}
_KITTI_LABEL_TYPES = (
    "Car", "Van", "Truck", "Pedestrian", "Person", "Person_sitting",
    "Cyclist", "Tram", "Misc", "DontCare",
)
_KITTI_RESULT_TYPE = {"car": "Car", "pedestrian": "Pedestrian", "cyclist": "Cyclist"}
_KITTI_TARGETS = {
    "car": (("Car",), ("Van",)),
    "pedestrian": (("Pedestrian",), ("Person", "Person_sitting")),
    "cyclist": (("Cyclist",), ()),
}
_MOT_PEDESTRIAN = 1
_MOT_DISTRACTORS = (2, 7, 8, 12)
_MOT_NUM_CLASSES = 13
MAX_FRAME = 100_000
"""Frame numbers above this are rejected as typos (sequences are built and tracked frame by frame)."""
MAX_COORD = 1_000_000.0
"""Box coordinates and sizes beyond this (in magnitude, pixels) are rejected as typos."""
MIN_DET_SIZE = 0.01
MAX_DET_AREA = 20_000_000
"""px^2: a larger detection box would take 100 * area beyond clingo's 32-bit integers (tracker.MAX_BOX_AREA)."""
"""Detection boxes must be at least this wide and high (results files keep two decimals)."""


# ---------------------------------------------------------------------------------------
# errors


class InputFormatError(ValueError):
    """A user mistake in an input file; the message is ``"<path>:<line>: <reason>"``."""

    def __init__(self, reason: str, path: str | os.PathLike, line: int | None = None):
        self.reason = reason
        self.path = str(path)
        self.line = line
        where = f"{self.path}:{line}" if line is not None else self.path
        super().__init__(f"{where}: {reason}")

    def __reduce__(self):  # keep it picklable (e.g. across a process pool)
        return (type(self), (self.reason, self.path, self.line))


class InputFormatWarning(UserWarning):
    """Rows a reader skipped by documented policy (they are also recorded on the result)."""


# ---------------------------------------------------------------------------------------
# data types


@dataclass(frozen=True)
class DetectionFrame:
    """The detections of one frame: xywh boxes, raw scores, 0..100 confidences and types."""

    frame: int
    boxes: np.ndarray
    scores: np.ndarray
    confidences: np.ndarray
    types: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.types)


@dataclass(frozen=True)
class DetectionSequence:
    """All frames of a sequence from first to last, empty frames included, in order."""

    name: str
    frames: tuple[DetectionFrame, ...]
    first_frame: int
    image_size: tuple[int, int] | None
    fps: float | None
    dropped: tuple[tuple[int, str], ...] = ()
    """(line, reason) of rows skipped by a documented policy (KITTI zero-area boxes)."""

    @property
    def num_frames(self) -> int:
        return len(self.frames)

    @property
    def num_detections(self) -> int:
        return sum(len(f) for f in self.frames)

    def frame(self, number: int) -> DetectionFrame:
        """The frame with this frame number (numbering as in the file)."""
        i = number - self.first_frame
        if not 0 <= i < len(self.frames):
            raise KeyError(number)
        return self.frames[i]


@dataclass(frozen=True)
class GroundTruth:
    """Ground-truth rows (sorted by frame, id) with target / distractor flags and ignore regions.

    ``considered`` rows are the targets that count; a hypothesis matched to a ``distractor``
    row is removed rather than counted; rows that are neither only take part in that matching.
    ``dontcare`` is a (k, 5) table ``frame, x, y, w, h`` of KITTI DontCare regions.
    """

    name: str
    frames: np.ndarray
    ids: np.ndarray
    boxes: np.ndarray
    considered: np.ndarray
    distractor: np.ndarray
    dontcare: np.ndarray
    first_frame: int
    num_frames: int
    visibility: np.ndarray | None = None
    """Visible fraction per row (MOT16+ column 9); all 1.0 where the format has none (None -> ones)."""

    def __post_init__(self) -> None:
        if self.visibility is None:
            object.__setattr__(self, "visibility", np.ones(len(self.frames)))
        n = len(self.frames)
        for name in ("ids", "boxes", "considered", "distractor", "visibility"):
            if len(getattr(self, name)) != n:
                raise ValueError(f"GroundTruth.{name} has {len(getattr(self, name))} rows, frames has {n}")

    @property
    def num_targets(self) -> int:
        return int(np.count_nonzero(self.considered))

    @property
    def last_frame(self) -> int:
        return self.first_frame + self.num_frames - 1


@dataclass(frozen=True)
class BenchmarkSequence:
    """Where one benchmark sequence's detections and ground truth live, and how to read them."""

    name: str
    dets_path: Path
    gt_path: Path
    format: str
    object_class: str
    seqinfo_path: Path | None = None


# ---------------------------------------------------------------------------------------
# low-level parsing


def _line_chunks(path: Path, size: int):
    """Lists of at most ``size`` (line number, stripped text) of the non-blank lines, read line by
    line (never the whole file at once); missing/empty/unreadable is an error."""
    chunk: list[tuple[int, str]] = []
    lineno, seen = 0, False
    try:
        # newline=None: \r\n and \r become \n, and a file object splits only at \n (str.splitlines
        # would also split at \f, \v, \x85, U+2028 ... and so name the wrong line numbers)
        with open(path, encoding="utf-8-sig", newline=None) as fh:
            for lineno, raw in enumerate(fh, start=1):
                text = raw.strip()
                if text:
                    chunk.append((lineno, text))
                    if len(chunk) >= size:
                        seen = True
                        yield chunk
                        chunk = []
    except FileNotFoundError:
        raise InputFormatError("file not found", path) from None
    except IsADirectoryError:
        raise InputFormatError("is a directory, expected a file", path) from None
    except UnicodeDecodeError as exc:
        raise InputFormatError(f"not a UTF-8 text file ({exc.reason} after line {lineno})", path) from None
    except OSError as exc:
        raise InputFormatError(f"cannot read file ({exc.strerror or exc})", path) from None
    if chunk:
        yield chunk
    elif not seen:
        raise InputFormatError("empty file (no data lines)", path)


def _read_lines(path: Path) -> list[tuple[int, str]]:
    """(line number, stripped text) of the non-blank lines; missing/empty/unreadable is an error."""
    return [line for chunk in _line_chunks(path, 1 << 62) for line in chunk]


def data_line_numbers(path: str | os.PathLike) -> list[int]:
    """The line numbers of a file's data (non-blank) lines: row k of a reader's array is on line [k]."""
    return [n for n, _ in _read_lines(Path(path))]


def _split(path: Path, lines: list[tuple[int, str]], sep: str | None, lo: int, hi: int,
           what: str) -> list[list[str]]:
    """Split every line into fields and check the field count is in lo..hi."""
    out = []
    for lineno, text in lines:
        fields = text.split(sep)  # numpy and float() accept surrounding blanks
        if not lo <= len(fields) <= hi:
            want = f"{lo}" if lo == hi else f"{lo} to {hi}"
            sep_name = "comma-separated" if sep == "," else "space-separated"
            raise InputFormatError(
                f"expected {want} {sep_name} fields ({what}), found {len(fields)}", path, lineno)
        out.append(fields)
    return out


def _numbers(path: Path, linenos: Sequence[int], rows: list[list[str]], columns: Sequence[int],
             names: Sequence[str]) -> np.ndarray:
    """The given columns of rows as a float array; non-numeric, NaN and inf fields are errors."""
    columns = list(columns)
    try:  # fast path: numpy parses the strings; on failure convert field by field to name the culprit
        if columns == list(range(len(columns))):
            table = [r[:len(columns)] for r in rows]
        else:
            table = [[r[c] for c in columns] for r in rows]
        out = np.array(table, dtype=float).reshape(len(rows), len(columns))
    except ValueError:
        out = np.empty((len(rows), len(columns)))
        for r, fields in enumerate(rows):
            for c, (col, name) in enumerate(zip(columns, names)):
                try:
                    out[r, c] = float(fields[col])
                except ValueError:
                    raise InputFormatError(f"field {col + 1} ({name}) is not a number: {fields[col]!r}",
                                           path, linenos[r]) from None
    bad = np.argwhere(~np.isfinite(out))
    if len(bad):
        r, c = (int(v) for v in bad[0])
        raise InputFormatError(f"field {columns[c] + 1} ({names[c]}) is not finite: {rows[r][columns[c]]!r}",
                               path, linenos[r])
    return out


_CHUNK = 50_000
"""Lines split and converted at a time: the per-field Python strings of a large file never exist all at once."""


def _table(path: Path, lines: list[tuple[int, str]], sep: str | None, lo: int, hi: int, what: str,
           columns: Sequence[int], names: Sequence[str]) -> np.ndarray:
    """_split then _numbers, chunk by chunk (the first error found is reported, in file order per chunk)."""
    parts = []
    for start in range(0, len(lines), _CHUNK):
        chunk = lines[start:start + _CHUNK]
        rows = _split(path, chunk, sep, lo, hi, what)
        parts.append(_numbers(path, [n for n, _ in chunk], rows, columns, names))
        del rows
    return np.vstack(parts) if parts else np.empty((0, len(list(columns))))


def _read_table(path: Path, sep: str | None, lo: int, hi: int, what: str, columns: Sequence[int],
                names: Sequence[str]) -> tuple[np.ndarray, list[int]]:
    """A numeric file read chunk by chunk, straight from disk: (the columns as floats, the line
    number of each row).  Its memory is the array plus one chunk of text; the first error is
    reported as soon as its chunk is read."""
    parts, linenos = [], []
    for chunk in _line_chunks(path, _CHUNK):
        rows = _split(path, chunk, sep, lo, hi, what)
        numbers = [n for n, _ in chunk]
        parts.append(_numbers(path, numbers, rows, columns, names))
        linenos.extend(numbers)
        del rows, chunk
    return np.vstack(parts), linenos


def _first_bad(mask: np.ndarray) -> int | None:
    idx = np.flatnonzero(mask)
    return int(idx[0]) if len(idx) else None


def _check_integral(path: Path, linenos: Sequence[int], values: np.ndarray, name: str) -> np.ndarray:
    bad = _first_bad((values != np.floor(values)) | (np.abs(values) > 2.0 ** 53))
    if bad is not None:
        raise InputFormatError(f"{name} is not an integer: {values[bad]:g}", path, linenos[bad])
    return values.astype(np.int64)


def _check_min_frame(path: Path, linenos: Sequence[int], frames: np.ndarray, first: int) -> None:
    """Frames >= first, and below MAX_FRAME (a typo must not make a billion-frame sequence)."""
    bad = _first_bad(frames < first)
    if bad is not None:
        raise InputFormatError(
            f"frame {frames[bad]} is before the first frame {first}", path, linenos[bad])
    _check_max_frame(path, linenos, frames, MAX_FRAME, "implausibly large frame number")


def _check_max_frame(path: Path, linenos: Sequence[int], frames: np.ndarray, last: int,
                     what: str) -> None:
    bad = _first_bad(frames > last)
    if bad is not None:
        raise InputFormatError(f"frame {frames[bad]} is after the last frame {last} ({what})",
                               path, linenos[bad])


def _check_coordinates(path: Path, linenos: Sequence[int], values: np.ndarray, names: Sequence[str]) -> None:
    """Box columns within +-MAX_COORD: a huge coordinate would overflow the solvers' integer boxes."""
    bad = np.argwhere(np.abs(values) > MAX_COORD)
    if len(bad):
        r, c = (int(v) for v in bad[0])
        raise InputFormatError(f"{names[c]} {values[r, c]:g} is implausibly large "
                               f"(box coordinates are pixels, at most {MAX_COORD:g} in magnitude)",
                               path, linenos[r])


def _check_positive_size(path: Path, linenos: Sequence[int], boxes: np.ndarray) -> None:
    bad = _first_bad((boxes[:, 2] <= 0) | (boxes[:, 3] <= 0))
    if bad is not None:
        w, h = boxes[bad, 2], boxes[bad, 3]
        raise InputFormatError(f"box width and height must be > 0, got w={w:g} h={h:g}",
                               path, linenos[bad])


def _check_unique(path: Path, linenos: Sequence[int], frames: np.ndarray, ids: np.ndarray) -> None:
    """Each (frame, id) at most once; the message names both lines."""
    if len(frames) < 2:
        return
    order = np.lexsort((np.arange(len(frames)), ids, frames))
    f, i = frames[order], ids[order]
    dup = _first_bad((f[1:] == f[:-1]) & (i[1:] == i[:-1]))
    if dup is not None:
        first, second = order[dup], order[dup + 1]
        raise InputFormatError(
            f"duplicate (frame {frames[second]}, id {ids[second]}); first seen on line {linenos[first]}",
            path, linenos[second])


def _round_half_up(x: np.ndarray) -> np.ndarray:
    return np.floor(np.asarray(x, dtype=float) + 0.5).astype(np.int64)


def _object_type(name: str, path: Path | str) -> str:
    key = str(name).strip().lower()
    if key not in OBJECT_TYPES:
        raise InputFormatError(
            f"unknown object class {name!r} (known: {', '.join(OBJECT_TYPES)})", path)
    return key


def _build_frames(frames: np.ndarray, boxes: np.ndarray, scores: np.ndarray, conf: np.ndarray,
                  types: Sequence[str], first: int, count: int) -> tuple[DetectionFrame, ...]:
    """One DetectionFrame per frame first..first+count-1, keeping file order within a frame."""
    order = np.argsort(frames, kind="stable")
    frames, boxes, scores, conf = frames[order], boxes[order], scores[order], conf[order]
    types = [types[i] for i in order]
    numbers = np.arange(first, first + count)
    starts = np.searchsorted(frames, numbers, side="left")
    ends = np.searchsorted(frames, numbers, side="right")
    out = []
    for n, a, b in zip(numbers, starts, ends):
        out.append(DetectionFrame(
            frame=int(n),
            boxes=boxes[a:b].copy(),
            scores=scores[a:b].copy(),
            confidences=conf[a:b].copy(),
            types=tuple(types[a:b]),
        ))
    return tuple(out)


# ---------------------------------------------------------------------------------------
# MOTChallenge


def read_seqinfo(path: str | os.PathLike) -> dict:
    """A MOTChallenge seqinfo.ini as a dict: name, frameRate, seqLength, imWidth, imHeight (+ others as str)."""
    path = Path(path)
    lines = _read_lines(path)  # missing / empty / unreadable
    parser = configparser.ConfigParser(interpolation=None)
    parser.optionxform = str  # keep key case
    try:
        parser.read_string("\n".join(s for _, s in lines), source=str(path))
    except configparser.Error as exc:
        raise InputFormatError(f"not a valid seqinfo.ini: {str(exc).splitlines()[0]}", path) from None
    if not parser.has_section("Sequence"):
        raise InputFormatError("no [Sequence] section", path)
    raw = {k: v.strip() for k, v in parser.items("Sequence")}
    by_lower = {k.lower(): k for k in raw}
    line_of = {}
    for lineno, text in lines:
        key = text.split("=", 1)[0].strip().lower()
        line_of.setdefault(key, lineno)
    out: dict = {k: v for k, v in raw.items()}
    for key, kind in (("name", str), ("frameRate", float), ("seqLength", int),
                      ("imWidth", int), ("imHeight", int)):
        if key.lower() not in by_lower:
            raise InputFormatError(f"missing key {key!r} in [Sequence]", path)
        orig = by_lower[key.lower()]
        text = raw[orig]
        del out[orig]
        try:
            value = kind(text)
        except ValueError:
            raise InputFormatError(f"{key} is not {'an integer' if kind is int else 'a number'}: {text!r}",
                                   path, line_of.get(key.lower())) from None
        # (an int may exceed the float range: np.isfinite would raise TypeError)
        if kind is not str and not (value > 0 and (kind is int or np.isfinite(value))):
            raise InputFormatError(f"{key} must be > 0, got {text!r}", path, line_of.get(key.lower()))
        if kind is str and not value:
            raise InputFormatError(f"{key} is empty", path, line_of.get(key.lower()))
        if key == "seqLength" and value > MAX_FRAME:
            raise InputFormatError(f"seqLength {value} is implausibly large (> {MAX_FRAME})",
                                   path, line_of.get(key.lower()))
        out[key] = value
    return out


def _resolve_seqinfo(seqinfo, data_path: Path) -> dict | None:
    """seqinfo given as a dict or a path, or found at ../seqinfo.ini relative to the file's folder."""
    if isinstance(seqinfo, Mapping):
        missing = [k for k in ("name", "frameRate", "seqLength", "imWidth", "imHeight") if k not in seqinfo]
        if missing:
            raise ValueError(f"seqinfo dict lacks {', '.join(missing)} (use read_seqinfo)")
        return dict(seqinfo)
    if seqinfo is not None:
        return read_seqinfo(seqinfo)
    candidate = data_path.parent.parent / "seqinfo.ini"
    return read_seqinfo(candidate) if candidate.is_file() else None


def _mot_sequence_name(path: Path, info: dict | None) -> str:
    if info is not None:
        return str(info["name"])
    if path.parent.name in ("det", "gt") and path.parent.parent.name:
        return path.parent.parent.name
    return path.stem


def _mot_frames_and_boxes(path: Path, linenos: Sequence[int], a: np.ndarray, info: dict | None):
    """The frame column (integral, 1..seqLength) and the xywh boxes (plausible, positive) of a MOT file."""
    frames = _check_integral(path, linenos, a[:, 0], "frame")
    _check_min_frame(path, linenos, frames, 1)
    if info is not None:
        _check_max_frame(path, linenos, frames, info["seqLength"], "seqLength in seqinfo.ini")
    boxes = a[:, 2:6]
    _check_coordinates(path, linenos, boxes, ("x", "y", "w", "h"))
    _check_positive_size(path, linenos, boxes)
    return frames, boxes


SCORE_RULES = ("auto", "probability", "raw")


def _mot_confidences(path: Path, linenos: Sequence[int], scores: np.ndarray, rule: str) -> np.ndarray:
    """The confidence rule of a MOTChallenge detection file (module doc), one rule for every row."""
    if rule not in SCORE_RULES:
        raise ValueError(f"scores must be one of {', '.join(SCORE_RULES)}, got {rule!r}")
    inside = (scores >= 0.0) & (scores <= 1.0)
    if rule == "auto":
        share = float(inside.mean())
        if share == 1.0:
            rule = "probability"
        elif share <= 0.5:
            rule = "raw"
        else:
            bad = _first_bad(~inside)
            raise InputFormatError(
                f"score {scores[bad]:g} is outside 0..1 although {int(inside.sum())} of {len(scores)} scores "
                "are probabilities in 0..1: fix the line, or choose the rule (--scores probability|raw)",
                path, linenos[bad])
    if rule == "probability":
        bad = _first_bad(~inside)
        if bad is not None:
            raise InputFormatError(f"score {scores[bad]:g} is not a probability in 0..1", path, linenos[bad])
        return _round_half_up(100.0 * scores)
    return _round_half_up(np.clip(scores, 0.0, 100.0))  # clip first: huge scores overflow int64


def _check_area(path: Path, linenos: Sequence[int], w: np.ndarray, h: np.ndarray) -> None:
    """A detection's area must fit the solvers' 32-bit arithmetic (refimpl.ranges): w*h <= MAX_DET_AREA."""
    bad = _first_bad(np.round(w) * np.round(h) > MAX_DET_AREA)
    if bad is not None:
        raise InputFormatError(f"box area w*h = {w[bad]:g}*{h[bad]:g} exceeds {MAX_DET_AREA} px^2 "
                               "(the solvers compute 100 * area in 32-bit integers)", path, linenos[bad])


def read_mot_detections(path: str | os.PathLike, seqinfo=None,
                        object_type: str = "pedestrian", scores_rule: str = "auto") -> DetectionSequence:
    """A MOTChallenge det.txt as a DetectionSequence over frames 1..seqLength (see module doc for conf)."""
    path = Path(path)
    otype = _object_type(object_type, path)
    a, linenos = _read_table(path, ",", 7, 10, "frame,id,x,y,w,h,score,...", range(7),
                             ("frame", "id", "x", "y", "w", "h", "score"))
    info = _resolve_seqinfo(seqinfo, path)
    frames, boxes = _mot_frames_and_boxes(path, linenos, a, info)
    tiny = _first_bad((boxes[:, 2] < MIN_DET_SIZE) | (boxes[:, 3] < MIN_DET_SIZE))
    if tiny is not None:
        raise InputFormatError(f"box width and height must be >= {MIN_DET_SIZE:g} pixels, got "
                               f"w={boxes[tiny, 2]:g} h={boxes[tiny, 3]:g}", path, linenos[tiny])
    _check_area(path, linenos, boxes[:, 2], boxes[:, 3])
    scores = a[:, 6]
    conf = _mot_confidences(path, linenos, scores, scores_rule)
    count = int(info["seqLength"]) if info is not None else int(frames.max())
    return DetectionSequence(
        name=_mot_sequence_name(path, info),
        frames=_build_frames(frames, boxes, scores, conf, [otype] * len(frames), 1, count),
        first_frame=1,
        image_size=(int(info["imWidth"]), int(info["imHeight"])) if info is not None else None,
        fps=float(info["frameRate"]) if info is not None else None,
    )


def read_mot_ground_truth(path: str | os.PathLike, seqinfo=None) -> GroundTruth:
    """A MOTChallenge gt.txt (MOT15 10 fields or MOT16/17/20 9 fields) with devkit target/distractor flags."""
    path = Path(path)
    lines = _read_lines(path)
    info = _resolve_seqinfo(seqinfo, path)
    rows = _split(path, lines, ",", 9, 10, "frame,id,x,y,w,h,flag,class,visibility or MOT15 frame,id,x,y,w,h,flag,wx,wy,wz")
    linenos = [n for n, _ in lines]
    widths = {len(r) for r in rows}
    if len(widths) > 1:
        bad = next(i for i, r in enumerate(rows) if len(r) != len(rows[0]))
        raise InputFormatError(
            f"mixed field counts: {len(rows[bad])} here, {len(rows[0])} on line {linenos[0]}",
            path, linenos[bad])
    mot15 = len(rows[0]) == 10
    if mot15:
        a = _numbers(path, linenos, rows, range(7), ("frame", "id", "x", "y", "w", "h", "flag"))
    else:
        a = _numbers(path, linenos, rows, range(9),
                     ("frame", "id", "x", "y", "w", "h", "flag", "class", "visibility"))
    frames, boxes = _mot_frames_and_boxes(path, linenos, a, info)
    ids = _check_integral(path, linenos, a[:, 1], "id")
    _check_unique(path, linenos, frames, ids)
    flag = a[:, 6] != 0
    if mot15:
        considered = flag
        distractor = np.zeros(len(frames), dtype=bool)
        visibility = np.ones(len(frames))
    else:
        classes = _check_integral(path, linenos, a[:, 7], "class")
        bad = _first_bad((classes < 1) | (classes > _MOT_NUM_CLASSES))
        if bad is not None:
            raise InputFormatError(
                f"unknown class {classes[bad]} (MOTChallenge classes are 1..{_MOT_NUM_CLASSES})",
                path, linenos[bad])
        considered = flag & (classes == _MOT_PEDESTRIAN)
        distractor = np.isin(classes, _MOT_DISTRACTORS)
        visibility = a[:, 8]
    order = np.lexsort((ids, frames))
    count = int(info["seqLength"]) if info is not None else int(frames.max())
    return GroundTruth(
        name=_mot_sequence_name(path, info),
        frames=frames[order],
        ids=ids[order],
        boxes=boxes[order],
        considered=considered[order],
        distractor=distractor[order],
        dontcare=np.zeros((0, 5)),
        first_frame=1,
        num_frames=count,
        visibility=visibility[order],
    )


def _results_array(path: Path, lines: list[tuple[int, str]], first_frame: int) -> np.ndarray:
    a = _table(path, lines, ",", 6, 10, "frame,id,x,y,w,h,...", range(6), ("frame", "id", "x", "y", "w", "h"))
    linenos = [n for n, _ in lines]
    frames = _check_integral(path, linenos, a[:, 0], "frame")
    ids = _check_integral(path, linenos, a[:, 1], "id")
    _check_min_frame(path, linenos, frames, first_frame)
    _check_coordinates(path, linenos, a[:, 2:6], ("x", "y", "w", "h"))
    _check_positive_size(path, linenos, a[:, 2:6])
    _check_unique(path, linenos, frames, ids)
    return a


def read_mot_results(path: str | os.PathLike, allow_empty: bool = False, first_frame: int = 1) -> np.ndarray:
    """A MOTChallenge results file as an (n, 6) float array ``frame, id, x, y, w, h`` in file order.

    An empty file is an error (usually a crashed tracker) unless ``allow_empty``.  Frames before
    ``first_frame`` are errors: 1 for MOTChallenge, 0 for KITTI results kept 0-based.
    """
    path = Path(path)
    try:
        lines = _read_lines(path)
    except InputFormatError as exc:
        if allow_empty and exc.reason.startswith("empty file"):
            return np.zeros((0, 6))
        raise
    return _results_array(path, lines, first_frame)


def _fmt2(v: float) -> str:
    return f"{round(float(v), 2) + 0.0:.2f}"  # + 0.0 turns -0.0 into 0.0


def write_text_atomic(path, text: str) -> None:
    """Write text atomically through refimpl.outputs (never a partial file; symlinks, device
    nodes, modes and the umask handled as its module doc says)."""
    from .outputs import write_atomic
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
    r = np.round(a[:, 2:6], 2)
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
    try:
        lines = _read_lines(path)
    except InputFormatError as exc:
        if allow_empty and exc.reason.startswith("empty file"):
            return np.zeros((0, 6))
        raise
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
    return np.column_stack([frames.astype(float), ids.astype(float), boxes])


RESULT_FORMATS = ("mot", "kitti")
"""Results file formats ``write_results`` writes (``--out-format``)."""


def results_formatter(out_format: str, first_frame: int = 1, object_class: str | None = None):
    """A function formatting (n, 6) rows as ``out_format`` lines (for streaming writers)."""
    if out_format == "mot":
        return lambda rows: format_mot_results(rows, first_frame)
    if out_format == "kitti":
        if object_class is None:
            raise ValueError("KITTI tracking results need the object class")
        return lambda rows: format_kitti_results(rows, object_class)
    raise ValueError(f"unknown results format {out_format!r} (known: {', '.join(RESULT_FORMATS)})")


def write_results(path: str | os.PathLike, rows, out_format: str, first_frame: int = 1,
                  object_class: str | None = None) -> None:
    """Write results rows as MOTChallenge (``mot``) or KITTI tracking (``kitti``, needs the class) lines."""
    if out_format == "mot":
        write_mot_results(path, rows, first_frame=first_frame)
    elif out_format == "kitti":
        if object_class is None:
            raise ValueError("KITTI tracking results need the object class")
        write_kitti_results(path, rows, object_class)
    else:
        raise ValueError(f"unknown results format {out_format!r} (known: {', '.join(RESULT_FORMATS)})")


def read_results(path: str | os.PathLike, data_format: str, object_class: str | None = None,
                 allow_empty: bool = False) -> np.ndarray:
    """The results of one sequence as (n, 6) ``frame, id, x, y, w, h`` for evaluation on ``data_format``.

    ``mot``: a MOTChallenge results file (1-based frames).  ``kitti``: 0-based frames, either in
    the KITTI tracking format (``write_kitti_results``, rows of ``object_class``) or as
    MOTChallenge lines (what ``refimpl track --format kitti`` writes by default), told apart by
    the separator of the first line (comma: MOTChallenge).
    """
    path = Path(path)
    if data_format == "mot":
        return read_mot_results(path, allow_empty=allow_empty, first_frame=1)
    if data_format != "kitti":
        raise ValueError(f"unknown format {data_format!r} (mot or kitti)")
    try:
        first = _read_lines(path)[0][1]
    except InputFormatError as exc:
        if allow_empty and exc.reason.startswith("empty file"):
            return np.zeros((0, 6))
        raise
    if "," in first:
        return read_mot_results(path, allow_empty=allow_empty, first_frame=0)
    if object_class is None:
        raise ValueError("KITTI tracking results need the object class")
    return read_kitti_results(path, object_class, allow_empty=allow_empty)


# ---------------------------------------------------------------------------------------
# KITTI tracking


def _kitti_label_num_frames(path: Path) -> int:
    """Number of frames of a KITTI label_02 file: its largest frame number + 1."""
    lines = _read_lines(path)
    rows = _split(path, lines, None, 17, 17, "KITTI tracking label")
    linenos = [n for n, _ in lines]
    frames = _check_integral(path, linenos, _numbers(path, linenos, rows, [0], ["frame"])[:, 0], "frame")
    _check_min_frame(path, linenos, frames, 0)
    return int(frames.max()) + 1


def read_kitti_detections(path: str | os.PathLike, object_class: str, num_frames: int | None = None,
                          on_degenerate: str = "drop") -> DetectionSequence:
    """PointRCNN detections of one class as a DetectionSequence over frames 0..num_frames-1.

    num_frames defaults to the frame count of ``../../label_02/NNNN.txt`` (relative to the class
    folder) if present, else max frame + 1.  Zero-width/height boxes: see module doc.
    """
    path = Path(path)
    otype = _object_type(object_class, path)
    if on_degenerate not in ("drop", "error"):
        raise ValueError("on_degenerate must be 'drop' or 'error'")
    a, linenos = _read_table(path, ",", 15, 15, "frame,type,x1,y1,x2,y2,score,h,w,l,x,y,z,rot_y,alpha", range(15),
                             ("frame", "type", "x1", "y1", "x2", "y2", "score", "h", "w", "l", "x", "y", "z",
                              "rot_y", "alpha"))
    frames = _check_integral(path, linenos, a[:, 0], "frame")
    types = _check_integral(path, linenos, a[:, 1], "type")
    _check_min_frame(path, linenos, frames, 0)
    bad = _first_bad(~np.isin(types, list(_KITTI_DET_TYPE.values())))
    if bad is not None:
        raise InputFormatError(
            f"unknown class type {types[bad]} (1 pedestrian, 2 car, 3 cyclist)", path, linenos[bad])
    if num_frames is None:
        label = path.parent.parent.parent / "label_02" / path.name
        num_frames = _kitti_label_num_frames(label) if label.is_file() else int(frames.max()) + 1
    elif num_frames < 1:
        raise ValueError("num_frames must be >= 1")
    _check_max_frame(path, linenos, frames, num_frames - 1, f"num_frames={num_frames}")
    _check_coordinates(path, linenos, a[:, 2:6], ("x1", "y1", "x2", "y2"))
    w = a[:, 4] - a[:, 2]
    h = a[:, 5] - a[:, 3]
    neg = _first_bad((w < 0) | (h < 0))
    if neg is not None:
        raise InputFormatError(
            f"box has negative size: x2-x1={w[neg]:g}, y2-y1={h[neg]:g}", path, linenos[neg])
    keep = types == _KITTI_DET_TYPE[otype]
    zero = keep & ((w < MIN_DET_SIZE) | (h < MIN_DET_SIZE))  # zero-area, or too thin for a results file
    dropped: list[tuple[int, str]] = []
    if zero.any():
        first = int(np.flatnonzero(zero)[0])
        if on_degenerate == "error":
            raise InputFormatError(
                f"box width and height must be > 0, got w={w[first]:g} h={h[first]:g}" if
                w[first] == 0 or h[first] == 0 else
                f"box width and height must be >= {MIN_DET_SIZE:g} pixels, got w={w[first]:g} h={h[first]:g}",
                path, linenos[first])
        for i in np.flatnonzero(zero):
            kind = "zero-area" if w[i] == 0 or h[i] == 0 else f"below {MIN_DET_SIZE:g} px"
            dropped.append((linenos[i], f"{kind} box w={w[i]:g} h={h[i]:g}"))
        warnings.warn(
            f"{path}: dropped {len(dropped)} zero-area (or thinner than {MIN_DET_SIZE:g} px) detection "
            f"box(es) on line(s) {', '.join(str(n) for n, _ in dropped)}", InputFormatWarning, stacklevel=2)
        keep &= ~zero
    _check_area(path, np.asarray(linenos)[keep], w[keep], h[keep])
    boxes = np.column_stack([a[:, 2], a[:, 3], w, h])[keep]
    scores = a[keep, 6]
    conf = _round_half_up(100.0 * 0.5 * (1.0 + np.tanh(0.5 * scores)))  # sigmoid, overflow-free
    return DetectionSequence(
        name=path.stem,
        frames=_build_frames(frames[keep], boxes, scores, conf, [otype] * int(keep.sum()), 0, num_frames),
        first_frame=0,
        image_size=KITTI_IMAGE_SIZE,
        fps=KITTI_FPS,
        dropped=tuple(dropped),
    )


def read_kitti_ground_truth(path: str | os.PathLike, object_class: str) -> GroundTruth:
    """A KITTI label_02 file: targets and distractors of one class plus DontCare regions (module doc)."""
    path = Path(path)
    otype = _object_type(object_class, path)
    lines = _read_lines(path)
    rows = _split(path, lines, None, 17, 17,
                  "frame id type truncated occluded alpha x1 y1 x2 y2 h w l x y z ry")
    linenos = [n for n, _ in lines]
    cols = [0, 1] + list(range(3, 17))
    names = ["frame", "id", "truncated", "occluded", "alpha", "x1", "y1", "x2", "y2",
             "h", "w", "l", "x", "y", "z", "ry"]
    a = _numbers(path, linenos, rows, cols, names)
    frames = _check_integral(path, linenos, a[:, 0], "frame")
    ids = _check_integral(path, linenos, a[:, 1], "id")
    _check_min_frame(path, linenos, frames, 0)
    types = [r[2] for r in rows]
    for t, lineno in zip(types, linenos):
        if t not in _KITTI_LABEL_TYPES:
            raise InputFormatError(
                f"unknown object type {t!r} (KITTI types: {', '.join(_KITTI_LABEL_TYPES)})",
                path, lineno)
    _check_coordinates(path, linenos, a[:, 5:9], ("x1", "y1", "x2", "y2"))
    x1, y1, x2, y2 = a[:, 5], a[:, 6], a[:, 7], a[:, 8]
    boxes = np.column_stack([x1, y1, x2 - x1, y2 - y1])
    _check_positive_size(path, linenos, boxes)
    types_arr = np.array(types, dtype=object)
    is_dc = types_arr == "DontCare"
    objects = ~is_dc
    obj_idx = np.flatnonzero(objects)
    _check_unique(path, [linenos[i] for i in obj_idx], frames[obj_idx], ids[obj_idx])
    targets, distractors = _KITTI_TARGETS[otype]
    is_target = np.isin(types_arr, list(targets))
    is_distr = np.isin(types_arr, list(distractors)) if distractors else np.zeros(len(types), bool)
    sel = np.flatnonzero(is_target | is_distr)
    sel = sel[np.lexsort((ids[sel], frames[sel]))]
    dc = np.flatnonzero(is_dc)
    dontcare = np.column_stack([frames[dc].astype(float), boxes[dc]]) if len(dc) else np.zeros((0, 5))
    return GroundTruth(
        name=path.stem,
        frames=frames[sel],
        ids=ids[sel],
        boxes=boxes[sel],
        considered=is_target[sel],
        distractor=is_distr[sel],
        dontcare=dontcare,
        first_frame=0,
        num_frames=int(frames.max()) + 1,
        visibility=np.ones(len(sel)),
    )


# ---------------------------------------------------------------------------------------
# benchmarks


MOT15_TRAIN = (
    "ADL-Rundle-6", "ADL-Rundle-8", "ETH-Bahnhof", "ETH-Pedcross2", "ETH-Sunnyday", "KITTI-13",
    "KITTI-17", "PETS09-S2L1", "TUD-Campus", "TUD-Stadtmitte", "Venice-2",
)
MOT15_SORT6 = ("TUD-Campus", "ETH-Sunnyday", "ETH-Pedcross2", "ADL-Rundle-8", "Venice-2", "KITTI-17")
KITTI_TRAIN = tuple(f"{i:04d}" for i in range(21))
KITTI_VAL_SEQMAP = Path("KITTI") / "tracking" / "training" / "evaluate_tracking.seqmap.val"
"""The val split (AB3DMOT's): the sequences it lists are held out; the other training sequences
are the split tuned on (``kitti-*-train``)."""
BENCHMARKS = ("mot15", "mot15-sort6", "kitti-car", "kitti-ped",
              "kitti-car-val", "kitti-ped-val", "kitti-car-train", "kitti-ped-train")


def _mot15(root: Path, names: Sequence[str]) -> list[BenchmarkSequence]:
    out = []
    for name in names:
        seq = root / "MOT15" / "train" / name
        out.append(BenchmarkSequence(
            name=name, dets_path=seq / "det" / "det_sort_frcnn.txt", gt_path=seq / "gt" / "gt.txt",
            format="mot", object_class="pedestrian", seqinfo_path=seq / "seqinfo.ini"))
    return out


def kitti_val_sequences(root: str | os.PathLike) -> tuple[str, ...]:
    """The sequence names listed in the KITTI val seqmap (first field of each non-empty line)."""
    path = Path(root) / KITTI_VAL_SEQMAP
    if not path.is_file():
        raise InputFormatError("KITTI val seqmap not found (needed for the kitti-*-val/-train splits)", path)
    names = []
    for lineno, line in _read_lines(path):
        name = line.split()[0]
        if name not in KITTI_TRAIN:
            raise InputFormatError(f"sequence {name!r} is not a KITTI training sequence (0000-0020)", path, lineno)
        if name in names:
            raise InputFormatError(f"sequence {name!r} listed twice", path, lineno)
        names.append(name)
    if not names:
        raise InputFormatError("the KITTI val seqmap lists no sequence", path)
    return tuple(names)


def _kitti(root: Path, object_class: str, split: str = "all") -> list[BenchmarkSequence]:
    base = root / "KITTI" / "tracking" / "training"
    det_dir = base / "det_02_pointrcnn" / {"car": "Car", "pedestrian": "Pedestrian"}[object_class]
    names = KITTI_TRAIN
    if split != "all":
        val = set(kitti_val_sequences(root))
        names = tuple(n for n in KITTI_TRAIN if (n in val) == (split == "val"))
    return [BenchmarkSequence(
        name=name, dets_path=det_dir / f"{name}.txt", gt_path=base / "label_02" / f"{name}.txt",
        format="kitti", object_class=object_class, seqinfo_path=None) for name in names]


def benchmark_sequences(name: str, data_root: str | os.PathLike) -> list[BenchmarkSequence]:
    """The sequences of a named benchmark under data_root (layout of /work/shared/data).

    ``mot15`` (11 MOT15 train sequences, SORT Faster R-CNN dets), ``mot15-sort6`` (the six
    sequences of the SORT paper's comparison), ``kitti-car`` / ``kitti-ped`` (KITTI tracking
    train 0000-0020, PointRCNN dets, label_02 ground truth), ``kitti-car-val`` / ``kitti-ped-val``
    (the sequences listed in ``KITTI/tracking/training/evaluate_tracking.seqmap.val``: 11) and
    ``kitti-car-train`` / ``kitti-ped-train`` (the other training sequences: 10), the split that
    anything tuned is tuned on.  Every file must exist.
    """
    root = Path(data_root)
    key = name.strip().lower()
    if key == "mot15":
        seqs = _mot15(root, MOT15_TRAIN)
    elif key == "mot15-sort6":
        seqs = _mot15(root, MOT15_SORT6)
    elif key.startswith("kitti-") and key in BENCHMARKS:
        _, cls, *split = key.split("-")
        if not root.is_dir():
            raise InputFormatError(f"data root for benchmark {key!r} not found", root)
        seqs = _kitti(root, {"car": "car", "ped": "pedestrian"}[cls], split[0] if split else "all")
    else:
        raise ValueError(f"unknown benchmark {name!r} (known: {', '.join(BENCHMARKS)})")
    if not root.is_dir():
        raise InputFormatError(f"data root for benchmark {key!r} not found", root)
    for s in seqs:
        for p in (s.dets_path, s.gt_path, s.seqinfo_path):
            if p is not None and not p.is_file():
                raise InputFormatError(
                    f"missing file of benchmark {key!r} (sequence {s.name}); is {root} the benchmark "
                    f"data root (holding MOT15/ and KITTI/)?", p)
    return seqs


def load_detections(seq: BenchmarkSequence) -> DetectionSequence:
    """Read a benchmark sequence's detections (KITTI frame count from its label file)."""
    if seq.format == "mot":
        return read_mot_detections(seq.dets_path, seqinfo=seq.seqinfo_path, object_type=seq.object_class)
    if seq.format == "kitti":
        n = _kitti_label_num_frames(Path(seq.gt_path))
        return read_kitti_detections(seq.dets_path, seq.object_class, num_frames=n)
    raise ValueError(f"unknown format {seq.format!r} (mot or kitti)")


def load_ground_truth(seq: BenchmarkSequence) -> GroundTruth:
    """Read a benchmark sequence's ground truth."""
    if seq.format == "mot":
        return read_mot_ground_truth(seq.gt_path, seqinfo=seq.seqinfo_path)
    if seq.format == "kitti":
        return read_kitti_ground_truth(seq.gt_path, seq.object_class)
    raise ValueError(f"unknown format {seq.format!r} (mot or kitti)")


def _demo_in(base: Path) -> BenchmarkSequence | None:
    seq = base / "TUD-Campus"
    paths = (seq / "det" / "det.txt", seq / "gt" / "gt.txt", seq / "seqinfo.ini")
    if all(p.is_file() for p in paths):
        return BenchmarkSequence(name="TUD-Campus", dets_path=paths[0], gt_path=paths[1],
                                 format="mot", object_class="pedestrian", seqinfo_path=paths[2])
    return None


def demo_sequence_paths() -> BenchmarkSequence:
    """The bundled TUD-Campus demo (MOT15 gt + SORT Faster R-CNN dets), from a checkout or an install."""
    checkout = Path(__file__).resolve().parent.parent / "data" / "demo"
    found = _demo_in(checkout)
    if found is not None:
        return found
    # an installed package holds data/ as refimpl/data/ (pyproject: package-dir refimpl.data)
    found = _demo_in(Path(__file__).resolve().parent / "data" / "demo")
    if found is None:
        raise InputFormatError("bundled demo sequence not found (expected data/demo/TUD-Campus in "
                               "the checkout or the refimpl.data package)", checkout)
    return found


# ---------------------------------------------------------------------------------------
# Event log files
# ---------------------------------------------------------------------------------------

def event_line(e) -> str:
    """One line of the event log in the paper's syntax: 'occurs_at(E,T).'"""
    return f"{e}.\n"


def event_json_line(e) -> str:
    """One JSON line of the event log: time, event name, arguments and the atom."""
    return json.dumps({"time": e.time, "event": e.event.name, "args": [str(a) for a in e.event.args],
                       "atom": str(e)}) + "\n"


class ResultWriter:
    """Writes results rows and event logs to open (staged) files as a streaming tracker decides
    them: a ``refimpl.tracker.ResultSink`` (rows of whole frames, then each frame's events).

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


def write_event_log(path: str, events: Iterable) -> None:
    """The event sequence in the paper's syntax, one 'occurs_at(E,T).' per line, in time order."""
    write_text_atomic(path, "".join(event_line(e) for e in events))


def write_event_log_json(path: str, events: Iterable) -> None:
    """The event sequence as JSON lines: time, event name, arguments and the atom."""
    write_text_atomic(path, "".join(event_json_line(e) for e in events))
