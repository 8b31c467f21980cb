"""written_box="auto" (refimpl.tracking.written_box): per coordinate of the box, the one of the
filtered box and the detection that the sequence so far shows closer to the midpoint of the
detections one frame before and after."""

from __future__ import annotations

import numpy as np
import pytest

from refimpl.io import DetectionFrame, DetectionSequence
from refimpl.tracking.options import TrackerOptions, WrittenBox
from refimpl.tracking.pipeline import run_sequence
from refimpl.tracking.written_box import MIN_CHECKS, WrittenBoxEvidence, WrittenBoxLearner, centre_size
from tracking_helpers import setup_with

FRAMES = 30


def _jittered(scale: float = 1.0):
    """A standing object (truth (100, 100, 50, 100)) whose detected width jitters by +-2 px from
    frame to frame, and a perfect smoother's filtered box (the truth)."""
    truth = np.array([100.0, 100.0, 50.0, 100.0])
    for t in range(FRAMES):
        d = truth + np.array([0.0, 0.0, 2.0 * (-1) ** t, 0.0])
        yield t, d * scale, truth * scale


def _growing(scale: float = 1.0):
    """An object whose width grows 5 px a frame, detected exactly, and a filter that lags 3 px
    behind in width."""
    for t in range(FRAMES):
        d = np.array([100.0, 100.0, 50.0 + 5.0 * t, 100.0])
        yield t, d * scale, (d - np.array([0.0, 0.0, 3.0, 0.0])) * scale


def _written(frames):
    learner = WrittenBoxLearner()
    out = [learner.written("trk_1", t, d, f) for t, d, f in frames]
    return out, learner.evidence


def test_jittered_detections_write_the_filtered_box():
    # width: the neighbours' midpoint has width 50 -+ 2 where the detection has 50 +- 2, so the
    # detection is 4 px (4/52 or 4/48 box widths) from it and the filtered box 2 px: filtered is
    # closer; centre x = x + w / 2 jitters by +-1, the same way (2 against 1); y and h do not
    # move: 0 against 0, and a tie stays with the filter
    out, evidence = _written(_jittered())
    assert evidence.checks == FRAMES - 2
    assert not evidence.from_detection().any()
    np.testing.assert_array_equal(out, [np.array([100.0, 100.0, 50.0, 100.0])] * FRAMES)
    w = [52.0 if t % 2 else 48.0 for t in range(1, FRAMES - 1)]  # the middle detection's width
    np.testing.assert_allclose(evidence.detected[2], sum((4 / x) ** 2 for x in w))
    np.testing.assert_allclose(evidence.filtered[2], sum((2 / x) ** 2 for x in w))


def test_exact_detections_of_a_growing_object_write_the_detection_after_min_checks():
    # the width is linear in time, so the midpoint of the neighbours IS the detection (distance
    # 0) while the lagging filter is 3 px off in width and 1.5 px in centre x: those two
    # coordinates are written from the detection once MIN_CHECKS checks were made; the check of
    # frame t-1 is made at frame t (t >= 2), so at frame t there are t - 1 checks: frames
    # 0 .. MIN_CHECKS write the filtered box, frames MIN_CHECKS + 1 .. the detection's width
    frames = list(_growing())
    out, evidence = _written(frames)
    assert evidence.from_detection().tolist() == [True, False, True, False]
    assert evidence.detected[0] == evidence.detected[2] == 0.0 and evidence.filtered[2] > 0
    for t, d, f in frames:
        assert np.array_equal(out[t], f if t <= MIN_CHECKS else d), t


def test_half_resolution_makes_the_same_choice():
    # every distance is divided by the detection's size: halving every box halves the distances
    # and the sizes, so the sums and the choices are the same and the written boxes are halved
    for make in (_jittered, _growing):
        full, e_full = _written(make())
        half, e_half = _written(make(0.5))
        np.testing.assert_allclose(e_half.detected, e_full.detected, rtol=1e-12)
        np.testing.assert_allclose(e_half.filtered, e_full.filtered, rtol=1e-12)
        np.testing.assert_allclose(np.array(half), np.array(full) / 2, rtol=1e-12)


def test_online_a_frame_written_does_not_depend_on_later_frames():
    # frame t's box is returned when frame t is observed, from the checks of frames < t: the same
    # for the first k frames of a sequence as for the whole of it, whatever follows
    frames = list(_growing())
    out, _ = _written(frames)
    for k in (5, MIN_CHECKS + 1, MIN_CHECKS + 4):
        other = frames[:k] + list(_jittered())[k:]
        prefix, _ = _written(other)
        np.testing.assert_array_equal(prefix[:k], out[:k])


