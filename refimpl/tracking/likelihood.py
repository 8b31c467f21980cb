"""The matching likelihood ML_t of a frame: the IoU "between predictions and detections" (the
paper, Section 3.1), on its integer scale, with the alternative predictions the tracker options
add (refimpl decisions, docs/model.md): a new track started with the scene's motion is also
matched at rest (scene_velocity, 3.20), a halted track at faster and slower speeds along its path
(uncertain_speed, 3.27), a track started in the frame before at any speed up to a bound
(new_speed, 3.35), and an unmatched track at its prediction moved by the image shift a turning
camera gave the scene (scene_shift, 3.28); and no track is matched to a detection of an
implausibly different size (size_gate, 3.34).  Only ML_t changes, never the boxes of P_t.

scene_shift: the tracks observed in the frame before (active) are predicted; if most of them
overlap no detection (IoU >= MATCHED_IOU), the shift is the one image translation of their
predictions under which the most of them do, provided it explains at least SHIFT_SUPPORT of them
and SHIFT_SUPPORT more than no shift does (:func:`scene_shift`); every track that overlaps no
detection is then also matched at its prediction moved by it (:func:`shifted_likelihood`).
"""

from __future__ import annotations

import numpy as np

from ..core.geometry import iou_matrix, scale_iou
from ..core.spec import IOU_SCALE

GAP_SPEEDS = (0.75, 1.25, 1.5)
"""The tracker option uncertain_speed (docs/model.md 3.27): the factors on the motion a halted
track's filter predicts since its last observation at which it is matched besides 1 (the
prediction itself).  Chosen on the tuning sets' worst case over the shifts (model/presets.json);
slower ones lost HOTA under bursty misses on kitti-car-train (63.2 -> 62.3 with 1, 0.75, 0.5, in a
first version that scaled the size too)."""

_FACTORS = np.array(GAP_SPEEDS)[:, None, None]  # one factor per slice of _speed_boxes

MATCHED_IOU = 0.5
"""A track overlapping a detection by at least this is matched as predicted (the overlap at which
the MOTChallenge and KITTI scorers take two boxes for one object; the model's iou_thresh_occupied)."""

MATCHED_SHARE = 0.8
"""No shift is looked for while at least this share of the active tracks is matched as predicted:
the filters follow the scene."""

SHIFT_SUPPORT = 3
"""A shift must let at least this many active tracks be matched, and this many more than no shift
does: one or two tracks that happen to land on a neighbour are no turn of the camera."""

NEAREST = 3
"""Candidate shifts: from each active track's prediction to its NEAREST nearest detections of a
similar width (within SIZE_RATIO either way)."""

SIZE_RATIO = 1.5

NEW_SPEED_WEIGHT = 0.5
"""The tracker option new_speed (docs/model.md 3.35): the share of its overlap at which a track
seen once is matched at a speed it has not shown: below a track's own prediction at the same
overlap, so that a detection it does overlap, or another track's, is the better explanation.
Chosen on kitti-car-train among 0.3 (matches nothing: times a detection's confidence it stays
below iou_thresh), 0.5 and 0.7 by the worst case over the shifts (model/presets.json)."""

_MATCHED = int(MATCHED_IOU * IOU_SCALE)  # MATCHED_IOU on ML_t's integer scale


def scene_shift(active: np.ndarray, boxes: np.ndarray, likelihood: np.ndarray) -> np.ndarray | None:
    """The image shift (dx, dy) that the scene shows between the active tracks' predicted boxes
    ``active`` (n, 4 xywh) and the frame's detections ``boxes`` (m, 4 xywh), or None;
    ``likelihood``: their ML_t as predicted (integer, n x m).

    Deterministic: candidates are rounded to 0.1 px and taken in sorted order; among those that
    match the most tracks the smallest shift wins, then the first in that order."""
    if len(active) < SHIFT_SUPPORT or len(boxes) == 0:
        return None
    matched = likelihood.max(axis=1) >= _MATCHED
    hits = int(matched.sum())
    if hits / len(matched) >= MATCHED_SHARE or len(active) - hits < SHIFT_SUPPORT:  # (hits / n: mean()'s division)
        return None  # (a shift matches at most the unmatched tracks besides the matched ones)
    centres = active[:, :2] + active[:, 2:] / 2
    disp = (boxes[:, :2] + boxes[:, 2:] / 2)[None] - centres[:, None]  # (n, m, 2)
    ratio = boxes[None, :, 2] / active[:, None, 2]
    distance = np.where((ratio > 1 / SIZE_RATIO) & (ratio < SIZE_RATIO), np.hypot(disp[..., 0], disp[..., 1]), np.inf)
    nearest = np.argsort(distance, axis=1, kind="stable")[:, :NEAREST]  # (n, k): each track's nearest
    rows = np.arange(len(active))[:, None]
    usable = np.isfinite(distance[rows, nearest])
    near_disp = disp[rows, nearest]  # (n, k, 2)
    from_unmatched = usable & ~matched[:, None]  # a matched track's own detection proposes no shift
    candidates = np.unique(np.round(near_disp[from_unmatched], 1).reshape(-1, 2), axis=0)
    if not len(candidates):
        return None
    # a track supports a shift c when c moves its predicted box onto one of its nearest detections
    # (IoU >= MATCHED_IOU): the IoU of two boxes whose centres are (near_disp - c) apart
    size, other = active[:, None, 2:], boxes[nearest][..., 2:]  # (n, 1, 2), (n, k, 2)
    offset = np.abs(near_disp[None] - candidates[:, None, None])  # (c, n, k, 2)
    side = np.clip(np.minimum((size + other) / 2 - offset, np.minimum(size, other)), 0, None)
    inter = side[..., 0] * side[..., 1]
    union = size[..., 0] * size[..., 1] + other[..., 0] * other[..., 1] - inter
    support = ((inter >= MATCHED_IOU * union) & usable).any(axis=2).sum(axis=1)
    best = np.lexsort((np.hypot(candidates[:, 0], candidates[:, 1]), -support))[0]
    if support[best] < hits + SHIFT_SUPPORT:  # >= SHIFT_SUPPORT, and that many more
        return None
    return candidates[best]


