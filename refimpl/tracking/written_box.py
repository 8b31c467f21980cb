"""The written box learned online: ``written_box="auto"`` (refimpl.tracking.options.WrittenBox.AUTO).

A track observed in a frame writes either the Kalman state after the update (FILTERED, SORT's
output) or the detection's own box (DETECTION).  Which one is closer to the object depends on the
detector: a detector whose boxes jitter is smoothed by the filter; one whose boxes are precise
while the object's image size changes fast (a car at 10 fps) is followed with a lag, and the
detection is better (docs/tracking.md, 'The written box').  AUTO learns it from the sequence so
far, without labels, one coordinate of the box at a time: centre x, centre y, width, height.

The check.  For a track observed in three consecutive frames t-1, t, t+1, the midpoint of the
detections before and after, m = (d[t-1] + d[t+1]) / 2, is an estimate of the true box at t whose
noise is independent of d[t]'s (detection noise is independent from frame to frame; the motion's
curvature enters as (d2x/dt2) / 2).  So, per coordinate, with n the detection noise of one frame,

    E[(m - d[t])^2] = error(detection)^2 + var(n) / 2 + curvature
    E[(m - f[t])^2] = error(filtered)^2  + var(n) / 2 + curvature (+ a small share: f[t] took d[t-1])

and comparing the two sums of squares compares the two boxes' errors, the midpoint's own noise
cancelling.  Each term is divided by the detection's size at t (its width for centre x and width,
its height for centre y and height), so the sums are in box sizes, not pixels: a sequence at half
the resolution gives the same sums and the same choice.  They are pooled over every track of the
sequence and every frame so far (WrittenBoxEvidence); a coordinate is written from the detection
while its pooled detection sum is smaller by more than STANDARD_ERRORS standard errors (of the
mean over the checks of the difference, detection's minus filtered's), and from the filter
otherwise, and always from the filter until MIN_CHECKS checks were made.

Online: the check of frame t is made when frame t+1's detection arrives, so the choice for frame
t+1 reads frames <= t+1 only, and no frame's rows wait longer than before.  Only the written box
changes: the filter that predicts, and so the frame problems, the hypotheses and the identities,
is the same.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

MIN_CHECKS = 10
"""Checks (three consecutive observations of one track) before the evidence decides; before
them every coordinate is written from the filter (SORT's output, the previous default)."""
STANDARD_ERRORS = 0.5
"""How many standard errors the detection's mean advantage must exceed (measured among 0, 0.5
and 1 on kitti-car-train and kitti-ped-train, docs/tracking.md 'The written box, learned')."""


def centre_size(box: np.ndarray) -> np.ndarray:
    """(x, y, w, h) -> (centre x, centre y, w, h), shape (4,)."""
    x, y, w, h = (float(v) for v in box)
    return np.array([x + w / 2.0, y + h / 2.0, w, h])


def corner_box(c: np.ndarray) -> np.ndarray:
    """(centre x, centre y, w, h) -> (x, y, w, h), shape (4,)."""
    u, v, w, h = (float(x) for x in c)
    return np.array([u - w / 2.0, v - h / 2.0, w, h])


@dataclass(frozen=True)
class WrittenBoxEvidence:
    """The pooled neighbour checks of a sequence so far: per coordinate (centre x, centre y,
    width, height), the sum of the squared distances, in box sizes, from the neighbours' midpoint
    to the filtered box and to the detection."""

    filtered: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    detected: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    squares: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    """The sum of the squared differences (detection's - filtered's) of the checks."""
    checks: int = 0

    def checked(self, before: np.ndarray, detected: np.ndarray, filtered: np.ndarray,
                after: np.ndarray) -> "WrittenBoxEvidence":
        """With one more check: the detections before and after a frame, and the frame's detection
        and filtered box, all as (centre x, centre y, w, h)."""
        midpoint = (before + after) / 2.0
        size = np.array([detected[2], detected[3], detected[2], detected[3]])
        f = ((midpoint - filtered) / size) ** 2
        d = ((midpoint - detected) / size) ** 2
        return WrittenBoxEvidence(tuple((np.array(self.filtered) + f).tolist()),
                                  tuple((np.array(self.detected) + d).tolist()),
                                  tuple((np.array(self.squares) + (d - f) ** 2).tolist()), self.checks + 1)

    def from_detection(self) -> np.ndarray:
        """Which coordinates are written from the detection: (4,) bools, none before MIN_CHECKS."""
        if self.checks < MIN_CHECKS:
            return np.zeros(4, dtype=bool)
        n = self.checks
        mean = (np.array(self.detected) - np.array(self.filtered)) / n  # per check, < 0: detection closer
        var = np.maximum(np.array(self.squares) / n - mean ** 2, 0.0)
        return mean < -STANDARD_ERRORS * np.sqrt(var / n)


@dataclass
class WrittenBoxLearner:
    """One sequence's AUTO written box: the evidence, and each track's last observations (at most
    two, of consecutive frames) that the next check needs."""

    evidence: WrittenBoxEvidence = WrittenBoxEvidence()
    recent: dict[str, list[tuple[int, np.ndarray, np.ndarray]]] = field(default_factory=dict)
    """track id -> [(frame, detection, filtered)] of its last consecutive observed frames."""

    def written(self, track: str, frame: int, detection: np.ndarray, filtered: np.ndarray) -> np.ndarray:
        """The (x, y, w, h) box the track writes for this frame, given its detection and its
        filtered box there; learns from the check this observation completes first."""
        d, f = centre_size(detection), centre_size(filtered)
        seen = self.recent.get(track, [])
        if seen and seen[-1][0] != frame - 1:
            seen = []  # not consecutive: a gap broke the run
        if len(seen) == 2:
            (_, before, _), (_, middle, middle_filtered) = seen
            self.evidence = self.evidence.checked(before, middle, middle_filtered, d)
        self.recent[track] = [*seen[-1:], (frame, d, f)]
        return corner_box(np.where(self.evidence.from_detection(), d, f))

    def forget(self, frame: int) -> None:
        """Drop the runs no later check can extend (no observation in this frame)."""
        self.recent = {t: s for t, s in self.recent.items() if s[-1][0] >= frame}
