"""HOTA, DetA and AssA (Luiten et al., IJCV 2021) computed by TrackEval's own HOTA metric.

refimpl does not re-implement HOTA: ``trackeval.metrics.HOTA`` (TrackEval 1.3.0) scores the
rows that ``refimpl.evaluation.evaluate`` has already preprocessed for the CLEAR metrics, so HOTA, MOTA
and IDF1 always see the same data:

* ground truth: the ``considered`` rows only (MOT15 rows with flag 0, MOT16+ non-pedestrian
  classes, KITTI Van / Person rows are not targets);
* results: the hypotheses left after distractor and KITTI DontCare removal
  (``evaluate._preprocess``);
* frames: every ground-truth frame plus any result frame outside it (all false positives);
* similarity: the IoU of every (target, hypothesis) pair of a frame, boxes ``x, y, w, h`` with
  ``x2 = x + w`` (TrackEval's ``_calculate_box_ious`` convention).

TrackEval evaluates HOTA at the 19 localisation thresholds alpha = 0.05, 0.10, ..., 0.95 and
reports the mean over alpha.  Several sequences are combined as TrackEval does: the per-alpha
counts TP / FN / FP are summed, the per-alpha association scores are averaged weighted by TP,
and only then DetA_alpha = TP / (TP + FN + FP), HOTA_alpha = sqrt(DetA_alpha * AssA_alpha) and
the means over alpha are taken (``HOTA.combine_sequences``) -- never an average of per-sequence
scores.  Each per-sequence result therefore carries its per-alpha fields (``ALPHA_KEY``), plain
lists so that the dict stays JSON-serialisable.

Nothing to score (no targets and no hypotheses) gives NaN, like refimpl's other ratios;
TrackEval itself would report 0 there.  TrackEval 1.3.0's HOTA code runs unchanged on NumPy 2
(it calls no removed NumPy alias), so no compatibility shim is involved.
"""

from __future__ import annotations

import math
from typing import Iterable, Sequence

import numpy as np

ALPHA_KEY = "hota_alpha"
"""Key of the per-alpha TrackEval fields in a per-sequence result (needed to combine sequences)."""

_ALPHA_FIELDS = ("HOTA_TP", "HOTA_FN", "HOTA_FP", "AssA", "AssRe", "AssPr", "LocA")


def trackeval_package():
    """The ``trackeval`` package, imported when a score is first computed (it pulls in scipy and
    its datasets): this module is the one that imports it, for its HOTA metric here and for its
    dataset pipeline (refimpl.evaluation.trackeval_devkit)."""
    import trackeval

    return trackeval


def _metric():
    return trackeval_package().metrics.HOTA()


def _relabel(ids: Sequence[np.ndarray]) -> tuple[list[np.ndarray], int]:
    """Map the ids of every frame onto 0..k-1 (TrackEval's metrics index arrays by id)."""
    arrays = [np.asarray(a, dtype=np.int64).reshape(-1) for a in ids]
    nonempty = [a for a in arrays if len(a)]
    if not nonempty:
        return arrays, 0
    unique = np.unique(np.concatenate(nonempty))
    return [np.searchsorted(unique, a).astype(np.int64) for a in arrays], len(unique)


def _scores(fields: dict) -> dict:
    """hota / deta / assa (means over alpha) and the per-alpha fields, from TrackEval's result dict."""
    tp, fn, fp = (np.asarray(fields[k], dtype=float) for k in ("HOTA_TP", "HOTA_FN", "HOTA_FP"))
    empty = not np.any(tp + fn + fp > 0)
    out = {
        "hota": math.nan if empty else float(np.mean(fields["HOTA"])),
        "deta": math.nan if empty else float(np.mean(fields["DetA"])),
        "assa": math.nan if empty else float(np.mean(fields["AssA"])),
    }
    out[ALPHA_KEY] = {k: [int(round(v)) if k.startswith("HOTA_") else float(v) for v in np.asarray(fields[k])]
                      for k in _ALPHA_FIELDS}
    return out


def hota_sequence(gt_ids: Sequence[np.ndarray], tracker_ids: Sequence[np.ndarray],
                  similarity: Sequence[np.ndarray]) -> dict:
    """HOTA of one sequence from per-frame target ids, hypothesis ids and (n_gt, n_hyp) IoU matrices.

    Returns ``{"hota", "deta", "assa", ALPHA_KEY}``; the first three are fractions in [0, 1]
    (means over TrackEval's 19 alphas), NaN when there is nothing to score.
    """
    if not len(gt_ids) == len(tracker_ids) == len(similarity):
        raise ValueError("gt_ids, tracker_ids and similarity need one entry per frame")
    g, num_g = _relabel(gt_ids)
    t, num_t = _relabel(tracker_ids)
    sims = [np.asarray(s, dtype=float).reshape(len(a), len(b)) for a, b, s in zip(g, t, similarity)]
    data = {
        "gt_ids": g, "tracker_ids": t, "similarity_scores": sims,
        "num_gt_ids": num_g, "num_tracker_ids": num_t,
        "num_gt_dets": int(sum(len(a) for a in g)), "num_tracker_dets": int(sum(len(b) for b in t)),
        "num_timesteps": len(g),
    }
    return _scores(_metric().eval_sequence(data))


def combine_hota(per_sequence: Iterable[dict]) -> dict:
    """The overall HOTA / DetA / AssA of several per-sequence results, by TrackEval's combination.

    Every result must carry ``ALPHA_KEY`` (as ``hota_sequence`` / ``evaluate_sequence`` give);
    if one does not, the three scores are NaN (they cannot be combined correctly).
    """
    rows = list(per_sequence)
    if not rows or any(ALPHA_KEY not in r for r in rows):
        return {"hota": math.nan, "deta": math.nan, "assa": math.nan}
    all_res = {str(i): {k: np.asarray(r[ALPHA_KEY][k], dtype=float) for k in _ALPHA_FIELDS}
               for i, r in enumerate(rows)}
    return _scores(_metric().combine_sequences(all_res))