def test_a_gap_breaks_the_run_and_forget_drops_stale_tracks():
    learner = WrittenBoxLearner()
    box = np.array([0.0, 0.0, 10.0, 10.0])
    for t in (0, 1, 3, 4):  # 0, 1 | 3, 4: no three consecutive frames, no check
        learner.written("trk_1", t, box, box)
    assert learner.evidence.checks == 0
    learner.written("trk_1", 5, box, box)  # 3, 4, 5: one
    assert learner.evidence.checks == 1
    learner.written("trk_2", 6, box, box)
    learner.forget(6)  # trk_1 was not observed in frame 6: no later check can extend its run
    assert set(learner.recent) == {"trk_2"}


def test_evidence_is_immutable_and_pooled():
    e = WrittenBoxEvidence()
    c = centre_size(np.array([0.0, 0.0, 10.0, 20.0]))
    e2 = e.checked(c, c + np.array([1.0, 0, 0, 0]), c, c)  # detection 1 px off the midpoint in x
    assert e.checks == 0 and e2.checks == 1
    np.testing.assert_allclose(e2.detected, (0.01, 0.0, 0.0, 0.0), rtol=1e-12)  # (1 / 10)^2
    assert e2.filtered == (0.0, 0.0, 0.0, 0.0)
    e3 = e2.checked(c, c + np.array([1.0, 0, 0, 0]), c, c)
    np.testing.assert_allclose(e3.detected, (0.02, 0.0, 0.0, 0.0), rtol=1e-12)


def _sequence() -> DetectionSequence:
    """Two objects over 25 frames, growing and moving, their detections jittered (seeded)."""
    rng = np.random.default_rng(7)
    frames = []
    for f in range(1, 26):
        boxes = np.array([[100.0 + 4 * f, 100.0, 40.0 + 2 * f, 80.0 + 3 * f],
                          [600.0 - 3 * f, 300.0, 30.0, 70.0]]) + rng.normal(0, 1.5, (2, 4))
        frames.append(DetectionFrame(f, boxes, np.full(2, 0.9), np.full(2, 90), ("car", "car")))
    return DetectionSequence("two", tuple(frames), 2, (1000, 600), 10.0)


def test_auto_abduces_the_same_hypotheses_and_identities_as_filtered():
    seq = _sequence()
    a = run_sequence(seq, setup_with("cpsat", written_box="filtered"))
    b = run_sequence(seq, setup_with("cpsat", written_box="auto"))
    assert a.events == b.events
    assert a.rows[:, :2].tolist() == b.rows[:, :2].tolist()
    # every written coordinate (centre x, centre y, w, h) is the filtered one or the detection's
    c = run_sequence(seq, setup_with("cpsat", written_box="detection"))
    for ra, rb, rc in zip(a.rows, b.rows, c.rows):
        fa, fb, fc = centre_size(ra[2:]), centre_size(rb[2:]), centre_size(rc[2:])
        assert all(np.isclose(fb[k], fa[k]) or np.isclose(fb[k], fc[k]) for k in range(4))


def test_auto_is_an_option_value_and_a_bad_one_names_it():
    assert TrackerOptions(written_box="auto").written_box is WrittenBox.AUTO
    assert TrackerOptions.from_mapping({"written_box": "auto"}).changed() == {"written_box": "auto"}
    with pytest.raises(ValueError, match="written_box must be one of filtered, detection, auto"):
        TrackerOptions(written_box="learned")


def test_a_noisy_advantage_of_the_detection_is_not_enough():
    # 16 checks whose differences (detection's - filtered's squared distance) have mean -0.1:
    # with standard deviation 1 the standard error is 1 / 4 = 0.25, and -0.1 is not below
    # -STANDARD_ERRORS * 0.25 = -0.125: filtered; with standard deviation 0.4 it is 0.1, and -0.1
    # is below -0.05: detection.  Sum of squares of the differences = 16 * (mean^2 + sd^2).
    from refimpl.tracking.written_box import STANDARD_ERRORS
    assert STANDARD_ERRORS == 0.5
    for sd, expected in ((1.0, False), (0.4, True)):
        e = WrittenBoxEvidence(filtered=(0.0, 0.0, 10.0, 0.0), detected=(0.0, 0.0, 8.4, 0.0),
                               squares=(0.0, 0.0, 16 * (0.01 + sd * sd), 0.0), checks=16)
        assert e.from_detection().tolist() == [False, False, expected, False], sd
