"""What a shift costs a tracker that associates perfectly (docs/peers.md, "Under shifts of the
detector and the camera"): the bound under issue 39's bar of a 2.0 HOTA drop.

    python tests/tools/shift_oracle.py [--data ../shared/data] [--benchmarks kitti-car-train,mot15]
        [--shift recall-bursty] [--fill 0,10,1000000] [--extend 0,1,3] [--margin 0.05]

The oracle writes every detection that the ground truth matches (one to one per frame, IoU >= 0.5,
the largest total IoU) with that object's id and the detection's box, drops the rest, and fills
each object's gaps of at most FILL frames by linear interpolation between the boxes around them (as
refimpl's bridged gaps do, docs/model.md 3.24, but knowing the identities and with any delay).  It
cannot write an object before its first detection or after its last, as no tracker that writes
boxes between detections can; with ``--extend E`` it also writes up to E frames before an object's
first detection and after its last, at the constant velocity of its first (last) two, while the box
stays inside the image's middle (``--margin``: the left and right twentieths left out by 0.05).  Prints HOTA / DetA / AssA (refimpl.evaluation, TrackEval's HOTA)
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


def extended(rows: np.ndarray, frames: int, image_size, margin: float) -> np.ndarray:
    """The rows with each id written up to ``frames`` frames before its first and after its last
    row, at the velocity of its first (last) two rows, while the box lies inside the image's middle
    (x in [margin W, (1 - margin) W], y >= 0, positive size); the oracle's guess of a missed end."""
    width, _ = image_size
    out = [rows]
    for tid in np.unique(rows[:, 1]):
        track = rows[rows[:, 1] == tid]
        track = track[np.argsort(track[:, 0], kind="stable")]
        if len(track) < 2:
            continue
        for end, other, step in ((track[0], track[1], -1), (track[-1], track[-2], 1)):
            velocity = (end[2:] - other[2:]) / abs(end[0] - other[0])
            for k in range(1, frames + 1):
                x, y, w, h = end[2:] + velocity * k
                if x < margin * width or y < 0 or x + w > (1 - margin) * width or w <= 0 or h <= 0:
                    break
                out.append(np.array([[end[0] + step * k, tid, x, y, w, h]]))
    return np.vstack(out)


def _within(gt, rows: np.ndarray) -> np.ndarray:
    """The rows inside the ground truth's frames (an extension may reach beyond them)."""
    keep = (rows[:, 0] >= gt.first_frame) & (rows[:, 0] < gt.first_frame + gt.num_frames)
    return rows[keep]


def _extent(seq) -> tuple[float, float]:
    """An image size where the sequence gives none: the detections' right and bottom edges."""
    boxes = np.vstack([np.asarray(f.boxes, dtype=float).reshape(-1, 4) for f in seq.frames])
    return float((boxes[:, 0] + boxes[:, 2]).max()), float((boxes[:, 1] + boxes[:, 3]).max())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="../shared/data")
    ap.add_argument("--benchmarks", default="kitti-car-train,kitti-ped-train,mot15")
    ap.add_argument("--shift", default="recall-bursty")
    ap.add_argument("--fill", default="0,10,1000000", help="comma-separated gap lengths to interpolate")
    ap.add_argument("--extend", default="0", help="comma-separated frames written beyond each end")
    ap.add_argument("--margin", type=float, default=0.0, help="with --extend: the image's left and right share left out")
    args = ap.parse_args()
    fills = [int(f) for f in args.fill.split(",")]
    extends = [int(e) for e in args.extend.split(",")]
    for name in args.benchmarks.split(","):
        plain = load_dataset(name, args.data)
        shifted = shifted_dataset(plain, args.shift)
        for fill, extend in ((f, e) for f in fills for e in extends):
            scores = [combine([evaluate_sequence(gt, _within(gt, extended(oracle_rows(seq, gt, fill), extend,
                                                                           seq.image_size or _extent(seq),
                                                                           args.margin)))
                               for _, seq, gt in ds])
                      for ds in (plain, shifted)]
            a, b = (100 * s["hota"] for s in scores)
            print(f"{name} fill {fill} extend {extend}: HOTA / DetA / AssA none "
                  f"{a:.2f} / {100 * scores[0]['deta']:.2f} / {100 * scores[0]['assa']:.2f}, {args.shift} "
                  f"{b:.2f} / {100 * scores[1]['deta']:.2f} / {100 * scores[1]['assa']:.2f}, drop {a - b:.2f}",
                  flush=True)


if __name__ == "__main__":
    main()
