"""refimpl.Tracker: frame-by-frame update() gives the rows `refimpl track` writes; bad input is refused."""

from __future__ import annotations

import pickle
import warnings

import numpy as np
import pytest

import refimpl
from refimpl import io
from refimpl.api import confidences_from_scores
from refimpl.cli import main
from refimpl.tracking.pipeline import Setup, run_sequence
from refimpl.tracking.options import TrackerOptions
from refimpl.solvers import BACKENDS, LIBRARIES


def _xyxys(frame) -> np.ndarray:
    """A DetectionFrame as the API's (N, 5) x1, y1, x2, y2, score."""
    b = frame.boxes
    return np.column_stack([b[:, 0], b[:, 1], b[:, 0] + b[:, 2], b[:, 1] + b[:, 3], frame.scores]).reshape(-1, 5)


def _online(seq, scores="auto"):
    tracker = refimpl.Tracker("cpsat", img_size=seq.image_size, preset="none", fps=seq.fps, scores=scores,
                              history=True)
    rows = []
    for fr in seq.frames:
        out = tracker.update(_xyxys(fr))
        assert out.shape[1] == 5
        assert list(out[:, 4]) == sorted(out[:, 4])  # by track id
        rows += [[fr.frame, r[4], r[0], r[1], r[2] - r[0], r[3] - r[1]] for r in out]
    return tracker, np.array(rows, dtype=float).reshape(-1, 6)


def test_update_frame_by_frame_gives_the_rows_refimpl_track_writes(shared_data, tmp_path):
    # KITTI-17 (145 frames, SORT's Faster R-CNN detections, scores 0.5..1 read as probabilities by
    # the reader and the API alike) has bridged gaps, so the one exception shows.
    dets = shared_data / "MOT15" / "train" / "KITTI-17" / "det" / "det_sort_frcnn.txt"
    out = tmp_path / "KITTI-17.txt"
    # --no-preset: the API runs model/constants.lp as is; track would add the mot/pedestrian preset
    assert main(["track", "--dets", str(dets), "--backend", "cpsat", "--out", str(out), "--quiet", "--no-preset",
                 "--scores", "probability"]) == 0
    written = io.read_mot_results(out)
    seq = io.read_mot_detections(dets, scores_rule="probability")
    tracker, online = _online(seq, "probability")

    on = {(int(r[0]), int(r[1])): r for r in online}
    filed = {(int(r[0]), int(r[1])): r for r in written}
    assert len(on) == len(online)  # no (frame, id) twice
    # every online row is in the file, with the same box to the file's two decimals
    assert set(on) <= set(filed)
    for key, r in on.items():
        assert np.all(np.abs(r[2:] - filed[key][2:]) <= 0.005 + 1e-9), key
    # ... and written through the same writer, byte for byte the file's lines
    online_file = tmp_path / "online.txt"
    io.write_mot_results(online_file, online)
    file_lines = out.read_text().splitlines()
    assert set(online_file.read_text().splitlines()) <= set(file_lines)

    # The rows missing online are exactly the interpolated rows of bridged gaps: frames at which
    # the track was not observed, strictly inside a gap of at most bridge_gap frames (a tracker option) between two
    # observed frames of that track, and halted there.
    missing = set(filed) - set(on)
    assert missing, "KITTI-17 should exercise a bridged gap"
    records = {int(t.id.rsplit("_", 1)[1]): t for t in tracker.result().tracks}
    for frame, tid in missing:
        observed = [f for f, _ in records[tid].observed]
        halted = {f for f, _ in records[tid].halted}
        assert frame not in observed and frame in halted
        before = max(f for f in observed if f < frame)
        after = min(f for f in observed if f > frame)
        assert after - before - 1 <= TrackerOptions().bridge_gap  # no preset: the option's default, 2
    assert {(int(r[0]), int(r[1])) for r in tracker.interpolated_rows()} == missing
    # the finished result equals the batch run's rows to float rounding of x2 - x1
    batch = run_sequence(seq, Setup("cpsat"))
    assert tracker.result().rows.shape == batch.rows.shape
    assert np.allclose(tracker.result().rows, batch.rows, rtol=0, atol=1e-9)
    assert tracker.events == batch.events


def test_demo_sequence_events_and_scene():
    seq = io.load_detections(io.demo_sequence_paths())
    tracker, online = _online(seq)
    batch = run_sequence(seq, Setup("cpsat"))
    assert tracker.events == batch.events and len(tracker.events) > 0
    scene = tracker.scene()
    assert scene.name == "sequence" and scene.image_size == (640, 480)
    assert {t.id for t in scene.tracks} == {r.id for r in batch.tracks}
    # TUD-Campus has no bridged gap: online rows are all the rows
    assert len(online) == len(batch.rows)


