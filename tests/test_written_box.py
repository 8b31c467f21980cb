"""The tracker option written_box (refimpl.tracking.tracker.WrittenBox / TrackerOptions): which box a track
writes for an observed frame, carried by presets, the CLI, the API and calibration."""

from __future__ import annotations

import io as stdio
import json

import numpy as np
import pytest

from refimpl.io import DetectionFrame, DetectionSequence, ResultWriter, format_mot_results
from refimpl.tracking.options import TRACKER_OPTIONS, TrackerOptions, WrittenBox
from refimpl.tracking.pipeline import Setup, run_sequence
from tracking_helpers import setup_with

# one object over three frames, moving right and getting wider (x, y, w, h)
BOXES = [(100.0, 100.0, 40.0, 80.0), (104.0, 100.0, 44.0, 80.0), (109.0, 101.0, 46.0, 80.0)]


def _three_frames() -> DetectionSequence:
    frames = tuple(DetectionFrame(f, np.array([b]), np.full(1, 0.9), np.full(1, 90), ("car",))
                   for f, b in enumerate(BOXES, start=1))
    return DetectionSequence("three", frames, 1, (1000, 600), 10.0)


def test_detection_mode_writes_the_detection_boxes_exactly_under_the_same_identity():
    result = run_sequence(_three_frames(), setup_with("cpsat", written_box="detection"))
    # frames 1-3 are within the first min_hits = 3 frames: all written, one track (number 1)
    assert result.rows.tolist() == [[f, 1, *b] for f, b in enumerate(BOXES, start=1)]
    assert [b for _, b in result.tracks[0].observed] == BOXES


def test_filtered_mode_writes_the_kalman_state_after_the_update():
    result = run_sequence(_three_frames(), Setup("cpsat"))  # the default: filtered
    rows = {int(r[0]): r[2:] for r in result.rows}
    assert set(result.rows[:, 1].tolist()) == {1}
    # frame 2, derived by hand from SORT's filter (refimpl/tracking/motion.py): a new track starts at
    # z1 = (u, v, s, r) = (120, 140, 3200, 0.5) with P0 = diag(10 x4, 10000 x3); one prediction
    # with zero velocity gives the prior z1 with variance 10 + 10000 + 1 for u, v, s (position
    # plus its velocity plus Q) and 10 + 1 for r (no velocity); R = diag(1, 1, 10, 10); the
    # prior's (u, v, s, r) block is diagonal, so each component is updated on its own with gain
    # K = P / (P + R) towards z2 = (126, 140, 3520, 0.55).
    k_pos, k_area, k_ratio = 10011 / 10012, 10011 / 10021, 11 / 21
    u = 120 + k_pos * (126 - 120)
    v = 140.0
    s = 3200 + k_area * (3520 - 3200)
    r = 0.5 + k_ratio * (0.55 - 0.5)
    w = np.sqrt(s * r)
    h = s / w
    np.testing.assert_allclose(rows[2], [u - w / 2, v - h / 2, w, h], rtol=0, atol=1e-9)
    # the aspect ratio is filtered hard (gain 11/21): the written box is not the detection
    assert abs(rows[2][2] - BOXES[1][2]) > 0.9  # 44 -> 43.04


def test_both_modes_abduce_the_same_hypotheses_and_identities():
    seq = _three_frames()
    a = run_sequence(seq, setup_with("cpsat", written_box=WrittenBox.FILTERED))
    b = run_sequence(seq, setup_with("cpsat", written_box=WrittenBox.DETECTION))
    assert a.events == b.events
    assert a.rows[:, :2].tolist() == b.rows[:, :2].tolist()


def test_unknown_written_box_is_a_value_error_naming_the_choices():
    with pytest.raises(ValueError, match="filtered, detection"):
        run_sequence(_three_frames(), setup_with("cpsat", written_box="smoothed"))
    with pytest.raises(ValueError, match="unknown tracker option"):
        TrackerOptions.from_mapping({"box": "detection"})


