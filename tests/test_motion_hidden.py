"""Motion while hidden (issue 12, item 4): BoxKalman.predict(hold=True), BoxKalman.reupdate, and the tracker options."""

from __future__ import annotations

import numpy as np
import pytest

from refimpl.io import DetectionFrame, DetectionSequence
from refimpl.tracking.motion import HIDDEN_MAX_SPEED, BoxKalman
from refimpl.tracking.pipeline import Setup, run_sequence
from tracking_helpers import setup_with


def _moving(n: int, x0: float = 100.0, vx: float = 10.0, w: float = 40.0, h: float = 80.0, grow: float = 0.0):
    """n boxes moving vx px/frame to the right, width and height growing by `grow` px/frame."""
    return [np.array([x0 + vx * i, 200.0, w + grow * i, h + grow * i]) for i in range(n)]


def _filter(boxes) -> BoxKalman:
    kf = BoxKalman(boxes[0])
    for b in boxes[1:]:
        kf.predict()
        kf.update(b)
    return kf


def test_hold_freezes_the_size_from_the_second_unobserved_frame():
    kf = _filter(_moving(15, grow=2.0))  # the area grows: ds > 0
    assert kf.state[6] > 0
    first = kf.predict(hold=True)  # the first unobserved frame is predicted before anyone knows
    s_before, u_before, du = kf.state[2], kf.state[0], kf.state[4]
    assert kf.state[6] > 0
    second = kf.predict(hold=True)
    # ds := 0, so s stays; the aspect ratio has no velocity; the centre moves by du (below the cap)
    assert kf.state[6] == 0 and kf.state[2] == pytest.approx(s_before)
    assert second[2] * second[3] == pytest.approx(first[2] * first[3])
    assert kf.state[0] == pytest.approx(u_before + du)
    for _ in range(100):
        box = kf.predict(hold=True)
    assert box[2] * box[3] == pytest.approx(first[2] * first[3])


def test_without_hold_the_size_keeps_growing():
    kf = _filter(_moving(15, grow=2.0))
    a = [np.prod(kf.predict()[2:]) for _ in range(3)]
    assert a[0] < a[1] < a[2]


def test_hold_caps_the_speed_of_a_hidden_track():
    kf = _filter(_moving(5))
    kf.predict()
    kf.kf.x[4, 0], kf.kf.x[5, 0] = 3000.0, 4000.0  # an absurd velocity, 5000 px/frame
    s = kf.state[2]
    u, v = kf.state[0], kf.state[1]
    kf.predict(hold=True)
    cap = HIDDEN_MAX_SPEED * np.sqrt(s)  # 0.5 * sqrt(40 * 80) = 28.3 px per frame
    step = np.hypot(kf.state[0] - u, kf.state[1] - v)
    assert step == pytest.approx(cap)
    # direction kept: 3:4
    assert (kf.state[0] - u) / (kf.state[1] - v) == pytest.approx(0.75)


def test_reupdate_equals_a_filter_fed_the_interpolated_boxes():
    boxes = _moving(6)
    kf = _filter(boxes)
    for _ in range(10):  # 9 frames hidden, the 10th prediction is the frame it comes back
        kf.predict()
    back = np.array([300.0, 230.0, 44.0, 88.0])
    kf.reupdate(back)
    # the same filter fed the last observed box, then 9 virtual boxes on the straight line to
    # `back` (at 1/10 .. 9/10), then `back`
    last = boxes[-1]
    ref = _filter(boxes + [last + (back - last) * (i / 10) for i in range(1, 10)] + [back])
    assert np.allclose(kf.state, ref.state) and np.allclose(kf.covariance, ref.covariance)
    assert kf.time_since_update == 0 and kf.hits == 5 + 1


def test_reupdate_after_no_gap_is_update():
    a, b = _filter(_moving(5)), _filter(_moving(5))
    a.predict(), b.predict()
    a.update(np.array([150.0, 200.0, 40.0, 80.0]))
    b.reupdate(np.array([150.0, 200.0, 40.0, 80.0]))
    assert np.array_equal(a.state, b.state) and np.array_equal(a.covariance, b.covariance)


