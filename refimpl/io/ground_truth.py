"""Ground truth: GroundTruth, what every format's ground-truth reader makes of a file (the readers:
refimpl.io.formats.mot, .kitti), with its targets, distractors and ignore regions (the conventions:
refimpl.io's package doc)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


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