@pytest.mark.parametrize("written", ["detection", "auto"])
def test_streamed_rows_equal_result_rows(written):
    # a walker missed now and then: bridged gaps interpolate between written boxes; streaming (a
    # sink, keep_records=False: the tracker forgets, auto's learner drops stale runs) writes the
    # same rows as keeping everything
    from refimpl.experiments.walkers import frames as walk_frames
    seq = DetectionSequence("walk", tuple(walk_frames(80, 6, 3)), 1, (1920, 1080), 30.0)
    at_end = run_sequence(seq, setup_with("cpsat", written_box=written))
    out = stdio.StringIO()
    run_sequence(seq, setup_with("cpsat", written_box=written), keep_records=False,
                 sink=ResultWriter(out, None, None, seq.first_frame))
    assert len(at_end.rows) and out.getvalue() == format_mot_results(at_end.rows, seq.first_frame)
    if written != "detection":
        return
    # and the observed rows are detection boxes of their frame
    dets = {fr.frame: {tuple(b) for b in fr.boxes.tolist()} for fr in seq.frames}
    observed = {(f, b) for t in at_end.tracks for f, b in t.observed}
    assert observed and all(b in dets[f] for f, b in observed)


def test_api_tracker_returns_the_detection_box_when_asked():
    from refimpl import Tracker
    t = Tracker("cpsat", written_box="detection", object_type="car", img_size=(1000, 600), preset="none")
    for x, y, w, h in BOXES:
        out = t.update(np.array([[x, y, x + w, y + h, 0.9]]))
        np.testing.assert_array_equal(out, [[x, y, x + w, y + h, 1.0]])
    with pytest.raises(ValueError, match="written_box"):
        Tracker("cpsat", written_box="raw")


# presets and the CLI


def test_presets_carry_tracker_options_and_no_preset_gives_the_defaults(tmp_path):
    from refimpl.experiments.calibrate import write_preset
    from refimpl.tracking.presets import Preset, load_presets, merge_options, resolve_preset
    path = tmp_path / "presets.json"
    write_preset(Preset("kitti", "car", {"iou_thresh": 20000}, "kitti-car-train", "test",
                        TrackerOptions(WrittenBox.DETECTION)), path)
    # every option is written (the defaults too, in table order), written_box as its text
    written = json.loads(path.read_text())["kitti/car"]["tracker"]
    assert list(written) == [o.name for o in TRACKER_OPTIONS]
    assert written == {**TrackerOptions().as_dict(), "written_box": "detection"}
    assert load_presets(path)["kitti/car"].tracker.written_box is WrittenBox.DETECTION
    # what pipeline.setup_for runs with: the preset's options, then the overrides
    car = resolve_preset("kitti", "car", path)
    assert merge_options(car).written_box is WrittenBox.DETECTION
    assert merge_options(None) == TrackerOptions()
    assert merge_options(car, {"written_box": "filtered"}) == TrackerOptions()
    assert merge_options(resolve_preset("mot", "pedestrian", path)) == TrackerOptions()  # no preset: defaults
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"kitti/car": {"constants": {}, "tracker": {"written_box": "x"}}}))
    with pytest.raises(ValueError, match="bad.json"):
        load_presets(bad)


def test_cli_written_box_detection_writes_detection_boxes(tmp_path):
    from refimpl.cli import main
    seq = _three_frames()
    dets = tmp_path / "det.txt"
    dets.write_text("".join(f"{f},-1,{x},{y},{w},{h},0.9,-1,-1,-1\n" for f, (x, y, w, h) in enumerate(BOXES, 1)))
    out_d, out_f = tmp_path / "d.txt", tmp_path / "f.txt"
    # --no-preset: model/constants.lp and the default options (the mot preset's thresholds aside);
    # --written-box applies on top of it
    common = ["track", "--dets", str(dets), "--backend", "cpsat", "--img-size", "1000,600", "--quiet", "--no-preset"]
    assert main(common + ["--out", str(out_d), "--written-box", "detection"]) == 0
    assert main(common + ["--out", str(out_f)]) == 0
    d = np.loadtxt(out_d, delimiter=",").reshape(-1, 10)
    f = np.loadtxt(out_f, delimiter=",").reshape(-1, 10)
    np.testing.assert_allclose(d[:, 2:6], np.array(BOXES), atol=1e-3)  # MOT files keep 3 decimals
    assert abs(f[1, 4] - BOXES[1][2]) > 0.9  # the filtered width of frame 2 (test above)
    assert seq.frames and d[:, 1].tolist() == f[:, 1].tolist() == [1, 1, 1]


