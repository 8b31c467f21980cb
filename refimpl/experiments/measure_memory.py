"""Memory over a long sequence: track 10,000 synthetic frames and sample the heap every 1,000.

    python -m refimpl.experiments.measure_memory [--frames 10000] [--objects 15] [--backend cpsat]

Objects walk across a 1920x1080 image, each missed with probability 0.1 per frame and replaced
by a new one when it leaves; the tracker's state (live tracks and their compacted histories) must
stay bounded; the results rows and the event log are output and grow with the sequence.
"""

from __future__ import annotations

import argparse
import resource
import time
import tracemalloc

import numpy as np

from ..io import DetectionFrame
from ..solvers import DEFAULT_BACKEND, get_solver
from ..tracking.tracker import AbductionTracker


def frames(n_frames: int, n_objects: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    pos = rng.uniform([0, 200], [1800, 900], size=(n_objects, 2))
    vel = rng.normal(0, 4, size=(n_objects, 2))
    for f in range(1, n_frames + 1):
        pos += vel
        out = (pos[:, 0] < -50) | (pos[:, 0] > 1900) | (pos[:, 1] < 0) | (pos[:, 1] > 1000)
        pos[out] = rng.uniform([0, 200], [1800, 900], size=(int(out.sum()), 2))
        vel[out] = rng.normal(0, 4, size=(int(out.sum()), 2))
        seen = rng.random(n_objects) > 0.1
        boxes = np.column_stack([pos[seen], np.full((seen.sum(), 2), [60.0, 150.0])])
        n = len(boxes)
        yield DetectionFrame(f, boxes, np.full(n, 0.95), np.full(n, 95), ("pedestrian",) * n)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=10_000)
    ap.add_argument("--objects", type=int, default=15)
    ap.add_argument("--backend", default=DEFAULT_BACKEND)
    args = ap.parse_args()
    tracker = AbductionTracker(get_solver(args.backend), {"img_width": 1920, "img_height": 1080})
    tracemalloc.start()
    start = time.perf_counter()
    print("| frame | live tracks | history events of live tracks | events logged | heap (MiB) | max RSS (MiB) | s |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for fr in frames(args.frames, args.objects):
        tracker.step(fr.frame, fr.boxes, fr.confidences, fr.types)
        if fr.frame % 1000 == 0:
            heap = tracemalloc.get_traced_memory()[0] / 2**20
            rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
            hist = sum(len(t.history) for t in tracker.tracks.values())
            print(f"| {fr.frame} | {len(tracker.tracks)} | {hist} | {len(tracker.events)} | {heap:.1f} | {rss:.0f} "
                  f"| {time.perf_counter() - start:.0f} |", flush=True)


if __name__ == "__main__":
    main()
