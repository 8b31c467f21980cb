"""Boxes and the matching likelihood: vectorised IoU and its integer scale (IoU x 100000).

Boxes are numpy arrays of shape (n, 4) in (x, y, w, h) pixels unless a name says xyxy.
The integer IoU is what both solver backends see, so it is computed here, once.
"""

from __future__ import annotations

import numpy as np

from .spec import IOU_SCALE, Box


def xywh_to_xyxy(boxes: np.ndarray) -> np.ndarray:
    """(x, y, w, h) -> (x1, y1, x2, y2)."""
    b = np.asarray(boxes, dtype=float).reshape(-1, 4)
    return np.concatenate((b[:, :2], b[:, :2] + b[:, 2:]), axis=1)  # the same additions, one array


_IOU_BLOCK = 1 << 20
"""Pairs of boxes iou_matrix computes at a time: each pair's IoU is computed elementwise, the same
operations whatever the block, so blocks change no value; they bound the temporaries (about 7
floats a pair) to ~60 MB beside the (n, m) result (a 5,000 x 5,000 frame: 1.4 GB at once before)."""


def iou_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """IoU of every box in a (n, 4 xywh) with every box in b (m, 4 xywh): an (n, m) array in [0, 1]."""
    a = np.asarray(a, dtype=float).reshape(-1, 4)
    b = np.asarray(b, dtype=float).reshape(-1, 4)
    if len(a) == 0 or len(b) == 0:
        return np.zeros((len(a), len(b)))
    if len(a) * len(b) > _IOU_BLOCK:  # rows in blocks: the temporaries of one block, not of the whole
        step = max(1, _IOU_BLOCK // len(b))
        out = np.empty((len(a), len(b)))
        for start in range(0, len(a), step):
            out[start:start + step] = iou_matrix(a[start:start + step], b)
        return out
    # corners (x1, y1) and (x2, y2) = (x + w, y + h), as xywh_to_xyxy computes them; the x and y
    # coordinates go through each step together (the last axis), the same operations elementwise;
    # the corners, sides and areas of a's and b's boxes computed on them stacked (one call each)
    n = len(a)
    c = np.concatenate((a, b))
    c1 = c[:, :2]
    c2 = c1 + c[:, 2:]
    wc = c2 - c1
    area = wc[:, 0] * wc[:, 1]
    a1, b1, a2, b2 = c1[:n], c1[n:], c2[:n], c2[n:]
    side = (np.minimum(a2[:, None], b2[None]) - np.maximum(a1[:, None], b1[None])).clip(0, None)  # np.clip's
    inter = side[..., 0] * side[..., 1]
    union = area[:n, None] + area[None, n:] - inter
    # inter / union where union > 0, else 0.0 (the divisions of np.where(union > 0, inter / union, 0.0),
    # without computing, or warning about, the ones it throws away)
    return np.divide(inter, union, out=np.zeros_like(inter), where=union > 0)


def scale_iou(iou: np.ndarray) -> np.ndarray:
    """IoU in [0, 1] -> integers 0..100000, rounding half up (0.346245 -> 34625)."""
    return np.floor(np.asarray(iou, dtype=float) * IOU_SCALE + 0.5).astype(np.int64)


def integer_box(box: np.ndarray) -> Box:
    """A float (x, y, w, h) box as the integer box2d of the fact format (rounded half up, w, h >= 1)."""
    x, y, w, h = (int(np.floor(float(v) + 0.5)) for v in box)
    return (x, y, max(w, 1), max(h, 1))


_EXACT_INT = 2.0 ** 52
"""Below this every float64 is exactly convertible to int64 after rounding (integer_boxes)."""


def integer_boxes(boxes: np.ndarray) -> list[Box]:
    """[integer_box(b) for b in boxes] for an (n, 4) float array, computed on the whole array: the
    same rounding (floor(v + 0.5): one float64 addition and floor, elementwise), the same integers.
    Where a value is not finite or too large to round exactly in int64 (|v| >= 2^52), every box
    goes through integer_box, so such values fail (or convert) exactly as they do there."""
    b = np.asarray(boxes, dtype=float).reshape(-1, 4)
    if not (np.abs(b) < _EXACT_INT).all():  # also False for NaN
        return [integer_box(v) for v in b]
    r = np.floor(b + 0.5).astype(np.int64)
    np.maximum(r[:, 2:], 1, out=r[:, 2:])
    return list(map(tuple, r.tolist()))  # type: ignore[arg-type]


def integer_box_array(*arrays: np.ndarray) -> np.ndarray | None:
    """integer_boxes of several (n_k, 4) float arrays as one int64 array (the arrays' rows in
    order), rounded as one concatenated array (the same elementwise rounding, so the same
    integers), or None where some value is not finite or too large for it (then integer_boxes
    takes each array on its own)."""
    b = np.concatenate([np.asarray(a, dtype=float).reshape(-1, 4) for a in arrays])
    if not (np.abs(b) < _EXACT_INT).all():  # also False for NaN
        return None
    r = np.floor(b + 0.5).astype(np.int64)
    np.maximum(r[:, 2:], 1, out=r[:, 2:])
    return r


def intersection_area(a: Box, b: Box) -> int:
    """Integer overlap area of two integer boxes (the spatial relations use integers, as the ASP model does)."""
    iw = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
    ih = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
    return max(iw, 0) * max(ih, 0)
