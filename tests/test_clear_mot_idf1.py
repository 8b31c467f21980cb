"""refimpl.evaluation.evaluate: CLEAR MOT / IDF1 on hand-made sequences, preprocessing, overall row, NumPy 2."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from refimpl.io.datasets import benchmark_sequences
from refimpl.evaluation import evaluate as ev
from refimpl import io
from refimpl.io import GroundTruth

REPO = Path(__file__).resolve().parent.parent
DATA = Path(os.environ.get("REFIMPL_DATA_ROOT", Path(__file__).resolve().parent.parent.parent / "shared" / "data"))


def make_gt(rows, num_frames, first_frame=1, dontcare=(), name="seq"):
    """rows: (frame, id, x, y, w, h, kind) with kind 't' target, 'd' distractor, 'o' other."""
    rows = sorted(rows, key=lambda r: (r[0], r[1]))
    a = np.array([r[:6] for r in rows], dtype=float).reshape(-1, 6)
    kinds = [r[6] for r in rows]
    return GroundTruth(
        name=name,
        frames=a[:, 0].astype(np.int64),
        ids=a[:, 1].astype(np.int64),
        boxes=a[:, 2:6],
        considered=np.array([k == "t" for k in kinds], dtype=bool),
        distractor=np.array([k == "d" for k in kinds], dtype=bool),
        dontcare=np.array(dontcare, dtype=float).reshape(-1, 5),
        first_frame=first_frame,
        num_frames=num_frames,
    )


# Two objects over 3 frames: A (id 1) at x=0, B (id 2) at x=100, both 10x10.
TWO_OBJECTS = make_gt([(f, 1, 0, 0, 10, 10, "t") for f in (1, 2, 3)]
                      + [(f, 2, 100, 0, 10, 10, "t") for f in (1, 2, 3)], num_frames=3)
# Hypotheses: h1 follows A in frames 1-2; h2 follows B in frames 1-2 (shifted 1 px in frame 1);
# h3 is a false alarm far away in frame 2 and then takes over A in frame 3; B is missed in frame 3.
HYPS = np.array([
    [1, 1, 0, 0, 10, 10],
    [1, 2, 101, 0, 10, 10],   # IoU with B = 9*10 / (100 + 100 - 90) = 90/110 = 9/11
    [2, 1, 0, 0, 10, 10],
    [2, 2, 100, 0, 10, 10],
    [2, 3, 300, 300, 10, 10],  # FP: overlaps nothing
    [3, 3, 0, 0, 10, 10],      # matches A, which was matched to h1 before: ID switch
])


def test_hand_made_sequence_counts_one_fp_one_fn_one_switch():
    r = ev.evaluate_sequence(TWO_OBJECTS, HYPS)
    # num_gt = 2 objects x 3 frames = 6; FP = 1 (h3 frame 2), FN = 1 (B frame 3), IDSW = 1 (A frame 3)
    assert (r["num_gt"], r["fp"], r["fn"], r["idsw"], r["num_frames"]) == (6, 1, 1, 1, 3)
    # MOTA = 1 - (FN + FP + IDSW) / num_gt = 1 - 3/6 = 0.5
    assert r["mota"] == pytest.approx(1 - (1 + 1 + 1) / 6)
    # matches (incl. the switch): frame 1: 2, frame 2: 2, frame 3: 1 -> 5; all IoU 1 except 9/11
    # MOTP (overlap) = (4 * 1 + 9/11) / 5
    assert r["num_matches"] == 5
    assert r["motp"] == pytest.approx((4 * 1 + 9 / 11) / 5)
    # IDF1: best global id mapping A<->h1 (2 frames), B<->h2 (2 frames) -> IDTP = 4;
    # num_gt = 6, num_predictions = 6 -> IDF1 = 2*4 / (6 + 6) = 2/3
    assert r["idtp"] == 4 and r["num_predictions"] == 6
    assert r["idf1"] == pytest.approx(2 * 4 / (6 + 6))
    # A covered 3/3 frames (>= 80%) -> MT; B covered 2/3 (between 20% and 80%) -> PT; none ML
    assert (r["mt"], r["pt"], r["ml"]) == (1, 1, 0)
    # B's coverage ends with the miss, nothing resumes afterwards -> no fragmentation
    assert r["frag"] == 0


def test_fragmentation_is_a_track_interrupted_and_resumed():
    gt = make_gt([(f, 1, 0, 0, 10, 10, "t") for f in (1, 2, 3)], num_frames=3)
    hyps = np.array([[1, 7, 0, 0, 10, 10], [3, 7, 0, 0, 10, 10]])
    r = ev.evaluate_sequence(gt, hyps)
    # tracked, missed, tracked again: 1 fragmentation, 1 FN; MOTA = 1 - 1/3
    assert (r["frag"], r["fn"], r["idsw"]) == (1, 1, 0)
    assert r["mota"] == pytest.approx(1 - 1 / 3)


def test_perfect_results_score_one():
    res = np.column_stack([TWO_OBJECTS.frames, TWO_OBJECTS.ids, TWO_OBJECTS.boxes])
    r = ev.evaluate_sequence(TWO_OBJECTS, res)
    assert (r["mota"], r["motp"], r["idf1"], r["mt"], r["fp"], r["fn"]) == (1.0, 1.0, 1.0, 2, 0, 0)


def test_hypotheses_on_distractors_are_removed_not_counted():
    gt = make_gt([(1, 1, 0, 0, 10, 10, "t"),       # target
                  (1, 2, 100, 0, 10, 10, "d"),     # distractor (e.g. static person, Van)
                  (1, 3, 200, 0, 10, 10, "o")],    # neither (e.g. MOT17 car): not protected
                 num_frames=1)
    hyps = np.array([[1, 1, 0, 0, 10, 10],
                     [1, 2, 101, 0, 10, 10],      # IoU 9/11 >= 0.5 with the distractor -> removed
                     [1, 3, 200, 0, 10, 10],      # on the 'other' row -> an FP
                     [1, 4, 104, 0, 10, 10]])     # IoU 6*10/(200-60) = 0.43 < 0.5 -> FP
    r = ev.evaluate_sequence(gt, hyps)
    assert r["removed_distractor"] == 1
    # num_gt = 1 (only the target counts); FP = 2 (hyp 3 and hyp 4); MOTA = 1 - 2/1 = -1
    assert (r["num_gt"], r["fp"], r["fn"]) == (1, 2, 0)
    assert r["mota"] == pytest.approx(1 - 2 / 1)


def test_distractor_matching_is_one_to_one():
    gt = make_gt([(1, 1, 0, 0, 10, 10, "d")], num_frames=1)
    hyps = np.array([[1, 1, 0, 0, 10, 10], [1, 2, 1, 0, 10, 10]])
    r = ev.evaluate_sequence(gt, hyps)
    # Hungarian: one distractor takes one hypothesis (the exact one); the other stays an FP
    assert (r["removed_distractor"], r["fp"], r["num_gt"]) == (1, 1, 0)
    assert np.isnan(r["mota"]) and np.isnan(r["motp"])  # no targets, no matches: undefined ratios


def test_unmatched_hypotheses_inside_dontcare_regions_are_removed():
    # DontCare region in frame 1: x 50..150, y 0..100
    gt = make_gt([(1, 1, 0, 0, 20, 20, "t"), (1, 2, 60, 10, 20, 20, "t")], num_frames=1,
                 first_frame=0, dontcare=[(1, 50, 0, 100, 100)])
    hyps = np.array([[1, 1, 0, 0, 20, 20],       # matches target 1
                     [1, 2, 60, 10, 20, 20],     # inside DontCare but matched to target 2: kept
                     [1, 3, 120, 50, 20, 20],    # fully inside, unmatched -> removed
                     [1, 4, 140, 50, 20, 20],    # cover = 10*20 / (20*20) = 0.5 -> removed (>= 0.5)
                     [1, 5, 142, 50, 20, 20]])   # cover = 8*20 / 400 = 0.4 -> FP
    r = ev.evaluate_sequence(gt, hyps)
    assert r["removed_dontcare"] == 2
    # num_gt = 2 matched; FP = 1 (hyp 5)
    assert (r["num_gt"], r["num_matches"], r["fp"], r["fn"]) == (2, 2, 1, 0)


def test_results_outside_the_gt_frame_range_are_false_positives():
    r = ev.evaluate_sequence(TWO_OBJECTS, np.vstack([HYPS, [[9, 8, 0, 0, 10, 10]]]))
    # the frame-9 hypothesis adds one FP and one evaluated frame: FP = 1 + 1, frames = 3 + 1
    assert (r["fp"], r["num_frames"]) == (2, 4)


def test_duplicate_result_ids_in_a_frame_are_rejected():
    with pytest.raises(ValueError, match="duplicate"):
        ev.evaluate_sequence(TWO_OBJECTS, np.array([[1, 1, 0, 0, 10, 10], [1, 1, 5, 5, 10, 10]]))


def test_evaluate_many_overall_is_computed_from_summed_counts():
    single = make_gt([(f, 1, 0, 0, 10, 10, "t") for f in (1, 2, 3)], num_frames=3)
    half = np.array([[1, 5, 0, 0, 10, 10], [2, 5, 0, 0, 20, 10]])  # frame 2: IoU 100/200 = 0.5 -> match
    per, overall = ev.evaluate_many([("a", TWO_OBJECTS, HYPS), ("b", single, half)])
    a, b = per["a"], per["b"]
    assert list(per) == ["a", "b"]
    # b: 3 gt, 2 matches, FN 1 (frame 3), FP 0 -> MOTA_b = 1 - 1/3; MOTP_b = (1 + 0.5) / 2
    assert (b["num_gt"], b["num_matches"], b["fn"], b["fp"]) == (3, 2, 1, 0)
    assert b["motp"] == pytest.approx((1 + 0.5) / 2)
    for key in ("fp", "fn", "idsw", "frag", "mt", "ml", "num_gt", "num_frames", "num_matches",
                "idtp", "idfp", "idfn"):
        assert overall[key] == a[key] + b[key], key
    # MOTA over summed counts: 1 - (FN + FP + IDSW) / num_gt = 1 - ((1+1) + (1+0) + (1+0)) / (6+3)
    assert overall["mota"] == pytest.approx(1 - (2 + 1 + 1) / 9)
    # MOTP weighted by matches: (5 * MOTP_a + 2 * MOTP_b) / 7
    assert overall["motp"] == pytest.approx((5 * a["motp"] + 2 * b["motp"]) / 7)
    # IDF1 from summed ID counts: 2 IDTP / (2 IDTP + IDFP + IDFN)
    idtp, idfp, idfn = a["idtp"] + b["idtp"], a["idfp"] + b["idfp"], a["idfn"] + b["idfn"]
    assert overall["idf1"] == pytest.approx(2 * idtp / (2 * idtp + idfp + idfn))
    with pytest.raises(ValueError, match="twice"):
        ev.evaluate_many([("a", single, half), ("a", single, half)])


def test_format_table_prints_percentages_and_an_overall_row():
    per, overall = ev.evaluate_many([("TWO", TWO_OBJECTS, HYPS)])
    table = ev.format_table(per, overall)
    lines = table.strip().splitlines()
    assert lines[0] == "| Sequence | HOTA | DetA | AssA | MOTA | MOTP | IDF1 | MT | ML | FP | FN | IDs | Frag |"
    # HOTA / DetA / AssA in percent with one decimal (their values are tested in test_hota.py)
    r = per["TWO"]
    hota = " | ".join(f"{100 * r[k]:.1f}" for k in ("hota", "deta", "assa"))
    # MOTA 0.5 -> 50.0; MOTP (4 + 9/11)/5 = 0.9636 -> 96.4; IDF1 2/3 -> 66.7
    assert lines[2] == f"| TWO | {hota} | 50.0 | 96.4 | 66.7 | 1 | 0 | 1 | 1 | 1 | 0 |"
    assert lines[3].startswith(f"| OVERALL | {hota} | 50.0 | 96.4 | 66.7 |")


def test_iou_distances_equal_motmetrics_on_numpy1_semantics():
    # motmetrics' iou_matrix: 1 - IoU, NaN above max_iou. Boxes (x, y, w, h): a = (0,0,10,10);
    # b = (5,0,10,10) overlaps a by 50 px of 150 in union -> IoU 1/3, distance 2/3 (> 0.5: NaN);
    # c = a -> distance 0.
    import motmetrics as mm
    d = ev._iou_distances(mm, np.array([[0, 0, 10, 10]]), np.array([[5, 0, 10, 10], [0, 0, 10, 10]]), 0.5)
    assert np.isnan(d[0, 0]) and d[0, 1] == 0.0
    d = ev._iou_distances(mm, np.array([[0, 0, 10, 10]]), np.array([[5, 0, 10, 10]]), 0.7)
    assert d[0, 0] == pytest.approx(2 / 3)
    assert ev._iou_distances(mm, np.zeros((0, 4)), np.array([[0, 0, 1, 1]]), 0.5).shape == (0, 0)


@pytest.mark.skipif(int(np.__version__.split(".")[0]) < 2, reason="np.asfarray exists before NumPy 2")
def test_motmetrics_runs_end_to_end_without_patching_numpy():
    # A fresh interpreter: evaluating must neither need nor add np.asfarray (no process-wide patch).
    script = textwrap.dedent("""
        import numpy as np
        import refimpl.evaluation.evaluate as ev
        from refimpl.io import GroundTruth
        gt = GroundTruth(name="s", frames=np.array([1, 2]), ids=np.array([1, 1]),
                            boxes=np.array([[0, 0, 10, 10], [0, 0, 10, 10]], float),
                            considered=np.array([True, True]), distractor=np.array([False, False]),
                            dontcare=np.zeros((0, 5)), first_frame=1, num_frames=2)
        r = ev.evaluate_sequence(gt, np.array([[1, 4, 0, 0, 10, 10], [2, 4, 0, 0, 10, 10]]))
        assert r["mota"] == 1.0 and r["idf1"] == 1.0, r
        assert not hasattr(np, "asfarray"), "evaluating must not patch numpy"
        print("ok", np.__version__)
    """)
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env,
                         cwd=str(REPO), timeout=120)
    assert out.returncode == 0, out.stderr + out.stdout
    assert out.stdout.startswith("ok 2.")


@pytest.mark.skipif(not (DATA / "KITTI").is_dir(), reason=f"benchmark data folder {DATA} absent")
def test_kitti_ground_truth_as_results_scores_perfect_with_vans_removed():
    import warnings

    seq = benchmark_sequences("kitti-car", DATA)[0]
    gt = io.load_ground_truth(seq)
    # Feed every Car AND Van row back as a hypothesis: the 292 Van hypotheses match distractors
    # and are removed, the 243 Car hypotheses match their targets -> MOTA = 1, FP = 0.
    res = np.column_stack([gt.frames, gt.ids, gt.boxes])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = ev.evaluate_sequence(gt, res)
    assert (r["mota"], r["fp"], r["fn"], r["removed_distractor"], r["num_gt"]) == (1.0, 0, 0, 292, 243)