def test_scores_map_to_confidences_as_the_mot_reader_does(tmp_path):
    # half up: 0.005 -> floor(0.5 + 0.5) = 1, 0.0049 -> floor(0.49 + 0.5) = 0, 0.125 -> 13, 1 -> 100
    scores = [0.005, 0.0049, 0.125, 0.5, 0.999, 1.0, 0.0]
    path = tmp_path / "det.txt"
    path.write_text("".join(f"1,-1,{10 * i},10,20,40,{s}\n" for i, s in enumerate(scores)))
    read = io.read_mot_detections(path, scores_rule="probability").frames[0].confidences
    assert list(confidences_from_scores(scores)) == [1, 0, 13, 50, 100, 100, 0]
    assert list(read) == list(confidences_from_scores(scores))
    t = refimpl.Tracker(scores="probability", preset="none", min_hits=1, history=True)
    t.update([[10 * i, 10, 10 * i + 20, 50, s] for i, s in enumerate(scores)])
    # the probability rule in the API: the same integers (start needs conf > conf_thresh_new_track 40:
    # 0.5, 0.999 and 1.0 start tracks, in detection order)
    assert [t.type for t in t.result().tracks] == ["pedestrian"] * 3


def test_empty_frames_and_an_empty_list():
    t = refimpl.Tracker(history=True)
    assert t.update(np.zeros((0, 5))).shape == (0, 5)
    assert t.update([]).shape == (0, 5)
    assert t.frame == 3 and t.events == ()


def test_classes_name_the_type_in_any_case():
    t = refimpl.Tracker("cpsat", min_hits=1, preset="none", history=True)  # start needs conf 90 > 40 (constants.lp)
    out = t.update([[10, 10, 60, 40, 0.9]], classes=["Car"])
    # the first min_hits frames are written at once (SORT's rule): track 1 at the detection's box
    assert out.tolist() == [[10.0, 10.0, 60.0, 40.0, 1.0]]
    assert t.result().tracks[0].type == "car"


@pytest.mark.parametrize("dets, classes, message", [
    (np.zeros((3, 4)), None, "(N, 5)"),
    ([[0, 0, 10, 10, np.nan]], None, "NaN or inf"),
    ([[0, 0, np.inf, 10, 0.5]], None, "NaN or inf"),
    ([[0, 0, 10, 10, 1.5]], None, "outside 0..1"),  # with scores="probability" (below)
    ([[0, 0, 10, 10, -0.1]], None, "outside 0..1"),
    ([[0, 0, 10, 10, 50]], None, "outside 0..1"),  # a 0..100 confidence, not a score
    ([[12, 0, 10, 10, 0.5]], None, "x2 < x1 or y2 < y1"),  # a negative size: refused, as by both readers
    ([[0, 20, 10, 10, 0.5]], None, "x2 < x1 or y2 < y1"),
    ([[0, 0, 10, 10, 0.5]], ["car", "car"], "1 detections, got 2 entries"),
    ([[0, 0, 10, 10, 0.5]], "car", "got a string"),
    ([[0, 0, 10, 10, 0.5]], [" ? "], "has no letter or digit"),
    ("boxes", None, "numeric"),
])
def test_bad_input_is_a_clear_error(dets, classes, message):
    t = refimpl.Tracker(scores="probability") if "0..1" in message else refimpl.Tracker()
    with pytest.raises(ValueError) as err:
        t.update(dets, classes=classes)
    assert message in str(err.value)
    assert t.frame == 1  # nothing consumed


