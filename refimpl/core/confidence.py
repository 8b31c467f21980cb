"""The confidence of a detection in VO_t: a detector's score as the model's integer 0..100.

The paper gives every detection of VO_t an integer confidence (``det(det_0, car, 99)``), and the
model's thresholds (``conf_thresh_new_track``, ``conf_thresh_assign``, ``conf_thresh_resume``,
``bridge_conf``) compare against it.  A detector's raw score says nothing by its scale: PointRCNN
writes logits, SORT's Faster R-CNN probabilities, MOT15's ACF values of 0..139.  So refimpl's
default rule (``rank``, a refimpl decision, docs/model.md "The confidence of a detection") maps
each score to its place among every score the sequence has shown so far, this frame included:

    confidence(s) = floor(100 * #{scores seen so far <= s} / #{scores seen so far} + 1/2)

A confidence of 90 then means "at least 90 % of this detector's evidence so far is no stronger",
whatever the detector.  The rule is online (frame t uses frames <= t only, so a file run and the
library's ``update`` see the same numbers) and depends on the order of scores alone: any strictly
increasing rescale of a detector's scores gives the same confidences, hence the same tracks.

``probability`` (scores in 0..1, times 100) and ``raw`` (scores already 0..100) stay as explicit
rules (``--scores``); the file readers apply them (refimpl.io).
"""

from __future__ import annotations

import numpy as np

RANK = "rank"


class OnlineRank:
    """The rank rule's state: every score seen so far, sorted.  ``confidences(scores)`` adds one
    frame's scores and returns their confidences; memory grows by one float per detection."""

    def __init__(self) -> None:
        self._seen = np.zeros(0, dtype=float)

    def confidences(self, scores) -> np.ndarray:
        s = np.asarray(scores, dtype=float).reshape(-1)
        if not len(s):
            return np.zeros(0, dtype=np.int64)
        if not np.isfinite(s).all():
            raise ValueError("a detection score is NaN or infinite")
        add = np.sort(s, kind="stable")
        self._seen = np.insert(self._seen, np.searchsorted(self._seen, add, side="left"), add)
        at_most = np.searchsorted(self._seen, s, side="right")  # scores seen so far <= s, itself included
        return (100 * at_most * 2 + len(self._seen)) // (2 * len(self._seen))  # floor(100 * k / n + 1/2), exact

    def reset(self) -> None:
        self._seen = np.zeros(0, dtype=float)


def rank_confidences(frames_scores) -> list[np.ndarray]:
    """The rank rule over a whole sequence, frame by frame in order (what an online tracker sees)."""
    ranker = OnlineRank()
    return [ranker.confidences(s) for s in frames_scores]
