"""Ground truth: MOTChallenge gt.txt and KITTI label_02 files with their targets, distractors and
ignore regions (the conventions: refimpl.io's package doc)."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import InputFormatError
from .lines import (_check_coordinates, _check_frame_sizes, _check_integral, _check_min_frame, _check_positive_size,
                    _check_unique, _first_bad, _numbers, _object_type, _read_lines, _split)
from .seqinfo import _mot_frames_and_boxes, _mot_sequence_name, _resolve_seqinfo


_KITTI_LABEL_TYPES = (
    "Car", "Van", "Truck", "Pedestrian", "Person", "Person_sitting",
    "Cyclist", "Tram", "Misc", "DontCare",
)
_KITTI_TARGETS = {
    "car": (("Car",), ("Van",)),
    "pedestrian": (("Pedestrian",), ("Person", "Person_sitting")),
    "cyclist": (("Cyclist",), ()),
}
_MOT_PEDESTRIAN = 1
_MOT_DISTRACTORS = (2, 7, 8, 12)
_MOT_NUM_CLASSES = 13


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
