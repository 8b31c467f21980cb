"""refimpl.Tracker driven as the ecosystem's users drive their trackers (issue 36): BoxMOT's
``update(dets, img)`` with (N, 6) arrays and the frame's image, roboflow ``trackers``'
``update(detections)`` with supervision.Detections; COCO's class ids, a class the model has no type
for, degenerate boxes, an image that gives the image size.  The rows come out as ``refimpl track``
writes them for the same file."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import refimpl
from refimpl import io
from refimpl.cli import main
from refimpl.core.constants import default_constants

DEMO = Path(__file__).resolve().parent.parent / "data" / "demo" / "TUD-Campus" / "det" / "det.txt"
KITTI_CAR = ("KITTI", "tracking", "training", "det_02_pointrcnn", "Car")


def _kitti_frames(path: Path, num_frames: int) -> list[np.ndarray]:
    """The file's Car rows (type 2) frame by frame as a BoxMOT user hands them over: (N, 6)
    x1, y1, x2, y2, score, class id, with COCO's id of a car (2), every box as the file has it
    (zero-width ones too)."""
    a = np.loadtxt(path, delimiter=",", ndmin=2)
    a = a[a[:, 1] == 2]
    return [np.column_stack([a[a[:, 0] == f][:, 2:7], np.full(int((a[:, 0] == f).sum()), 2.0)]).reshape(-1, 6)
            for f in range(num_frames)]


def _mot_frames(path: Path, num_frames: int) -> list[np.ndarray]:
    """A det.txt's rows (frame,id,x,y,w,h,score) as (N, 5) x1, y1, x2, y2, score per frame 1..n."""
    a = np.loadtxt(path, delimiter=",", ndmin=2)
    out = []
    for f in range(1, num_frames + 1):
        r = a[a[:, 0] == f]
        out.append(np.column_stack([r[:, 2], r[:, 3], r[:, 2] + r[:, 4], r[:, 3] + r[:, 5], r[:, 6]]).reshape(-1, 5))
    return out


def _as_detector_wrote_it(tmp_path, frames: list[np.ndarray]) -> Path:
    """The (N, 5) xyxy frames as the det.txt a detector writes from them (x, y, x2 - x1, y2 - y1,
    every float as repr, so it reads back bit for bit), beside TUD-Campus's seqinfo.ini."""
    folder = tmp_path / "TUD-Campus"
    (folder / "det").mkdir(parents=True)
    (folder / "seqinfo.ini").write_bytes((DEMO.parent.parent / "seqinfo.ini").read_bytes())
    lines = [f"{f},-1,{x1!r},{y1!r},{x2 - x1!r},{y2 - y1!r},{s!r},-1,-1,-1\n"
             for f, dets in enumerate(frames, start=1) for x1, y1, x2, y2, s in dets.tolist()]
    (folder / "det" / "det.txt").write_text("".join(lines))
    return folder / "det" / "det.txt"


def _same_rows_to_a_rounding(api: bytes, filed: bytes) -> None:
    """The rows of the original det.txt (x, y, w, h): the same frames and ids, boxes equal but for a
    rounding step of the file's two decimals (0.01): the API's w is x2 - x1 of x + w, which can
    differ from w in the last bit (56.6878 + 93.5572 - 56.6878), and a filtered box on a .xx5 edge
    rounds the other way."""
    a = np.loadtxt(api.decode().splitlines(), delimiter=",")
    b = np.loadtxt(filed.decode().splitlines(), delimiter=",")
    assert a.shape == b.shape and np.array_equal(a[:, :2], b[:, :2])
    assert np.abs(a - b).max() <= 0.01 + 1e-9


def _track_file(tmp_path, argv) -> bytes:
    out = tmp_path / "track.txt"
    assert main(["track", *argv, "--out", str(out), "--quiet"]) == 0
    return out.read_bytes()


def _written(tmp_path, tracker, first_frame: int) -> bytes:
    path = tmp_path / "api.txt"
    io.write_mot_results(path, tracker.result().rows, first_frame=first_frame)
    return path.read_bytes()