@pytest.mark.parametrize("kwargs, message", [
    ({"backend": "baseline"}, f"backend must be one of {', '.join(BACKENDS)}"),
    ({"constants": {"iou_treshold": 1}}, "unknown model constant 'iou_treshold'"),
    ({"constants": {"iou_thresh": 0.3}}, "must be an integer"),
    # a value outside the range its rule needs (refimpl.core.ranges.check_constant), refused when
    # the tracker is made rather than at its first frame
    ({"constants": {"likelihood_conf": 150}}, "likelihood_conf=150 must be within 0..100"),
    ({"constants": {"leave_visible": -1}}, "leave_visible=-1 must be within 0..100"),
    # a halted track's weight (<= 100000) times likelihood_halving must stay within 32 bits
    ({"constants": {"likelihood_halving": 10001}}, "likelihood_halving=10001 must be within 0..10000"),
    ({"constants": {"likelihood_halving": -1}}, "likelihood_halving=-1 must be within 0..10000"),
    # a count of frames of observation (docs/model.md 3.32); below 0 it would mean nothing
    ({"constants": {"glimpse_frames": -1}}, "glimpse_frames=-1 must be >= 0"),
    ({"img_size": (640,)}, "(width, height)"),
    ({"img_size": (640, 0)}, "positive integers"),
    ({"min_hits": -1}, "non-negative integer"),
    ({"object_type": "-"}, "object_type: class name '-' has no letter or digit"),
    ({"format": "kitti"}, "format='kitti' needs object_type="),
    ({"fps": -1}, "fps must be a frame rate from 0.1 to 1000 frames per second, got -1"),
    ({"fps": float("inf")}, "fps must be a frame rate from 0.1"),
    ({"fps": 0}, "fps must be a frame rate from 0.1"),
    ({"fps": "25"}, "fps must be a frame rate from 0.1"),
    # beyond the range the presets' conversions leave their options' ranges (core.ranges.FPS_MIN):
    # kitti/car's velocity noise at 0.01 fps would be 10 * (10 / 0.01) ** 2 = 10^7 > 10^6
    ({"fps": 0.01, "format": "kitti", "object_type": "car"}, "fps must be a frame rate from 0.1 to 1000"),
    ({"fps": 1e300}, "fps must be a frame rate from 0.1 to 1000"),
    ({"class_types": {-1: "car"}}, "class id -1 is not a non-negative integer"),
    ({"preset": "kitti/truck"}, "unknown preset 'kitti/truck'"),
    ({"format": "coco"}, "format must be one of"),
    ({"scores": "logit"}, "scores must be one of"),
])
def test_bad_options_are_a_clear_error(kwargs, message):
    with pytest.raises(ValueError) as err:
        refimpl.Tracker(**kwargs)
    assert message in str(err.value)


def test_the_readme_example_runs():
    # the README's Python API example, fed the bundled TUD-Campus detections frame by frame
    import contextlib
    import io as stdio
    import re
    from pathlib import Path
    readme = (Path(__file__).resolve().parent.parent / "README.md").read_text()
    code = re.search(r"## Python API.*?```python\n(.*?)```", readme, re.S).group(1)
    assert len(code.strip().splitlines()) <= 12
    seq = io.load_detections(io.demo_sequence_paths())
    scope = {"frames": [_xyxys(fr) for fr in seq.frames]}
    out = stdio.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, "README.md", "exec"), scope)
    tracker = scope["tracker"]
    # one printed line per row update() returned: every row of the run but those only known after
    # the fact (backfilled confirmations, filled episodes: interpolated_rows), then the events line
    assert len(out.getvalue().splitlines()) == len(tracker.result().rows) - len(tracker.interpolated_rows()) + 1
    assert tracker.setup.preset == "mot/pedestrian"  # the README's tracker runs the preset track runs
    assert scope["scene"].tracks


def test_default_rows_equal_refimpl_track_on_a_kitti_car_sequence(shared_data, tmp_path):
    # The user's two ways on one file, each with its defaults: `refimpl track` (the preset of
    # kitti/car, the rank rule for the scores) and Tracker(format="kitti", object_type="car") fed
    # the file's raw scores; the API's rows after the fact are the file's rows, byte for byte.
    dets = shared_data / "KITTI" / "tracking" / "training" / "det_02_pointrcnn" / "Car" / "0001.txt"
    out = tmp_path / "0001.txt"
    assert main(["track", "--dets", str(dets), "--format", "kitti", "--class", "Car", "--out", str(out),
                 "--quiet"]) == 0
    seq = io.get_format("kitti").read_detections(dets, object_class="car")
    tracker = refimpl.Tracker(format="kitti", object_type="car", history=True)
    assert tracker.setup.preset == "kitti/car" and tracker.backend == "cpsat"
    for fr in seq.frames:
        tracker.update(_xyxys(fr))
    online = tmp_path / "online.txt"
    io.write_mot_results(online, tracker.result().rows, first_frame=0)
    assert online.read_bytes() == out.read_bytes()
    assert len(out.read_bytes()) > 0


@pytest.mark.parametrize("backend", list(BACKENDS))
def test_a_tracker_pickled_mid_stream_goes_on_as_the_original(backend):
    # a clingo Tracker could not be pickled ("cannot pickle 'module' object": the clingo module, and
    # its worker's child process and pipe); now both are left out and come back on first use.  The
    # demo's first 40 frames, pickled after 20 with clingo's worker process running (inline_solves
    # 0: every solve in the child): the copy and the original then return the same rows at every
    # frame, the copy from a child of its own.  Every backend of the registry pickles
    pytest.importorskip(LIBRARIES[backend])
    seq = io.load_detections(io.demo_sequence_paths())
    frames = [_xyxys(fr) for fr in seq.frames[:40]]
    original = refimpl.Tracker(backend, img_size=(640, 480), fps=25)
    solver = original._tracker.solver
    if hasattr(solver, "inline_solves"):  # clingo's
        solver.inline_solves = 0
    for dets in frames[:20]:
        original.update(dets)
    copy = pickle.loads(pickle.dumps(original))
    rows = 0
    for dets in frames[20:]:
        a, b = original.update(dets), copy.update(dets)
        assert a.tobytes() == b.tobytes()
        rows += len(a)
    assert rows > 50 and copy.frame == original.frame == 41
    if hasattr(solver, "inline_solves"):
        workers = original._tracker.solver._worker, copy._tracker.solver._worker
        assert workers[0]._proc.pid != workers[1]._proc.pid and workers[1].started == workers[0].started + 1


