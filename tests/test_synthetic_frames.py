"""Synthetic frame problems: determinism, track counts, realised overlap share, fact round trip, iou facts."""

from __future__ import annotations

import math
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from refimpl.knowledge.events import EventState
from refimpl.knowledge.event_table import explaining
from refimpl.core.geometry import iou_matrix, scale_iou
from refimpl.core.spec import IOU_SCALE, FrameProblem, write_facts
from refimpl.core.facts import parse_facts, read_problem
from refimpl.experiments.synthetic import (
    overlapping_count,
    synthetic_frame,
)

SIZES = (0, 1, 2, 5, 10, 20, 50, 100, 200)
OVERLAPS = (0.0, 0.2, 0.5, 0.8, 1.0)


def inter(a, b) -> int:
    iw = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
    ih = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
    return max(iw, 0) * max(ih, 0)


def inter_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Integer intersection areas of integer xywh boxes, all pairs (exact, int64)."""
    iw = np.minimum(a[:, None, 0] + a[:, None, 2], b[None, :, 0] + b[None, :, 2]) - np.maximum(a[:, None, 0], b[None, :, 0])
    ih = np.minimum(a[:, None, 1] + a[:, None, 3], b[None, :, 1] + b[None, :, 3]) - np.maximum(a[:, None, 1], b[None, :, 1])
    return np.clip(iw, 0, None) * np.clip(ih, 0, None)


def boxes_of(items) -> np.ndarray:
    return np.array([x.box for x in items], dtype=np.int64).reshape(-1, 4)


def hideable(p: FrameProblem) -> set[str]:
    """Tracks T1 with some T2 covering > 10 % of T1's area whose bottom edge is not above T1's
    (overlapping_top with the default hide_overlap = 10, written out independently here)."""
    b = boxes_of(p.tracks)
    covered = 100 * inter_matrix(b, b) > 10 * (b[:, 2] * b[:, 3])[:, None]
    in_front = (b[:, 1] + b[:, 3])[None, :] >= (b[:, 1] + b[:, 3])[:, None]
    ok = covered & in_front
    np.fill_diagonal(ok, False)
    return {p.tracks[i].id for i in np.flatnonzero(ok.any(axis=1))}


def check_problem(p: FrameProblem, n: int, overlap: float) -> None:
    # ids, types, confidences
    assert [t.id for t in p.tracks] == [f"trk_{i}" for i in range(n)]
    assert [d.id for d in p.detections] == [f"det_{j}" for j in range(len(p.detections))]
    assert {t.type for t in p.tracks} | {d.type for d in p.detections} <= {"pedestrian", "car"}
    assert all(0 <= d.conf <= 100 for d in p.detections)
    # overlap share realised exactly
    assert len(hideable(p)) == overlapping_count(n, overlap)
    # round trip through the fact format
    assert parse_facts(write_facts(p)) == p
    # iou facts are the geometry of the integer boxes: every pair with IoU > 0, no other, in order
    tb, db = boxes_of(p.tracks), boxes_of(p.detections)
    ml = scale_iou(iou_matrix(tb.astype(float), db.astype(float))).reshape(len(tb), len(db))
    expected = [(p.tracks[i].id, p.detections[j].id, int(ml[i, j])) for i, j in zip(*np.nonzero(ml > 0))]
    assert list(p.iou) == expected
    # ... and the float IoU is at most one unit off the exact rational inter / union
    i = inter_matrix(tb, db)
    union = (tb[:, 2] * tb[:, 3])[:, None] + (db[:, 2] * db[:, 3])[None, :] - i
    assert np.all(np.abs(ml * union - IOU_SCALE * i) <= union)
    assert np.all(i[ml > 0] > 0)  # a positive likelihood needs intersecting integer boxes


def test_same_arguments_give_the_same_problem_and_another_seed_another():
    a = synthetic_frame(50, 0.5, seed=3)
    b = synthetic_frame(50, 0.5, seed=3)
    assert a == b and write_facts(a) == write_facts(b)
    assert synthetic_frame(50, 0.5, seed=4) != a
    assert synthetic_frame(50, 0.2, seed=3) != a


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("overlap", OVERLAPS)
def test_track_count_overlap_share_round_trip_and_iou(n, overlap):
    for seed in range(2):
        p = synthetic_frame(n, overlap, seed)
        assert len(p.tracks) == n
        check_problem(p, n, overlap)


def test_overlap_share_is_the_requested_share():
    for n in (10, 20, 50, 100, 200):
        for overlap in (0.2, 0.5, 0.8):
            got = len(hideable(synthetic_frame(n, overlap, seed=0)))
            assert got == math.floor(overlap * n + 0.5)
    assert overlapping_count(5, 1.0) == 4  # a depth order has a frontmost track
    assert overlapping_count(0, 0.5) == 0
    assert overlapping_count(5, 0.5) == 3  # 2.5 rounds half up


@settings(max_examples=40, deadline=None)
@given(n=st.integers(0, 60), overlap=st.floats(0, 1), seed=st.integers(0, 2**32 - 1),
       time=st.integers(4, 10_000), miss=st.floats(0, 1), halted=st.floats(0, 1), fp=st.floats(0, 2),
       with_history=st.booleans())
def test_any_arguments_give_a_valid_problem(n, overlap, seed, time, miss, halted, fp, with_history):
    p = synthetic_frame(n, overlap, seed, time=time, miss_rate=miss, halted_rate=halted, fp_rate=fp,
                        with_history=with_history, image_size=(1280, 720))
    check_problem(p, n, overlap)
    assert p.time == time
    assert sum(t.state == "halted" for t in p.tracks) == math.floor(halted * n + 0.5)  # half up
    if not with_history:
        assert p.history == ()
    assert all(0 <= h.time < time for h in p.history)


def test_histories_explain_the_track_states():
    # the fluents at curr_time after each track's history, by the event calculus (refimpl.knowledge.events,
    # tested on its own in test_event_calculus.py); roles from the event table, so a new event of a role
    # the generator draws from is checked too
    starting = {e.name for e in explaining("start")}
    kinds = set()
    for n in (10, 50, 200):
        for overlap in (0.2, 0.8):
            for seed in range(3):
                p = synthetic_frame(n, overlap, seed, halted_rate=0.3)
                ids = [t.id for t in p.tracks]
                state = EventState(p.history, ids)
                boxes = {t.id: t.box for t in p.tracks}
                for t in p.tracks:
                    # its start logged once, at its start
                    assert sum(h.event.name in starting and h.event.args[0].name == t.id for h in p.history) == 1
                    hidden_by = [o for o in ids if o != t.id and state.holds_at(("hidden_by", t.id, o), "true")]
                    if t.state == "active":  # active tracks are never clipped or hidden
                        assert state.values(("visibility", t.id)) == {"fully_visible"}
                        assert state.values(("clipped", t.id)) == {"false"} and not hidden_by
                    else:  # a halted track's halt is explained: a halting event after its start
                        assert state.halted_at(t.id) is not None and state.halted_at(t.id) > state.started_at(t.id)
                    for other in hidden_by:  # hidden behind a track that covers it from the front
                        b1, b2 = boxes[t.id], boxes[other]
                        assert 100 * inter(b1, b2) > 10 * b1[2] * b1[3] and b2[1] + b2[3] >= b1[1] + b1[3]
                        assert state.values(("visibility", other)) == {"fully_visible"}
                # each track's events are in time order, start first
                by_track: dict[str, list] = {}
                for h in p.history:
                    by_track.setdefault(h.event.args[0].name, []).append(h)
                for evs in by_track.values():
                    assert evs[0].event.name in starting
                    assert [h.time for h in evs] == sorted(h.time for h in evs)
                    assert len({h.time for h in evs}) == len(evs)
                kinds |= {h.event.name for h in p.history}
    # the generator exercises every history event the tracker can log for a live track: its start
    # (enters_fov), its halts (hides_behind, missing_detections) and its resumes (unhides_from_behind,
    # recover), each with an occluder or of one track
    assert kinds == {e.name for action in ("start", "halt", "resume") for e in explaining(action)
                     if e.arity == 1 or e.occluder is not None}


def test_detections_follow_tracks_and_include_false_positives():
    p = synthetic_frame(200, 0.5, seed=1, miss_rate=0.1, fp_rate=0.1)
    best = {}
    for t, d, v in p.iou:
        best[t] = max(best.get(t, 0), v)
    active = [t for t in p.tracks if t.state == "active"]
    well_matched = sum(best.get(t.id, 0) > 50_000 for t in active)
    assert 0.8 * len(active) <= well_matched <= len(active)
    low = sum(d.conf < 40 for d in p.detections)
    assert low >= 5  # false positives carry low confidences (Poisson mean 20 here)
    assert len(p.detections) > len(active)
    assert dict(p.constants) == {"img_width": 1920, "img_height": 1080}


def test_miss_rate_one_and_zero_false_positives_leave_only_reappearing_halted_tracks():
    p = synthetic_frame(20, 0.5, seed=0, miss_rate=1.0, fp_rate=0.0, new_rate=0.0, reappear_rate=0.0)
    assert p.detections == () and p.iou == ()


def test_bad_arguments_are_rejected():
    for kwargs in ({"n_tracks": -1}, {"overlap": 1.5}, {"time": 2}, {"miss_rate": 2.0}, {"fp_rate": -1.0}):
        args = {"n_tracks": 5, "overlap": 0.5, "seed": 0} | kwargs
        with pytest.raises(ValueError):
            synthetic_frame(**args)


def test_a_synthetic_frame_round_trips_through_a_fact_file(tmp_path):
    # what `refimpl solve` reads back is the frame written (spec.write_facts, spec.read_problem)
    for n, overlap, seed in ((5, 0.2, 0), (20, 0.5, 1)):
        expected = synthetic_frame(n, overlap, seed)
        path = tmp_path / f"n{n}_s{seed}.lp"
        path.write_text(write_facts(expected), encoding="utf-8")
        assert read_problem(str(path)) == expected
