"""Detections: MOTChallenge det.txt and KITTI PointRCNN files as DetectionSequence, with the
confidence rule (refimpl.io's package doc)."""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Sequence

import numpy as np

from ..core.confidence import EVIDENCE, RANK, online_rule
from .errors import InputFormatError, InputFormatWarning
from .ground_truth import _kitti_label_num_frames
from .lines import (MAX_DET_AREA, MAX_FRAME, MIN_DET_SIZE, _check_coordinates, _check_frame_sizes, _check_integral,
                    _check_max_frame, _check_min_frame, _first_bad, _object_type, _read_table, _round_half_up)
from .seqinfo import _mot_frames_and_boxes, _mot_sequence_name, _resolve_seqinfo


KITTI_IMAGE_SIZE = (1242, 375)
KITTI_FPS = 10.0

_KITTI_DET_TYPE = {"pedestrian": 1, "car": 2, "cyclist": 3}


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

    @property
    def confidence_range(self) -> tuple[int, int] | None:
        """The smallest and largest confidence of its detections (None: there are none)."""
        conf = [int(c) for f in self.frames for c in f.confidences]
        return (min(conf), max(conf)) if conf else None

    def frame(self, number: int) -> DetectionFrame:
        """The frame with this frame number (numbering as in the file)."""
        i = number - self.first_frame
        if not 0 <= i < len(self.frames):
            raise KeyError(number)
        return self.frames[i]


@dataclass(frozen=True)
class _Rows:
    """The validated detections of some lines (a whole file, or one line of a stream), in line order:
    what a reader keeps of them (KITTI: the requested class, degenerate boxes dropped)."""

    frames: np.ndarray
    """int64 frame numbers."""
    boxes: np.ndarray
    """(n, 4) x, y, w, h."""
    scores: np.ndarray
    linenos: tuple[int, ...]
    dropped: tuple[tuple[int, str], ...] = ()
    """(line, reason) of rows dropped by the documented policy (KITTI's degenerate boxes)."""


MOT_DET_TABLE = (",", 7, 10, "frame,id,x,y,w,h,score,...", range(7), ("frame", "id", "x", "y", "w", "h", "score"))
"""A MOTChallenge detection line: separator, field counts, layout, the columns read and their names."""
KITTI_DET_TABLE = (",", 15, 15, "frame,type,x1,y1,x2,y2,score,h,w,l,x,y,z,rot_y,alpha", range(15),
                   ("frame", "type", "x1", "y1", "x2", "y2", "score", "h", "w", "l", "x", "y", "z", "rot_y", "alpha"))
"""A KITTI PointRCNN detection line (as MOT_DET_TABLE)."""


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


SCORE_RULES = ("auto", EVIDENCE, RANK, "probability", "sigmoid", "raw")
"""How a file's scores become confidences, the same rules for every format (refimpl.core.confidence;
docs/model.md 3.19): ``auto`` (the default) is ``evidence``, the scores calibrated on how persistent
the detections of each score are in the sequence itself (any detector, any scale: only the order of
the scores matters); ``rank`` (a score's place among those seen so far); and the fixed scales
``probability`` (scores in 0..1, times 100), ``sigmoid`` (logits, such as KITTI's PointRCNN
scores, through a sigmoid, times 100) and ``raw`` (0..100 as they are, clipped)."""
DEFAULT_SCORE_RULE = "auto"
ONLINE_RULES = (EVIDENCE, RANK)
"""The rules that read a frame's confidences from the frames up to it (refimpl.core.confidence)."""


def resolve_rule(rule: str) -> str:
    """The rule ``rule`` names (``auto`` is ``evidence``); ValueError naming the rules otherwise."""
    _check_rule(rule, SCORE_RULES)
    return EVIDENCE if rule == "auto" else rule


def _check_rule(rule: str, allowed: Sequence[str]) -> None:
    if rule not in allowed:
        raise ValueError(f"scores must be one of {', '.join(allowed)}, got {rule!r}")