def _growing_car_behind_bus() -> DetectionSequence:
    """A car (growing 2 px/frame in width and height: approaching) passes behind a parked bus.

    Bus x 300..700, bottom edge 500; the car's bottom edge is at 380 and its height at most
    60 + 2*8 = 76 px, so it stands farther away; detected frames 1-9, missed 10-27.
    """
    frames = []
    for f in range(1, 33):
        boxes = [[300.0, 200.0, 400.0, 300.0]]
        if f <= 9 or f >= 28:
            w, h = 80.0 + 2 * (f - 1), 60.0 + 2 * (f - 1)
            boxes.append([100.0 + 20 * (f - 1), 380.0 - h, w, h])
        n = len(boxes)
        frames.append(DetectionFrame(f, np.array(boxes), np.full(n, 0.9), np.full(n, 90), ("car",) * n))
    return DetectionSequence("growing", tuple(frames), 1, (1000, 600), 25.0)


def test_tracker_option_holds_the_size_of_a_halted_track():
    seq = _growing_car_behind_bus()
    plain = next(t for t in run_sequence(seq, Setup()).tracks if t.id == "trk_2")
    held = next(t for t in run_sequence(seq, setup_with(hold_hidden=True)).tracks if t.id == "trk_2")
    area = lambda rec: [round(b[2] * b[3]) for _, b in rec.halted]  # noqa: E731
    assert [f for f, _ in held.halted] == [f for f, _ in plain.halted] and len(held.halted) >= 10
    # halted frame 1 was predicted while the track was still active; from the 2nd on the size is held
    assert len(set(area(held)[1:])) == 1
    assert area(plain)[1:] == sorted(area(plain)[1:]) and area(plain)[-1] > area(plain)[1]


def test_size_change_bounds_a_shrinking_prediction_from_the_second_unobserved_frame():
    # a box shrinking 3 px a frame in width and height: the filter's area velocity ds < 0, and
    # without the bound the area keeps falling by ds a frame until SORT's guard stops it at s + ds <= 0
    boxes = _moving(15, w=80.0, h=120.0, grow=-3.0)
    free, bounded = _filter(boxes), _filter(boxes)
    bounded.size_change = 1.25
    assert free.state[6] < 0
    first_free, first = free.predict(), bounded.predict()  # predicted before anyone knows: unbounded
    assert np.array_equal(first_free, first)
    s = bounded.state[2]
    for _ in range(6):  # then ds is clipped to s / 1.25 - s: the area falls by a factor 1.25 a frame
        bounded.predict()
        free.predict()
        s /= 1.25
        assert bounded.state[2] == pytest.approx(s)
    assert free.state[2] < bounded.state[2]


def test_size_change_bounds_a_growing_prediction_and_leaves_a_slow_one_alone():
    # an area velocity of 60 % of the area a frame (a car close by, coming nearer): from the
    # second unobserved frame on ds is clipped to s * 1.25 - s
    grower = _filter(_moving(15, grow=2.0))
    grower.size_change = 1.25
    grower.predict()
    s = grower.state[2]
    grower.kf.x[6, 0] = 0.6 * s
    grower.predict()
    assert grower.state[2] == pytest.approx(1.25 * s)
    # growing 0.5 px a frame (ds about 2 % of the area): inside the bound, the free filter's prediction
    slow, free = _filter(_moving(15, grow=0.5)), _filter(_moving(15, grow=0.5))
    slow.size_change = 1.25
    for _ in range(3):
        assert np.array_equal(slow.predict(), free.predict())


def test_size_change_is_zero_or_a_factor_above_one():
    for bad in (1.0, 0.5, -2.0, float("inf"), float("nan")):
        with pytest.raises(ValueError, match="size_change must be 0 or a finite factor > 1"):
            BoxKalman([0.0, 0.0, 10.0, 10.0], size_change=bad)


