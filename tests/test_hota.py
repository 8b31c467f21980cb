"""HOTA / DetA / AssA (refimpl.hota via refimpl.evaluate): a hand-derived case, and agreement with
TrackEval's own MOTChallenge pipeline on tracked MOT15 sequences."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from refimpl import evaluate as ev
from refimpl import io

from test_evaluate import make_gt

DATA = Path(__file__).resolve().parent.parent.parent / "shared" / "data"

# ---------------------------------------------------------------------------------------
# A hand-derived case.
#
# TrackEval's HOTA at a localisation threshold alpha: per frame, targets and hypotheses are
# matched (IoU >= alpha); DetA = TP / (TP + FN + FP); each TP contributes the association IoU
# A(c) = TPA / (TPA + FNA + FPA) of its (target, hypothesis) pair, where TPA is the number of
# frames the pair is matched, FNA the frames of the target not matched to this hypothesis, FPA
# the frames of the hypothesis not matched to this target; AssA = mean of A over TPs;
# HOTA = sqrt(DetA * AssA).  The reported numbers are means over alpha = 0.05, 0.10, ..., 0.95
# (19 values).  All boxes are 10 x 10.
#
# Sequence "a" (4 frames): target A (id 1) at x=0 in frames 1-4, target B (id 2) at x=100 in
# frames 1-2, a distractor D at x=200 in frame 2.  Hypotheses: h1 on A in frames 1-2, h2 on A in
# frames 3-4 (all IoU 1), h3 far away at x=500 in frame 1, h4 exactly on the distractor in frame 2.
# h4 is removed by the distractor preprocessing (as for CLEAR), B is never covered.
#   At every alpha: TP = 4 (A, frames 1-4), FN = 2 (B), FP = 1 (h3) -> DetA = 4/7.
#   Pairs (A,h1) and (A,h2): TPA = 2, A has 4 frames, each hypothesis 2 -> A = 2/(4 + 2 - 2) = 1/2,
#   so AssA = 1/2 and HOTA = sqrt(4/7 * 1/2) = sqrt(2/7) = 0.5345.
#   (Had h4 been kept as a false positive, DetA would be 4/8.)
#
# Sequence "b" (2 frames): target C at x=0 in frames 1-2; hypothesis h at x=0 in frame 1 and at
# x=2 in frame 2: IoU = 8*10 / (100 + 100 - 80) = 2/3.
#   alpha <= 0.65 (13 of the 19 alphas): TP = 2, FN = FP = 0, A = 1 -> DetA = AssA = HOTA = 1.
#   alpha >= 0.70 (6 alphas): frame 2 unmatched: TP = 1, FN = 1, FP = 1 -> DetA = 1/3;
#   the pair is matched 1 frame of C's 2 and h's 2 -> A = 1/(2 + 2 - 1) = 1/3 -> HOTA = 1/3.
#   Means: DetA = AssA = HOTA = (13 + 6/3) / 19 = 15/19.
#
# Both sequences combined, the TrackEval way (per-alpha counts summed, A averaged over all TPs):
#   alpha <= 0.65: TP 6, FN 2, FP 1 -> DetA 6/9 = 2/3; AssA (4 * 1/2 + 2 * 1) / 6 = 2/3; HOTA 2/3.
#   alpha >= 0.70: TP 5, FN 3, FP 2 -> DetA 5/10 = 1/2; AssA (4 * 1/2 + 1 * 1/3) / 5 = 7/15;
#                  HOTA sqrt(1/2 * 7/15) = sqrt(7/30).
#   Means: DetA = (13 * 2/3 + 6 * 1/2) / 19 = 35/57, AssA = (13 * 2/3 + 6 * 7/15) / 19 = 172/285,
#   HOTA = (13 * 2/3 + 6 * sqrt(7/30)) / 19 = 0.6089 -- not the mean of the two sequences'
#   HOTAs ((0.5345 + 0.7895) / 2 = 0.6620).

SEQ_A = make_gt([(f, 1, 0, 0, 10, 10, "t") for f in (1, 2, 3, 4)]
                + [(f, 2, 100, 0, 10, 10, "t") for f in (1, 2)]
                + [(2, 9, 200, 0, 10, 10, "d")], num_frames=4, name="a")
HYP_A = np.array([
    [1, 1, 0, 0, 10, 10], [2, 1, 0, 0, 10, 10],
    [3, 2, 0, 0, 10, 10], [4, 2, 0, 0, 10, 10],
    [1, 3, 500, 0, 10, 10],
    [2, 4, 200, 0, 10, 10],
])
SEQ_B = make_gt([(f, 1, 0, 0, 10, 10, "t") for f in (1, 2)], num_frames=2, name="b")
HYP_B = np.array([[1, 7, 0, 0, 10, 10], [2, 7, 2, 0, 10, 10]])


def test_hand_derived_hota_of_one_sequence():
    a = ev.evaluate_sequence(SEQ_A, HYP_A)
    assert a["removed_distractor"] == 1
    assert a["deta"] == pytest.approx(4 / 7)
    assert a["assa"] == pytest.approx(1 / 2)
    assert a["hota"] == pytest.approx(math.sqrt(2 / 7))
    b = ev.evaluate_sequence(SEQ_B, HYP_B)
    for key in ("hota", "deta", "assa"):
        assert b[key] == pytest.approx(15 / 19)


def test_sequences_are_combined_from_per_alpha_counts_not_averaged():
    per, overall = ev.evaluate_many([("a", SEQ_A, HYP_A), ("b", SEQ_B, HYP_B)])
    assert overall["deta"] == pytest.approx(35 / 57)
    assert overall["assa"] == pytest.approx(172 / 285)
    assert overall["hota"] == pytest.approx((13 * 2 / 3 + 6 * math.sqrt(7 / 30)) / 19)
    assert overall["hota"] != pytest.approx((per["a"]["hota"] + per["b"]["hota"]) / 2, abs=1e-3)
    # combine() works from the dicts alone, e.g. after a JSON round trip
    import json
    again = ev.combine(json.loads(json.dumps(list(per.values()))))
    assert again["hota"] == pytest.approx(overall["hota"])


def test_nothing_to_score_is_nan_and_all_false_positives_is_zero():
    empty = make_gt([], num_frames=3)
    r = ev.evaluate_sequence(empty, np.zeros((0, 6)))
    assert math.isnan(r["hota"]) and math.isnan(r["deta"]) and math.isnan(r["assa"])
    r = ev.evaluate_sequence(empty, np.array([[1, 1, 0, 0, 10, 10]]))
    assert r["hota"] == 0.0 and r["deta"] == 0.0  # one FP, nothing else: TP = 0 at every alpha
