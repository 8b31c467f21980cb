"""Reading a data file line by line: splitting into fields, numbers, and the checks every reader
shares (integral frames and ids, plausible frames and coordinates, positive sizes, unique ids).

Every check raises ``InputFormatError("<path>:<line>: <reason>")`` for the first bad row.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Sequence

import numpy as np

from ..core.records import MAX_LINE_CHARS, RecordTooLong, bounded_lines
from .errors import InputFormatError


OBJECT_TYPES = ("pedestrian", "car", "cyclist")
"""Object types in the paper's vocabulary."""
MAX_FRAME = 100_000
"""Frame numbers above this are rejected as typos (sequences are built and tracked frame by frame)."""
MAX_DETECTIONS_PER_FRAME = 5_000
"""Detections one frame may hold (after a reader's class filter): five times the 1000 x 1000 frame
of the scale benchmark, 25 times the densest frame of MOT17 and KITTI.  The IoU of every live track
with every detection is a track x detection matrix (SORT's Hungarian assignment takes it dense),
so two frames of 100,000 boxes allocated 20 GiB (docs/robustness.md, "Huge frames")."""
MAX_COORD = 1_000_000.0
"""Box coordinates and sizes beyond this (in magnitude, pixels) are rejected as typos."""
MIN_DET_SIZE = 0.01
"""Detection boxes must be at least this wide and high (results files keep two decimals)."""
MAX_DET_AREA = 20_000_000
"""px^2: a larger detection box would take 100 * area beyond clingo's 32-bit integers (refimpl.tracking.bounds.MAX_BOX_AREA)."""


def _data_lines(fh, path: Path | str):
    """(line number, stripped text) of the non-blank lines of an open text stream, one at a time as
    they arrive (a file or a pipe); text that is not UTF-8 or cannot be read is an error, and so is
    a line longer than MAX_LINE_CHARS, refused after reading that many characters of it
    (refimpl.core.records: /dev/zero is not read whole)."""
    lineno = 0
    try:
        # a file object opened with newline=None splits only at \n, \r\n and \r (str.splitlines
        # would also split at \f, \v, \x85, U+2028 ... and so name the wrong line numbers)
        for lineno, raw in enumerate(bounded_lines(fh, MAX_LINE_CHARS), start=1):
            text = raw.strip()
            if text:
                yield lineno, text
    except RecordTooLong as exc:
        raise InputFormatError(f"longer than {MAX_LINE_CHARS} characters (a data line is a few dozen): "
                               "not a data file?", path, exc.line) from None
    except UnicodeDecodeError as exc:
        raise InputFormatError(f"not a UTF-8 text file ({exc.reason} after line {lineno})", path) from None
    except OSError as exc:
        raise InputFormatError(f"cannot read file ({exc.strerror or exc})", path) from None


def _line_chunks(path: Path, size: int):
    """Lists of at most ``size`` (line number, stripped text) of the non-blank lines, read line by
    line (never the whole file at once); missing/empty/unreadable is an error."""
    chunk: list[tuple[int, str]] = []
    seen = False
    try:
        fh = open(path, encoding="utf-8-sig", newline=None)
    except FileNotFoundError:
        raise InputFormatError("file not found", path) from None
    except IsADirectoryError:
        raise InputFormatError("is a directory, expected a file", path) from None
    except OSError as exc:
        raise InputFormatError(f"cannot read file ({exc.strerror or exc})", path) from None
    with fh:
        for line in _data_lines(fh, path):
            chunk.append(line)
            if len(chunk) >= size:
                seen = True
                yield chunk
                chunk = []
    if chunk:
        yield chunk
    elif not seen:
        raise InputFormatError("empty file (no data lines)", path)


def _read_lines(path: Path) -> list[tuple[int, str]]:
    """(line number, stripped text) of the non-blank lines; missing/empty/unreadable is an error."""
    return [line for chunk in _line_chunks(path, 1 << 62) for line in chunk]


def data_lines(path: str | os.PathLike) -> list[str]:
    """A file's data (non-blank) lines, stripped (no BOM, no \\r), as every reader of this package sees them."""
    return [text for _, text in _read_lines(Path(path))]


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


def _line_numbers(path: Path | str, lineno: int, text: str, sep: str | None, lo: int, hi: int, what: str,
                  columns: Sequence[int], names: Sequence[str]) -> np.ndarray:
    """One line's columns as a (1, k) float array: _split then _numbers (a stream read line by line)."""
    return _numbers(path, [lineno], _split(path, [(lineno, text)], sep, lo, hi, what), columns, names)


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


def _check_min_frame(path: Path, linenos: Sequence[int], frames: np.ndarray, first: int,
                     max_frame: int | None = MAX_FRAME) -> None:
    """Frames >= first, and up to MAX_FRAME (a typo must not make a billion-frame sequence);
    ``max_frame=None``: no such bound (a pipe bounds the gap between two rows instead)."""
    bad = _first_bad(frames < first)
    if bad is not None:
        raise InputFormatError(
            f"frame {frames[bad]} is before the first frame {first}", path, linenos[bad])
    if max_frame is not None:
        _check_max_frame(path, linenos, frames, max_frame, "implausibly large frame number")


def _check_max_frame(path: Path, linenos: Sequence[int], frames: np.ndarray, last: int,
                     what: str) -> None:
    bad = _first_bad(frames > last)
    if bad is not None:
        raise InputFormatError(f"frame {frames[bad]} is after the last frame {last} ({what})",
                               path, linenos[bad])


def _check_frame_sizes(path: Path, linenos: Sequence[int], frames: np.ndarray) -> None:
    """At most MAX_DETECTIONS_PER_FRAME rows of one frame; the error names the first row beyond it."""
    if len(frames) <= MAX_DETECTIONS_PER_FRAME:
        return
    order = np.argsort(frames, kind="stable")
    f = frames[order]
    over = _first_bad(f[MAX_DETECTIONS_PER_FRAME:] == f[:-MAX_DETECTIONS_PER_FRAME])
    if over is not None:
        k = int(order[over + MAX_DETECTIONS_PER_FRAME])  # the frame's row one beyond the cap, in file order
        raise InputFormatError(too_many_detections(int(frames[k])), path, linenos[k])


def too_many_detections(frame: int) -> str:
    """The one line for a frame beyond MAX_DETECTIONS_PER_FRAME (a file, a pipe and the API say it alike)."""
    return (f"frame {frame} has more than {MAX_DETECTIONS_PER_FRAME} detections (refimpl's cap per frame, "
            "docs/robustness.md: the track x detection IoU would not fit in memory)")


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
