"""refimpl detectors: raw-detection recall/precision, the real-detector report, the simulated sweep."""

from __future__ import annotations

import numpy as np
import pytest

from refimpl import io
from refimpl.cli import main
from refimpl.experiments.detectors import DetectionQuality, detection_quality, first_frames


def _dets(frames: dict[int, list[tuple[tuple[float, float, float, float], int]]], count: int) -> io.DetectionSequence:
    out = []
    for f in range(1, count + 1):
        rows = frames.get(f, [])
        out.append(io.DetectionFrame(
            frame=f, boxes=np.array([b for b, _ in rows], dtype=float).reshape(-1, 4),
            scores=np.array([c / 100 for _, c in rows], dtype=float),
            confidences=np.array([c for _, c in rows], dtype=np.int64), types=("pedestrian",) * len(rows)))
    return io.DetectionSequence("hand", tuple(out), 1, None, None)


def _gt() -> io.GroundTruth:
    # frame 1: targets 1 at (0,0,10,10) and 2 at (100,0,10,10); frame 2: target 1 at (0,0,10,10) and a
    # distractor 3 at (200,0,10,10); a DontCare region (300,0,50,50) in frame 2
    return io.GroundTruth(
        name="hand", frames=np.array([1, 1, 2, 2]), ids=np.array([1, 2, 1, 3]),
        boxes=np.array([[0, 0, 10, 10], [100, 0, 10, 10], [0, 0, 10, 10], [200, 0, 10, 10]], dtype=float),
        considered=np.array([True, True, True, False]), distractor=np.array([False, False, False, True]),
        dontcare=np.array([[2, 300, 0, 50, 50]], dtype=float), first_frame=1, num_frames=2)


def test_recall_and_precision_of_a_hand_built_detection_file():
    dets = _dets({
        1: [((1, 0, 10, 10), 90),     # IoU with target 1: 9*10 / (100+100-90) = 0.818 -> match
            ((105, 0, 10, 10), 30)],  # IoU with target 2: 5*10 / (200-50) = 0.333 -> false positive
        2: [((0, 2, 10, 10), 30),     # IoU with target 1: 10*8 / (200-80) = 0.667 -> match (conf 30 <= 40)
            ((200, 0, 10, 10), 99),   # the distractor's own box -> removed before counting
            ((310, 10, 10, 10), 99),  # wholly inside the DontCare region, unmatched -> removed
            ((500, 0, 10, 10), 50)],  # nothing there -> false positive
    }, count=2)
    q = detection_quality(_gt(), dets, conf_thresh=40)
    # 3 considered rows; 6 - 2 removed = 4 detections counted; 2 matches, one with conf 90 > 40
    assert q == DetectionQuality(num_gt=3, num_dets=4, matches=2, removed=2, matches_startable=1)
    assert q.recall == pytest.approx(2 / 3) and q.precision == 0.5 and q.startable == 0.5
    # a stricter IoU threshold (0.7) loses the 0.667 match
    assert detection_quality(_gt(), dets, iou_threshold=0.7, conf_thresh=40).matches == 1


def test_a_detection_is_matched_once_and_counts_add_up():
    # two detections on the same target: one match, one false positive (one-to-one matching)
    dets = _dets({1: [((0, 0, 10, 10), 80), ((0, 1, 10, 10), 80)]}, count=2)
    q = detection_quality(_gt(), dets, conf_thresh=40)
    assert (q.matches, q.num_dets, q.num_gt) == (1, 2, 3)
    total = q + q
    assert (total.matches, total.num_dets, total.num_gt) == (2, 4, 6)


def test_first_frames_cuts_detections_ground_truth_and_dontcare():
    dets = _dets({1: [((0, 0, 10, 10), 80)], 2: [((0, 0, 10, 10), 80)]}, count=2)
    d1, g1 = first_frames(dets, _gt(), 1)
    assert len(d1.frames) == 1 and g1.num_frames == 1
    assert g1.frames.tolist() == [1, 1] and len(g1.dontcare) == 0
    assert first_frames(dets, _gt(), None)[1].num_frames == 2


