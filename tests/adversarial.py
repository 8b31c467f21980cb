"""Frames built to make CP-SAT's objectives large (issue 26): the shape on which a 62-bit packed
objective let CP-SAT report OPTIMAL a few units above the optimum.

* one cluster of overlapping boxes, so every track pairs with most detections (many candidate
  pairs: large level-10 and level-5 ranges and a long tie-break pair part);
* halted tracks (the first track always), with tracker-like histories (tests/framegen.py), so
  resumes compete at level 5 and events at level 1;
* detections often an exact copy of the previous detection's box: two pairs equal on levels
  10..1, separated only by the tie-break (level 0);
* half of the frames small (2-4 tracks, 2-5 detections), so that levels 10..1 and the tie-break
  pack into one objective of 55-62 bits.
"""

from __future__ import annotations

import random

import numpy as np

from framegen import CURR_TIME, _random_history
from refimpl.core.geometry import iou_matrix, scale_iou
from refimpl.core.spec import Detection, FrameProblem, TrackPrediction


def adversarial_frame(rng: random.Random) -> FrameProblem:
    """One frame of the shape above, drawn from ``rng``."""
    n_trk, n_det = (2, 9), (2, 9)
    if rng.random() < 0.5:
        n_trk, n_det = (2, 4), (2, 5)
    nt, nd = rng.randint(*n_trk), rng.randint(*n_det)
    tboxes = []
    for _ in range(nt):
        s = rng.choice((2, 5, 10))
        tboxes.append((50 + rng.randint(-s, s), 50 + rng.randint(-s, s), 30 + rng.randint(-s, s),
                       40 + rng.randint(-s, s)))
    states = ["halted" if rng.random() < 0.4 else "active" for _ in range(nt)]
    states[0] = "halted"
    tracks = tuple(TrackPrediction(f"trk_{k + 1}", "car", states[k], tboxes[k]) for k in range(nt))
    dboxes: list[tuple[int, int, int, int]] = []
    for _ in range(nd):
        if dboxes and rng.random() < 0.4:
            dboxes.append(dboxes[-1])  # an identical box
        else:
            b, s = rng.choice(tboxes), rng.choice((1, 3, 6))
            dboxes.append((b[0] + rng.randint(-s, s), b[1] + rng.randint(-s, s),
                           max(1, b[2] + rng.randint(-s, s)), max(1, b[3] + rng.randint(-s, s))))
    dets = tuple(Detection(f"det_{j}", "car", rng.randint(40, 100), dboxes[j]) for j in range(nd))
    ml = scale_iou(iou_matrix(np.array(tboxes, float), np.array(dboxes, float)))
    iou = tuple((tracks[i].id, dets[j].id, int(ml[i, j])) for i in range(nt) for j in range(nd) if ml[i, j] > 0)
    return FrameProblem(time=CURR_TIME, detections=dets, tracks=tracks, iou=iou,
                        history=tuple(_random_history(rng, tracks)))
