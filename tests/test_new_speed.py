"""The tracker option new_speed (docs/model.md 3.35): a track seen once has not shown its speed, so
its second detection is matched within a bounded speed, at half the overlap."""

import numpy as np
import pytest

from refimpl.core.geometry import scale_iou
from refimpl.io import DetectionFrame, DetectionSequence
from refimpl.solvers import get_solver
from refimpl.tracking.likelihood import NEW_SPEED_WEIGHT, new_speed
from refimpl.tracking.motion import BoxKalman
from refimpl.tracking.options import TrackerOptions
from refimpl.tracking.pipeline import run_sequence
from refimpl.tracking.tracker import AbductionTracker

from tracking_helpers import setup_with

SPEED = 60.0
"""px a frame: a 40 px car moves 1.5 times its width between frames, so two of its boxes overlap
by nothing (IoU 0) and a track started at rest never overlaps the next."""


def _crossing_car() -> DetectionSequence:
    """A 40 x 40 car crossing the view to the right at SPEED px a frame, frames 0-5, confidence 90."""
    frames = [DetectionFrame(f, np.array([[100.0 + SPEED * f, 250.0, 40.0, 40.0]]), np.ones(1), np.full(1, 90),
                             ("car",)) for f in range(6)]
    return DetectionSequence("crossing", tuple(frames), 1, (1400, 600), 10.0)


def test_a_track_seen_once_is_matched_within_its_reach_at_half_the_overlap():
    # One track seen at (100, 250, 40, 40) a frame ago, reach 1.5 box sizes: 1.5 x sqrt(1600) = 60 px.
    # det 0, 60 px to the right, same size: the box moved the whole way is the detection, IoU 1,
    #   times NEW_SPEED_WEIGHT 0.5: 50000.
    # det 1, 80 px to the right: the box moved 60 px lies 20 px short; overlap 20 x 40 = 800 of
    #   1600 + 1600 - 800 = 2400: IoU 1/3, times 0.5: 1/6, 16667 (rounded half up).
    # det 2, 60 px to the right but 60 x 60 (2.25 times the area, beyond similar 1.25): 0.
    # det 3, 30 px to the right, 44 x 40 (1.1 times the area): moved 30 + 2 = 32 px, centre on centre
    #   (the detection's centre is 30 + 22 = 52 px from x 100, the track's 20: 32 px, within 60):
    #   overlap 40 x 40 = 1600 of 1600 + 1760 - 1600 = 1760: IoU 10/11, times 0.5: 45455.
    # A likelihood already above stays (the maximum is kept): the pair given 60000 keeps 60000.
    first = np.array([100.0, 250.0, 40.0, 40.0])
    boxes = np.array([[160.0, 250.0, 40.0, 40.0], [180.0, 250.0, 40.0, 40.0], [150.0, 240.0, 60.0, 60.0],
                      [130.0, 250.0, 44.0, 40.0]])
    ml = np.zeros((2, 4), dtype=np.int64)
    ml[1, 0] = 60000  # another track's own overlap with det 0, untouched
    new_speed([(0, first, 1)], boxes, ml, 1.5, 1.25)
    assert NEW_SPEED_WEIGHT == 0.5
    assert ml[0].tolist() == [50000, 16667, 0, 45455]
    assert ml[1].tolist() == [60000, 0, 0, 0]
    # two frames since: twice the reach, 120 px, so det 1 (80 px) is met whole: 50000
    ml = np.zeros((1, 4), dtype=np.int64)
    new_speed([(0, first, 2)], boxes, ml, 1.5, 1.25)
    assert ml[0].tolist() == [50000, 50000, 0, 45455]
    assert scale_iou(np.array(0.5 / 3)).item() == 16667


@pytest.mark.parametrize("backend", ["cpsat", "cpsat-full", "clingo"])
def test_a_car_crossing_faster_than_its_width_keeps_one_identity_with_new_speed(backend):
    # Without the option every frame's box overlaps nothing the tracks predict (the new track is at
    # rest 60 px behind, IoU 0): six tracks of one frame each.  With new_speed 1.5 the track started
    # at frame 0 is matched at frame 1 at 50000 (the test above), above iou_thresh 30000, and
    # assigned; from then on its filter has a velocity: its own prediction (computed below as the
    # tracker runs BoxKalman) overlaps each next box by more than iou_thresh, so one identity holds.
    if backend == "clingo":
        pytest.importorskip("clingo")
    seq = _crossing_car()
    without = run_sequence(seq, setup_with(backend))
    assert [[f for f, _ in rec.observed] for rec in without.tracks] == [[f] for f in range(6)]
    with_rule = run_sequence(seq, setup_with(backend, new_speed=1.5))
    assert [[f for f, _ in rec.observed] for rec in with_rule.tracks] == [list(range(6))]
    kalman = BoxKalman(seq.frames[0].boxes[0])
    for fr in seq.frames[1:]:
        predicted = kalman.predict()
        if fr.frame >= 2:  # from the second observation on, the plain prediction is enough
            x = max(predicted[0], fr.boxes[0, 0])
            inter = max(0.0, min(predicted[0] + predicted[2], fr.boxes[0, 0] + 40) - x) * min(predicted[3], 40.0)
            assert inter / (predicted[2] * predicted[3] + 1600 - inter) > 0.3
        kalman.update(fr.boxes[0])
    # the frame problem at frame 1 carries the pair at 50000 (IoU fact: the likelihood before the
    # model weighs it)
    tracker = AbductionTracker(get_solver(backend), {"img_width": 1400, "img_height": 600},
                               options=TrackerOptions(new_speed=1.5))
    fr0, fr1 = seq.frames[:2]
    tracker.step(fr0.frame, fr0.boxes, fr0.confidences, fr0.types)
    problem = tracker.frame_problem(fr1.frame, fr1.boxes, fr1.confidences, fr1.types)
    assert problem.iou == (("trk_1", "det_0", 50000),)


def test_new_speed_is_a_speed_at_another_frame_rate_and_a_bad_value_is_one_line():
    # kitti/car's 1.5 box sizes a frame at 10 fps is 3 at 5 fps and 0.75 at 20 fps (the same per
    # second); the other presets leave it off (0).
    import refimpl

    def reach(**kw):
        return refimpl.Tracker(**kw)._tracker.options.new_speed
    car = {"format": "kitti", "object_type": "car"}
    assert [reach(**car, fps=f) for f in (5, 20, 10)] == [3.0, 0.75, 1.5] and reach(**car) == 1.5
    assert reach(format="mot", fps=12.5) == 0.0 and reach(format="kitti", object_type="pedestrian") == 0.0
    assert reach(**car, fps=5, new_speed=1.0) == 1.0  # given: per frame as given
    assert reach(**car, fps=0.1) == 100.0  # 1.5 x 100 = 150, held at the option's largest value (REACH_MAX)
    with pytest.raises(ValueError, match=r"^Tracker: new_speed must be a number of box sizes 0..100, got -1$"):
        refimpl.Tracker(new_speed=-1)
