"""The data-format registry: everything refimpl knows about a file format, in one row.

In the style of py-motmetrics' ``io.loadtxt(fmt=...)``: a format is named once (``MOT``, ``KITTI``)
and ``FORMATS[name]`` says how its detections, ground truth and results are read and written, how
its frames are numbered, whether reading needs the object class, and where its ground truth and
side files live.  The command line's ``--format`` / ``--out-format`` choices, the catalogue, the
folder evaluation and the tracking commands read this table; nothing else compares format names.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from .detections import DEFAULT_SCORE_RULE, DetectionSequence, read_kitti_detections, read_mot_detections
from .errors import InputFormatError
from .ground_truth import GroundTruth, _kitti_label_num_frames, read_kitti_ground_truth, read_mot_ground_truth
from .lines import _read_lines
from .stream import DetectionStream, stream_kitti_detections, stream_mot_detections
from .results import (format_kitti_results, format_mot_results, read_kitti_results, read_mot_results,
                      write_kitti_results, write_mot_results)

MOT, KITTI = "mot", "kitti"
"""The format names; the only place they are spelled."""


def _need_class(name: str, object_class: str | None) -> str:
    if object_class is None:
        raise ValueError(f"{name} files hold several classes: reading or writing them needs the object class")
    return object_class


def _stream_kitti(fh, object_class: str | None = None, seqinfo=None, scores_rule: str = DEFAULT_SCORE_RULE,
                  image_size: tuple[int, int] | None = None) -> DetectionStream:
    if seqinfo is not None:
        raise ValueError("KITTI detections have no seqinfo.ini (the format gives their image size and frame rate)")
    return stream_kitti_detections(fh, _need_class(KITTI, object_class), scores_rule=scores_rule,
                                   image_size=image_size)


def _kitti_label_dir(gt_root: Path) -> Path:
    sub = gt_root / "label_02"
    return sub if sub.is_dir() else gt_root


@dataclass(frozen=True)
class DataFormat:
    """One file format: detections, ground truth and results (see refimpl.io for the conventions)."""

    name: str
    title: str
    first_frame: int
    """The number of a sequence's first frame in its files (MOTChallenge 1, KITTI 0)."""
    needs_class: bool
    """Its files hold several object classes: reading (and writing results) needs ``--class``."""
    read_detections: Callable[..., DetectionSequence]
    """(path, object_class=None, seqinfo=None, num_frames=None, scores_rule=DEFAULT_SCORE_RULE)."""
    stream_detections: Callable[..., DetectionStream]
    """(text stream, object_class=None, seqinfo=None, scores_rule=DEFAULT_SCORE_RULE, image_size=None):
    detections read as the lines arrive (``track --dets -``, refimpl.io.stream)."""
    read_ground_truth: Callable[..., GroundTruth]
    """(path, object_class=None, seqinfo=None)."""
    frames_from_gt: Callable[[Path], int] | None
    """ground-truth path -> the sequence's frame count, where the detections cannot tell it (KITTI:
    the label file; MOTChallenge: None, seqinfo.ini says it)."""
    gt_layout: str
    """Where a ground-truth root holds a sequence's file (for messages)."""
    gt_candidates: Callable[[Path, str], list[Path]]
    """(ground-truth root, sequence name) -> the paths its ground truth may have."""
    gt_names: Callable[[Path], list[str]]
    """ground-truth root -> the names of the sequences with ground truth under it."""
    side_file: Callable[[Path], tuple[str, Path]]
    """detections path -> (label, path) of the file read beside it (seqinfo.ini, the label file)."""
    results_formatter: Callable[[int, str | None], Callable[[np.ndarray], str]]
    """(first_frame, object_class) -> a function formatting (n, 6) rows as results lines."""
    write_results: Callable[[str | os.PathLike, np.ndarray, int, str | None], None]
    read_results: Callable[[Path, str | None, bool], np.ndarray]
    """(path, object_class, allow_empty) -> (n, 6) rows, for evaluation on this format."""


