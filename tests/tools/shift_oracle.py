"""What a shift costs a tracker that associates perfectly (docs/peers.md, "Under shifts of the
detector and the camera"): the bound under issue 39's bar of a 2.0 HOTA drop.

    python tests/tools/shift_oracle.py [--data ../shared/data] [--benchmarks kitti-car-train,mot15]
        [--shift recall-bursty] [--fill 0,10,1000000]

The oracle writes every detection that the ground truth matches (one to one per frame, IoU >= 0.5,
the largest total IoU) with that object's id and the detection's box, drops the rest, and fills
each object's gaps of at most FILL frames by linear interpolation between the boxes around them (as
refimpl's bridged gaps do, docs/model.md 3.24, but knowing the identities and with any delay).  It
cannot write an object before its first detection or after its last, as no tracker that writes
boxes between detections can.  Prints HOTA / DetA / AssA (refimpl.evaluation, TrackEval's HOTA)
of the unshifted and the shifted benchmark per fill, and the drop.  A measurement of the shift, not
a tracker: nothing of refimpl's is tuned on it.
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.optimize import linear_sum_assignment

from refimpl.core.geometry import iou_matrix
from refimpl.evaluation.evaluate import combine, evaluate_sequence
from refimpl.io.datasets import load_dataset
from refimpl.io.shifts import shifted_dataset


def oracle_rows(seq, gt, fill: int) -> np.ndarray:
    """(n, 6) rows frame, id, x, y, w, h: the matched detections under their ground-truth ids,
    each id's gaps of at most ``fill`` frames interpolated."""
    rows = []
    for fr in seq.frames:
        here = gt.frames == fr.frame
        boxes = np.asarray(fr.boxes, dtype=float).reshape(-1, 4)
        if not len(boxes) or not here.any():
            continue
        iou = iou_matrix(boxes, gt.boxes[here].astype(float))
        for i, j in zip(*linear_sum_assignment(-iou)):
            if iou[i, j] >= 0.5:
                rows.append([fr.frame, int(gt.ids[here][j]), *boxes[i]])
    out = np.array(rows, dtype=float).reshape(-1, 6)
    filled = []
    for tid in np.unique(out[:, 1]):
        track = out[out[:, 1] == tid]
        track = track[np.argsort(track[:, 0], kind="stable")]
        for a, b in zip(track[:-1], track[1:]):
            gap = int(b[0] - a[0])
            if 1 < gap <= fill + 1:
                for k in range(1, gap):
                    w = k / gap
                    filled.append([a[0] + k, tid, *((1 - w) * a[2:] + w * b[2:])])
    return np.vstack([out, np.array(filled)]) if filled else out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="../shared/data")
    ap.add_argument("--benchmarks", default="kitti-car-train,kitti-ped-train,mot15")
    ap.add_argument("--shift", default="recall-bursty")
    ap.add_argument("--fill", default="0,10,1000000", help="comma-separated gap lengths to interpolate")
    args = ap.parse_args()
    fills = [int(f) for f in args.fill.split(",")]
    for name in args.benchmarks.split(","):
        plain = load_dataset(name, args.data)
        shifted = shifted_dataset(plain, args.shift)
        for fill in fills:
            scores = [combine([evaluate_sequence(gt, oracle_rows(seq, gt, fill)) for _, seq, gt in ds])
                      for ds in (plain, shifted)]
            a, b = (100 * s["hota"] for s in scores)
            print(f"{name} fill {fill}: HOTA / DetA / AssA none "
                  f"{a:.2f} / {100 * scores[0]['deta']:.2f} / {100 * scores[0]['assa']:.2f}, {args.shift} "
                  f"{b:.2f} / {100 * scores[1]['deta']:.2f} / {100 * scores[1]['assa']:.2f}, drop {a - b:.2f}",
                  flush=True)


if __name__ == "__main__":
    main()
