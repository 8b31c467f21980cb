"""Memory over a long sequence: track 10,000 synthetic frames and sample the heap every 1,000.

    python benchmarks/measure_memory.py [--frames 10000] [--objects 15] [--backend cpsat]

Objects walk across a 1920x1080 image (refimpl.experiments.walkers), each missed with probability
0.1 per frame and replaced by a new one when it leaves; the tracker's state (live tracks and their compacted histories) must
stay bounded; the results rows and the event log are output and grow with the sequence.
"""

from __future__ import annotations

import argparse
import resource
import time
import tracemalloc

from refimpl.experiments.walkers import frames
from refimpl.solvers import DEFAULT_BACKEND, get_solver
from refimpl.tracking.tracker import AbductionTracker


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
