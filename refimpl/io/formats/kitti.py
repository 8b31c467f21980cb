"""KITTI tracking: AB3DMOT's PointRCNN detections (``det_02_pointrcnn/<Class>/NNNN.txt``), the
``label_02`` ground truth, results in the KITTI tracking layout; everything the format decides (its
conventions: refimpl.io's package doc), and its row of the format registry, :data:`FORMAT`."""

from __future__ import annotations

import os
from pathlib import Path
from typing import IO, Sequence

import numpy as np

from ...core.confidence import EVIDENCE
from ..detections import (DEFAULT_SCORE_RULE, DetectionSequence, _build_frames, _check_area, _Rows, _warn_dropped,
                          calibrated, resolve_rule, scale_confidences)
from ..errors import InputFormatError
from ..ground_truth import GroundTruth
from ..lines import (MAX_FRAME, MIN_DET_SIZE, _check_coordinates, _check_frame_sizes, _check_integral,
                     _check_max_frame, _check_min_frame, _check_positive_size, _check_unique, _first_bad, _numbers,
                     _object_type, _read_lines, _read_table, _split)
from ..results import _fmt2, _result_lines, _sorted_result_rows, write_text_atomic
from ..stream import STDIN_NAME, DetectionStream, _Scores
from .data_format import KITTI_DEVKIT, DataFormat, SequenceFiles, need_class
from .mot import read_mot_results

KITTI = "kitti"
"""The format's name; the only place it is spelled."""
SCORE_RULE = EVIDENCE
"""What ``--scores auto`` reads PointRCNN's logits with (calibrated on the sequence itself)."""

KITTI_IMAGE_SIZE = (1242, 375)
"""The usual image_02 size (individual sequences differ by a few pixels: 1224 x 370, 1238 x 374)."""
KITTI_FPS = 10.0
"""KITTI's recording rate."""

_KITTI_DET_TYPE = {"pedestrian": 1, "car": 2, "cyclist": 3}


KITTI_DET_TABLE = (",", 15, 15, "frame,type,x1,y1,x2,y2,score,h,w,l,x,y,z,rot_y,alpha", range(15),
                   ("frame", "type", "x1", "y1", "x2", "y2", "score", "h", "w", "l", "x", "y", "z", "rot_y", "alpha"))
"""A KITTI PointRCNN detection line (as MOT_DET_TABLE)."""


def _kitti_rows(path, linenos: Sequence[int], a: np.ndarray, otype: str, num_frames: int | None,
                on_degenerate: str, max_frame: int | None = MAX_FRAME) -> _Rows:
    """Every check of KITTI PointRCNN detection rows (KITTI_DET_TABLE columns, as floats), and the
    rows kept: integral frames from 0 (below num_frames if given), a known class type, plausible
    boxes of non-negative size, areas the solvers can compute; only rows of ``otype``, its
    degenerate boxes dropped and recorded (``on_degenerate="drop"``) or refused (``"error"``)."""
    frames = _check_integral(path, linenos, a[:, 0], "frame")
    types = _check_integral(path, linenos, a[:, 1], "type")
    _check_min_frame(path, linenos, frames, 0, max_frame)
    bad = _first_bad(~np.isin(types, list(_KITTI_DET_TYPE.values())))
    if bad is not None:
        raise InputFormatError(
            f"unknown class type {types[bad]} (1 pedestrian, 2 car, 3 cyclist)", path, linenos[bad])
    if num_frames is not None:
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
        keep &= ~zero
    kept = np.asarray(linenos)[keep]
    _check_area(path, kept, w[keep], h[keep])
    return _Rows(frames[keep], np.column_stack([a[:, 2], a[:, 3], w, h])[keep], a[keep, 6],
                 tuple(int(n) for n in kept), tuple(dropped))


def read_kitti_detections(path: str | os.PathLike, object_class: str, num_frames: int | None = None,
                          on_degenerate: str = "drop", scores_rule: str = DEFAULT_SCORE_RULE) -> DetectionSequence:
    """PointRCNN detections of one class as a DetectionSequence over frames 0..num_frames-1.

    num_frames defaults to the frame count of ``../../label_02/NNNN.txt`` (relative to the class
    folder) if present, else max frame + 1.  Zero-width/height boxes: see module doc.
    """
    path = Path(path)
    otype = _object_type(object_class, path)
    if on_degenerate not in ("drop", "error"):
        raise ValueError("on_degenerate must be 'drop' or 'error'")
    rule = resolve_rule(scores_rule, SCORE_RULE)
    a, linenos = _read_table(path, *KITTI_DET_TABLE)
    if num_frames is None:
        label = path.parent.parent.parent / "label_02" / path.name
        if label.is_file():
            num_frames = _kitti_label_num_frames(label)
    elif num_frames < 1:
        raise ValueError("num_frames must be >= 1")
    rows = _kitti_rows(path, linenos, a, otype, num_frames, on_degenerate)
    _check_frame_sizes(path, rows.linenos, rows.frames)
    if rows.dropped:
        _warn_dropped(path, rows.dropped)
    if num_frames is None:
        num_frames = int(a[:, 0].max()) + 1  # every row's frame (any class), integral and checked
    seq = DetectionSequence(
        name=path.stem,
        frames=_build_frames(rows.frames, rows.boxes, rows.scores,
                             scale_confidences(path, rows.linenos, rows.scores, rule),
                             [otype] * len(rows.scores), 0, num_frames),
        first_frame=0,
        image_size=KITTI_IMAGE_SIZE,
        fps=KITTI_FPS,
        dropped=rows.dropped,
    )
    return calibrated(seq, rule)


