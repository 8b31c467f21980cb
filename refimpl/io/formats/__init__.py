"""The file formats, one module each, and their registry: everything refimpl knows about a format.

In the style of py-motmetrics' ``io.loadtxt(fmt=...)``: a format is one module of this package
(:mod:`.mot` MOTChallenge, :mod:`.kitti` KITTI tracking) that fills in one
:class:`~.data_format.DataFormat` (its readers and writers of detections, ground truth and results,
streaming included; its frame numbering, default image size and frame rate, score rule, ground-truth
classes and distractors, preset key, devkit conventions, benchmark layout and held-out split), and
one row of ``FORMATS`` below.  The command line's ``--format`` / ``--out-format`` choices, the
catalogue, the library's ``refimpl.Tracker(format=...)``, the evaluation devkits, the tracking
commands and the calibration read the row; nothing compares format names.

A format of one's own is a module filling in a DataFormat: :func:`registered` adds it to the
registry for the length of a ``with`` block (the registry is as it was afterwards).
"""

from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator, KeysView

import numpy as np

from ..event_logs import event_json_line, event_line
from . import kitti, mot
from .data_format import KITTI_DEVKIT, MOTCHALLENGE_DEVKIT, DataFormat, SequenceFiles, need_class  # noqa: F401
from .kitti import KITTI  # noqa: F401  (re-exported)
from .mot import MOT  # noqa: F401  (re-exported)

FORMATS: dict[str, DataFormat] = {f.name: f for f in (mot.FORMAT, kitti.FORMAT)}
"""The format registry: name -> its row, in the order the command line lists them."""

FORMAT_NAMES: KeysView[str] = FORMATS.keys()
"""Every format name, in the order the command line lists them (a view of the registry: a format
:func:`registered` is among them while it is)."""
RESULT_FORMATS = FORMAT_NAMES
"""Results file formats ``write_results`` writes (``--out-format``)."""


def get_format(name: str) -> DataFormat:
    """The format of that name; ValueError (one line) for an unknown one."""
    try:
        return FORMATS[name]
    except KeyError:
        raise ValueError(f"unknown format {name!r} (known: {', '.join(FORMATS)})") from None


@contextmanager
def registered(fmt: DataFormat) -> Iterator[DataFormat]:
    """``fmt`` in the registry (``--format NAME``, ``get_format``, ``refimpl.Tracker(format=NAME)``)
    for the length of the ``with`` block; the registry is as before afterwards, however it ends.
    ValueError for a name already taken."""
    if fmt.name in FORMATS:
        raise ValueError(f"format {fmt.name!r} is already registered")
    FORMATS[fmt.name] = fmt
    try:
        yield fmt
    finally:
        del FORMATS[fmt.name]


def results_formatter(out_format: str, first_frame: int = 1, object_class: str | None = None):
    """A function formatting (n, 6) rows as ``out_format`` lines (for streaming writers)."""
    return get_format(out_format).results_formatter(first_frame, object_class)


def write_results(path: str | os.PathLike, rows, out_format: str, first_frame: int = 1,
                  object_class: str | None = None) -> None:
    """Write results rows in ``out_format`` (atomically; KITTI needs the class)."""
    get_format(out_format).write_results(path, rows, first_frame, object_class)


def read_results(path: str | os.PathLike, data_format: str, object_class: str | None = None,
                 allow_empty: bool = False) -> np.ndarray:
    """The results of one sequence as (n, 6) ``frame, id, x, y, w, h`` for evaluation on ``data_format``."""
    return get_format(data_format).read_results(Path(path), object_class, allow_empty)


class ResultWriter:
    """Writes results rows and event logs to open (staged) files as a streaming tracker decides
    them: a ``refimpl.tracking.tracker.ResultSink`` (rows of whole frames, then each frame's events).

    ``results_format``: a function formatting (n, 6) rows as text (default MOTChallenge lines,
    :func:`~.mot.format_mot_results`); chunks of whole frames concatenate to the text of all rows."""

    def __init__(self, results=None, events=None, events_json=None, first_frame: int = 1, results_format=None):
        self.results, self.events_lp, self.events_json = results, events, events_json
        self.format = results_format or (lambda rows: mot.format_mot_results(rows, first_frame))
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