def _read_kitti_results_any(path: Path, object_class: str | None, allow_empty: bool) -> np.ndarray:
    """0-based frames, as KITTI tracking results or as MOTChallenge lines (what ``refimpl track
    --format kitti`` writes by default), told apart by the separator of the first line."""
    try:
        first = _read_lines(path)[0][1]
    except InputFormatError as exc:
        if allow_empty and exc.reason.startswith("empty file"):
            return np.zeros((0, 6))
        raise
    if "," in first:
        return read_mot_results(path, allow_empty=allow_empty, first_frame=0)
    return read_kitti_results(path, _need_class(KITTI, object_class), allow_empty=allow_empty)


FORMATS: dict[str, DataFormat] = {f.name: f for f in (
    DataFormat(
        MOT, "MOTChallenge", 1, False,
        read_detections=lambda path, object_class=None, seqinfo=None, num_frames=None, scores_rule=DEFAULT_SCORE_RULE:
            read_mot_detections(path, seqinfo=seqinfo, object_type=object_class or "pedestrian",
                                scores_rule=scores_rule),
        stream_detections=lambda fh, object_class=None, seqinfo=None, scores_rule=DEFAULT_SCORE_RULE, image_size=None:
            stream_mot_detections(fh, seqinfo=seqinfo, object_type=object_class or "pedestrian",
                                  scores_rule=scores_rule, image_size=image_size),
        read_ground_truth=lambda path, object_class=None, seqinfo=None: read_mot_ground_truth(path, seqinfo=seqinfo),
        frames_from_gt=None,
        gt_layout="<SEQ>/gt/gt.txt",
        gt_candidates=lambda root, name: [root / name / "gt" / "gt.txt"],
        gt_names=lambda root: sorted(p.name for p in root.iterdir() if (p / "gt" / "gt.txt").is_file()),
        side_file=lambda dets: ("seqinfo.ini", dets.parent.parent / "seqinfo.ini"),
        results_formatter=lambda first_frame, object_class: lambda rows: format_mot_results(rows, first_frame),
        write_results=lambda path, rows, first_frame, object_class: write_mot_results(path, rows, first_frame),
        read_results=lambda path, object_class, allow_empty: read_mot_results(path, allow_empty=allow_empty,
                                                                              first_frame=1),
    ),
    DataFormat(
        KITTI, "KITTI tracking", 0, True,
        read_detections=lambda path, object_class=None, seqinfo=None, num_frames=None, scores_rule=DEFAULT_SCORE_RULE:
            read_kitti_detections(path, _need_class(KITTI, object_class), num_frames=num_frames,
                                  scores_rule=scores_rule),
        stream_detections=_stream_kitti,
        read_ground_truth=lambda path, object_class=None, seqinfo=None:
            read_kitti_ground_truth(path, _need_class(KITTI, object_class)),
        frames_from_gt=_kitti_label_num_frames,
        gt_layout="label_02/<SEQ>.txt or <SEQ>.txt",
        gt_candidates=lambda root, name: [_kitti_label_dir(root) / f"{name}.txt"],
        gt_names=lambda root: sorted(p.stem for p in _kitti_label_dir(root).glob("*.txt")
                                     if not p.name.startswith(".")),
        side_file=lambda dets: ("label_02", dets.parent.parent.parent / "label_02" / dets.name),
        results_formatter=lambda first_frame, object_class:
            (lambda cls: lambda rows: format_kitti_results(rows, cls))(_need_class(KITTI, object_class)),
        write_results=lambda path, rows, first_frame, object_class:
            write_kitti_results(path, rows, _need_class(KITTI, object_class)),
        read_results=_read_kitti_results_any,
    ),
)}

FORMAT_NAMES: tuple[str, ...] = tuple(FORMATS)
"""Every format name, in the order the command line lists them."""
RESULT_FORMATS = FORMAT_NAMES
"""Results file formats ``write_results`` writes (``--out-format``)."""


def get_format(name: str) -> DataFormat:
    """The format of that name; ValueError (one line) for an unknown one."""
    try:
        return FORMATS[name]
    except KeyError:
        raise ValueError(f"unknown format {name!r} (known: {', '.join(FORMAT_NAMES)})") from None


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
