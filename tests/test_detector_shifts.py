"""Detector and camera shifts (refimpl.io.shifts, their table refimpl.experiments.shift_table, `refimpl benchmark --shift`)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from refimpl.cli import main
from refimpl.experiments.shift_table import shift_table
from refimpl.io.shifts import SHIFTS, parse_shifts, shifted_dataset
from refimpl.io import DetectionFrame, DetectionSequence, GroundTruth


def _toy(n: int = 6):
    """n frames (1..n), one box walking right 4 px a frame with score 0.5 + t/100, and its ground truth."""
    frames = tuple(DetectionFrame(t, np.array([[10.0 + 4 * t, 20.0, 40.0, 80.0]]), np.array([0.5 + t / 100]),
                                  np.array([50], dtype=np.int64), ("pedestrian",)) for t in range(1, n + 1))
    seq = DetectionSequence("toy", frames, 1, (640, 480), 30.0)
    gt = GroundTruth("toy", np.arange(1, n + 1), np.ones(n, dtype=int),
                     np.array([[10.0 + 4 * t, 20.0, 40.0, 80.0] for t in range(1, n + 1)]), np.ones(n, dtype=bool),
                     np.zeros(n, dtype=bool), np.zeros((0, 5)), 1, n)
    return [("toy", seq, gt)]


def test_half_frame_rate_keeps_every_second_frame_renumbered():
    (_, seq, gt), = shifted_dataset(_toy(6), "half-fps")
    # frames 1, 3, 5 kept (offsets 0, 2, 4 from the first), renumbered 1 + offset / 2 = 1, 2, 3
    assert [f.frame for f in seq.frames] == [1, 2, 3] and seq.fps == 15.0
    assert [f.boxes[0, 0] for f in seq.frames] == [14.0, 22.0, 30.0]  # 10 + 4t at t = 1, 3, 5
    assert gt.frames.tolist() == [1, 2, 3] and gt.num_frames == 3 and gt.boxes[:, 0].tolist() == [14.0, 22.0, 30.0]


def test_half_resolution_halves_boxes_image_and_truth():
    (_, seq, gt), = shifted_dataset(_toy(2), "half-res")
    assert seq.image_size == (320, 240)
    assert seq.frames[0].boxes[0].tolist() == [7.0, 10.0, 20.0, 40.0]  # (14, 20, 40, 80) / 2
    assert gt.boxes[0].tolist() == [7.0, 10.0, 20.0, 40.0]


@pytest.mark.parametrize("shift", ["scores-x0.6", "scores-power3", "scores-0-100", "scores-logit"])
def test_score_rescales_keep_the_order_so_the_default_rule_gives_the_same_confidences(shift):
    (_, a, _), = shifted_dataset(_toy(30), "none")
    (_, b, _), = shifted_dataset(_toy(30), shift)
    assert not np.array_equal(a.frames[0].scores, b.frames[0].scores)  # the scores did change
    (_, c, _), = shifted_dataset(_toy(30), "scores-x0.6")  # read again by the default rule
    assert [f.confidences.tolist() for f in b.frames] == [f.confidences.tolist() for f in c.frames]


def test_bursty_misses_and_extra_detections_are_deterministic_and_of_the_expected_size():
    rng = np.random.default_rng(3)
    frames = tuple(DetectionFrame(t, np.column_stack([rng.random((20, 2)) * 500, np.full((20, 2), 30.0)]),
                                  rng.random(20), np.zeros(20, dtype=np.int64), ("car",) * 20) for t in range(400))
    data = [("s", DetectionSequence("s", frames, 0, (640, 480), 10.0), _toy(1)[0][2])]
    kept = sum(len(f) for f in shifted_dataset(data, "recall-bursty")[0][1].frames)
    # boxes scattered at random barely link across frames: almost every detection is missed with
    # 0.12, so about 88 % of the 8,000 stay (binomial sd about 29)
    assert 6900 < kept < 7200
    assert kept == sum(len(f) for f in shifted_dataset(data, "recall-bursty")[0][1].frames)  # same seed
    extra = sum(len(f) for f in shifted_dataset(data, "fp-extra")[0][1].frames) - 8000
    assert 1850 < extra < 2150  # Poisson(0.25 * 20 = 5) a frame over 400 frames: 2,000, sd about 45


def test_shift_names_and_the_table():
    # all: the family the defaults are chosen by; scores-same, box-noise, fp-static and fp-duplicate
    # by name only
    assert parse_shifts("all") == tuple(n for n in SHIFTS
                                        if n not in ("scores-same", "box-noise", "fp-static", "fp-duplicate"))
    assert parse_shifts("half-res") == ("none", "half-res")
    assert parse_shifts("scores-same") == ("none", "scores-same")
    with pytest.raises(ValueError, match="unknown shift 'blur'"):
        parse_shifts("half-res,blur")
    table = shift_table({"none": {"a": (0.5, 0.6)}, "half-res": {"a": (0.45, 0.6)}})
    # worst HOTA 45.0, the largest drop from none 50.0 - 45.0 = 5.0
    assert "| half-res | 45.0 / 60.0 |" in table and "| worst HOTA | 45.0 |" in table
    assert "| largest HOTA drop | 5.0 |" in table


def test_benchmark_shift_prints_one_table_with_rescales_equal(data_root_with_val, capsys):
    # kitti-ped-train on a data root whose train split is 0014 and 0017 (every other training
    # sequence in its val seqmap): 1,104 Pedestrian detections, not the shared split's 10 sequences
    from refimpl.io.catalogue import KITTI_TRAIN
    root = str(data_root_with_val(*(s for s in KITTI_TRAIN if s not in ("0014", "0017"))))
    assert main(["benchmark", "kitti-ped-train", "--shift", "scores-x0.6,scores-x0.6+scores-power3", "--quiet",
                 "--data", root]) == 0
    out = capsys.readouterr().out
    rows = {line.split("|")[1].strip(): line.split("|")[2:] for line in out.splitlines() if line.startswith("| ")}
    assert rows["none"] == rows["scores-x0.6"]  # the default rule reads the order of the scores only
    assert rows["none"] == rows["scores-x0.6+scores-power3"]  # two increasing rescales keep the order too
    assert main(["benchmark", "kitti-ped-train", "--shift", "blur", "--quiet", "--data", root]) == 2


def test_box_noise_moves_centres_and_scales_sizes_by_a_tenth_of_the_box():
    # 400 frames of one 40 x 80 box: the centre's offsets are N(0, 0.1) times 40 and 80 px, so their
    # standard deviations are about 4 and 8 px (sd of an sd estimate over 400: about 3.5 %); the log
    # of width / 40 is N(0, 0.1); the ground truth is untouched, the scores too
    (_, a, gt0), = shifted_dataset(_toy(400), "none")
    (_, b, gt), = shifted_dataset(_toy(400), "box-noise")
    before = np.vstack([f.boxes for f in a.frames])
    after = np.vstack([f.boxes for f in b.frames])
    dcx = (after[:, 0] + after[:, 2] / 2) - (before[:, 0] + before[:, 2] / 2)
    dcy = (after[:, 1] + after[:, 3] / 2) - (before[:, 1] + before[:, 3] / 2)
    assert 3.6 < dcx.std() < 4.4 and 7.2 < dcy.std() < 8.8
    assert 0.09 < np.log(after[:, 2] / 40.0).std() < 0.11 and abs(np.log(after[:, 3] / 80.0).mean()) < 0.02
    assert np.array_equal(gt.boxes, gt0.boxes)
    assert all(np.array_equal(x.scores, y.scores) for x, y in zip(a.frames, b.frames))


def test_static_false_positives_come_back_at_the_same_few_places_with_low_scores():
    # 20 detections a frame over 400 frames: round(0.25 * 20) = 5 false places, each seen with
    # probability 0.5 a frame, so about 1,000 false detections (binomial sd about 22), every one
    # within a few jitters (sd 0.05 of 30 px = 1.5 px) of one of 5 places, scored from the lower half
    rng = np.random.default_rng(3)
    frames = tuple(DetectionFrame(t, np.column_stack([rng.random((20, 2)) * 500, np.full((20, 2), 30.0)]),
                                  rng.random(20), np.zeros(20, dtype=np.int64), ("car",) * 20) for t in range(400))
    data = [("s", DetectionSequence("s", frames, 0, (640, 480), 10.0), _toy(1)[0][2])]
    (_, shifted, _), = shifted_dataset(data, "fp-static")
    extra = np.vstack([f.boxes[20:] for f in shifted.frames])
    assert 930 < len(extra) < 1070
    places: list[np.ndarray] = []  # each box joins the first place within 10 px (6 jitter sd), else starts one
    for xy in extra[:, :2]:
        if not any(np.abs(xy - p).max() <= 10.0 for p in places):
            places.append(xy)
    assert len(places) == 5
    median = np.median(np.concatenate([f.scores[:20] for f in frames]))
    assert max(f.scores[20:].max(initial=-1.0) for f in shifted.frames) <= median
    again = shifted_dataset(data, "fp-static")[0][1]
    assert all(np.array_equal(a.boxes, b.boxes) for a, b in zip(again.frames, shifted.frames))  # same seed


def test_duplicate_false_positives_sit_beside_three_in_ten_detections_with_low_scores():
    # one 40 x 80 box a frame over 2,000 frames, scores rising 0.51..20.5: a second box beside it with
    # probability 0.3, so about 600 (binomial sd about 20); its centre offset is N(0, 0.3) of 40 and
    # 80 px (sd 12 and 24 px, about 3 % error over 600), its log width / 40 N(0, 0.2); its score from
    # the lower half, at most the median score. The toy's image widened to 9000 px so that it stays in
    # view (x <= 10 + 4 x 2000 + 40); its centre y = 60 is 2.5 sd from the top, so about 0.6 % of the
    # second boxes (4 of 600) are kept at y = 0, which moves the sd by less than the tolerance
    wide = [(n, replace(s, image_size=(9000, 480)), g) for n, s, g in _toy(2000)]
    (_, a, _), = shifted_dataset(wide, "none")
    (_, b, _), = shifted_dataset(wide, "fp-duplicate")
    twins = [(f.boxes[1:], f.boxes[0], f.scores[1:]) for f in b.frames if len(f) > 1]
    assert all(len(f) <= 2 for f in b.frames) and 540 < len(twins) < 660
    extra = np.vstack([t for t, _, _ in twins])
    own = np.vstack([np.repeat(o[None], len(t), axis=0) for t, o, _ in twins])
    dcx = (extra[:, 0] + extra[:, 2] / 2) - (own[:, 0] + own[:, 2] / 2)
    dcy = (extra[:, 1] + extra[:, 3] / 2) - (own[:, 1] + own[:, 3] / 2)
    assert 11.0 < dcx.std() < 13.0 and 22.0 < dcy.std() < 26.0 and abs(dcx.mean()) < 1.5
    assert 0.18 < np.log(extra[:, 2] / 40.0).std() < 0.22
    assert max(s.max() for _, _, s in twins) <= np.median(np.concatenate([f.scores for f in a.frames]))
    assert all(np.array_equal(x.boxes, y.boxes[:1]) for x, y in zip(a.frames, b.frames))  # the true box kept


def test_a_second_box_is_centred_in_the_image_as_a_detectors_boxes_are():
    # The toy's box walks right 4 px a frame out of its 640 x 480 image (centre x = 30 + 4t > 640 from
    # t = 153 on): its second boxes are centred on the image, x at most 640 and y in 0..480, and the
    # ones beside it once it is out sit on the right border, x = 640 (their centre moved by N(0, 12 px)
    # from beyond it). No detection of the benchmark sets is centred outside its image.
    (_, b, _), = shifted_dataset(_toy(400), "fp-duplicate")
    twins = [(f.frame, f.boxes[1:]) for f in b.frames if len(f) > 1]
    centres = np.vstack([t[:, :2] + t[:, 2:] / 2 for _, t in twins])
    assert centres[:, 0].max() <= 640.0 and centres[:, 1].min() >= 0.0 and centres[:, 1].max() <= 480.0
    late = np.vstack([t[:, :2] + t[:, 2:] / 2 for frame, t in twins if frame >= 170])  # 30 + 4 x 170 = 710
    assert len(late) > 50 and np.allclose(late[:, 0], 640.0)


def test_joined_shifts_apply_one_after_the_other_the_first_as_it_does_alone():
    # fp-duplicate+half-res: the first part draws as fp-duplicate alone does (same second boxes),
    # then every box is halved; half-fps+half-res: 6 frames -> frames 1, 3, 5 renumbered 1, 2, 3,
    # each box halved (the toy's box at frame t: x = 10 + 4t, 40 x 80 -> x / 2, 20 x 40)
    (_, dup, _), = shifted_dataset(_toy(400), "fp-duplicate")
    (_, both, _), = shifted_dataset(_toy(400), "fp-duplicate+half-res")
    assert all(np.allclose(a.boxes * 0.5, b.boxes) for a, b in zip(dup.frames, both.frames))
    (_, seq, gt), = shifted_dataset(_toy(6), "half-fps+half-res")
    assert [f.frame for f in seq.frames] == [1, 2, 3]
    assert np.allclose(np.vstack([f.boxes for f in seq.frames]), [[7.0, 10.0, 20.0, 40.0], [11.0, 10.0, 20.0, 40.0],
                                                                    [15.0, 10.0, 20.0, 40.0]])
    assert parse_shifts("box-noise+fp-duplicate,half-res") == ("none", "box-noise+fp-duplicate", "half-res")
    for bad, name in (("box-noise+blur", "blur"), ("none+half-res", "none"), ("all+half-res", "all")):
        with pytest.raises(ValueError, match=f"unknown shift '{name}'"):
            parse_shifts(bad)
