"""An object's apparent size changes gradually: the tracker option size_gate
(refimpl.tracking.likelihood.size_gate, docs/model.md 3.34)."""

from __future__ import annotations

import numpy as np
import pytest

from refimpl.tracking.likelihood import size_gate
from refimpl.tracking.options import TrackerOptions
from refimpl.tracking.pipeline import run_sequence
from refimpl.io.detections import DetectionFrame, DetectionSequence
from tracking_helpers import setup_with


def test_the_gate_zeroes_a_likelihood_whose_areas_differ_more_than_the_factor_grown_per_frame():
    # One track last seen 1 frame ago as 40 x 80 (3200 px^2), one seen 3 frames ago as 20 x 20
    # (400 px^2); factor 1.6 and size_change 1.25: bounds 1.6 x 1.25 = 2.0 and 1.6 x 1.25^3 = 3.125.
    ml = np.full((2, 4), 50000)
    boxes = np.array([[0, 0, 80, 80],      # 6400: 2.0 x the first (kept, not above), 16 x the second
                      [0, 0, 81, 80],      # 6480: 2.025 x the first (zeroed)
                      [0, 0, 40, 40],      # 1600: 0.5 x the first (1 / 2.0, kept), 4 x the second (zeroed)
                      [0, 0, 35, 35]],     # 1225: 0.38 x the first (zeroed), 3.06 x the second (kept)
                     dtype=float)
    size_gate(ml, boxes, [(0, 1, np.array([5.0, 5.0, 40.0, 80.0])), (1, 3, np.array([9.0, 9.0, 20.0, 20.0]))],
              1.6, 1.25)
    assert ml.tolist() == [[50000, 0, 50000, 0], [0, 0, 0, 50000]]


def test_a_track_not_named_keeps_its_likelihood_and_without_growth_the_factor_is_the_bound():
    ml = np.array([[40000, 40000], [70000, 70000]])
    boxes = np.array([[0, 0, 10, 10], [0, 0, 10, 17]], dtype=float)  # 100 and 170 px^2
    # track 1 last seen 5 frames ago as 10 x 10; growth 1 (no size_change): bound 1.6 at any gap
    size_gate(ml, boxes, [(1, 5, np.array([0.0, 0.0, 10.0, 10.0]))], 1.6, 1.0)
    assert ml.tolist() == [[40000, 40000], [70000, 0]]  # 170 / 100 = 1.7 > 1.6


def test_the_option_is_zero_or_a_factor_above_one():
    assert TrackerOptions().size_gate == 0.0
    for bad in (0.5, 1.0, -2, "x"):
        with pytest.raises(ValueError, match="size_gate must be 0"):
            TrackerOptions(size_gate=bad)


def _car_missed_once(last_size: tuple[float, float]) -> DetectionSequence:
    """A car of 100 x 50 px driving right 10 px a frame, detected (confidence 95) in frames 0-5,
    missed in frame 6; in frame 7 one box of ``last_size`` centred where the car now is (x centre
    50 + 10 x 7 = 120, y centre 125)."""
    frames = []
    for f in range(8):
        if f == 6:
            boxes = np.zeros((0, 4))
        else:
            w, h = last_size if f == 7 else (100.0, 50.0)
            boxes = np.array([[50.0 + 10 * f - w / 2, 125.0 - h / 2, w, h]])
        conf = np.full(len(boxes), 95.0)
        frames.append(DetectionFrame(f, boxes, conf, conf, ("car",) * len(boxes)))
    return DetectionSequence("car", tuple(frames), 0, (640, 480), 10.0)


@pytest.mark.parametrize("size, gated, resumed", [
    # 70 x 35 = 2450 px^2 against 5000: ratio 2.04; centred on the car, IoU about 2450 / 5000 = 0.49,
    # above iou_thresh_resume (0.1): resumed without the gate; the car last seen 2 frames before, so
    # with factor 1.6 and no size_change the bound is 1.6 < 2.04: not resumed, a second car starts
    ((70.0, 35.0), 0.0, True),
    ((70.0, 35.0), 1.6, False),
    # 90 x 45 = 4050 px^2: ratio 1.23 <= 1.6, resumed with the gate too
    ((90.0, 45.0), 1.6, True),
])
def test_a_halted_car_is_not_resumed_by_a_box_of_another_size(backend, size, gated, resumed):
    if backend == "clingo":
        pytest.importorskip("clingo")
    answers = {}
    run_sequence(_car_missed_once(size), setup_with(backend, size_gate=gated),
                 observer=lambda p, h: answers.setdefault(p.time, sorted(h.actions)))
    assert answers[6] == ["halt(trk_1)"]
    assert answers[7] == (["resume(trk_1,det_0)"] if resumed else ["ignore_trk(trk_1)", "start(det_0)"])
