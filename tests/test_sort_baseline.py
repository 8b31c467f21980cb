"""The paper's baseline, SORT: gating by min_hits, ids, deletion after max_age, association, and the published MOT15 result."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from refimpl.io.datasets import benchmark_sequences
from refimpl.tracking.baseline import SortTracker, associate, track_sequence

# Two pedestrians-sized boxes moving apart by 5 px per frame (A left, B right).
# The Kalman velocity starts at 0, so the first prediction is the previous box: the IoU of a
# 50 x 100 box with itself shifted by 5 px is 45*100 / (55*100) = 0.82 > 0.3, so the
# detections are always matched to their own track while the track exists.


def box_a(frame: int) -> list[float]:
    return [100.0 - 5.0 * (frame - 1), 100.0, 50.0, 100.0]


def box_b(frame: int) -> list[float]:
    return [300.0 + 5.0 * (frame - 1), 100.0, 50.0, 100.0]


def ids(rows: np.ndarray) -> list[int]:
    return [int(i) for i in rows[:, 0]]


def test_two_boxes_moving_apart_gating_ids_deletion_and_new_id_after_a_gap():
    trk = SortTracker(max_age=1, min_hits=3, iou_threshold=0.3)
    # frame 1: two new tracks, ids in detection order; output although hit_streak = 0,
    # because frame_count 1 <= min_hits
    out = trk.update(np.array([box_a(1), box_b(1)]))
    assert ids(out) == [1, 2]
    np.testing.assert_allclose(out[:, 1:], [box_a(1), box_b(1)])  # a new track's box is its detection
    # frame 2: both matched (hit_streak 1), still start-up (frame_count 2 <= 3)
    assert ids(trk.update(np.array([box_a(2), box_b(2)]))) == [1, 2]
    # frame 3: B missing -> B not output (not updated this frame); A output (frame_count 3 <= 3)
    assert ids(trk.update(np.array([box_a(3)]))) == [1]
    assert len(trk.tracks) == 2  # B missed 1 frame: time_since_update 1 <= max_age, kept
    # frame 4: B missing again -> time_since_update 2 > max_age = 1: deleted.
    # A: hit_streak 3 (updates in frames 2, 3, 4) >= min_hits -> output after start-up
    assert ids(trk.update(np.array([box_a(4)]))) == [1]
    assert [t.id for t in trk.tracks] == [1]
    # frame 5: B is back -> a new identity 3, not output (hit_streak 0 < 3, frame_count 5 > 3)
    out = trk.update(np.array([box_a(5), box_b(5)]))
    assert ids(out) == [1]
    assert [t.id for t in trk.tracks] == [1, 3]


def test_a_track_is_output_after_min_hits_consecutive_updates_once_start_up_is_over():
    trk = SortTracker(max_age=1, min_hits=3)
    for f in range(1, 5):  # frames 1-4: only A
        trk.update(np.array([box_a(f)]))
    # B appears in frame 5 (id 2) and is matched in frames 6, 7, 8: hit_streak 1, 2, 3
    seen = [ids(trk.update(np.array([box_a(f), box_b(f)]))) for f in range(5, 9)]
    assert seen == [[1], [1], [1], [1, 2]]


def test_a_single_missed_frame_keeps_the_identity_but_restarts_the_streak():
    trk = SortTracker(max_age=1, min_hits=3)
    frames = [[box_a(f), box_b(f)] for f in range(1, 6)]
    frames += [[box_a(6)]]                                  # B missed once (kept: 1 <= max_age)
    frames += [[box_a(f), box_b(f)] for f in range(7, 11)]  # B back: same id 2, streak 1, 2, 3, 4
    seen = [ids(trk.update(np.array(fr))) for fr in frames]
    assert seen[4] == [1, 2]
    assert seen[5] == [1]
    assert seen[6:] == [[1], [1], [1, 2], [1, 2]]  # streak restarts: output again at streak 3
    assert [t.id for t in trk.tracks] == [1, 2]


def test_output_box_is_the_filtered_state_not_the_raw_detection():
    trk = SortTracker(min_hits=0)
    trk.update(np.array([box_a(1)]))
    out = trk.update(np.array([box_a(2)]))
    # predicted x = 100 (velocity 0), measured 95; the posterior lies strictly between
    assert 95.0 < out[0, 1] < 100.0


def test_empty_frames_advance_time_and_age_tracks():
    trk = SortTracker(max_age=1, min_hits=3)
    trk.update(np.array([box_a(1)]))
    assert trk.update(np.zeros((0, 4))).shape == (0, 5)
    assert trk.update(np.zeros((0, 4))).shape == (0, 5)
    assert trk.tracks == []  # two frames without update > max_age
    assert trk.frame_count == 3


def test_association_keeps_an_iou_exactly_at_the_threshold_and_rejects_below():
    trk_box = np.array([[0.0, 0.0, 10.0, 10.0]])
    # IoU of (0, 0, 10, 10) with (0, 0, 10, h), h < 10: 10h / 100 -> 0.3 for h = 3
    m, ut, ud = associate(trk_box, np.array([[0.0, 0.0, 10.0, 3.0]]), 0.3)
    assert m.tolist() == [[0, 0]] and ut.size == 0 and ud.size == 0
    m, ut, ud = associate(trk_box, np.array([[0.0, 0.0, 10.0, 2.9]]), 0.3)
    assert m.shape == (0, 2) and ut.tolist() == [0] and ud.tolist() == [0]


def test_association_maximises_the_summed_iou_not_greedily():
    # 10 x 10 boxes on a line: t0 at x 0, t1 at x 10; d0 at x 5 (between them), d1 at x -5.
    # IoU(t0, d0) = IoU(t1, d0) = IoU(t0, d1) = 5*10 / (100 + 100 - 50) = 1/3 > 0.3, IoU(t1, d1) = 0.
    # Taking the first best pair (t0, d0) would leave t1 and d1 unmatched (sum 1/3);
    # the optimal assignment is (t0, d1) + (t1, d0) with sum 2/3.
    trks = np.array([[0.0, 0.0, 10.0, 10.0], [10.0, 0.0, 10.0, 10.0]])
    dets = np.array([[5.0, 0.0, 10.0, 10.0], [-5.0, 0.0, 10.0, 10.0]])
    m, _, _ = associate(trks, dets, 0.3)
    assert sorted(map(tuple, m.tolist())) == [(0, 1), (1, 0)]


def test_association_with_no_tracks_or_no_detections():
    m, ut, ud = associate(np.zeros((0, 4)), np.array([box_a(1)]))
    assert m.shape == (0, 2) and ut.size == 0 and ud.tolist() == [0]
    m, ut, ud = associate(np.array([box_a(1)]), np.zeros((0, 4)))
    assert m.shape == (0, 2) and ut.tolist() == [0] and ud.size == 0


def test_degenerate_detections_are_ignored():
    trk = SortTracker()
    out = trk.update(np.array([[0.0, 0.0, 0.0, 10.0], [1.0, 1.0, 5.0, np.nan], box_a(1)]))
    assert ids(out) == [1] and len(trk.tracks) == 1


def _toy_sequence():
    frames = [SimpleNamespace(frame=10 + f, boxes=np.array([box_a(f), box_b(f)]) if f != 3 else np.zeros((0, 4)))
              for f in range(1, 8)]
    return SimpleNamespace(frames=tuple(frames))


def test_track_sequence_uses_the_sequence_frame_numbers_and_processes_empty_frames():
    rows = track_sequence(_toy_sequence())
    assert rows.shape[1] == 6
    # frames 11, 12 (start-up) output both; 13 is empty; both tracks survive the single miss but
    # their streak restarts at 14: output from the third consecutive update, frame 16 (and 17)
    assert sorted(set(rows[:, 0].astype(int))) == [11, 12, 16, 17]
    assert set(rows[:, 1].astype(int)) == {1, 2}


def test_track_sequence_is_deterministic():
    a = track_sequence(_toy_sequence())
    b = track_sequence(_toy_sequence())
    np.testing.assert_array_equal(a, b)


# ---------------------------------------------------------------------------------------
# real data: SORT's published MOT15 result (Bewley et al. 2016; SORT README "Main Results",
# Faster R-CNN detections, MOT devkit): MOTA 34.0, FP 3311, FN 11660, IDs 274 over
# TUD-Campus, ETH-Sunnyday, ETH-Pedcross2, ADL-Rundle-8, Venice-2, KITTI-17.

DATA_ROOT = Path(__file__).resolve().parent.parent.parent / "shared" / "data"


@pytest.fixture(scope="module")
def sort6_scores():
    if not (DATA_ROOT / "MOT15" / "train").is_dir():
        pytest.skip(f"MOT15 benchmark data not found at {DATA_ROOT} (needs ../shared/data beside the repo)")
    from refimpl.evaluation import evaluate
    from refimpl import io

    pairs = [(s.name, io.load_ground_truth(s), track_sequence(io.load_detections(s)))
             for s in benchmark_sequences("mot15-sort6", DATA_ROOT)]
    per_sequence, overall = evaluate.evaluate_many(pairs)
    return per_sequence, overall, {name: rows for name, _, rows in pairs}


def test_tud_campus_runs_all_71_frames_and_reproduces_sorts_published_row(sort6_scores):
    per_sequence, _, rows = sort6_scores
    r = per_sequence["TUD-Campus"]
    assert r["num_frames"] == 71
    assert set(rows["TUD-Campus"][:, 0].astype(int)) <= set(range(1, 72))
    # SORT README row TUD-Campus: FP 15, FN 113, IDs 6 on 359 gt boxes (pinned from our run,
    # identical to the published row): MOTA = 1 - (15 + 113 + 6) / 359 = 0.62674
    assert (r["fp"], r["fn"], r["idsw"], r["num_gt"]) == (15, 113, 6, 359)
    assert r["mota"] == pytest.approx(1 - (15 + 113 + 6) / 359)


def test_six_sequence_overall_reproduces_sorts_published_mota(sort6_scores):
    _, overall, _ = sort6_scores
    # MOT15 gt rows with flag 0 (43 ETH-Sunnyday, 495 ETH-Pedcross2, 99 KITTI-17) are not
    # targets in the devkit: 23724 - 637 = 23087 targets. FP and FN equal the published counts
    # exactly; MOTA = 1 - (3311 + 11660 + IDs) / 23087 = 0.3398 for IDs 272.
    assert overall["num_gt"] == 23087
    assert (overall["fp"], overall["fn"]) == (3311, 11660)
    # ID switches: the MOT devkit gives 274; motmetrics gives 272 on the same tracks, because it
    # keeps a target's last match across frames where the target was unmatched, while the
    # devkit only carries matches over from the immediately preceding frame (ETH-Pedcross2
    # 76 vs 77, ADL-Rundle-8 102 vs 103). Either counting is accepted here.
    assert overall["idsw"] in (272, 274)
    assert abs(100 * overall["mota"] - 34.0) <= 0.5
    assert overall["mota"] == pytest.approx(1 - (3311 + 11660 + overall["idsw"]) / 23087)


# SORT README per-sequence rows: (FP, FN, IDs)
PUBLISHED_SORT_ROWS = {
    "TUD-Campus": (15, 113, 6),
    "ETH-Sunnyday": (319, 418, 22),
    "ETH-Pedcross2": (330, 3014, 77),
    "ADL-Rundle-8": (959, 3781, 103),
    "Venice-2": (1650, 4109, 57),
    "KITTI-17": (38, 225, 9),
}


def test_every_sequence_matches_sorts_published_fp_and_fn(sort6_scores):
    per_sequence, _, _ = sort6_scores
    for name, (fp, fn, ids) in PUBLISHED_SORT_ROWS.items():
        r = per_sequence[name]
        assert (r["fp"], r["fn"]) == (fp, fn), name
        assert abs(r["idsw"] - ids) <= 1, name  # motmetrics vs devkit ID-switch rule, see above
