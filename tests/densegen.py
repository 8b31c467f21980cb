"""Dense crowd frames: every box piled on one small area, so the frame is one large component
with thousands of IoU pairs (issue 26, item 2: the frames clingo's 32-bit sums once refused on
every backend).

    python tests/densegen.py --tracks 200 --seed 0 > /tmp/dense200.lp

Tracks are 40 x 80 px boxes with top-left corners uniform in a square of side ``side``; one track
in ten is halted (with a missing_detections event before now); a detection is a jittered copy of
a track's box (``dets`` of them, of distinct tracks).  Two boxes overlap when their corners
differ by < 40 in x and < 80 in y: for side 210 about (80 / 210) * (160 / 210) ~ 29 % of the
pairs before the border effects; seed 0 gives 7,757 IoU pairs of 200 x 187, one component.
"""

from __future__ import annotations

import argparse
import random

import numpy as np

from refimpl.core.geometry import iou_matrix, scale_iou
from refimpl.core.spec import Detection, FrameProblem, HistoryEvent, Term, TrackPrediction
from refimpl.knowledge.event_table import explaining

CURR_TIME = 50


def dense_frame(n_tracks: int, n_dets: int, seed: int, side: int = 210) -> FrameProblem:
    rng = random.Random(seed)
    tboxes = [(rng.randint(0, side), rng.randint(0, side), 40, 80) for _ in range(n_tracks)]
    halted = set(rng.sample(range(n_tracks), n_tracks // 10))
    tracks = tuple(TrackPrediction(f"trk_{i}", "car", "halted" if i in halted else "active", tboxes[i])
                   for i in range(n_tracks))
    seen = rng.sample(range(n_tracks), min(n_dets, n_tracks))
    dboxes = [(tboxes[i][0] + rng.randint(-3, 3), tboxes[i][1] + rng.randint(-3, 3),
               40 + rng.randint(-3, 3), 80 + rng.randint(-3, 3)) for i in seen]
    dets = tuple(Detection(f"det_{j}", "car", rng.randint(60, 100), b) for j, b in enumerate(dboxes))
    ml = scale_iou(iou_matrix(np.array(tboxes, float), np.array(dboxes, float)))
    iou = tuple((tracks[i].id, dets[j].id, int(ml[i, j]))
                for i in range(len(tracks)) for j in range(len(dets)) if ml[i, j] > 0)
    halt = next(e.name for e in explaining("halt") if e.arity == 1)  # missing_detections
    history = tuple(HistoryEvent(Term(halt, (Term(f"trk_{i}"),)), CURR_TIME - 2)
                    for i in sorted(halted))
    return FrameProblem(time=CURR_TIME, detections=dets, tracks=tracks, iou=iou, history=history)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description="print a dense crowd frame problem as facts")
    ap.add_argument("--tracks", type=int, default=200)
    ap.add_argument("--dets", type=int, default=187)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--side", type=int, default=210)
    a = ap.parse_args()
    print(dense_frame(a.tracks, a.dets, a.seed, a.side).to_facts(), end="")