def test_a_run_calibrates_each_file_on_the_others_and_the_api_follows(shared_data, tmp_path):
    # KITTI Pedestrian 0003 holds no pedestrian in its ground truth, only false detections.  Alone,
    # the best of them are the best this detector has shown, and refimpl writes tracks of them; in
    # one run with 0017 and 0002 (real pedestrians), the score rule reads 0003's scores beside
    # theirs (docs/model.md 3.19, "A run's files pooled") and 0003 keeps fewer rows.  The library
    # given the other two files (calibrate_with=) writes the run's bytes; --pool-scores no writes
    # each file's bytes alone.
    folder = shared_data / "KITTI" / "tracking" / "training" / "det_02_pointrcnn" / "Pedestrian"
    files = [folder / f"{n}.txt" for n in ("0003", "0017", "0002")]
    flags = ["--format", "kitti", "--class", "Pedestrian", "--quiet"]
    assert main(["track", "--dets", *map(str, files), "--out-dir", str(tmp_path / "run"), *flags]) == 0
    assert main(["track", "--dets", *map(str, files), "--out-dir", str(tmp_path / "apart"), "--pool-scores", "no",
                 *flags]) == 0
    assert main(["track", "--dets", str(files[0]), "--out", str(tmp_path / "alone.txt"), *flags]) == 0
    run, alone = (tmp_path / "run" / "0003.txt").read_bytes(), (tmp_path / "alone.txt").read_bytes()
    assert (tmp_path / "apart" / "0003.txt").read_bytes() == alone
    assert alone.count(b"\n") > run.count(b"\n")
    seq = io.get_format("kitti").read_detections(files[0], object_class="pedestrian")
    tracker = refimpl.Tracker(format="kitti", object_type="pedestrian", history=True, calibrate_with=files[1:])
    # 0003 in the run reports nothing: after 10 s (100 frames at KITTI's 10 fps) the library says so
    with pytest.warns(UserWarning, match="100 frames, .* no track reported yet.*calibrate_with"):
        for fr in seq.frames:
            tracker.update(_xyxys(fr))
    online = tmp_path / "online.txt"
    io.write_mot_results(online, tracker.result().rows, first_frame=0)
    assert online.read_bytes() == run
    # the one file the run wrote the most of, the same way
    seq = io.get_format("kitti").read_detections(files[1], object_class="pedestrian")
    tracker = refimpl.Tracker(format="kitti", object_type="pedestrian", history=True,
                              calibrate_with=[files[0], files[2]])
    for fr in seq.frames:
        tracker.update(_xyxys(fr))
    io.write_mot_results(online, tracker.result().rows, first_frame=0)
    assert online.read_bytes() == (tmp_path / "run" / "0017.txt").read_bytes() and online.stat().st_size > 0


@pytest.mark.parametrize("paths, message", [
    ("0001.txt", "calibrate_with must be a list of detection files"),
    (["/nonexistent/0001.txt"], "calibrate_with: /nonexistent/0001.txt: file not found"),
])
def test_calibrate_with_refuses_what_is_not_a_list_of_readable_files(paths, message):
    with pytest.raises(ValueError, match=message):
        refimpl.Tracker(format="kitti", object_type="pedestrian", calibrate_with=paths)


def test_a_detection_centred_outside_the_given_image_is_said_once():
    # A box (300, 300)-(350, 400) is centred at ((300 + 350) / 2, (300 + 400) / 2) = (325, 350),
    # outside a 100 x 100 image; the one at (10, 10)-(50, 90) is inside. Frame 1 has only the inside
    # one, frames 2-4 both: one warning, naming frame 2 and that centre.
    tracker = refimpl.Tracker(img_size=(100, 100))
    inside = np.array([[10, 10, 50, 90, 0.9]])
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        tracker.update(inside)
        for _ in range(3):
            tracker.update(np.array([[300, 300, 350, 400, 0.9], [10, 10, 50, 90, 0.9]]))
    outside = [str(w.message) for w in said if "centred outside" in str(w.message)]
    assert len(outside) == 1 and outside[0].startswith("frame 2: 1 detection(s) centred outside the 100 x 100 image")
    assert "the first at (325, 350)" in outside[0]