def calibrated(seq: DetectionSequence, rule: str) -> DetectionSequence:
    """An online rule (``evidence`` or ``rank``) applied to the sequence's frames in order: each
    frame's confidences from the frames <= it, as a stream and the library compute them."""
    state = online_rule(rule)
    if state is None:
        return seq
    frames = tuple(replace(f, confidences=state.confidences(f.boxes, f.scores, f.types)) for f in seq.frames)
    return replace(seq, frames=frames)


def probability_scale(seq: DetectionSequence) -> DetectionSequence:
    """The sequence with its scores as a caller of a probability-scale tracker (SORT, ByteTrack,
    OC-SORT: refimpl.experiments.peers) puts them, times 100: probabilities as they are (every score
    in 0..1), logits (some score negative: KITTI's PointRCNN) through a sigmoid, any other scale
    (ACF's 0..139) by its rank."""
    scores = np.concatenate([f.scores for f in seq.frames]) if seq.frames else np.zeros(0)
    if len(scores) and ((scores >= 0.0) & (scores <= 1.0)).all():
        rule = "probability"
    elif len(scores) and (scores < 0.0).any():
        rule = "sigmoid"
    else:
        rule = RANK
    return read_again(seq, rule)


def read_again(seq: DetectionSequence, rule: str) -> DetectionSequence:
    """The sequence's confidences computed again from its scores by ``rule`` (a resolved rule), as a
    reader would compute them for a file of its rows."""
    seq = replace(seq, frames=tuple(replace(f, confidences=scale_confidences(seq.name, (), f.scores, rule))
                                    for f in seq.frames))
    return calibrated(seq, rule)


def scale_confidences(path, linenos: Sequence[int], scores: np.ndarray, rule: str, hint: str = "") -> np.ndarray:
    """The 0..100 confidences of scores on a fixed scale (``probability``, ``sigmoid``, ``raw``);
    zeros for an online rule (filled in frame by frame).  ``hint`` ends the message of a score that
    is not a probability."""
    if rule in ONLINE_RULES:
        return np.zeros(len(scores), dtype=np.int64)
    if rule == "probability":
        bad = _first_bad(~((scores >= 0.0) & (scores <= 1.0)))
        if bad is not None:
            raise InputFormatError(f"score {scores[bad]:g} is not a probability in 0..1{hint} "
                                   "(--scores auto reads any scale)", path, linenos[bad])
        return _round_half_up(100.0 * scores)
    if rule == "sigmoid":
        return _sigmoid(scores)
    return _round_half_up(np.clip(scores, 0.0, 100.0))  # raw; clip first: huge scores overflow int64


def _sigmoid(scores: np.ndarray) -> np.ndarray:
    """Logits as 0..100 confidences: round(100 * sigmoid(score)), overflow-free."""
    return _round_half_up(100.0 * 0.5 * (1.0 + np.tanh(0.5 * scores)))


def _check_area(path: Path, linenos: Sequence[int], w: np.ndarray, h: np.ndarray) -> None:
    """A detection's area must fit the solvers' 32-bit arithmetic (refimpl.core.ranges): w*h <= MAX_DET_AREA."""
    bad = _first_bad(np.round(w) * np.round(h) > MAX_DET_AREA)
    if bad is not None:
        raise InputFormatError(f"box area w*h = {w[bad]:g}*{h[bad]:g} exceeds {MAX_DET_AREA} px^2 "
                               "(the solvers compute 100 * area in 32-bit integers)", path, linenos[bad])


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
    rule = resolve_rule(scores_rule)
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


def _warn_dropped(path, dropped: Sequence[tuple[int, str]], stacklevel: int = 3) -> None:
    """One warning naming every line of a degenerate KITTI box that was dropped."""
    warnings.warn(
        f"{path}: dropped {len(dropped)} zero-area (or thinner than {MIN_DET_SIZE:g} px) detection "
        f"box(es) on line(s) {', '.join(str(n) for n, _ in dropped)}", InputFormatWarning, stacklevel=stacklevel)


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
    rule = resolve_rule(scores_rule)
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
