"""The simulated detector: determinism, visibility-driven recall, false-positive rate, valid boxes, names."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from refimpl.core.geometry import iou_matrix
from refimpl.io import GroundTruth, InputFormatError, read_mot_ground_truth, read_seqinfo
from refimpl.io.simulate import (
    MOT17,
    MOT20_01,
    DetectorParams,
    simulate_detections,
    simulated_benchmark_sequences,
    simulated_sequence_rows,
)

DATA = Path(__file__).resolve().parent.parent.parent / "shared" / "data"
IMAGE = (1920, 1080)
FRAMES = 2000

# three people standing still, far apart: fully visible, 10 % visible, 55 % visible
SOURCE_BOXES = np.array([[200.0, 200.0, 100.0, 250.0],
                         [1200.0, 200.0, 100.0, 250.0],
                         [700.0, 600.0, 100.0, 250.0]])
SOURCE_VIS = np.array([1.0, 0.1, 0.55])


def hand_made_gt(frames: int = FRAMES, boxes: np.ndarray = SOURCE_BOXES, vis: np.ndarray = SOURCE_VIS,
                 considered: np.ndarray | None = None) -> GroundTruth:
    k = len(boxes)
    return GroundTruth(
        name="HAND-01",
        frames=np.repeat(np.arange(1, frames + 1), k),
        ids=np.tile(np.arange(1, k + 1), frames),
        boxes=np.tile(boxes, (frames, 1)),
        considered=np.tile(np.ones(k, bool) if considered is None else considered, frames),
        distractor=np.zeros(frames * k, bool),
        dontcare=np.zeros((0, 5)),
        first_frame=1,
        num_frames=frames,
        visibility=np.tile(vis, frames),
    )


def detections_per_source(seq, boxes: np.ndarray) -> np.ndarray:
    """How many detections (over all frames) have their best IoU (> 0.3) with each source box."""
    counts = np.zeros(len(boxes), dtype=int)
    for fr in seq.frames:
        if len(fr):
            iou = iou_matrix(fr.boxes, boxes)
            best = iou.argmax(axis=1)
            ok = iou.max(axis=1) > 0.3
            counts += np.bincount(best[ok], minlength=len(boxes))
    return counts


def test_same_seed_gives_identical_arrays_and_different_seed_does_not():
    gt = hand_made_gt(frames=300)
    a = simulate_detections(gt, seed=7, image_size=IMAGE)
    b = simulate_detections(gt, seed=7, image_size=IMAGE)
    c = simulate_detections(gt, seed=8, image_size=IMAGE)
    ra, rb, rc = (simulated_sequence_rows(s) for s in (a, b, c))
    assert ra.tobytes() == rb.tobytes()
    for fa, fb in zip(a.frames, b.frames):
        assert fa.frame == fb.frame and fa.types == fb.types
        assert fa.boxes.tobytes() == fb.boxes.tobytes()
        assert fa.scores.tobytes() == fb.scores.tobytes()
        assert fa.confidences.tobytes() == fb.confidences.tobytes()
    assert ra.shape != rc.shape or not np.array_equal(ra, rc)


def test_recall_follows_visibility():
    """Detection rate of each source vs p = p_max * clip((v - v0) / (1 - v0), 0, 1).

    Defaults p_max = 0.95, v0 = 0.1, so the expected rates are
      v = 1.0:  0.95 * 1                     = 0.95
      v = 0.1:  0.95 * clip(0 / 0.9)         = 0     (exactly: never detected)
      v = 0.55: 0.95 * (0.45 / 0.9) = 0.95/2 = 0.475
    Each source is detected independently in each of N = 2000 frames, so its count is
    Binomial(N, p).  Hoeffding: P(|rate - p| >= eps) <= 2 exp(-2 N eps^2); with eps = 0.05 that is
    2 exp(-10) < 1e-4 per source, so the tolerance is not tuned to the seed.  (Jitter of 5 % of
    the size keeps every detection at IoU > 0.3 with its own box, and the boxes are far apart.)
    """
    params = DetectorParams(fp_per_frame=0.0)
    seq = simulate_detections(hand_made_gt(), seed=0, params=params, image_size=IMAGE)
    rates = detections_per_source(seq, SOURCE_BOXES) / FRAMES
    assert seq.num_detections == detections_per_source(seq, SOURCE_BOXES).sum()
    assert abs(rates[0] - 0.95) < 0.05
    assert rates[1] == 0.0
    assert abs(rates[2] - 0.475) < 0.05
    np.testing.assert_allclose(params.detection_probability(SOURCE_VIS), [0.95, 0.0, 0.475])


def test_only_considered_rows_are_sources():
    gt = hand_made_gt(frames=200, vis=np.ones(3), considered=np.array([True, False, True]))
    seq = simulate_detections(gt, seed=1, params=DetectorParams(p_max=1.0, fp_per_frame=0.0),
                              image_size=IMAGE)
    counts = detections_per_source(seq, SOURCE_BOXES)
    assert counts.tolist() == [200, 0, 200]


def test_false_positive_rate_is_the_poisson_mean():
    """With p_max = 0 every detection is a false positive; their total is Poisson(lambda), lambda = 2 * 2000.

    Chernoff bounds for Poisson: P(X >= lambda + t) <= exp(-t^2 / (2 (lambda + t))) and
    P(X <= lambda - t) <= exp(-t^2 / (2 lambda)).  With t = 0.16 * 2000 = 320 both are below
    1e-5 (exp(-11.8), exp(-12.8)), hence |mean per frame - 2| < 0.16.  No false positive is
    dropped by clipping here: the people stand far inside the image (a near false positive
    would need a shift of more than 8 standard deviations to leave it).
    """
    params = DetectorParams(p_max=0.0, fp_per_frame=2.0)
    seq = simulate_detections(hand_made_gt(), seed=0, params=params, image_size=IMAGE)
    per_frame = seq.num_detections / FRAMES
    assert abs(per_frame - 2.0) < 0.16
    scores = np.concatenate([f.scores for f in seq.frames])
    # Beta(1.5, 4): mean 0.273, sd 0.18; the mean of ~4000 draws is within 0.02 of it
    assert abs(scores.mean() - 1.5 / 5.5) < 0.02


def overlap_share(seq, boxes: np.ndarray) -> float:
    """Share of the detections that overlap (IoU > 0) some source box."""
    total = hit = 0
    for f in seq.frames:
        if len(f):
            total += len(f)
            hit += int((iou_matrix(f.boxes, boxes).max(axis=1) > 0).sum())
    return hit / total


def test_false_positives_near_people_or_anywhere():
    """fp_near_share = 1: false positives sit on people (shift sd 0.6 box sizes, so most still overlap
    their person); = 0: they overlap one of the three people only by chance (the boxes cover a few
    per cent of the image, the false positives are up to half the image tall)."""
    gt = hand_made_gt(frames=500)
    near = simulate_detections(gt, seed=0, params=DetectorParams(p_max=0.0, fp_near_share=1.0), image_size=IMAGE)
    far = simulate_detections(gt, seed=0, params=DetectorParams(p_max=0.0, fp_near_share=0.0), image_size=IMAGE)
    assert overlap_share(near, SOURCE_BOXES) > 0.7
    assert overlap_share(far, SOURCE_BOXES) < 0.3


def test_true_positive_scores_are_high_and_false_positive_scores_low():
    gt = hand_made_gt(frames=500)
    tp = simulate_detections(gt, seed=2, params=DetectorParams(fp_per_frame=0.0), image_size=IMAGE)
    fp = simulate_detections(gt, seed=2, params=DetectorParams(p_max=0.0), image_size=IMAGE)
    tp_conf = np.concatenate([f.confidences for f in tp.frames])
    fp_conf = np.concatenate([f.confidences for f in fp.frames])
    assert tp_conf.mean() > 70 and fp_conf.mean() < 35
    # confidences are round-half-up(100 * score), integers 0..100
    for s in (tp, fp):
        for f in s.frames:
            assert f.confidences.dtype.kind == "i"
            np.testing.assert_array_equal(f.confidences, np.floor(100 * f.scores + 0.5).astype(int))


def test_boxes_are_valid_frames_complete_and_sorted_by_score():
    gt = hand_made_gt(frames=400)
    seq = simulate_detections(gt, seed=3, params=DetectorParams(fp_per_frame=5.0), image_size=IMAGE, fps=25)
    assert [f.frame for f in seq.frames] == list(range(1, 401))
    assert seq.first_frame == 1 and seq.image_size == IMAGE and seq.fps == 25.0
    rows = simulated_sequence_rows(seq)
    assert rows.shape == (seq.num_detections, 10)
    assert np.all(np.isfinite(rows))
    assert np.all(rows[:, 4] > 0) and np.all(rows[:, 5] > 0)
    assert np.all(rows[:, 2] >= 0) and np.all(rows[:, 3] >= 0)
    assert np.all(rows[:, 2] + rows[:, 4] <= IMAGE[0] + 1e-9)
    assert np.all(rows[:, 3] + rows[:, 5] <= IMAGE[1] + 1e-9)
    assert np.all(rows[:, [1, 7, 8, 9]] == -1)
    for f in seq.frames:
        assert f.boxes.shape == (len(f), 4)
        assert f.types == ("pedestrian",) * len(f)
        assert np.all(np.diff(f.scores) <= 0)
        assert np.all((0 <= f.scores) & (f.scores <= 1))


def test_boxes_partly_outside_the_image_are_clipped():
    boxes = np.array([[-60.0, 100.0, 100.0, 250.0], [1900.0, 900.0, 100.0, 250.0]])
    gt = hand_made_gt(frames=100, boxes=boxes, vis=np.ones(2))
    seq = simulate_detections(gt, seed=0, params=DetectorParams(p_max=1.0, fp_per_frame=0.0),
                              image_size=IMAGE)
    rows = simulated_sequence_rows(seq)
    assert len(rows) == 200
    assert np.all(rows[:, 2] >= 0) and np.all(rows[:, 2] + rows[:, 4] <= IMAGE[0] + 1e-9)
    assert np.all(rows[:, 3] + rows[:, 5] <= IMAGE[1] + 1e-9)


def test_names_are_marked_simulated():
    gt = hand_made_gt(frames=10)
    assert simulate_detections(gt, seed=4).name == "HAND-01 (simulated dets, seed 4)"
    assert simulate_detections(gt, seed=0, name="MOT17-02").name == "MOT17-02 (simulated dets, seed 0)"


def test_without_image_size_the_gt_extent_bounds_the_boxes():
    gt = hand_made_gt(frames=200)
    seq = simulate_detections(gt, seed=5, params=DetectorParams(fp_per_frame=3.0))
    assert seq.image_size is None
    rows = simulated_sequence_rows(seq)
    right = (SOURCE_BOXES[:, 0] + SOURCE_BOXES[:, 2]).max()
    bottom = (SOURCE_BOXES[:, 1] + SOURCE_BOXES[:, 3]).max()
    assert np.all(rows[:, 2] + rows[:, 4] <= right + 1e-9)
    assert np.all(rows[:, 3] + rows[:, 5] <= bottom + 1e-9)


def test_changing_recall_keeps_the_other_draws():
    """Draws happen for every source, detected or not: a lower p_max only removes detections."""
    gt = hand_made_gt(frames=300)
    hi = simulate_detections(gt, seed=9, params=DetectorParams(p_max=1.0, fp_per_frame=1.0), image_size=IMAGE)
    lo = simulate_detections(gt, seed=9, params=DetectorParams(p_max=0.5, fp_per_frame=1.0), image_size=IMAGE)
    for fh, fl in zip(hi.frames, lo.frames):
        kept = {tuple(b) for b in fh.boxes.tolist()}
        assert all(tuple(b) in kept for b in fl.boxes.tolist())


def test_bad_parameters_are_rejected():
    with pytest.raises(ValueError):
        DetectorParams(p_max=1.5)
    with pytest.raises(ValueError):
        DetectorParams(v0=1.0)
    with pytest.raises(ValueError):
        DetectorParams(fp_per_frame=-1)


def test_missing_data_is_named(tmp_path):
    with pytest.raises(InputFormatError, match="ground truth of MOT17-02"):
        simulated_benchmark_sequences(MOT17, tmp_path)
    with pytest.raises(InputFormatError, match="data root for 'mot20-01-sim' not found"):
        simulated_benchmark_sequences(MOT20_01, tmp_path / "nowhere", name="mot20-01-sim")


# ---------------------------------------------------------------------------------------------
# real data

needs_mot = pytest.mark.skipif(
    not (DATA / "MOT17" / "train" / "MOT17-09-FRCNN" / "gt" / "gt.txt").is_file()
    or not (DATA / "MOT20" / "train" / "MOT20-01" / "gt" / "gt.txt").is_file(),
    reason=f"MOT17/MOT20 ground truth not found under {DATA} (the shared benchmark data sits beside the repo)")


@needs_mot
def test_mot17_09_simulates_every_frame():
    folder = DATA / "MOT17" / "train" / "MOT17-09-FRCNN"
    info = read_seqinfo(folder / "seqinfo.ini")
    gt = read_mot_ground_truth(folder / "gt" / "gt.txt", seqinfo=info)
    seq = simulate_detections(gt, seed=0, image_size=(info["imWidth"], info["imHeight"]))
    assert len(seq.frames) == 525
    assert [f.frame for f in seq.frames] == list(range(1, 526))
    assert "simulated dets, seed 0" in seq.name
    # a sanity band, not a calibration: about half the pedestrians are found
    matched = detections_per_frame_recall(seq, gt)
    assert 0.35 < matched < 0.75


def detections_per_frame_recall(seq, gt) -> float:
    found = 0
    for f in seq.frames:
        m = (gt.frames == f.frame) & gt.considered
        if len(f) and m.any():
            found += int((iou_matrix(gt.boxes[m], f.boxes).max(axis=1) >= 0.5).sum())
    return found / gt.num_targets


@needs_mot
def test_simulated_benchmarks_on_real_data():
    mot17 = simulated_benchmark_sequences(MOT17, DATA, seed=1)
    assert [n for n, _, _ in mot17] == ["MOT17-02", "MOT17-04", "MOT17-05", "MOT17-09", "MOT17-10",
                                        "MOT17-11", "MOT17-13"]
    lengths = {"MOT17-02": 600, "MOT17-04": 1050, "MOT17-05": 837, "MOT17-09": 525, "MOT17-10": 654,
               "MOT17-11": 900, "MOT17-13": 750}
    for name, dets, gt in mot17:
        assert dets.name == f"{name} (simulated dets, seed 1)"
        assert gt.name == name
        assert len(dets.frames) == lengths[name] == gt.num_frames
        assert dets.image_size == ((640, 480) if name == "MOT17-05" else (1920, 1080))
    # MOT17-02's gt is read from the FRCNN folder (the DPM copy lacks track 1's 600 rows)
    gt02 = mot17[0][2]
    assert int(np.sum(gt02.ids == 1)) == 600
    ((name, dets, gt),) = simulated_benchmark_sequences(MOT20_01, DATA)
    assert name == "MOT20-01" and len(dets.frames) == 429 and gt.num_targets == 19870
    assert dets.name == "MOT20-01 (simulated dets, seed 0)"
