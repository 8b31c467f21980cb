"""The long synthetic walk of the memory benchmarks (benchmarks/measure_memory.py,
benchmarks/long_sequence.py, docs/robustness.md) and of the streaming tests: objects walk across a
1920x1080 image (one seeded numpy generator), each missed with probability 0.1 per frame and
replaced by a new one when it leaves; scores are probabilities 0.95.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io import DetectionFrame


def frames(n_frames: int, n_objects: int, seed: int = 0):
    """The walk's DetectionFrames, frames 1..n_frames, one at a time."""
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


def write_sequence(out: str | Path, n_frames: int, n_objects: int, seed: int = 0) -> Path:
    """The walk as a MOTChallenge sequence folder: OUT/det/det.txt and OUT/seqinfo.ini (1920x1080,
    30 fps); the path of det.txt."""
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
