"""CLEAR MOT and IDF1 (motmetrics) and HOTA (TrackEval) of tracking results against ground truth.

Per frame, before counting (the MOTChallenge devkit / KITTI devkit conventions):

1. every hypothesis is matched to *all* ground-truth rows of the frame (IoU >= threshold,
   Hungarian assignment maximising the number of matches, then total IoU; for KITTI the rows
   are the loaded targets and distractors, see ``refimpl.io``);
   hypotheses matched to a ``distractor`` row are removed (MOT17 classes 2, 7, 8, 12;
   KITTI Van for Car, Person for Pedestrian);
2. hypotheses left unmatched by step 1 whose box lies mostly inside a KITTI DontCare region
   (intersection / hypothesis area >= 0.5) are removed;
3. only ``considered`` ground-truth rows take part in the count.

The rest is motmetrics: a ``MOTAccumulator`` fed with the IoU distance ``1 - IoU`` (pairs with
distance > 1 - threshold cannot match) for every frame of the sequence, and its standard
metrics.  MOTP is reported as MOTChallenge does, as an overlap (1 - mean distance).

motmetrics 1.4.0's ``distances.iou_matrix`` calls ``np.asfarray``, which NumPy 2 removed;
``_iou_distances`` computes the same matrix with motmetrics' own ``boxiou`` instead, so NumPy is
never patched.
"""

from __future__ import annotations

import math
from typing import Iterable

import numpy as np

from ..core.assignment import linear_sum_assignment
from ..core.geometry import iou_matrix, xywh_to_xyxy
from ..io import GroundTruth, InputFormatError, data_line_numbers
from .hota import ALPHA_KEY, combine_hota, hota_sequence

DONTCARE_MIN_COVER = 0.5
"""A hypothesis is inside a DontCare region if intersection / hypothesis area >= this."""

_COUNT_KEYS = ("mt", "pt", "ml", "fp", "fn", "idsw", "frag", "num_gt", "num_frames", "num_matches",
               "num_predictions", "num_unique_objects", "idtp", "idfp", "idfn",
               "removed_distractor", "removed_dontcare")

_MM_METRICS = ("mota", "motp", "idf1", "idtp", "idfp", "idfn", "num_objects", "num_predictions",
               "num_unique_objects", "mostly_tracked", "partially_tracked", "mostly_lost",
               "num_false_positives", "num_misses", "num_switches", "num_fragmentations",
               "num_detections")


# ---------------------------------------------------------------------------------------
# motmetrics, without touching NumPy


def _motmetrics():
    """motmetrics, imported lazily (it pulls in pandas)."""
    import motmetrics

    return motmetrics


def _iou_distances(mm, objs: np.ndarray, hyps: np.ndarray, max_iou: float) -> np.ndarray:
    """motmetrics.distances.iou_matrix, computed with its own boxiou: that function calls
    ``np.asfarray``, which NumPy 2 removed, and refimpl does not patch NumPy for everyone."""
    if np.size(objs) == 0 or np.size(hyps) == 0:
        return np.empty((0, 0))
    objs, hyps = np.asarray(objs, dtype=np.float64), np.asarray(hyps, dtype=np.float64)
    dist = 1 - mm.distances.boxiou(objs[:, None], hyps[None, :])
    return np.where(dist > max_iou, np.nan, dist)


# ---------------------------------------------------------------------------------------
# preprocessing


def _match(gt_boxes: np.ndarray, hyp_boxes: np.ndarray, iou_threshold: float) -> tuple[np.ndarray, np.ndarray]:
    """Hungarian matching with IoU >= threshold: (gt indices, hyp indices) of the matched pairs."""
    if len(gt_boxes) == 0 or len(hyp_boxes) == 0:
        return np.zeros(0, dtype=int), np.zeros(0, dtype=int)
    iou = iou_matrix(gt_boxes, hyp_boxes)
    valid = iou >= iou_threshold
    if not valid.any():
        return np.zeros(0, dtype=int), np.zeros(0, dtype=int)
    # Costs in [0, 1] for valid pairs; an invalid pair costs more than any full valid assignment,
    # so the number of matches is maximised first.
    big = 2.0 * min(iou.shape) + 1.0
    rows, cols = linear_sum_assignment(np.where(valid, 1.0 - iou, big))
    keep = valid[rows, cols]
    return rows[keep], cols[keep]


