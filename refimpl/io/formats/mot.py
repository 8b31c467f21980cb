"""MOTChallenge: ``det/det.txt``, ``gt/gt.txt`` and ``seqinfo.ini`` per sequence, results in
comma-separated lines; everything the format decides (its conventions: refimpl.io's package doc),
and its row of the format registry, :data:`FORMAT`."""

from __future__ import annotations

import os
from pathlib import Path
from typing import IO, Sequence

import numpy as np

from ...core.confidence import EVIDENCE
from ..detections import (DEFAULT_SCORE_RULE, DetectionSequence, _build_frames, _check_area, _Rows, calibrated,
                          resolve_rule, scale_confidences)
from ..errors import InputFormatError
from ..ground_truth import GroundTruth
from ..lines import (MAX_FRAME, MIN_DET_SIZE, _check_frame_sizes, _check_integral, _check_unique, _first_bad, _numbers,
                     _object_type, _read_table, _read_lines, _split)
from ..results import _fmt2, _result_lines, _results_array, _sorted_result_rows, write_text_atomic
from ..seqinfo import _mot_frames_and_boxes, _mot_sequence_name, _resolve_seqinfo
from ..stream import STDIN_NAME, DetectionStream, _Scores
from .data_format import MOTCHALLENGE_DEVKIT, DataFormat, SequenceFiles

MOT = "mot"
"""The format's name; the only place it is spelled."""
SCORE_RULE = EVIDENCE
"""What ``--scores auto`` reads a det.txt's scores with: any detector's scale (ACF's raw 0..139, a
Faster R-CNN's probabilities), calibrated on the sequence itself."""
OBJECT_CLASS = "pedestrian"
"""The class of every row of a det.txt (MOTChallenge tracks pedestrians)."""

MOT_DET_TABLE = (",", 7, 10, "frame,id,x,y,w,h,score,...", range(7), ("frame", "id", "x", "y", "w", "h", "score"))
"""A MOTChallenge detection line: separator, field counts, layout, the columns read and their names."""


def _mot_rows(path, linenos: Sequence[int], a: np.ndarray, info: dict | None,
              max_frame: int | None = MAX_FRAME) -> _Rows:
    """Every check of MOTChallenge detection rows (MOT_DET_TABLE columns, as floats): integral
    frames from 1 (to seqLength with a seqinfo), plausible boxes at least MIN_DET_SIZE wide and
    high, areas the solvers can compute."""
    frames, boxes = _mot_frames_and_boxes(path, linenos, a, info, max_frame)
    tiny = _first_bad((boxes[:, 2] < MIN_DET_SIZE) | (boxes[:, 3] < MIN_DET_SIZE))
    if tiny is not None:
        raise InputFormatError(f"box width and height must be >= {MIN_DET_SIZE:g} pixels, got "
                               f"w={boxes[tiny, 2]:g} h={boxes[tiny, 3]:g}", path, linenos[tiny])
    _check_area(path, linenos, boxes[:, 2], boxes[:, 3])
    return _Rows(frames, boxes, a[:, 6], tuple(linenos))


def read_mot_detections(path: str | os.PathLike, seqinfo=None,
                        object_type: str = "pedestrian", scores_rule: str = DEFAULT_SCORE_RULE) -> DetectionSequence:
    """A MOTChallenge det.txt as a DetectionSequence over frames 1..seqLength (see module doc for conf)."""
    path = Path(path)
    otype = _object_type(object_type, path)
    a, linenos = _read_table(path, *MOT_DET_TABLE)
    info = _resolve_seqinfo(seqinfo, path)
    rows = _mot_rows(path, linenos, a, info)
    _check_frame_sizes(path, rows.linenos, rows.frames)
    rule = resolve_rule(scores_rule, SCORE_RULE)
    conf = scale_confidences(path, linenos, rows.scores, rule)
    count = int(info["seqLength"]) if info is not None else int(rows.frames.max())
    seq = DetectionSequence(
        name=_mot_sequence_name(path, info),
        frames=_build_frames(rows.frames, rows.boxes, rows.scores, conf, [otype] * len(conf), 1, count),
        first_frame=1,
        image_size=(int(info["imWidth"]), int(info["imHeight"])) if info is not None else None,
        fps=float(info["frameRate"]) if info is not None else None,
    )
    return calibrated(seq, rule)


def stream_mot_detections(fh: IO[str], seqinfo=None, object_type: str = "pedestrian",
                          scores_rule: str = DEFAULT_SCORE_RULE, image_size: tuple[int, int] | None = None,
                          path: str = STDIN_NAME) -> DetectionStream:
    """MOTChallenge detection lines from a text stream (module doc); ``seqinfo``: a seqinfo.ini
    path or dict (the sequence's name, frame rate, image size and length), else none is known;
    ``image_size`` overrides its size."""
    otype = _object_type(object_type, path)
    info = _resolve_seqinfo(seqinfo, Path(path)) if seqinfo is not None else None
    size = (int(info["imWidth"]), int(info["imHeight"])) if info is not None else None
    return DetectionStream(fh, path, MOT_DET_TABLE, lambda linenos, a: _mot_rows(path, linenos, a, info, None),
                           _Scores(path, scores_rule, SCORE_RULE), otype, 1,
                           int(info["seqLength"]) if info is not None else None,
                           str(info["name"]) if info is not None else path, image_size or size,
                           float(info["frameRate"]) if info is not None else None)


_MOT_PEDESTRIAN = 1
_MOT_DISTRACTORS = (2, 7, 8, 12)
_MOT_NUM_CLASSES = 13


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
    _check_frame_sizes(path, linenos, frames)
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


GT_CLASSES = {OBJECT_CLASS: ((_MOT_PEDESTRIAN,), _MOT_DISTRACTORS)}
"""MOT16/17/20 gt.txt: the class of its targets and its distractor classes (MOT15 has neither)."""


def benchmark_layout(root: Path, detections: str, names: tuple[str, ...], split: str) -> list[SequenceFiles]:
    """MOT15/train/<sequence>/{det/<detections>, gt/gt.txt, seqinfo.ini} (no split)."""
    out = []
    for name in names:
        seq = root / "MOT15" / "train" / name
        out.append(SequenceFiles(name, seq / "det" / detections, seq / "gt" / "gt.txt", seq / "seqinfo.ini"))
    return out


FORMAT = DataFormat(
    MOT, "MOTChallenge", 1, False,
    read_detections=lambda path, object_class=None, seqinfo=None, num_frames=None, scores_rule=DEFAULT_SCORE_RULE:
        read_mot_detections(path, seqinfo=seqinfo, object_type=object_class or OBJECT_CLASS,
                            scores_rule=scores_rule),
    stream_detections=lambda fh, object_class=None, seqinfo=None, scores_rule=DEFAULT_SCORE_RULE, image_size=None:
        stream_mot_detections(fh, seqinfo=seqinfo, object_type=object_class or OBJECT_CLASS,
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
    image_size=None, fps=None, score_rule=SCORE_RULE, gt_classes=GT_CLASSES, devkit=MOTCHALLENGE_DEVKIT,
    benchmark_layout=benchmark_layout,
)
"""MOTChallenge's row of the format registry (refimpl.io.formats.FORMATS)."""