@pytest.mark.parametrize("seq", ["0001", "0000"])  # 0000 holds one zero-width Car box (line 614)
def test_boxmot_calls_on_kitti_give_the_rows_track_writes(shared_data, tmp_path, seq):
    path = shared_data.joinpath(*KITTI_CAR, f"{seq}.txt")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        expected = _track_file(tmp_path, ["--dets", str(path), "--format", "kitti", "--class", "Car"])
        frames = io.read_kitti_detections(path, "car").num_frames  # the video's frames (label_02's count)
    # as BoxMOT: one tracker, then update per frame; the user's own, with its defaults (no history),
    # and one that keeps the history, for the rows written after the fact
    user = refimpl.Tracker(format="kitti", object_type="car")
    tracker = refimpl.Tracker(format="kitti", object_type="car", history=True)
    image = np.zeros((375, 1242, 3), dtype=np.uint8)  # KITTI's image_02 size, as `track` assumes for a KITTI file
    dropped = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for dets in _kitti_frames(path, frames):
            out = tracker.update(dets, image)
            assert out.shape[1] == 6 and set(out[:, 5]) <= {2.0}  # the car's class id comes back as it came
            assert user.update(dets, image).tobytes() == out.tobytes()  # the history changes no row
        dropped = [str(w.message) for w in caught if issubclass(w.category, io.InputFormatWarning)]
    assert tracker.setup.preset == "kitti/car" and tracker.image_size == (1242, 375)
    assert _written(tmp_path, tracker, 0) == expected and len(expected) > 1000
    assert user.history is False and user._tracker.finished == []  # the default kept no finished track
    # 0000's zero-width box (x1 == x2 at the image's right border) is dropped with one warning per
    # tracker (two here), as by the reader
    assert len(dropped) == (2 if seq == "0000" else 0)


def _sv_detections(sv, dets: np.ndarray, class_id: int):
    return sv.Detections(xyxy=dets[:, :4].copy(), confidence=dets[:, 4].copy(),
                         class_id=np.full(len(dets), class_id, dtype=int))


def test_trackers_calls_on_tud_campus_give_the_rows_track_writes(tmp_path):
    sv = pytest.importorskip("supervision")
    frames = _mot_frames(DEMO, 71)  # seqinfo.ini: 71 frames, 640 x 480, 25 fps
    expected = _track_file(tmp_path, ["--dets", str(_as_detector_wrote_it(tmp_path, frames))])
    # roboflow trackers' user: SORTTracker(frame_rate=25).update(detections) -> Detections with tracker_id;
    # the user's tracker has the defaults (no history), the other keeps it for the rows after the fact
    user = refimpl.Tracker(fps=25, img_size=(640, 480))
    tracker = refimpl.Tracker(fps=25, img_size=(640, 480), history=True)
    seen: dict[int, set[int]] = {}
    for frame, dets in enumerate(frames, start=1):
        given = _sv_detections(sv, dets, 0)  # COCO 0: person
        out = tracker.update(given)
        assert user.update(given).tracker_id.tobytes() == out.tracker_id.tobytes()  # the history changes no id
        assert out is not given and given.tracker_id is None  # the caller's Detections are left as they are
        assert list(out.class_id) == [0] * len(dets) and len(out.tracker_id) == len(dets)
        seen[frame] = {int(i) for i in out.tracker_id if i >= 0}
        assert len(seen[frame]) == int((out.tracker_id >= 0).sum())  # one detection per reported track
    assert tracker.setup.preset == "mot/pedestrian"
    assert _written(tmp_path, tracker, 1) == expected
    _same_rows_to_a_rounding(expected, _track_file(tmp_path, ["--dets", str(DEMO)]))
    # the ids named on detections are the file's rows but those known only after the fact (backfill)
    later = {(int(r[0]), int(r[1])) for r in tracker.interpolated_rows()}
    rows = {(int(r[0]), int(r[1])) for r in tracker.result().rows}
    assert {(f, i) for f, ids in seen.items() for i in ids} == rows - later and len(rows - later) > 200