def stream_kitti_detections(fh: IO[str], object_class: str, scores_rule: str = DEFAULT_SCORE_RULE,
                            image_size: tuple[int, int] | None = None, on_degenerate: str = "drop",
                            path: str = STDIN_NAME) -> DetectionStream:
    """KITTI PointRCNN detection lines of one class from a text stream (module doc)."""
    otype = _object_type(object_class, path)
    if on_degenerate not in ("drop", "error"):
        raise ValueError("on_degenerate must be 'drop' or 'error'")
    return DetectionStream(fh, path, KITTI_DET_TABLE,
                           lambda linenos, a: _kitti_rows(path, linenos, a, otype, None, on_degenerate, None),
                           _Scores(path, scores_rule, SCORE_RULE), otype, 0, None, path,
                           image_size or KITTI_IMAGE_SIZE, KITTI_FPS)


_KITTI_LABEL_TYPES = (
    "Car", "Van", "Truck", "Pedestrian", "Person", "Person_sitting",
    "Cyclist", "Tram", "Misc", "DontCare",
)
GT_CLASSES = {
    "car": (("Car",), ("Van",)),
    "pedestrian": (("Pedestrian",), ("Person", "Person_sitting")),
    "cyclist": (("Cyclist",), ()),
}
"""object class -> (its target types, its distractor types) in label_02 (refimpl.io's package doc)."""


def _kitti_label_num_frames(path: Path) -> int:
    """Number of frames of a KITTI label_02 file: its largest frame number + 1."""
    lines = _read_lines(path)
    rows = _split(path, lines, None, 17, 17, "KITTI tracking label")
    linenos = [n for n, _ in lines]
    frames = _check_integral(path, linenos, _numbers(path, linenos, rows, [0], ["frame"])[:, 0], "frame")
    _check_min_frame(path, linenos, frames, 0)
    return int(frames.max()) + 1


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
    _check_frame_sizes(path, [linenos[i] for i in obj_idx], frames[obj_idx])
    targets, distractors = GT_CLASSES[otype]
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


_KITTI_RESULT_TYPE = {"car": "Car", "pedestrian": "Pedestrian", "cyclist": "Cyclist"}


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


KITTI_TRAIN = tuple(f"{i:04d}" for i in range(21))
KITTI_VAL_SEQMAP = Path("KITTI") / "tracking" / "training" / "evaluate_tracking.seqmap.val"
"""The val split (AB3DMOT's): the sequences it lists are held out; the other training sequences
are the split tuned on (``kitti-*-train``)."""


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


def benchmark_layout(root: Path, detections: str, names: tuple[str, ...], split: str) -> list[SequenceFiles]:
    """KITTI/tracking/training/{det_02_pointrcnn/<detections>/<sequence>.txt, label_02/<sequence>.txt}:
    all the sequences named (split ``all``), or those in the val seqmap (``val``) or not (``train``)."""
    base = root / "KITTI" / "tracking" / "training"
    if split != "all":
        val = set(kitti_val_sequences(root))
        names = tuple(n for n in names if (n in val) == (split == "val"))
    return [SequenceFiles(name, base / "det_02_pointrcnn" / detections / f"{name}.txt",
                          base / "label_02" / f"{name}.txt") for name in names]


def _stream_kitti(fh, object_class: str | None = None, seqinfo=None, scores_rule: str = DEFAULT_SCORE_RULE,
                  image_size: tuple[int, int] | None = None) -> DetectionStream:
    if seqinfo is not None:
        raise ValueError("KITTI detections have no seqinfo.ini (the format gives their image size and frame rate)")
    return stream_kitti_detections(fh, need_class(KITTI, object_class), scores_rule=scores_rule,
                                   image_size=image_size)


def _kitti_label_dir(gt_root: Path) -> Path:
    sub = gt_root / "label_02"
    return sub if sub.is_dir() else gt_root


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
    return read_kitti_results(path, need_class(KITTI, object_class), allow_empty=allow_empty)


FORMAT = DataFormat(
    KITTI, "KITTI tracking", 0, True,
    read_detections=lambda path, object_class=None, seqinfo=None, num_frames=None, scores_rule=DEFAULT_SCORE_RULE:
        read_kitti_detections(path, need_class(KITTI, object_class), num_frames=num_frames,
                              scores_rule=scores_rule),
    stream_detections=_stream_kitti,
    read_ground_truth=lambda path, object_class=None, seqinfo=None:
        read_kitti_ground_truth(path, need_class(KITTI, object_class)),
    frames_from_gt=_kitti_label_num_frames,
    gt_layout="label_02/<SEQ>.txt or <SEQ>.txt",
    gt_candidates=lambda root, name: [_kitti_label_dir(root) / f"{name}.txt"],
    gt_names=lambda root: sorted(p.stem for p in _kitti_label_dir(root).glob("*.txt")
                                 if not p.name.startswith(".")),
    side_file=lambda dets: ("label_02", dets.parent.parent.parent / "label_02" / dets.name),
    results_formatter=lambda first_frame, object_class:
        (lambda cls: lambda rows: format_kitti_results(rows, cls))(need_class(KITTI, object_class)),
    write_results=lambda path, rows, first_frame, object_class:
        write_kitti_results(path, rows, need_class(KITTI, object_class)),
    read_results=_read_kitti_results_any,
    image_size=KITTI_IMAGE_SIZE, fps=KITTI_FPS, score_rule=SCORE_RULE, gt_classes=GT_CLASSES, devkit=KITTI_DEVKIT,
    benchmark_layout=benchmark_layout, val_split=kitti_val_sequences,
)
"""KITTI's row of the format registry (refimpl.io.formats.FORMATS)."""