def test_cli_written_box_needs_an_abduction_backend(tmp_path, capsys):
    from refimpl.cli import main
    dets = tmp_path / "det.txt"
    dets.write_text("1,-1,1,1,10,10,0.9,-1,-1,-1\n")
    assert main(["track", "--dets", str(dets), "--backend", "baseline", "--out", str(tmp_path / "o.txt"),
                 "--written-box", "detection"]) == 2
    assert "--written-box" in capsys.readouterr().err


def test_calibration_grid_takes_written_box_as_an_axis():
    from refimpl.experiments.calibrate import DEFAULT_GRID, grid_points, parse_grid, split_point
    grid = parse_grid(["written_box=detection"])
    assert grid["written_box"] == ("detection",)
    assert all(dict(p)["written_box"] == "detection" for p in grid_points(grid))
    both = grid_points(parse_grid(["written_box=filtered,detection"]))
    assert len(both) == 2 * len(grid_points(grid))  # one axis of two values doubles the grid
    assert {k: v for k, v in DEFAULT_GRID.items() if k != "written_box"}.items() <= parse_grid([]).items()
    constants, options = split_point((("iou_thresh", 20000), ("written_box", "detection")))
    assert constants == {"iou_thresh": 20000} and options.written_box is WrittenBox.DETECTION
    with pytest.raises(ValueError, match="written_box"):
        parse_grid(["written_box=filtered,raw"])


def test_velocity_noise_scales_the_velocity_block_of_the_process_noise():
    from refimpl.tracking.motion import BoxKalman
    from refimpl.solvers import get_solver
    from refimpl.tracking.tracker import AbductionTracker
    # SORT's Q = diag(1, 1, 1, 1, 0.01, 0.01, 0.0001); x10 on the velocities du, dv, ds only
    np.testing.assert_allclose(np.diag(BoxKalman(BOXES[0], 10).kf.Q), [1, 1, 1, 1, 0.1, 0.1, 0.001])
    tracker = AbductionTracker(get_solver("cpsat"), {"img_width": 1000, "img_height": 600},
                               options=TrackerOptions(velocity_noise=10))
    fr = _three_frames().frames[0]
    tracker.step(fr.frame, fr.boxes, fr.confidences, fr.types)
    (trk,) = tracker.tracks.values()
    np.testing.assert_allclose(np.diag(trk.kalman.kf.Q), [1, 1, 1, 1, 0.1, 0.1, 0.001])
    assert TrackerOptions.from_mapping({"velocity_noise": "10"}).velocity_noise == 10.0  # --grid values
    for bad in (0, -1, "x", float("inf"), True):
        with pytest.raises(ValueError, match="velocity_noise"):
            TrackerOptions(velocity_noise=bad)


def test_peer_table_names_the_tracker_options_the_abduction_row_ran_with():
    from refimpl.experiments.peers import Comparison, TrackerScore, comparison_table
    o = {"hota": 0.5, "deta": 0.5, "assa": 0.5, "mota": 0.5, "idf1": 0.5, "idsw": 1, "frag": 2, "fp": 3, "fn": 4}
    c = Comparison("x", "X", (TrackerScore("refimpl abduction (cpsat)", o, {}, 10, 1.0),), {"iou_thresh": 20000},
                   TrackerOptions(WrittenBox.DETECTION, 10).changed())
    text = comparison_table(c)
    assert "iou_thresh=20000; tracker option velocity_noise=10.0; tracker option written_box=detection" in text