def test_size_change_means_the_same_per_second_at_another_frame_rate():
    # a factor per frame at the preset's frame rate: 1.25 per frame at 10 fps is 1.25 ** 2 = 1.5625
    # per frame at 5 fps and 1.25 ** 0.25 at 40 fps (the same 1.25 ** 10 a second); given by the user
    # (in_frames) it is per frame as given; 0 (off) stays 0
    from dataclasses import replace

    from refimpl.tracking.options import TrackerOptions
    from refimpl.tracking.pipeline import new_tracker
    setup = Setup(options=TrackerOptions(size_change=1.25), tuned_fps=10.0)
    change = lambda s, fps: new_tracker(s, (1000, 600), fps).options.size_change  # noqa: E731
    assert change(setup, 5.0) == 1.5625 and change(setup, 40.0) == pytest.approx(1.25 ** 0.25)
    assert change(setup, 10.0) == 1.25 and change(setup, None) == 1.25
    assert change(replace(setup, in_frames=("size_change",)), 5.0) == 1.25
    assert change(Setup(tuned_fps=10.0), 5.0) == 0.0
    # at the slowest frame rate a sequence may have (core.ranges.FPS_MIN, 0.1 fps) 1.25 ** 100 =
    # 4.9e9, held at the option's largest value, 1e6 (options.NOISE_FACTOR_MAX)
    assert change(setup, 0.1) == 1e6


@pytest.mark.parametrize("fps", [0.1, 1000.0])
def test_every_preset_converts_to_both_ends_of_the_frame_rate_range(fps):
    # core.ranges.FPS_MIN and FPS_MAX: every preset's per-frame rates convert to a valid tracker:
    # the velocity noise v * (tuned / fps) ** k, k the preset's velocity_exponent, at most 10^6
    # (kitti/car, k 4, at 0.1 fps: 10 * 100 ** 4 = 10^9, held at 10^6; mot/pedestrian, k 2: 1 *
    # 250 ** 2 = 62500), size_change F ** (tuned / fps), at most 10^6 (kitti/car at 0.1 fps: 1.25 **
    # 100, held at 10^6; at 1000 fps 1.25 ** 0.01 = 1.0022 > 1), and new_speed R * tuned / fps, at
    # most 100 (kitti/car at 0.1 fps: 1.5 * 100 = 150, held at 100; at 1000 fps 0.015)
    import refimpl
    from refimpl.tracking.presets import load_presets
    for name, preset in load_presets().items():
        options = refimpl.Tracker(preset=name, fps=fps)._tracker.options
        tuned, given = preset.fps, preset.tracker
        noise = min(given.velocity_noise * (tuned / fps) ** given.velocity_exponent, 1e6)
        assert options.velocity_noise == pytest.approx(noise)
        assert options.new_speed == pytest.approx(min(given.new_speed * tuned / fps, 100))
        change = given.size_change and min(given.size_change ** (tuned / fps), 1e6)
        assert options.size_change == pytest.approx(change) and (change == 0 or change > 1)


def _car_stopping_missed() -> DetectionSequence:
    """A car driving away and stopping: its box (centred at 400, 300) shrinks 12 px a frame in
    width and height over frames 1-6 (200 x 150 -> 140 x 90), then keeps its size; missed in frames
    7-10, detected again in frame 11 at 140 x 90."""
    frames = []
    for f in range(1, 12):
        boxes = []
        if f <= 6 or f == 11:
            w, h = 200.0 - 12 * (min(f, 6) - 1), 150.0 - 12 * (min(f, 6) - 1)
            boxes.append([400.0 - w / 2, 300.0 - h / 2, w, h])
        n = len(boxes)
        frames.append(DetectionFrame(f, np.array(boxes).reshape(-1, 4), np.full(n, 0.9), np.full(n, 90),
                                     ("car",) * n))
    return DetectionSequence("away", tuple(frames), 1, (1000, 600), 10.0)


def test_tracker_option_size_change_keeps_a_missed_car_resumable():
    # with kitti/car's area noise (100) the filter's area velocity follows the shrinking, and over
    # the missed frames the free prediction keeps shrinking by it until SORT's guard (s + ds <= 0)
    # stops it at 56 x 38: IoU with the car of frame 11, 56 * 38 / (140 * 90) = 0.17, below the
    # resume threshold 0.2, so the car starts a second track.  Bounded by 1.25 a frame the
    # prediction keeps about 74 x 50 (IoU 0.29) and the car resumes its track.
    seq = _car_stopping_missed()
    constants = {"lost_after_missing": 10, "iou_thresh_resume": 20000}
    tracks = lambda change: [t.id for t in run_sequence(  # noqa: E731
        seq, setup_with(constants=constants, area_noise=100.0, size_change=change)).tracks]
    assert tracks(0) == ["trk_1", "trk_2"]
    assert tracks(1.25) == ["trk_1"]
