"""Where a tracker's drop under a shift goes (docs/peers.md, "Under shifts of the detector and the
camera"): its own rows, then the same rows repaired step by step from the ground truth.

    python tests/tools/shift_decompose.py [--data ../shared/data] [--benchmark kitti-car-train]
        [--shift recall-bursty] [--tracker cpsat]

The tracker runs as `refimpl benchmark` runs it (the preset of the benchmark's format and class),
on the benchmark and on its shifted copy.  Each step keeps the one before and adds a repair:

  rows      what the tracker wrote;
  joined    every written track renamed to the object it writes most often (IoU >= 0.5, one to
            one per frame): fragments of one object joined, nothing else changed;
  inner     every frame between an object's first and last written frame where it is not
            written: its ground-truth box under its id (a gap the tracker did not fill, or filled
            off the object);
  head      from the object's first detection (IoU >= 0.5) to its first written frame: its box
            (an object followed too late);
  tail      from its last written frame to its last detection: its box (one given up too early).

Prints HOTA (refimpl.evaluation, TrackEval's HOTA) of each step unshifted and shifted, the drop,
and the frames each repair adds; then, for an abduction backend, where in the shifted run the
track writing an object changes across a short gap and why (``handovers``).  A step's share of
the drop is how much the drop falls across it.  A measurement of a tracker's output, not a
tracker: nothing of refimpl's is tuned on it.
"""

from __future__ import annotations

import argparse
from collections import Counter, defaultdict

if not __package__:  # run as a script: this checkout's refimpl first on the import path
    import _paths  # noqa: F401

import numpy as np
from scipy.optimize import linear_sum_assignment

from refimpl.core.geometry import iou_matrix
from refimpl.core.spec import track_number
from refimpl.evaluation.evaluate import combine, evaluate_sequence
from refimpl.io.datasets import dataset_kind, load_dataset
from refimpl.io.shifts import shifted_dataset
from refimpl.tracking.pipeline import setup_for, run_sequence

STEPS = ("rows", "joined", "inner", "head", "tail")
OFFSET = 10 ** 6
"""Ids of joined tracks: the object's id plus this, apart from every track number the tracker writes."""


def matches(boxes: np.ndarray, truth: np.ndarray) -> dict[int, int]:
    """Ground-truth index -> box index, one to one, the largest total IoU, IoU >= 0.5."""
    if not len(boxes) or not len(truth):
        return {}
    iou = iou_matrix(boxes, truth)
    rows, cols = linear_sum_assignment(-iou)
    return {int(j): int(i) for i, j in zip(rows, cols) if iou[i, j] >= 0.5}


def _written(rows: np.ndarray, seq, gt):
    """Which row writes each object in each frame, the frames each object is detected, how often
    each track writes each object, and the ground-truth boxes by (object, frame)."""
    detections = {fr.frame: np.asarray(fr.boxes, dtype=float).reshape(-1, 4) for fr in seq.frames}
    written = defaultdict(dict)   # object -> frame -> index of the row that writes it
    detected = defaultdict(list)  # object -> frames with a detection of it
    votes = defaultdict(Counter)  # track number -> object -> frames
    truth = {}
    for frame in np.unique(gt.frames).tolist():
        here = gt.frames == frame
        boxes, ids = gt.boxes[here].astype(float), gt.ids[here].tolist()
        for j, obj in enumerate(ids):
            truth[(obj, frame)] = boxes[j]
        at = np.flatnonzero(rows[:, 0] == frame)
        for j, i in matches(rows[at, 2:6], boxes).items():
            written[ids[j]][frame] = at[i]
            votes[int(rows[at[i], 1])][ids[j]] += 1
        for j in matches(detections.get(frame, np.zeros((0, 4))), boxes):
            detected[ids[j]].append(frame)
    return written, detected, votes, truth


def repaired(rows: np.ndarray, seq, gt, seen=None) -> tuple[dict[str, np.ndarray], Counter]:
    """Each step's rows (STEPS) for one sequence, and the frames each repair adds (``seen``: the
    rows' _written, where the caller has it)."""
    written, detected, votes, truth = seen or _written(rows, seq, gt)
    name = {track: OFFSET + count.most_common(1)[0][0] for track, count in votes.items()}
    joined = rows.copy()
    joined[:, 1] = [name.get(int(t), t) for t in rows[:, 1].tolist()]
    _, first = np.unique(joined[:, :2], axis=0, return_index=True)  # two fragments in one frame: the first row
    steps = {"rows": rows, "joined": joined[np.sort(first)]}
    added = Counter()
    spans = {"inner": lambda a, b, d0, d1: range(a + 1, b),
             "head": lambda a, b, d0, d1: range(min(d0, a), a),
             "tail": lambda a, b, d0, d1: range(b + 1, max(d1, b) + 1)}
    current = steps["joined"]
    for step, span in spans.items():
        new = []
        for obj, frames in written.items():
            a, b = min(frames), max(frames)
            d0, d1 = (min(detected[obj]), max(detected[obj])) if detected[obj] else (a, b)
            new += [[f, OFFSET + obj, *truth[(obj, f)]] for f in span(a, b, d0, d1)
                    if f not in frames and (obj, f) in truth]
        if new:
            new = np.array(new, dtype=float)
            keys = set(map(tuple, new[:, :2].astype(int).tolist()))
            keep = [tuple(r) not in keys for r in current[:, :2].astype(int).tolist()]
            current = np.vstack([current[keep], new])
        added[step] = len(new)
        steps[step] = current
    return steps, added


