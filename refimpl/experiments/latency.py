"""Latency: the CPU time of each frame's update, per tracker (an online tracker in a vehicle has a
deadline per frame, so the tail matters beside the mean).

Every tracker of a comparison is timed at the same boundary: ``time.process_time`` around one
frame's update, detections already in memory, scoring excluded (refimpl: ``run_sequence`` with
``frame_times``; the peers: their ``update`` call).  A :class:`Latency` summarises the frames of
one tracker on one dataset: frames per CPU second, the median and the 99th percentile per frame,
and the slowest frame with its size.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np


@dataclass(frozen=True)
class Latency:
    frames: int
    seconds: float
    """CPU seconds of all frames' updates."""
    median_ms: float
    p99_ms: float
    worst_ms: float
    worst: str
    """Where the slowest frame is: ``sequence frame N (k detections)``."""

    @property
    def fps(self) -> float:
        return self.frames / self.seconds if self.seconds > 0 else float("nan")


def summarise(frames: Sequence[tuple[float, str, int, int]]) -> Latency | None:
    """(CPU seconds, sequence, frame, detections) per frame -> a Latency (None without frames).
    Percentiles by numpy's default (linear) rule; ties for the slowest frame go to the first."""
    if not frames:
        return None
    t = np.array([f[0] for f in frames], dtype=float)
    k = int(np.argmax(t))
    seconds, seq, frame, dets = frames[k]
    return Latency(len(t), float(t.sum()), 1000 * float(np.median(t)), 1000 * float(np.percentile(t, 99)),
                   1000 * float(seconds), f"{seq} frame {frame} ({dets} detections)")