def test_boxmot_calls_on_tud_campus_take_the_image_size_from_the_image(tmp_path):
    frames = _mot_frames(DEMO, 71)
    expected = _track_file(tmp_path, ["--dets", str(_as_detector_wrote_it(tmp_path, frames))])
    tracker = refimpl.Tracker(fps=25, history=True)  # no img_size: BoxMOT's user hands over each frame's image
    image = np.zeros((480, 640, 3), dtype=np.uint8)
    for dets in frames:
        out = tracker.update(np.column_stack([dets, np.zeros(len(dets))]), image)
        assert set(out[:, 5]) <= {0.0}
    assert tracker.image_size == (640, 480)
    assert _written(tmp_path, tracker, 1) == expected
    _same_rows_to_a_rounding(expected, _track_file(tmp_path, ["--dets", str(DEMO)]))
    # the image's size is the field-of-view border: track 3 walks out at the right edge (x = 640) at
    # frame 28; without an image the border is not tested and the same track, missed from frame 27,
    # is kept halted to the video's end (frame 71: the preset's lost_after_missing is 40 frames)
    blind = refimpl.Tracker(fps=25, history=True)
    for dets in frames:
        blind.update(dets)
    said, unsaid = {str(e) for e in tracker.events}, {str(e) for e in blind.events}
    assert blind.image_size is None
    assert "occurs_at(leaves_fov(trk_3),28)" in said - unsaid and "occurs_at(missing_detections(trk_3),27)" in unsaid
    assert not [e for e in unsaid if e.startswith(("occurs_at(leaves_fov(trk_3)", "occurs_at(lost(trk_3)"))]
    tracker.reset()  # a new video: its first image says its size again
    assert tracker.image_size is None and tracker.frame == 1


def test_a_coco_bus_is_tracked_as_its_own_type_with_its_class_id():
    # A bus (COCO 5) in frames 1-3, then a car (COCO 2) on exactly the same box in frames 4-6.
    # Confidence 90 > conf_thresh_new_track 40 (model/constants.lp) starts a track; min_hits=1 writes it at once.
    # Same box, IoU 1: only the type match keeps the car out of the bus's track, so the car starts track 2.
    t = refimpl.Tracker(preset="none", min_hits=1, history=True)
    box = [100.0, 50.0, 300.0, 150.0]
    out = [t.update(np.array([[*box, 0.9, 5.0 if k < 3 else 2.0]])) for k in range(6)]
    assert [o[:, 4:].tolist() for o in out[:3]] == [[[1.0, 5.0]]] * 3  # track 1, class id 5 in column 6
    assert out[3][:, 4:].tolist() in ([], [[2.0, 2.0]]) and [o[:, 4:].tolist() for o in out[4:]] == [[[2.0, 2.0]]] * 2
    assert [(r.id, r.type) for r in t.result().tracks] == [("trk_1", "bus"), ("trk_2", "car")]


def test_the_class_id_comes_back_as_it_came_when_two_ids_name_one_type():
    # class_types maps bus (5) and truck (7) both to "car": one type, so one track may take both;
    # each row carries the id of the detection it came from (it used to say 7 for the class-5 bus).
    t = refimpl.Tracker(preset="none", min_hits=1, class_types={5: "car", 7: "car"})
    box = [100.0, 50.0, 300.0, 150.0]
    out = [t.update(np.array([[*box, 0.9, c]])) for c in (5.0, 5.0, 7.0)]
    assert [o[:, 4:].tolist() for o in out] == [[[1.0, 5.0]], [[1.0, 5.0]], [[1.0, 7.0]]]


def test_an_id_without_a_name_is_a_type_of_its_own():
    t = refimpl.Tracker(preset="none", min_hits=1, class_types={2: "car"}, history=True)
    out = t.update(np.array([[0, 0, 50, 50, 0.9, 2.0], [100, 0, 150, 50, 0.9, 80.0]]))
    assert out[:, 4:].tolist() == [[1.0, 2.0], [2.0, 80.0]]
    assert [r.type for r in t.result().tracks] == ["car", "class_80"]


