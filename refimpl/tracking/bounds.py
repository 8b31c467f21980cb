"""Where a prediction may lie: each track's predicted box clipped to the image extended by one image
size on every side, its area capped at MAX_BOX_AREA, so that a long-halted track's area velocity
cannot blow it past the ASP model's 32-bit integer arithmetic (the relations compute 100 * area).

``PredictionBounds.boxes`` clips a frame's predictions as one array; ``PredictionBounds.box`` one
box on Python floats.  Both give the bits np.clip gives: min(max(v, lo), hi) of a finite value (a
prediction is finite, refimpl.tracking.motion checks it), and +, -, *, / and sqrt round alike on
Python floats and numpy's float64 (tests/test_frame_arrays.py)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

MAX_BOX_AREA = 20_000_000
"""px^2 (working pixels, refimpl.tracking.camera.working_scale): 100 * area stays below clingo's 2^31
integer limit."""


@dataclass(frozen=True)
class PredictionBounds:
    width: float
    """The image's width in its own pixels (1500 where unknown)."""
    height: float
    cap: float
    """The largest area of a box in the image's pixels: MAX_BOX_AREA over the working scale squared
    (the cap is on the working box of the facts)."""

    @classmethod
    def of(cls, img_width: float, img_height: float, pixel_scale: float) -> "PredictionBounds":
        """From the image size in working pixels (0: unknown) and the working scale."""
        cap = MAX_BOX_AREA if pixel_scale == 1.0 else MAX_BOX_AREA / (pixel_scale * pixel_scale)
        return cls(float(img_width or 1500) / pixel_scale, float(img_height or 1500) / pixel_scale, cap)

    def boxes(self, boxes: np.ndarray) -> np.ndarray:
        """Every row of ``boxes`` (n, 4 xywh) bounded, as a new array: the clip elementwise (the same
        comparisons as ``box``), a row whose area exceeds the cap by ``box``."""
        w, h = self.width, self.height
        x1, y1 = np.minimum(np.maximum(boxes[:, 0], -w), 2 * w), np.minimum(np.maximum(boxes[:, 1], -h), 2 * h)
        x2 = np.minimum(np.maximum(boxes[:, 0] + boxes[:, 2], -w), 2 * w)
        y2 = np.minimum(np.maximum(boxes[:, 1] + boxes[:, 3], -h), 2 * h)
        out = np.column_stack((x1, y1, np.maximum(x2 - x1, 1.0), np.maximum(y2 - y1, 1.0)))
        for k in np.flatnonzero(out[:, 2] * out[:, 3] > self.cap).tolist():
            out[k] = self.box(*boxes[k].tolist())
        return out

    def box(self, bx: float, by: float, bw0: float, bh0: float) -> tuple[float, float, float, float]:
        """One box, given and returned as four Python floats."""
        w, h = self.width, self.height
        x1, y1 = min(max(bx, -w), 2 * w), min(max(by, -h), 2 * h)
        x2, y2 = min(max(bx + bw0, -w), 2 * w), min(max(by + bh0, -h), 2 * h)
        bw, bh = max(x2 - x1, 1.0), max(y2 - y1, 1.0)
        if bw * bh > self.cap:
            shrink = math.sqrt(self.cap / (bw * bh))
            cx, cy = x1 + bw / 2, y1 + bh / 2
            bw, bh = bw * shrink, bh * shrink
            x1, y1 = cx - bw / 2, cy - bh / 2
        return (x1, y1, bw, bh)
