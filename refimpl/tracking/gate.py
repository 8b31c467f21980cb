"""The association gate learned from the sequence's own matches (the tracker option
``learned_gate``; a refimpl decision, docs/model.md 3.33).

The paper's ``assignment_constraints`` let a track take a detection only where their ``iou/3``
fact (IoU x 100000 of the track's prediction and the detection) is above ``iou_thresh`` (SORT's 0.3).  How much a track's prediction and its own
detection overlap is a property of the detector and the camera: a detector that localizes well at
10 to 30 frames a second gives matches overlapping about 0.77 to 0.84 (the median on mot15 and
kitti-car-train), one whose boxes wander by a tenth of their size about 0.61, half the frame rate
about 0.73 to 0.78.  A fixed gate of 0.3 is then far below a clean detector's matches and close to
a noisy one's, which it cuts: the track is halted, a new one started on its object.

:class:`MatchGate` counts the ``iou/3`` value of every assignment the tracker has made so far in
the sequence (bins of 1,000) and, once it has counted GATE_MIN_MATCHES, gives the frame
problem the gate

    iou_thresh = min(preset, max(floor, ratio / 100 * median))

where ``preset`` is the constant the run was given, ``floor`` two thirds of it (0.2 for 0.3, the
IoU ByteTrack's first association asks) and ``median`` the median of the counted likelihoods (its
bin's middle).  The presets' ratio of 45 leaves a clean detector at the constant's 0.3 (0.45 x 0.77
= 0.35 and 0.45 x 0.84 = 0.38 are above it) and lowers the gate where matches overlap less.  Only the constant changes: the frame
problem carries it (``#const iou_thresh``), so every backend, the checker and ``refimpl diff`` read
the same gate, and the rules are the paper's.  Integer arithmetic throughout: the same matches give
the same gate on any machine.
"""

from __future__ import annotations

from typing import Iterable

GATE_MIN_MATCHES = 50
"""The gate stays the preset's until the sequence has shown this many assignments."""
GATE_BIN = 1000
"""The iou/3 values (IoU x 100000) are counted in bins of this width (101 bins, 0..100000)."""


class MatchGate:
    """The learned ``iou_thresh`` of one sequence (module doc)."""

    def __init__(self, ratio: int, preset: int) -> None:
        self.ratio = int(ratio)
        self.preset = int(preset)
        self.floor = self.preset * 2 // 3
        self.counts = [0] * (100000 // GATE_BIN + 1)
        self.n = 0
        self._gate = self.preset  # gate(), recomputed when a frame's assignments are counted

    def add(self, likelihoods: Iterable[int]) -> None:
        """Count the iou/3 values (0..100000) of one frame's assignments."""
        counts, added = self.counts, self.n
        for v in likelihoods:
            counts[min(max(int(v), 0), 100000) // GATE_BIN] += 1
            self.n += 1
        if self.n != added:
            median = self.median
            self._gate = (self.preset if median is None or self.ratio == 0
                          else min(self.preset, max(self.floor, self.ratio * median // 100)))

    @property
    def median(self) -> int | None:
        """The middle of the median's bin (None before GATE_MIN_MATCHES): the lower median of an
        even count, so that integer arithmetic decides it."""
        if self.n < GATE_MIN_MATCHES:
            return None
        half, below = (self.n + 1) // 2, 0
        for b, c in enumerate(self.counts):  # the first bin whose running count reaches half
            below += c
            if below >= half:
                return min(100000, b * GATE_BIN + GATE_BIN // 2)
        raise AssertionError("unreachable: the counts sum to n")

    def gate(self) -> int:
        """The frame problem's ``iou_thresh``: the preset's until enough matches were counted."""
        return self._gate

    def lowered(self) -> bool:
        """Whether the gate is below the preset: the sequence's matches show a detector whose boxes
        wander (the tracker option wander_noise reads it, docs/tracking.md 'A detector whose boxes
        wander')."""
        return self.gate() < self.preset
