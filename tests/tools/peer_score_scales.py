"""How much a peer's scores depend on the scale its detections' scores are given in (docs/peers.md,
"The peers' score scale"): every named peer on one benchmark, the scores given as
``refimpl bench-peers`` gives them (refimpl.io.detections.probability_scale: ACF's 0..139 by their
rank) and, before that, divided by the benchmark's largest score or by 100 (clipped to 0..1).

    python tests/tools/peer_score_scales.py [--data ../shared/data] [--benchmark mot15-acf]
        [--peers boxmot-hybridsort,boxmot-bytetrack,ocsort]

A fairness check of the peers, not a tuning of refimpl: the abduction tracker is not run (its
evidence rule reads any increasing rescale of the scores alike, docs/model.md 3.19).  Prints one
line per scale and peer: HOTA / IDF1 / MOTA.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np

from refimpl.experiments.peers import compare, parse_peers
from refimpl.io.datasets import load_dataset


def rescaled(dataset, f):
    """The dataset with every frame's scores mapped by f (boxes and ground truth as they are)."""
    return [(name, replace(seq, frames=tuple(replace(fr, scores=f(np.asarray(fr.scores, dtype=float)))
                                             for fr in seq.frames)), gt)
            for name, seq, gt in dataset]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="../shared/data")
    ap.add_argument("--benchmark", default="mot15-acf")
    ap.add_argument("--peers", default="boxmot-hybridsort,boxmot-bytetrack,ocsort")
    args = ap.parse_args()
    dataset = load_dataset(args.benchmark, args.data)
    top = max(float(np.max(fr.scores)) for _, seq, _ in dataset for fr in seq.frames if len(fr.scores))
    scales = {"as bench-peers gives them": lambda s: s,
              f"divided by the largest ({top:g})": lambda s: np.clip(s / top, 0.0, 1.0),
              "divided by 100": lambda s: np.clip(s / 100.0, 0.0, 1.0)}
    for label, f in scales.items():
        c = compare(args.benchmark, args.data, parse_peers(args.peers), dataset=rescaled(dataset, f),
                    without_preset=False)
        for s in c.scores[2:]:  # refimpl's baseline and abduction rows come first
            o = s.overall
            print(f"{label:34s} {s.label:36s} {100 * o['hota']:.1f} / {100 * o['idf1']:.1f} / {100 * o['mota']:.1f}",
                  flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
