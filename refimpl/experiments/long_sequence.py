"""A long synthetic MOTChallenge sequence for the memory benchmark of docs/robustness.md.

    python -m refimpl.experiments.long_sequence OUT_DIR [--frames 20000] [--objects 20] [--seed 0]

writes OUT_DIR/det/det.txt and OUT_DIR/seqinfo.ini (1920x1080, 30 fps).  Objects walk across the
image (seeded numpy generator), each missed with probability 0.1 per frame and replaced by a new
one when it leaves, as in refimpl/experiments/measure_memory.py; scores are probabilities 0.95.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from .measure_memory import frames  # the same seeded walk


def write_sequence(out: str | Path, n_frames: int, n_objects: int, seed: int = 0) -> Path:
    out = Path(out)
    (out / "det").mkdir(parents=True, exist_ok=True)
    (out / "seqinfo.ini").write_text(
        f"[Sequence]\nname={out.name}\nimDir=img1\nframeRate=30\nseqLength={n_frames}\n"
        "imWidth=1920\nimHeight=1080\nimExt=.jpg\n", encoding="utf-8")
    with open(out / "det" / "det.txt", "w", encoding="utf-8") as fh:
        for fr in frames(n_frames, n_objects, seed):
            for x, y, w, h in fr.boxes:
                fh.write(f"{fr.frame},-1,{x:.2f},{y:.2f},{w:.2f},{h:.2f},0.95,-1,-1,-1\n")
    return out / "det" / "det.txt"


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
