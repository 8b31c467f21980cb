"""Runs that end with nothing say so: no track written, an empty results file scored, defaults a
user expects (issue 24)."""

from __future__ import annotations

from pathlib import Path

from refimpl import io
from refimpl.cli import main

REPO = Path(__file__).resolve().parent.parent
DEMO_DETS = REPO / "data" / "demo" / "TUD-Campus" / "det" / "det.txt"


def _kitti_car(shared_data, seq="0011"):
    return shared_data / "KITTI" / "tracking" / "training" / "det_02_pointrcnn" / "Car" / f"{seq}.txt"


def test_a_class_not_in_the_file_says_no_track_and_why(shared_data, tmp_path, capsys):
    # the Car file of 0011 holds type-2 rows only: read as Cyclist it has no detection at all
    out = tmp_path / "x.txt"
    assert main(["track", "--dets", str(_kitti_car(shared_data)), "--format", "kitti", "--class", "Cyclist",
                 "--out", str(out), "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "no track written" in err and "no detection of class cyclist" in err and "--class" in err
    assert out.read_text() == ""


def test_every_detection_under_the_start_threshold_names_the_range(tmp_path, capsys):
    # --scores raw reads TUD-Campus's probabilities (SORT's detections, 0.5..1.0) as 0..100
    # confidences: every one rounds half up to 1, none exceeds conf_thresh_new_track 40, so no track
    # can start
    out = tmp_path / "x.txt"
    assert main(["track", "--dets", str(DEMO_DETS), "--scores", "raw", "--no-preset", "--out", str(out),
                 "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "no track written" in err and "confidences 1..1" in err and "conf_thresh_new_track" in err


def test_eval_scores_an_empty_results_file_as_every_target_missed(shared_data, tmp_path, capsys):
    gt_path = shared_data / "KITTI" / "tracking" / "training" / "label_02" / "0011.txt"
    empty = tmp_path / "empty.txt"
    empty.write_text("")
    assert main(["eval", str(empty), "--gt", str(gt_path), "--format", "kitti", "--class", "Car",
                 "--json", str(tmp_path / "m.json")]) == 0
    captured = capsys.readouterr()
    assert "scored as no tracks" in captured.err
    import json
    overall = json.loads((tmp_path / "m.json").read_text())["overall"]
    gt = io.read_kitti_ground_truth(gt_path, "car")
    # no tracker row: nothing is a true or false positive, every considered ground-truth box is a miss
    assert overall["FP"] == 0 and overall["IDs"] == 0
    assert overall["FN"] == int(gt.considered.sum()) > 0
    assert overall["MOTA"] == 0.0


def test_track_and_benchmark_run_the_papers_method_by_default(tmp_path, capsys):
    out = tmp_path / "x.txt"
    assert main(["track", "--dets", str(DEMO_DETS), "--out", str(out)]) == 0
    err = capsys.readouterr().err
    # the one line saying what ran: the abduction backend and the MOTChallenge preset
    assert "refimpl track: note: cpsat, preset mot/pedestrian" in err


def test_help_shows_the_defaults(capsys):
    for command in ("track", "benchmark"):
        try:
            main([command, "--help"])
        except SystemExit:
            pass
        text = " ".join(capsys.readouterr().out.split())
        assert "(default: cpsat)" in text
        assert command != "track" or "(default: mot)" in text


def test_scores_far_from_the_presets_tuning_set_get_one_warning(shared_data, tmp_path, capsys):
    # KITTI Car 0020 (a tuning sequence) with every logit s as s / 10 - 2 (strictly increasing): the
    # largest logit of the file is below 15.94, so s / 10 - 2 < -0.406 and sigmoid < 0.40: read on the
    # fixed sigmoid scale no detection passes the Car preset's conf_thresh_new_track 50, against
    # 70.2 % on kitti-car-train (presets.json)
    src = _kitti_car(shared_data, "0020")
    assert max(float(line.split(",")[6]) for line in src.read_text().splitlines()) < 15.94
    folder = tmp_path / "training" / "det_02_pointrcnn" / "Car"
    folder.mkdir(parents=True)
    (folder / "0020.txt").write_text("".join(
        ",".join(c[:6] + [repr(float(c[6]) / 10 - 2)] + c[7:]) + "\n"
        for c in (line.split(",") for line in src.read_text().splitlines())))
    assert main(["track", "--dets", str(folder / "0020.txt"), "--format", "kitti", "--class", "Car",
                 "--scores", "sigmoid", "--out", str(tmp_path / "x.txt")]) == 0
    err = capsys.readouterr().err
    assert err.count("may be on another scale") == 1
    assert "0.0 % of its detections pass conf_thresh_new_track 50, against 69.1 % on kitti-car-train" in err
    # the default rule (evidence) reads the order of the scores only: the rescaled file gives the
    # original's rows, and neither gets a warning
    for name, path in (("y", src), ("z", folder / "0020.txt")):
        assert main(["track", "--dets", str(path), "--format", "kitti", "--class", "Car", "--out",
                     str(tmp_path / f"{name}.txt")]) == 0
        assert "another scale" not in capsys.readouterr().err
    assert (tmp_path / "y.txt").read_bytes() == (tmp_path / "z.txt").read_bytes()


def test_the_library_warns_once_when_ten_seconds_report_no_track():
    # as test_every_detection_under_the_start_threshold_names_the_range, through the library:
    # scores="raw" reads TUD-Campus's probabilities (0.5..1.0) as confidences 0..100, every one
    # rounding to 1, none above conf_thresh_new_track 40 (no preset: model/constants.lp), so no
    # track starts; at fps 2, THIN_SECONDS 10 are 20 frames, and the warning comes once, at the
    # 20th frame, naming the range.  With the default scores (the evidence rule) rows come before
    # that, and nothing is said.
    import warnings

    import numpy as np

    import refimpl
    from refimpl.api import THIN_SECONDS
    assert THIN_SECONDS * 2 == 20
    seq = io.read_mot_detections(DEMO_DETS)
    frames = [np.column_stack([f.boxes[:, 0], f.boxes[:, 1], f.boxes[:, 0] + f.boxes[:, 2],
                               f.boxes[:, 1] + f.boxes[:, 3], f.scores]) for f in seq.frames]
    for scores, expected in (("raw", 1), ("auto", 0)):
        tracker = refimpl.Tracker(scores=scores, preset="none", fps=2)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            for k, dets in enumerate(frames):
                tracker.update(dets)
                if k == 18:
                    assert not caught  # not before the 20th frame
        thin = [str(w.message) for w in caught if "no track reported" in str(w.message)]
        assert len(thin) == expected, thin
        if expected:
            assert "20 frames" in thin[0] and "confidences are 1..1" in thin[0]
            assert "a new track needs > 40: conf_thresh_new_track" in thin[0]
