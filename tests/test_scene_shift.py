"""The tracker option scene_shift (refimpl decision, docs/model.md 3.28): a turning camera moves
every object in the image by the same shift, so where the active tracks all miss their detections
by one shift, they are matched at their predictions moved by it."""

from __future__ import annotations

import numpy as np
import pytest

from refimpl.core.geometry import iou_matrix, scale_iou
from refimpl.io import DetectionFrame, DetectionSequence
from refimpl.solvers import get_solver
from refimpl.tracking.options import TrackerOptions
from refimpl.tracking.pipeline import run_sequence
from refimpl.tracking.likelihood import scene_shift, shifted_likelihood
from refimpl.tracking.tracker import AbductionTracker
from tracking_helpers import setup_with

XS = (100.0, 400.0, 700.0, 1000.0)
"""Four parked cars, 100 x 60 px, 300 px apart."""


def _cars(xs, dx: float = 0.0) -> np.ndarray:
    return np.array([[x + dx, 200.0, 100.0, 60.0] for x in xs])


def _panning_camera() -> DetectionSequence:
    """Four parked cars seen from a standing camera in frames 0-5; between frames 5 and 6 the
    camera turns and every car appears 70 px further right, where it then stays (frames 6-8)."""
    frames = [DetectionFrame(f, _cars(XS, 70.0 if f >= 6 else 0.0), np.ones(4), np.full(4, 90), ("car",) * 4)
              for f in range(9)]
    return DetectionSequence("pan", tuple(frames), 0, (1400, 600), 10.0)


def test_one_shift_of_every_prediction_is_found_and_a_coincidence_of_two_is_not():
    # Predicted where they stood, the cars' detections are 70 px on: IoU 30 / 170 = 0.18 < 0.5,
    # no track matched.  Candidates are each track's three nearest detections: +70 (its own car),
    # +370 and +670 (the cars beyond) or -230 (the car before).  +70 moves all four onto their
    # cars (support 4 >= 0 + 3); +370 three (the last car has none beyond): +70 wins.
    likelihood = scale_iou(iou_matrix(_cars(XS), _cars(XS, 70.0)))
    assert likelihood.max() < 50000
    np.testing.assert_allclose(scene_shift(_cars(XS), _cars(XS, 70.0), likelihood), [70.0, 0.0])
    # Two cars: a shift matching both is support 2 < 3, no turn of the camera.
    two = _cars(XS[:2])
    assert scene_shift(two, _cars(XS[:2], 70.0), scale_iou(iou_matrix(two, _cars(XS[:2], 70.0)))) is None
    # Four of five tracks matched as predicted (80 %): the filters follow the scene, nothing is looked for.
    five = _cars((*XS, 1300.0))
    seen = np.vstack([_cars(XS), _cars((1300.0,), 70.0)])
    assert scene_shift(five, seen, scale_iou(iou_matrix(five, seen))) is None


def test_the_shift_moves_only_the_likelihood_of_tracks_that_overlap_no_detection():
    # Track 0 is predicted on a detection (IoU 1 >= 0.5): its row is kept; track 1 is predicted
    # 70 px short of its car (IoU 0.18 -> 17647) and moved by the shift it overlaps it fully.
    predicted = np.array([[100.0, 200.0, 100.0, 60.0], [400.0, 200.0, 100.0, 60.0]])
    boxes = np.array([[100.0, 200.0, 100.0, 60.0], [470.0, 200.0, 100.0, 60.0]])
    ml = scale_iou(iou_matrix(predicted, boxes))
    before = ml.copy()
    shifted_likelihood(predicted, boxes, ml, np.array([70.0, 0.0]))
    assert ml[0].tolist() == before[0].tolist() == [100000, 0]
    assert before[1].tolist() == [0, 17647] and ml[1].tolist() == [0, 100000]


@pytest.mark.parametrize("backend", ["cpsat", "cpsat-full", "clingo"])
def test_parked_cars_keep_their_tracks_when_the_camera_turns(backend):
    # The four tracks, at rest from frames 0-5, predict each car 70 px short of it at frame 6:
    # IoU 0.18, below iou_thresh (0.3), so without the rule the model halts them and starts four
    # new tracks.  With scene_shift their likelihood is the IoU at the prediction moved by the
    # shift, 1, and each car is assigned to its own track from frame 0 to 8.
    if backend == "clingo":
        pytest.importorskip("clingo")
    seq = _panning_camera()
    with_rule = run_sequence(seq, setup_with(backend, scene_shift=True))
    without = run_sequence(seq, setup_with(backend))
    assert sorted([f for f, _ in rec.observed] for rec in with_rule.tracks) == [list(range(9))] * 4
    assert len(without.tracks) == 8 and {min(f for f, _ in rec.observed) for rec in without.tracks} == {0, 6}
    tracker = AbductionTracker(get_solver(backend), {"img_width": 1400, "img_height": 600},
                               options=TrackerOptions(scene_shift=True))
    for fr in seq.frames[:6]:
        tracker.step(fr.frame, fr.boxes, fr.confidences, fr.types)
    fr = seq.frames[6]
    problem = tracker.frame_problem(fr.frame, fr.boxes, fr.confidences, fr.types)
    assert sorted(v for _, _, v in problem.iou if v > 50000) == [100000] * 4
