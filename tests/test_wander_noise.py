"""A detector whose boxes wander is smoothed by the Kalman filter (tracker option wander_noise,
refimpl.tracking.motion.centre_noise; docs/tracking.md 'A detector whose boxes wander')."""

from __future__ import annotations

import numpy as np
import pytest

from refimpl.core.constants import resolve_constants
from refimpl.solvers import get_solver
from refimpl.tracking.gate import GATE_MIN_MATCHES
from refimpl.tracking.motion import BoxKalman, centre_noise, measurement_noise
from refimpl.tracking.options import TrackerOptions
from refimpl.tracking.tracker import AbductionTracker


def _state(w: float, h: float) -> np.ndarray:
    x = np.zeros((7, 1))
    x[:4, 0] = (50.0, 100.0, w * h, w / h)
    return x


def test_the_centres_noise_is_a_share_of_the_predicted_box_never_below_sorts():
    # a 100 x 200 box: 3 % of it is 3 px across and 6 px down, variances 9 and 36 px^2
    assert np.allclose(np.diag(centre_noise(_state(100, 200), 0.03)), [9.0, 36.0, 10.0, 10.0])
    # 0.5 % of it is 0.5 and 1 px: below SORT's 1 px^2 the variance stays SORT's
    assert np.allclose(np.diag(centre_noise(_state(100, 200), 0.005)), [1.0, 1.0, 10.0, 10.0])
    assert np.array_equal(centre_noise(_state(100, 200), 0.0), measurement_noise())
    degenerate = _state(100, 200)
    degenerate[2, 0] = -1.0  # no box: SORT's R
    assert np.array_equal(centre_noise(degenerate, 0.03), measurement_noise())


def test_a_wandering_update_moves_the_centre_by_the_gain_of_its_noise():
    # A new filter's centre variance is P0 = 10 px^2 (SORT's); a detection 10 px to the right moves
    # the centre by 10 * P0 / (P0 + R): with SORT's R = 1, 100 / 11 = 9.0909 px; with a 3 % wander of
    # a 100 px wide box, R = 9, 100 / 19 = 5.2632 px.  Nothing else of the box moved.
    for wander, moved in ((0.0, 100 / 11), (0.03, 100 / 19)):
        k = BoxKalman(np.array([0.0, 0.0, 100.0, 200.0]))
        k.update(np.array([10.0, 0.0, 100.0, 200.0]), wander)
        assert k.state[0] == pytest.approx(50.0 + moved, abs=1e-9)
        assert k.state[1] == pytest.approx(100.0, abs=1e-9)
    # the batch gives the same numbers as one filter at a time
    batch = [BoxKalman(np.array([0.0, 0.0, 100.0, 200.0])), BoxKalman(np.array([300.0, 0.0, 50.0, 100.0]))]
    BoxKalman.update_many(batch, np.array([[10.0, 0.0, 100.0, 200.0], [310.0, 0.0, 50.0, 100.0]]), 0.03)
    # the second box is 50 px wide: R = 1.5^2 = 2.25, the centre moves 100 / 12.25 px
    assert batch[0].state[0] == pytest.approx(50.0 + 100 / 19, abs=1e-9)
    assert batch[1].state[0] == pytest.approx(325.0 + 100 / 12.25, abs=1e-9)


def _walker(frames: int, jitter: float, shapes: bool):
    """One person standing at (600, 500): a 200 x 400 px box, with ``shapes`` alternating with a square
    of the same area (the prediction overlaps either by about 0.55 to 0.75: a wandering detector,
    test_learned_gate), its centre ``jitter`` px left and right of 600 in turn."""
    for f in range(frames):
        w, h = (200.0, 400.0) if f % 2 == 0 or not shapes else (80000 ** 0.5, 80000 ** 0.5)
        u = 600.0 + (jitter if f % 2 == 0 else -jitter)
        yield f, np.array([[u - w / 2, 500.0 - h / 2, w, h]]), np.array([95]), ("pedestrian",)


def _centres(backend: str, wander: int, frames, gate: int = 40):
    tracker = AbductionTracker(get_solver(backend), {"img_width": 1280, "img_height": 1000},
                               options=TrackerOptions(learned_gate=gate, wander_noise=wander))
    out = []
    for f, boxes, conf, types in frames:
        problems = []
        tracker.step(f, boxes, conf, types, observer=lambda p, h: problems.append(p))
        # the filtered centre after the frame, and the gate the frame's problem carried
        out.append((float(tracker.tracks["trk_1"].kalman.state[0]), resolve_constants(problems[0])["iou_thresh"]))
    return out


def test_a_wandering_detectors_centres_are_smoothed_once_the_gate_has_learned_it(backend):
    if backend == "clingo":
        pytest.importorskip("clingo")
    frames = GATE_MIN_MATCHES + 21
    smooth = _centres(backend, 3, list(_walker(frames, 20.0, shapes=True)))
    plain = _centres(backend, 0, list(_walker(frames, 20.0, shapes=True)))
    # Until the gate has counted 50 assignments (frames 1..50) it is the constant, wander_noise has
    # nothing to go by, and the filters are the same, bit for bit.
    assert [c for c, _ in smooth[:GATE_MIN_MATCHES + 1]] == [c for c, _ in plain[:GATE_MIN_MATCHES + 1]]
    # From then on the gate is below 0.3 (the shapes overlap the prediction by about 0.675), and
    # the detections' centres, 40 px apart in turn, are taken to wander by 3 % of a box about 200 to
    # 283 px wide (R = 36 to 72 px^2 instead of 1): the filtered centre swings less about 600.
    assert smooth[-1][1] < 30000
    swing = lambda run: np.ptp([c for c, _ in run[-10:]])
    assert swing(smooth) < 0.8 * swing(plain)
    assert abs(np.mean([c for c, _ in smooth[-10:]]) - 600.0) < 5.0


def test_a_precise_detector_keeps_sorts_filter(backend):
    if backend == "clingo":
        pytest.importorskip("clingo")
    # The same person with a steady 200 x 400 box jittering 4 px: the prediction overlaps every
    # detection by more than 0.9, 45 % of the median is above 0.3, the gate stays the constant and
    # wander_noise changes no bit of the filter.
    frames = list(_walker(GATE_MIN_MATCHES + 21, 4.0, shapes=False))
    with_option = _centres(backend, 3, frames, gate=45)
    without = _centres(backend, 0, frames, gate=45)
    assert [c for c, _ in with_option] == [c for c, _ in without]
    assert all(gate == 30000 for _, gate in with_option)


def test_the_option_is_parsed_as_a_percent():
    assert TrackerOptions.from_mapping({"wander_noise": "3"}).wander_noise == 3
    with pytest.raises(ValueError, match="wander_noise must be a confidence 0..100"):
        TrackerOptions.from_mapping({"wander_noise": -1})