def test_a_zero_width_box_is_dropped_with_a_warning_and_the_rest_tracked():
    good = [10.0, 10.0, 60.0, 40.0, 0.9]
    a = refimpl.Tracker(preset="none", min_hits=1)
    with pytest.warns(io.InputFormatWarning, match=r"frame 1: dropped 1 detection\(s\) of zero width .* row\(s\) 0"):
        out = a.update([[70.0, 10.0, 70.0, 40.0, 0.9], good])
    b = refimpl.Tracker(preset="none", min_hits=1)
    assert np.array_equal(out, b.update([good])) and out.tolist() == [[10.0, 10.0, 60.0, 40.0, 1.0]]


def test_fps_sets_the_safety_bound_on_halts():
    # lost_after_hidden_max = round(HIDDEN_MAX_SECONDS 10 s * fps): 250 frames at 25 fps, 100 at 10 fps (KITTI)
    assert refimpl.Tracker(fps=25)._tracker.constant_map["lost_after_hidden_max"] == 250
    assert refimpl.Tracker(format="kitti", object_type="car")._tracker.constant_map["lost_after_hidden_max"] == 100


def test_an_image_that_is_no_image_is_a_clear_error():
    with pytest.raises(ValueError, match=r"img must be the frame's image .* update\(dets, classes=\[...\]\)"):
        refimpl.Tracker().update([[0, 0, 10, 10, 0.5]], ["car"])


def test_a_presets_durations_mean_the_same_seconds_at_another_frame_rate():
    # model/presets.json: mot/pedestrian was tuned at 25 fps with lost_after_missing 40,
    # fill_hidden 30 frames and noise_max_age 0, and model/constants.lp's lost_after_hidden 30.
    # At 50 fps each is twice as many frames (frames_at: round half up of frames * 50 / 25); at
    # 25 fps exactly the preset's; at 5 fps a fifth: 8, 6, 0 and 6 (0 s is 0 frames at any rate).
    def durations(**kw):
        t = refimpl.Tracker(**kw)._tracker
        c = {**default_constants(), **t.constant_map}
        return [c[n] for n in ("lost_after_missing", "lost_after_hidden", "noise_max_age")] + [t.options.fill_hidden]
    assert durations(fps=25) == [40, 30, 0, 30]
    assert durations(fps=50) == [80, 60, 0, 60]
    assert durations(fps=5) == [8, 6, 0, 6]
    # without a frame rate the preset's frames stay; a duration the user gives is frames as given
    assert durations() == [40, 30, 0, 30]
    assert durations(fps=50, constants={"lost_after_missing": 7}, fill_hidden=4) == [7, 60, 0, 4]
    # kitti/pedestrian, tuned at 10 fps, keeps constants.lp's noise_max_age 3: at 20 fps 6 frames, at
    # 5 fps round(1.5) = 2 (half up); its lost_after_missing 10 and fill_hidden 30 twice and half as many
    assert durations(preset="kitti/pedestrian", fps=20) == [20, 60, 6, 60]
    assert durations(preset="kitti/pedestrian", fps=5) == [5, 15, 2, 15]


