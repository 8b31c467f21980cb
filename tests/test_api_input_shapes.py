"""refimpl.Tracker in the ecosystem's shapes (issue 29): (N, 6) arrays with class ids,
supervision.Detections, reset() between videos; each pinned against the (N, 5) path."""

from __future__ import annotations

import numpy as np
import pytest

import refimpl
from refimpl import io

KITTI = ("KITTI", "tracking", "training", "det_02_pointrcnn")


def _xyxys(frame) -> np.ndarray:
    b = frame.boxes
    return np.column_stack([b[:, 0], b[:, 1], b[:, 0] + b[:, 2], b[:, 1] + b[:, 3], frame.scores]).reshape(-1, 5)


def _kitti(shared_data, cls: str, seq: str = "0010"):
    return io.read_kitti_detections(shared_data.joinpath(*KITTI, cls.capitalize(), f"{seq}.txt"), cls)


def _run(seq, feed) -> list:
    tracker = refimpl.Tracker(format="kitti", object_type="car")
    return [feed(tracker, fr) for fr in seq.frames]


def test_n6_with_one_class_gives_the_tracks_of_n5(shared_data):
    seq = _kitti(shared_data, "car")
    five = _run(seq, lambda t, fr: t.update(_xyxys(fr)))
    six = _run(seq, lambda t, fr: t.update(np.column_stack([_xyxys(fr), np.full(len(fr), 2.0)])))  # 2: car
    assert sum(len(r) for r in five) > 100
    for a, b in zip(five, six):
        assert b.shape[1] == 6 and np.array_equal(a, b[:, :5]) and set(b[:, 5]) <= {2.0}


def test_supervision_detections_get_the_ids_of_their_tracks(shared_data):
    sv = pytest.importorskip("supervision")
    seq = _kitti(shared_data, "car")
    five = _run(seq, lambda t, fr: t.update(_xyxys(fr)))

    def feed(t, fr):
        a = _xyxys(fr)
        return t.update(sv.Detections(xyxy=a[:, :4], confidence=a[:, 4], class_id=np.full(len(a), 2)))
    marked = _run(seq, feed)
    for rows, dets in zip(five, marked):
        # every track reported in the frame is named on exactly one detection, and nothing else is
        named = sorted(int(i) for i in dets.tracker_id if i >= 0)
        assert named == sorted(int(n) for n in rows[:, 4])
        assert len(dets) == len(dets.tracker_id)


def test_reset_gives_the_results_of_a_fresh_tracker(shared_data):
    car = _kitti(shared_data, "car")
    ped = _kitti(shared_data, "pedestrian", "0013")
    t = refimpl.Tracker(format="kitti", object_type="car", history=True)
    for fr in ped.frames:  # another video first: its tracks, events and scores must all be forgotten
        t.update(_xyxys(fr))
    t.reset()
    again = [t.update(_xyxys(fr)) for fr in car.frames]
    u = refimpl.Tracker(format="kitti", object_type="car", history=True)
    fresh = [u.update(_xyxys(fr)) for fr in car.frames]
    assert sum(len(r) for r in fresh) > 100
    assert all(np.array_equal(a, b) for a, b in zip(again, fresh))
    assert t.frame == car.first_frame + len(car.frames)  # frame numbers restart too
    assert np.array_equal(t.result().rows, u.result().rows) and t.events == u.events


def test_classes_in_one_stream_never_share_a_track(shared_data):
    # KITTI 0013's Car and Pedestrian detections as one (N, 6) stream (COCO ids: 2 car, 0 person):
    # every track holds detections of one class only (the type match of both encodings)
    car, ped = _kitti(shared_data, "car", "0013"), _kitti(shared_data, "pedestrian", "0013")
    t = refimpl.Tracker(format="kitti", object_type="car", history=True)
    owner_class: dict[int, set] = {}
    for fc, fp in zip(car.frames, ped.frames):
        dets = np.vstack([np.column_stack([_xyxys(fc), np.full(len(fc), 2.0)]),
                          np.column_stack([_xyxys(fp), np.zeros(len(fp))])]).reshape(-1, 6)
        t.update(dets)
        for j, trk in t._tracker.owners.items():
            owner_class.setdefault(int(trk.rsplit("_", 1)[1]), set()).add(dets[j, 5])
    assert all(len(classes) == 1 for classes in owner_class.values())
    kinds = [r.type for r in t.result().tracks]
    assert kinds.count("car") >= 3 and kinds.count("pedestrian") >= 3


@pytest.mark.parametrize("dets, message", [
    (np.array([[0, 0, 10, 10, 0.5, -1]]), "class id -1 is not a non-negative integer"),
    (np.array([[0, 0, 10, 10, 0.5, 0.5]]), "class id 0.5 is not a non-negative integer"),
])
def test_bad_class_ids_are_a_clear_error(dets, message):
    with pytest.raises(ValueError, match=message):
        refimpl.Tracker().update(dets)
