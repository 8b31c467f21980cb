"""A long synthetic MOTChallenge sequence for the memory benchmark of docs/robustness.md.

    python benchmarks/long_sequence.py OUT_DIR [--frames 20000] [--objects 20] [--seed 0]

writes OUT_DIR/det/det.txt and OUT_DIR/seqinfo.ini (1920x1080, 30 fps).  Objects walk across the
image (seeded numpy generator), each missed with probability 0.1 per frame and replaced by a new
one when it leaves (refimpl.experiments.walkers, as benchmarks/measure_memory.py tracks it);
scores are probabilities 0.95.
"""

from __future__ import annotations

import argparse

from refimpl.experiments.walkers import write_sequence


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--frames", type=int, default=20_000)
    ap.add_argument("--objects", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    print(write_sequence(a.out, a.frames, a.objects, a.seed))


if __name__ == "__main__":
    main()