def shifted_likelihood(predicted: np.ndarray, boxes: np.ndarray, ml: np.ndarray, shift: np.ndarray) -> None:
    """ML_t (integer, tracks x detections, in place): a track that overlaps no detection by
    MATCHED_IOU is also matched at its predicted box moved by ``shift`` (the better of the two)."""
    unmatched = ml.max(axis=1) < _MATCHED
    if unmatched.any():
        moved = np.hstack([predicted[unmatched, :2] + shift, predicted[unmatched, 2:]])
        ml[unmatched] = np.maximum(ml[unmatched], scale_iou(iou_matrix(moved, boxes)))


def matching_likelihood(predicted: np.ndarray, boxes: np.ndarray, states: list[str],
                        at_rest: list[tuple[int, np.ndarray]], last_seen: list[tuple[int, np.ndarray]],
                        shifted: bool, seen_once: list[tuple[int, np.ndarray, int]] = (),
                        reach: float = 0.0, similar: float = 1.0) -> np.ndarray:
    """ML_t (integer, tracks x detections) of the tracks' ``predicted`` boxes (n, 4) and the
    frame's detections ``boxes`` (m, 4): the scaled IoU, then each option's alternative prediction
    where it is better.  ``states``: each track's state; ``at_rest``: (index, first box) of the
    tracks started with the scene's motion and not seen since (scene_velocity); ``last_seen``:
    (index, last observed box) of the halted tracks, given with uncertain_speed; ``shifted``:
    the option scene_shift; ``seen_once``, ``reach``, ``similar``: those of :func:`new_speed`.
    (The tracker options are read by the caller: options.py reads this module's constants for its
    help texts.)"""
    n = len(predicted)
    if last_seen:  # the halted tracks' moved boxes in the same iou_matrix call (elementwise: the same values)
        every = iou_matrix(np.concatenate((predicted, _speed_boxes(last_seen, predicted))), boxes)
        ml, moved = scale_iou(every[:n]), every[n:]
    else:
        ml, moved = scale_iou(iou_matrix(predicted, boxes)), None
    if shifted:
        active = [k for k, state in enumerate(states) if state == "active"]
        shift = scene_shift(predicted[active], boxes, ml[active]) if active else None
        if shift is not None:
            shifted_likelihood(predicted, boxes, ml, shift)
    if at_rest:
        either_motion(at_rest, boxes, ml)
    if moved is not None:
        uncertain_speed(last_seen, moved, ml)
    if seen_once and reach > 0 and len(boxes):
        new_speed(seen_once, boxes, ml, reach, similar)
    return ml


def either_motion(at_rest: list[tuple[int, np.ndarray]], boxes: np.ndarray, ml: np.ndarray) -> None:
    """The tracker option scene_velocity, refimpl decision (docs/model.md 3.20): a track started
    with the scene's motion and not observed since has two predictions, the scene's motion and
    rest where it was seen; its matching likelihood (ML_t, in place) is the better of the two.
    The scene's median motion is the motion of a turning camera, not of a car on either side of
    a camera driving forward."""
    rest = [k for k, _ in at_rest]
    still = np.array([box for _, box in at_rest], dtype=float).reshape(-1, 4)
    ml[rest] = np.maximum(ml[rest], scale_iou(iou_matrix(still, boxes)))


def _speed_boxes(last_seen: list[tuple[int, np.ndarray]], predicted: np.ndarray) -> np.ndarray:
    """The boxes uncertain_speed matches besides the predictions, (len(GAP_SPEEDS) * h, 4), factor
    by factor, each every halted track of ``last_seen`` (index, last observed box): the predicted
    box's centre moved GAP_SPEEDS times as far from the centre of the last observed box as the
    filter predicts, the predicted size kept."""
    halted = [k for k, _ in last_seen]
    last = np.array([box for _, box in last_seen], dtype=float).reshape(-1, 4)
    pred = predicted[halted]
    start, size = last[:, :2] + last[:, 2:] / 2, pred[:, 2:]
    moved = pred[:, :2] + size / 2 - start
    out = np.empty((len(GAP_SPEEDS), len(halted), 4))
    out[..., :2] = start + _FACTORS * moved - size / 2
    out[..., 2:] = size
    return out.reshape(-1, 4)