def _cover(hyp_boxes: np.ndarray, regions: np.ndarray) -> np.ndarray:
    """(n, k) intersection area / hypothesis area of each hypothesis with each region (xywh)."""
    a = xywh_to_xyxy(hyp_boxes)
    b = xywh_to_xyxy(regions)
    iw = np.minimum(a[:, None, 2], b[None, :, 2]) - np.maximum(a[:, None, 0], b[None, :, 0])
    ih = np.minimum(a[:, None, 3], b[None, :, 3]) - np.maximum(a[:, None, 1], b[None, :, 1])
    inter = np.clip(iw, 0, None) * np.clip(ih, 0, None)
    area = (a[:, 2] - a[:, 0]) * (a[:, 3] - a[:, 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(area[:, None] > 0, inter / area[:, None], 0.0)


def _frame_slices(frames: np.ndarray, numbers: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For frames sorted ascending: start/end index of each frame number's rows."""
    return np.searchsorted(frames, numbers, "left"), np.searchsorted(frames, numbers, "right")


def _check_results(results) -> np.ndarray:
    r = np.asarray(results, dtype=float)
    if r.size == 0:
        return np.zeros((0, 6))
    if r.ndim != 2 or r.shape[1] < 6:
        raise ValueError(f"results must be an (n, 6) array frame,id,x,y,w,h; got shape {r.shape}")
    r = r[:, :6]
    if not np.all(np.isfinite(r)):
        raise ValueError("results contain NaN or inf")
    if np.any(r[:, :2] != np.floor(r[:, :2])):
        raise ValueError("result frame and id must be integers")
    order = np.lexsort((r[:, 1], r[:, 0]))
    r = r[order]
    same = (r[1:, 0] == r[:-1, 0]) & (r[1:, 1] == r[:-1, 1])
    if same.any():
        k = int(np.flatnonzero(same)[0])
        raise ValueError(f"duplicate (frame {int(r[k, 0])}, id {int(r[k, 1])}) in results")
    return r


def _preprocess(gt: GroundTruth, res: np.ndarray, iou_threshold: float,
                numbers: np.ndarray) -> tuple[np.ndarray, int, int]:
    """Mask of hypotheses kept after distractor and DontCare removal, and the two removal counts."""
    keep = np.ones(len(res), dtype=bool)
    g_order = np.argsort(gt.frames, kind="stable")
    g_frames = gt.frames[g_order]
    g0, g1 = _frame_slices(g_frames, numbers)
    h0, h1 = _frame_slices(res[:, 0], numbers)
    dc = np.asarray(gt.dontcare, dtype=float).reshape(-1, 5)
    dc = dc[np.argsort(dc[:, 0], kind="stable")]
    d0, d1 = _frame_slices(dc[:, 0], numbers)
    removed_distractor = removed_dontcare = 0
    has_distractors = bool(np.any(gt.distractor))
    for k in range(len(numbers)):
        if h0[k] == h1[k]:
            continue
        hyp_idx = np.arange(h0[k], h1[k])
        hyp_boxes = res[hyp_idx, 2:6]
        gt_idx = g_order[g0[k]:g1[k]]
        gi, hi = _match(gt.boxes[gt_idx], hyp_boxes, iou_threshold)
        if has_distractors and len(gi):
            drop = hi[gt.distractor[gt_idx[gi]]]
            keep[hyp_idx[drop]] = False
            removed_distractor += len(drop)
        if d1[k] > d0[k]:
            unmatched = np.ones(len(hyp_idx), dtype=bool)
            unmatched[hi] = False
            cand = np.flatnonzero(unmatched)
            if len(cand):
                cover = _cover(hyp_boxes[cand], dc[d0[k]:d1[k], 1:5])
                drop = cand[cover.max(axis=1) >= DONTCARE_MIN_COVER]
                keep[hyp_idx[drop]] = False
                removed_dontcare += len(drop)
    return keep, removed_distractor, removed_dontcare


# ---------------------------------------------------------------------------------------
# evaluation


def evaluate_sequence(gt: GroundTruth, results, iou_threshold: float = 0.5) -> dict:
    """CLEAR MOT + IDF1 of (n, 6) ``frame, id, x, y, w, h`` results on one sequence.

    Keys: hota, deta, assa, mota, motp, idf1 (fractions; motp as overlap), mt, ml (counts), fp,
    fn, idsw, frag, num_gt, num_frames, plus pt, num_matches, num_predictions, num_unique_objects,
    idtp, idfp, idfn, the preprocessing counts removed_distractor / removed_dontcare, and
    ``hota_alpha`` (TrackEval's per-alpha HOTA fields, used by ``combine``).  HOTA / DetA / AssA are
    TrackEval's, computed on the same preprocessed rows and frames (``refimpl.evaluation.hota``).  A ratio with a zero
    denominator (no targets, no matches) is NaN.  Frames evaluated: every frame of the ground
    truth plus any result frame outside it (those hypotheses are false positives).
    """
    if not 0.0 < iou_threshold <= 1.0:
        raise ValueError("iou_threshold must be in (0, 1]")
    mm = _motmetrics()
    res = _check_results(results)
    first, last = gt.first_frame, gt.first_frame + gt.num_frames - 1
    extra = res[:, 0][(res[:, 0] < first) | (res[:, 0] > last)].astype(np.int64)
    numbers = np.union1d(np.arange(first, last + 1), extra)  # results outside the gt range count as FP
    keep, removed_distractor, removed_dontcare = _preprocess(gt, res, iou_threshold, numbers)
    res = res[keep]

    cons = np.flatnonzero(gt.considered)
    cons = cons[np.argsort(gt.frames[cons], kind="stable")]
    o_frames, o_ids, o_boxes = gt.frames[cons], gt.ids[cons], gt.boxes[cons]
    o0, o1 = _frame_slices(o_frames, numbers)
    h0, h1 = _frame_slices(res[:, 0], numbers)
    acc = mm.MOTAccumulator(auto_id=False)
    max_dist = 1.0 - iou_threshold
    frame_gt_ids, frame_hyp_ids, frame_iou = [], [], []  # the same rows, for HOTA
    for k, frame in enumerate(numbers):
        oboxes, hboxes = o_boxes[o0[k]:o1[k]], res[h0[k]:h1[k], 2:6]
        gids, hids = o_ids[o0[k]:o1[k]], res[h0[k]:h1[k], 1].astype(np.int64)
        dists = _iou_distances(mm, oboxes, hboxes, max_dist)
        acc.update(gids, hids, dists, frameid=int(frame))
        frame_gt_ids.append(gids)
        frame_hyp_ids.append(hids)
        frame_iou.append(iou_matrix(oboxes, hboxes))
    s = mm.metrics.create().compute(acc, metrics=list(_MM_METRICS), return_dataframe=False)
    hota = hota_sequence(frame_gt_ids, frame_hyp_ids, frame_iou)

    matches, num_gt, num_pred = int(s["num_detections"]), int(s["num_objects"]), int(s["num_predictions"])
    return {
        "hota": hota["hota"],
        "deta": hota["deta"],
        "assa": hota["assa"],
        "mota": float(s["mota"]) if num_gt else math.nan,
        "motp": 1.0 - float(s["motp"]) if matches else math.nan,
        "idf1": float(s["idf1"]) if num_gt + num_pred else math.nan,
        "mt": int(s["mostly_tracked"]),
        "ml": int(s["mostly_lost"]),
        "fp": int(s["num_false_positives"]),
        "fn": int(s["num_misses"]),
        "idsw": int(s["num_switches"]),
        "frag": int(s["num_fragmentations"]),
        "num_gt": num_gt,
        "num_frames": int(len(numbers)),
        "pt": int(s["partially_tracked"]),
        "num_matches": matches,
        "num_predictions": num_pred,
        "num_unique_objects": int(s["num_unique_objects"]),
        "idtp": int(round(float(s["idtp"]))),
        "idfp": int(round(float(s["idfp"]))),
        "idfn": int(round(float(s["idfn"]))),
        "removed_distractor": removed_distractor,
        "removed_dontcare": removed_dontcare,
        ALPHA_KEY: hota[ALPHA_KEY],
    }


def _safe_div(a: float, b: float) -> float:
    return a / b if b else math.nan


def combine(per_sequence: Iterable[dict]) -> dict:
    """The overall row of several sequences, as MOT benchmarks compute it (from summed counts).

    MOTA = 1 - (FN + FP + IDSW) / num_gt, MOTP weighted by matches, IDF1 = 2 IDTP / (2 IDTP +
    IDFP + IDFN), all over the summed counts; HOTA / DetA / AssA as TrackEval combines sequences
    (per-alpha TP / FN / FP summed, AssA weighted by TP, then the means over alpha).
    """
    rows = list(per_sequence)
    out = {k: sum(int(r[k]) for r in rows) for k in _COUNT_KEYS}
    out["mota"] = 1.0 - _safe_div(out["fn"] + out["fp"] + out["idsw"], out["num_gt"]) if out["num_gt"] else math.nan
    out["motp"] = _safe_div(sum(r["motp"] * r["num_matches"] for r in rows if r["num_matches"]),
                            out["num_matches"])
    out["idf1"] = _safe_div(2 * out["idtp"], 2 * out["idtp"] + out["idfp"] + out["idfn"])
    out.update(combine_hota(rows))  # from the summed per-alpha counts (refimpl.evaluation.hota)
    return out


def evaluate_many(pairs: Iterable[tuple[str, GroundTruth, np.ndarray]],
                  iou_threshold: float = 0.5) -> tuple[dict[str, dict], dict]:
    """Evaluate (name, gt, results) triples: per-sequence scores (in input order) and the overall row."""
    per_sequence: dict[str, dict] = {}
    for name, gt, results in pairs:
        if name in per_sequence:
            raise ValueError(f"sequence name {name!r} given twice")
        per_sequence[name] = evaluate_sequence(gt, results, iou_threshold)
    return per_sequence, combine(per_sequence.values())


def _pct(v: float) -> str:
    return "-" if v is None or not np.isfinite(v) else f"{100.0 * v:.1f}"


def format_table(per_sequence: dict[str, dict], overall: dict) -> str:
    """A markdown table: one row per sequence plus OVERALL; HOTA .. IDF1 in percent."""
    head = "| Sequence | HOTA | DetA | AssA | MOTA | MOTP | IDF1 | MT | ML | FP | FN | IDs | Frag |"
    rule = "|---|" + "---:|" * 12

    def row(name: str, r: dict) -> str:
        cells = [name, *(_pct(r[k]) for k in ("hota", "deta", "assa")),
                 _pct(r["mota"]), _pct(r["motp"]), _pct(r["idf1"]),
                 *(str(int(r[k])) for k in ("mt", "ml", "fp", "fn", "idsw", "frag"))]
        return "| " + " | ".join(cells) + " |"

    lines = [head, rule, *(row(n, r) for n, r in per_sequence.items()), row("OVERALL", overall)]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------------------
# Does a results file belong to this ground truth?
# ---------------------------------------------------------------------------------------

FIT_MIN_ROWS = 20
"""Results with fewer rows are too few to judge which sequence they belong to."""
FIT_MIN_SHARE = 0.2
"""At least this share of the result rows must overlap (IoU >= 0.5) a ground-truth box of their frame."""


def check_results_fit(gt: GroundTruth, results: np.ndarray) -> tuple[int, str] | None:
    """Why results cannot be scored against gt, as (row index, reason), or None if they fit.

    Two rules (docs/robustness.md, "eval"):
    * every result frame lies within the ground truth's frames first_frame..last_frame (results
      past the last frame would count silently as false positives; TrackEval refuses them too);
    * results with at least FIT_MIN_ROWS rows have at least FIT_MIN_SHARE of their rows
      overlapping (IoU >= 0.5, the CLEAR MOT threshold) some ground-truth box (any row: target,
      distractor or other) of the same frame.  Measured on the 11 MOT15 train sequences with
      SORT (refimpl baseline): its results on their own sequence match 62 % to 98 % of their
      rows (Faster R-CNN or ACF detections); its results of any other sequence, where their
      frames fit, match at most 9.1 %.  20 % lies between with a margin on both sides.
    """
    res = np.asarray(results, dtype=float).reshape(-1, 6)
    if not len(res):
        return None
    past = np.flatnonzero(res[:, 0] > gt.last_frame)
    if len(past):
        k = int(past[0])
        return k, (f"frame {int(res[k, 0])} is past the last ground-truth frame {gt.last_frame} of {gt.name}: "
                   "results of another sequence?")
    if len(res) < FIT_MIN_ROWS:
        return None
    order = np.argsort(gt.frames, kind="stable")
    g_frames, g_boxes = gt.frames[order], gt.boxes[order]
    matched = 0
    for f in np.unique(res[:, 0]):
        a, b = np.searchsorted(g_frames, f, "left"), np.searchsorted(g_frames, f, "right")
        if a == b:
            continue
        rows = res[res[:, 0] == f, 2:6]
        matched += int(np.count_nonzero(iou_matrix(rows, g_boxes[a:b]).max(axis=1) >= 0.5))
    if matched < FIT_MIN_SHARE * len(res):
        return 0, (f"only {matched} of {len(res)} result rows overlap a ground-truth box of {gt.name} "
                   f"(IoU >= 0.5; at least {FIT_MIN_SHARE:.0%} expected): results of another sequence?")
    return None


def refuse_misfit(gt: GroundTruth, results: np.ndarray, path) -> None:
    """Raise InputFormatError (naming the line where it can) if results do not fit gt (check_results_fit)."""
    misfit = check_results_fit(gt, results)
    if misfit is None:
        return
    row, reason = misfit
    lines = data_line_numbers(path) if row else []
    # a line number only when every data line is a row (MOTChallenge lines; KITTI results skip other classes)
    raise InputFormatError(reason, path, lines[row] if len(lines) == len(results) else None)