def test_real_detector_report_on_one_mot15_sequence(shared_data, capsys):
    assert main(["detectors", "--data", str(shared_data), "--benchmarks", "mot15", "--sequences", "TUD-Campus",
                 "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "1 sequences where every detector exists: TUD-Campus (71 frames, 359 ground-truth boxes)" in out
    rows = {line.split("|")[1].strip(): [c.strip() for c in line.split("|")[1:-1]]
            for line in out.splitlines() if line.startswith("| acf") or line.startswith("| frcnn")}
    # PROVENANCE.md: TUD-Campus det.txt (ACF) has 322 lines, det_sort_frcnn.txt 321 (MOT15 has no
    # distractors or DontCare, so every detection is counted); TUD-Campus gt has 359 lines, all flag 1
    assert rows["acf"][1] == "322" and rows["frcnn"][1] == "321"
    # the default score rule (evidence) reads each detector on its own scale: a true detection's
    # confidence is how persistent the detections of its score have been, so some true detections
    # of either detector (an occluded person's, the rank prior's in the first frames) are at or below
    # the model's default conf_thresh_new_track 40: neither share is 100 %, neither is 0
    for name in ("frcnn", "acf"):
        assert 0.0 < float(rows[name][4]) < 100.0
    assert "raw scores 0.09 .. 117.88" in out


def test_mot15_compares_acf_and_frcnn_on_the_seven_acf_sequences(shared_data):
    from refimpl.experiments.detectors import common_sequences
    # PROVENANCE.md: the official det.txt exists for these 7 sequences only
    assert common_sequences("mot15", shared_data) == [
        "ETH-Sunnyday", "KITTI-13", "KITTI-17", "PETS09-S2L1", "TUD-Campus", "TUD-Stadtmitte", "Venice-2"]


def test_sweep_two_points_on_a_few_mot17_frames(shared_data, tmp_path, capsys):
    out_md = tmp_path / "detectors.md"
    argv = ["detectors", "--sweep", "--data", str(shared_data), "--sweep-datasets", "mot17", "--sequences",
            "MOT17-09", "--max-frames", "15", "--p-max", "0,1", "--fp-per-frame", "0", "--noise", "0",
            "--out", str(out_md), "--quiet"]
    assert main(argv) == 0
    text = out_md.read_text()
    lines = [line for line in text.splitlines() if line.startswith("| 0 |") or line.startswith("| 1 |")]
    assert len(lines) == 2
    cells = [[c.strip() for c in line.split("|")[1:-1]] for line in lines]
    # p_max 0, no false positives: no detections at all -> recall 0, precision undefined, both trackers
    # output nothing -> MOTA = 1 - FN / num_gt = 0, and no identity switches or fragmentations
    # (and HOTA 0: no true positives at any alpha)
    assert cells[0][3:7] == ["0.000", "-", "0.0 / 0.0", "0.0 / 0.0"] and cells[0][10] == "0 / 0"
    # p_max 1, no noise, no false positives: every detection is an unmoved considered ground-truth box,
    # clipped to the 1920x1080 image.  A box B clipped to C has IoU(B, C) = area(C) / area(B), so a
    # detection counts as matched iff at least half of its source box lies inside the image.  Derive
    # the expected counts that way from the simulated boxes (same seed and parameters as the command).
    from refimpl.experiments.detector_sweep import detector_params, sweep_data
    from refimpl.io.simulate import simulate_detections
    (_, gt, size, fps), = sweep_data("mot17", shared_data, ["MOT17-09"])
    dets = simulate_detections(gt, seed=0, params=detector_params("mot17", 1.0, 0.0, 0.0), image_size=size)
    matched = total = 0
    for f in dets.frames[:15]:
        src = gt.boxes[gt.considered & (gt.frames == f.frame)]
        for x, y, w, h in f.boxes:
            total += 1
            # its source: the considered box that contains it with the same visible part
            ratio = [w * h / (b[2] * b[3]) for b in src
                     if b[0] <= x + 1e-6 and b[1] <= y + 1e-6 and x + w <= b[0] + b[2] + 1e-6
                     and y + h <= b[1] + b[3] + 1e-6]
            matched += max(ratio, default=0.0) >= 0.5
    num_gt = int(np.count_nonzero(gt.considered & (gt.frames <= 15)))
    assert 0 < matched < total  # some boxes are mostly outside the image here (MOT17-09 frame 1: x=1886, w=156)
    assert cells[1][3:5] == [f"{matched / num_gt:.3f}", f"{matched / total:.3f}"]
    png = tmp_path / "detectors-sweep.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["detectors-sweep.png", "detectors.md"]  # no temp files
    # running again replaces the section rather than appending a second one
    assert main(argv) == 0
    assert out_md.read_text().count("<!-- detectors-sweep:begin -->") == 1


@pytest.mark.parametrize("argv, fragment", [
    (["detectors", "--benchmarks", "mot15", "--sequences", "ADL-Rundle-6"], "not among the sequences"),
    (["detectors", "--benchmarks", "mot17"], "--benchmarks takes"),
    (["detectors", "--sweep", "--p-max", "0.5,x"], "comma-separated numbers"),
    (["detectors", "--sweep", "--p-max", "1.5", "--sweep-datasets", "mot17"], "p_max must be within"),
])
def test_detectors_mistakes_end_in_one_line_and_exit_2(argv, fragment, shared_data, capsys):
    assert main([*argv, "--data", str(shared_data), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert fragment in err and "\n" not in err


def test_every_registered_detector_benchmark_is_a_known_benchmark():
    from refimpl.io.datasets import BENCHMARKS
    from refimpl.experiments.detectors import REAL_DETECTORS
    assert set(REAL_DETECTORS) <= set(BENCHMARKS)