def uncertain_speed(last_seen: list[tuple[int, np.ndarray]], moved_iou: np.ndarray, ml: np.ndarray) -> None:
    """The tracker option uncertain_speed, refimpl decision (docs/model.md 3.27): an object not
    seen for a while has moved at a speed known only roughly.  A halted track's matching
    likelihood (ML_t, in place) is the best overlap of a detection with its predicted box and
    with that box's centre moved GAP_SPEEDS times as far from the centre of its last observed
    box as the filter predicts (the predicted size kept).  ``moved_iou``: the IoU of the boxes of
    _speed_boxes with the frame's detections."""
    halted = [k for k, _ in last_seen]
    best = moved_iou.reshape(len(GAP_SPEEDS), len(halted), -1).max(axis=0)
    ml[halted] = np.maximum(ml[halted], scale_iou(best))  # scale_iou is monotone: the max commutes


def new_speed(seen_once: list[tuple[int, np.ndarray, int]], boxes: np.ndarray, ml: np.ndarray,
              reach: float, similar: float) -> None:
    """The tracker option new_speed, refimpl decision (docs/model.md 3.35): a track seen once has
    not shown its speed (a car crossing the view moves further than its own width between frames,
    so its second detection overlaps neither its first nor the filter's prediction at rest).  Its
    matching likelihood (ML_t, in place) with a detection of about its size
    (areas within ``similar`` either way) is also NEW_SPEED_WEIGHT times the overlap of that
    detection with its box moved towards it by at most ``reach`` times the square root of its area
    per frame since it was seen.  ``seen_once``: (track index, its observed box, frames since >= 1)
    in the pixels of ``boxes``; the tracker gives the tracks started in the frame before (frames
    since 1): for halted ones too, the reach growing with the frames, a false detection seen once
    latched onto the next near it (docs/model.md 3.35)."""
    rows = [k for k, _, _ in seen_once]
    first = np.array([box for _, box, _ in seen_once], dtype=float).reshape(-1, 4)
    since = np.array([n for _, _, n in seen_once], dtype=float)
    size = first[:, None, 2:]  # (t, 1, 2): the box keeps its size
    start = first[:, None, :2] + size / 2
    step = (boxes[None, :, :2] + boxes[None, :, 2:] / 2) - start  # (t, m, 2) centre to centre
    far = np.hypot(step[..., 0], step[..., 1])
    bound = (reach * since * np.sqrt(first[:, 2] * first[:, 3]))[:, None]
    centre = start + step * np.minimum(1.0, bound / np.maximum(far, 1e-9))[..., None]
    low = np.maximum(centre - size / 2, boxes[None, :, :2])
    high = np.minimum(centre + size / 2, boxes[None, :, :2] + boxes[None, :, 2:])
    inter = np.prod(np.clip(high - low, 0.0, None), axis=2)
    own, theirs = (first[:, 2] * first[:, 3])[:, None], (boxes[:, 2] * boxes[:, 3])[None, :]
    overlap = inter / (own + theirs - inter)
    alike = (theirs <= own * similar) & (theirs * similar >= own)
    ml[rows] = np.maximum(ml[rows], np.where(alike, scale_iou(NEW_SPEED_WEIGHT * overlap), 0))


def size_gate(ml: np.ndarray, boxes: np.ndarray, last_seen: list[tuple[int, int, np.ndarray]], factor: float,
              growth: float) -> None:
    """The tracker option size_gate, refimpl decision (docs/model.md 3.34): an object's apparent
    size changes gradually.  A track's matching likelihood (ML_t, in place) with a detection is 0
    where the detection's area and the track's last observed area differ by more than ``factor``
    times ``growth`` per frame since that observation, either way.  ``last_seen``: (track index,
    frames since its last observation >= 1, last observed box) in the pixels of ``boxes`` (n, 4
    xywh); ``growth``: the tracker option size_change at the sequence's frame rate (1 without it).
    Zero likelihood leaves the pair without an iou fact: neither assigned nor resumed."""
    if not last_seen or not len(boxes):
        return
    rows = np.array([k for k, _, _ in last_seen])
    since = np.array([gap for _, gap, _ in last_seen], dtype=float)
    last = np.array([box for _, _, box in last_seen], dtype=float).reshape(-1, 4)
    ratio = (boxes[:, 2] * boxes[:, 3])[None, :] / (last[:, 2] * last[:, 3])[:, None]
    bound = (float(factor) * float(growth) ** since)[:, None]
    ml[rows] = np.where((ratio > bound) | (ratio * bound < 1.0), 0, ml[rows])