def test_the_motion_noise_means_the_same_per_second_at_another_frame_rate():
    # velocity_noise is a variance per frame at the preset's frame rate, times (tuned fps / fps) to the
    # power velocity_exponent (2 for mot/pedestrian): its 1.0 at 25 fps is (25 / 12.5) ** 2 = 4 at
    # 12.5 fps, (25 / 50) ** 2 = 0.25 at 50 fps, 1 at 25 fps and without a frame rate; kitti/car (4: a
    # steady acceleration) has 10 at 10 fps, 10 * (10 / 5) ** 4 = 160 at 5 fps and 10 * (10 / 20) ** 4 =
    # 0.625 at 20 fps; with velocity_exponent 2 given, 10 * 2 ** 2 = 40 at 5 fps.  A velocity_noise the
    # user gives is per frame as given; at 0.1 fps kitti/car's would be 10 * 100 ** 4 = 1e9, held at
    # the option's largest value, 1e6 (NOISE_FACTOR_MAX).
    def noise(**kw):
        return refimpl.Tracker(**kw)._tracker.options.velocity_noise
    assert [noise(fps=f) for f in (12.5, 50, 25)] == [4.0, 0.25, 1.0] and noise() == 1.0
    car = {"format": "kitti", "object_type": "car"}
    assert [noise(**car, fps=f) for f in (5, 20, 10)] == [160.0, 0.625, 10.0] and noise(**car) == 10.0
    assert noise(**car, fps=5, velocity_exponent=2) == 40.0
    assert noise(**car, fps=0.1) == 1e6
    assert noise(fps=50, velocity_noise=3.0) == 3.0
    assert noise(fps=50, velocity_noise=3.0, velocity_exponent=4) == 3.0


def test_the_pixel_constants_scale_with_the_image():
    # model/constants.lp gives size_threshold 100 px^2 and border_margin 10 px at 1920 x 1080
    # (camera.REFERENCE_IMAGE), and the model reasons in working pixels: the image's, doubled or
    # halved until the width is in (960, 1920] (camera.working_scale).  1920 x 1080 is its own
    # working image; 960 x 540 and 3840 x 2160 are it at twice and half the scale: the same
    # (100, 10) in working pixels.  KITTI's 1242 x 375 (scale 1): 100 * 465750 / 2073600 = 22.46 ->
    # 22 and 10 * sqrt(0.2246) = 4.74 -> 5.  TUD's 640 x 480 works at 1280 x 960: 100 * 1228800 /
    # 2073600 = 59.26 -> 59 and 10 * sqrt(0.5926) = 7.70 -> 8.  A constant the user gives is in the
    # image's pixels: 100 px^2 at 960 x 540 is 400 working px^2.
    def pixels(**kw):
        t = refimpl.Tracker(**kw)._tracker
        return t.constant_map["size_threshold"], t.constant_map["border_margin"], t.constant_map["img_width"]
    assert pixels(img_size=(1920, 1080)) == (100, 10, 1920)
    assert pixels(img_size=(960, 540)) == (100, 10, 1920)
    assert pixels(img_size=(3840, 2160)) == (100, 10, 1920)
    assert pixels(format="kitti", object_type="car") == (22, 5, 1242)
    assert pixels(img_size=(640, 480)) == (59, 8, 1280)
    assert pixels(img_size=(960, 540), constants={"size_threshold": 100}) == (400, 10, 1920)


def test_half_the_resolution_tracks_alike(shared_data):
    # A camera of half the resolution sees every box halved.  KITTI Car 0004 at 1242 x 374 (an even
    # height, so the half image is exactly half: 621 x 187) works at scale 1, the half image at
    # scale 2 (camera.working_scale): the facts' working boxes are the same numbers (x 1 and x 2 of
    # the halved ones, both exact in floating point), and so is every decision; the Kalman filter's
    # arithmetic is exact under halving too.  The rows come out halved, the identities the same.
    # (Before working pixels the half image's border margin was 2 px for the full one's 5, and its
    # boxes were rounded to whole half pixels: the runs parted at frame 36, a track at the border.)
    path = shared_data.joinpath(*KITTI_CAR, "0004.txt")
    full = refimpl.Tracker(format="kitti", object_type="car", img_size=(1242, 374))
    half = refimpl.Tracker(format="kitti", object_type="car", img_size=(621, 187))
    written = 0
    for dets in _kitti_frames(path, 314):
        dets = dets[(dets[:, 2] > dets[:, 0]) & (dets[:, 3] > dets[:, 1])]
        a = full.update(dets)
        b = half.update(np.column_stack([dets[:, :4] * 0.5, dets[:, 4:]]))
        assert np.array_equal(b[:, :4] * 2, a[:, :4]) and np.array_equal(b[:, 4:], a[:, 4:])
        written += len(a)
    assert written > 750  # 794 rows in 314 frames: the runs are compared on real tracking
