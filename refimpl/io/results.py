"""Results files: what every format's results reader and writer shares (refimpl.io.formats.mot,
.kitti): the checks of a results table, the rows sorted and checked before they are written, and
the atomic write."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import InputFormatError
from .lines import (_check_coordinates, _check_frame_sizes, _check_integral, _check_min_frame, _check_positive_size,
                    _check_unique, _read_lines, _table)
from .outputs import write_atomic


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