def handovers(rows: np.ndarray, tracks, seq, gt, seen=None) -> Counter:
    """Where the track writing an object changes across a gap of 1 to 10 unwritten frames, from
    track A (the gap's first side) to track B: ``changes``; of these, A not ended by then
    (``alive``); of these, B started after A last wrote the object (``started``); of these, B's
    first box at least twice A's last observed area before it (``grown``); of these, A observed
    during the gap a box at least 3/4 inside the object's and overlapping it by IoU < 0.5: a
    smaller box within it, another object's or a part (``inside``).  ``seen``: as for repaired."""
    record = {track_number(t.id): t for t in tracks}
    count = Counter()
    if not record:  # a tracker that keeps no records of its tracks (refimpl's SORT baseline)
        return count
    written, _, _, truth = seen or _written(rows, seq, gt)
    for obj, frames in written.items():
        ordered = sorted(frames)
        for p, q in zip(ordered[:-1], ordered[1:]):
            a, b = int(rows[frames[p], 1]), int(rows[frames[q], 1])
            if not 1 <= q - p - 1 <= 10 or a == b:
                continue
            count["changes"] += 1
            ta, tb = record[a], record[b]
            if ta.ended_at is not None and ta.ended_at <= q:
                continue
            count["alive"] += 1
            start = tb.observed[0][0]
            if start <= p:
                continue
            count["started"] += 1
            before = [box for f, box in ta.observed if f < start]
            if not before or np.prod(tb.observed[0][1][2:]) < 2 * np.prod(before[-1][2:]):
                continue
            count["grown"] += 1
            for f, box in ta.observed:
                if p < f < start and (obj, f) in truth:
                    box, mine = np.asarray(box, dtype=float), truth[(obj, f)]
                    width = min(box[0] + box[2], mine[0] + mine[2]) - max(box[0], mine[0])
                    height = min(box[1] + box[3], mine[1] + mine[3]) - max(box[1], mine[1])
                    inside = max(width, 0) * max(height, 0) / (box[2] * box[3])
                    if inside >= 0.75 and iou_matrix(box[None], mine[None])[0, 0] < 0.5:
                        count["inside"] += 1
                        break
    return count


def decompose(name: str, data: str, shift: str, tracker: str) -> tuple[dict, dict, Counter, Counter, Counter]:
    """HOTA of every step, unshifted and shifted (two dicts), the frames each repair adds, and the
    shifted run's handovers."""
    fmt, object_class = dataset_kind(name, data)
    setup = setup_for(fmt, object_class, tracker)
    plain = load_dataset(name, data)
    out = []
    for dataset in (plain, shifted_dataset(plain, shift)):
        scores, added, changes = defaultdict(list), Counter(), Counter()
        for _, seq, gt in dataset:
            result = run_sequence(seq, setup)
            rows = result.rows[:, :6].astype(float)
            seen = _written(rows, seq, gt)  # the ground-truth matching, once for both
            steps, n = repaired(rows, seq, gt, seen)
            added += n
            changes += handovers(rows, result.tracks, seq, gt, seen)
            for step in STEPS:
                scores[step].append(evaluate_sequence(gt, steps[step]))
        out.append(({step: 100 * combine(scores[step])["hota"] for step in STEPS}, added, changes))
    (a, na, _), (b, nb, changes) = out
    return a, b, na, nb, changes


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="../shared/data")
    ap.add_argument("--benchmark", default="kitti-car-train")
    ap.add_argument("--shift", default="recall-bursty")
    ap.add_argument("--tracker", default="cpsat")
    args = ap.parse_args()
    a, b, na, nb, changes = decompose(args.benchmark, args.data, args.shift, args.tracker)
    print(f"{args.benchmark}, {args.tracker}: HOTA unshifted -> {args.shift}")
    print(f"{'step':8s} {'none':>7s} {args.shift:>14s} {'drop':>6s} {'frames added':>14s}")
    for step in STEPS:
        frames = f"{na[step]} / {nb[step]}" if step in na else ""
        print(f"{step:8s} {a[step]:7.2f} {b[step]:14.2f} {a[step] - b[step]:6.2f} {frames:>14s}")
    if changes:
        print(f"{args.shift}: handovers (handovers' doc) " + ", ".join(
            f"{k} {changes[k]}" for k in ("changes", "alive", "started", "grown", "inside")))


if __name__ == "__main__":
    main()
