"""The tracker options (refimpl.tracking.options): one table, and what backfill and scene_velocity do."""

from __future__ import annotations

import dataclasses
import io as stdio

import numpy as np
import pytest

from refimpl.io import DetectionFrame, DetectionSequence, ResultWriter, format_mot_results
from refimpl.tracking.options import TRACKER_OPTIONS, TrackerOptions, WrittenBox, option_flags
from refimpl.solvers import get_solver
from refimpl.tracking.pipeline import Setup, run_sequence
from tracking_helpers import setup_with
from refimpl.tracking.tracker import AbductionTracker
from test_streaming_output import _walk
from test_abduction_tracker import _occlusion_sequence


PLAIN_TRACKER = {"written_box": "filtered", "velocity_noise": 1.0, "velocity_exponent": 2.0, "area_noise": 1.0, "size_change": 0.0, "size_gate": 0.0,
                 "backfill_gap": 0,
                 "fill_hidden": 0, "bridge_gap": 2, "bridge_conf": 90, "write_evidence": 0, "write_peak": 0,
                 "peak_wait": 0, "new_speed": 0.0, "learned_gate": 0, "wander_noise": 0}
"""The values that make the plain tracker (SORT's filter, its size unbounded while unseen and ungated, and its output, no gap backfilled or occlusion filled in,
the tracker's bridge of old: gaps of at most 2 frames resumed at confidence >= 90, the constant iou_thresh and SORT's measurement noise,
docs/tracking.md; velocity_exponent only acts with a preset's frame rate, and 2 is the conversion the presets had before it)
for the options that are not switches; every switch (choices yes/no) is off."""



def _option(name: str):
    """The row of the option table named so."""
    (row,) = [o for o in TRACKER_OPTIONS if o.name == name]
    return row

def test_every_option_row_has_one_field_and_the_defaults_are_the_plain_tracker():
    names = tuple(o.name for o in TRACKER_OPTIONS)
    assert tuple(f.name for f in dataclasses.fields(TrackerOptions)) == TrackerOptions.names() == names
    defaults = TrackerOptions().as_dict()
    assert tuple(defaults) == names
    switches = {o.name for o in TRACKER_OPTIONS if o.choices == ("yes", "no")}
    assert {k: v for k, v in defaults.items() if k not in switches} == PLAIN_TRACKER
    assert all(defaults[k] is False for k in switches)
    assert TrackerOptions().changed() == {}


def test_option_flags_list_every_row_in_table_order():
    flags = [o.flag for o in TRACKER_OPTIONS]
    assert flags[:4] == ["--written-box", "--velocity-noise", "--velocity-exponent", "--area-noise"]  # name -> flag: _ becomes -
    # the flags joined by ", " with " and " before the last; the extra flags come first
    assert option_flags() == ", ".join(flags[:-1]) + " and " + flags[-1]
    assert option_flags("--const") == "--const, " + ", ".join(flags[:-1]) + " and " + flags[-1]


def test_option_values_parse_from_their_text_and_round_trip_through_presets_json():
    o = TrackerOptions.from_mapping({"written_box": "detection", "velocity_noise": "10", "backfill": "yes",
                                     "scene_velocity": "no", "fill_hidden": "30"})
    assert (o.written_box, o.velocity_noise, o.backfill, o.scene_velocity, o.fill_hidden) == \
        (WrittenBox.DETECTION, 10.0, True, False, 30)
    assert TrackerOptions.from_mapping(o.as_dict()) == o
    assert o.changed() == {"written_box": "detection", "velocity_noise": 10.0, "backfill": True, "fill_hidden": 30}
    for name, bad in (("backfill", "maybe"), ("scene_velocity", 2), ("velocity_noise", 0), ("written_box", "box"),
                      ("fill_hidden", -1), ("fill_hidden", 1.5), ("fill_hidden", "ten")):
        with pytest.raises(ValueError, match=name):
            TrackerOptions.from_mapping({name: bad})
    with pytest.raises(ValueError, match="unknown tracker option"):
        TrackerOptions.from_mapping({"nosuch": 1})
    assert _option("backfill").choices == ("yes", "no")


def _rows_of(result, number: int) -> list[int]:
    return sorted(int(f) for f, i, *_ in result.rows.tolist() if i == number)


def test_backfill_writes_the_frames_that_confirmed_a_resumed_track():
    # the car of _occlusion_sequence (trk_2) resumes at frame 28 after hiding in 9-27: its streak
    # restarts at 1 (28), 2 (29), 3 (30) = min_hits, so it is written again from 30.  With backfill,
    # frame 30 also writes 28 and 29 (the walk back stops at 27, not observed).
    plain = run_sequence(_occlusion_sequence(), Setup("cpsat"))
    back = run_sequence(_occlusion_sequence(), setup_with("cpsat", backfill=True))
    assert _rows_of(plain, 2) == list(range(1, 9)) + list(range(30, 33))
    assert _rows_of(back, 2) == list(range(1, 9)) + list(range(28, 33))
    assert [str(e) for e in back.events] == [str(e) for e in plain.events]  # the same hypotheses


def _late_pedestrian() -> DetectionSequence:
    """A walker detected in every frame 1-12 and a second one from frame 6 on, plus one false
    detection at frame 9 only (far from both)."""
    frames = []
    for f in range(1, 13):
        boxes = [[10.0 * f, 50.0, 40.0, 80.0]]
        if f >= 6:
            boxes.append([600.0 - 10.0 * f, 300.0, 40.0, 80.0])
        if f == 9:
            boxes.append([900.0, 20.0, 40.0, 80.0])
        n = len(boxes)
        frames.append(DetectionFrame(f, np.array(boxes), np.ones(n), np.full(n, 90), ("pedestrian",) * n))
    return DetectionSequence("late", tuple(frames), 1, (1000, 600), 25.0)


def test_backfill_writes_a_new_tracks_first_frames_but_never_a_one_frame_detection():
    # the second walker starts trk_2 at frame 6 (hit streak 0) and is updated at 7, 8, 9: streak 3
    # = min_hits at frame 9, SORT's first written frame.  Backfill also writes 6, 7 and 8.  The
    # false detection of frame 9 starts trk_3, which is never updated, never confirmed, never written.
    plain = run_sequence(_late_pedestrian(), Setup("cpsat"))
    back = run_sequence(_late_pedestrian(), setup_with("cpsat", backfill=True))
    assert _rows_of(plain, 2) == list(range(9, 13))
    assert _rows_of(back, 2) == list(range(6, 13))
    assert _rows_of(back, 1) == _rows_of(plain, 1) == list(range(1, 13))
    assert set(back.rows[:, 1].tolist()) == {1, 2}


@pytest.mark.parametrize("keep_records", [False, True])
def test_backfilled_rows_stream_to_the_same_file(keep_records):
    # the sink holds a frame until no later frame can add a row to it (min_hits = 3 frames late
    # with backfill): the streamed file equals the one written at the end
    seq = _walk(120, 8, seed=3)
    result = run_sequence(seq, setup_with("cpsat", backfill=True))
    out = stdio.StringIO()
    run_sequence(seq, setup_with("cpsat", backfill=True), sink=ResultWriter(out, first_frame=1),
                 keep_records=keep_records)
    assert out.getvalue() == format_mot_results(result.rows, 1)
    assert len(result.rows) > len(run_sequence(seq, Setup("cpsat")).rows)


def _blinking_car() -> DetectionSequence:
    """A car driving through frames 1-14 (it keeps the frame count past min_hits) and a parked car
    detected from frame 6 on, missed once, at frame 8."""
    frames = []
    for f in range(1, 15):
        boxes = [[10.0 * f, 50.0, 40.0, 80.0]]
        if f >= 6 and f != 8:
            boxes.append([600.0, 300.0, 40.0, 80.0])
        n = len(boxes)
        frames.append(DetectionFrame(f, np.array(boxes), np.ones(n), np.full(n, 90), ("car",) * n))
    return DetectionSequence("blink", tuple(frames), 1, (1000, 600), 10.0)


@pytest.mark.parametrize("backend", ["cpsat", "cpsat-full", "clingo"])
def test_backfill_gap_writes_a_new_tracks_frames_before_a_missed_one(backend):
    # The parked car starts trk_2 at frame 6 (streak 0), is updated at 7 (1), missed at 8
    # (missing_detections: halted; noise_max_age 0, so no end as noise) and resumed at 9 (recover):
    # its streak restarts, 1 at 9, 2 at 10, 3 = min_hits at 11, SORT's first written frame.
    # Backfill writes the streak, 9 and 10.  With backfill_gap 2 the walk back also crosses the
    # one-frame gap: 7 and 6 are written and 8 interpolated between the boxes of 7 and 9, equal.
    if backend == "clingo":
        pytest.importorskip("clingo")
    constants = {"noise_max_age": 0}
    plain = run_sequence(_blinking_car(), setup_with(backend, constants))
    streak = run_sequence(_blinking_car(), setup_with(backend, constants, backfill=True))
    gaps = run_sequence(_blinking_car(), setup_with(backend, constants, backfill=True, backfill_gap=2))
    assert _rows_of(plain, 2) == list(range(11, 15))
    assert _rows_of(streak, 2) == list(range(9, 15))
    assert _rows_of(gaps, 2) == list(range(6, 15))
    assert [r[2:6] for r in gaps.rows.tolist() if r[:2] == [8, 2]] == [[600.0, 300.0, 40.0, 80.0]]
    assert [str(e) for e in gaps.events] == [str(e) for e in plain.events]  # the same hypotheses
    assert _rows_of(gaps, 1) == list(range(1, 15))


@pytest.mark.parametrize("keep_records", [False, True])
def test_rows_backfilled_across_gaps_stream_to_the_same_file(keep_records):
    # the gap's interpolated rows are handed to the sink with the confirmation, within the delay
    # (min_hits + backfill_gap frames): the streamed file equals the one written at the end
    setup = setup_with("cpsat", {"noise_max_age": 0}, backfill=True, backfill_gap=2)
    result = run_sequence(_blinking_car(), setup)
    out = stdio.StringIO()
    run_sequence(_blinking_car(), setup, sink=ResultWriter(out, first_frame=1), keep_records=keep_records)
    assert out.getvalue() == format_mot_results(result.rows, 1)
    assert len(result.rows) == 14 + 9  # both cars, every frame of each (8 interpolated)


def _doubtful_walkers() -> DetectionSequence:
    """Walker A at confidence 90 in frames 1-12; walker B from frame 6, at 45 in 6-8 and 90 in
    9-12; C, a false detection at confidence 45 that stays put in frames 1-12 (a persistent
    false positive: a pole).  45 starts a track: model/constants.lp's conf_thresh_new_track is 40."""
    frames = []
    for f in range(1, 13):
        boxes, conf = [[10.0 * f, 50.0, 40.0, 80.0], [900.0, 400.0, 40.0, 80.0]], [90, 45]
        if f >= 6:
            boxes.append([600.0 - 10.0 * f, 300.0, 40.0, 80.0])
            conf.append(45 if f <= 8 else 90)
        n = len(boxes)
        frames.append(DetectionFrame(f, np.array(boxes), np.ones(n), np.array(conf), ("pedestrian",) * n))
    return DetectionSequence("doubtful", tuple(frames), 1, (1000, 600), 25.0)


@pytest.mark.parametrize("backend", ["cpsat", "cpsat-full", "clingo"])
def test_write_evidence_writes_a_track_once_its_mean_confidence_reaches_it(backend):
    if backend == "clingo":
        pytest.importorskip("clingo")
    # trk_1 = A, trk_2 = C, trk_3 = B (started in detection order).  Without the option: C is
    # confirmed with A in the first min_hits = 3 frames and written in all 12; B's streak reaches 3
    # at frame 8, which backfills 6 and 7.  With write_evidence 60: A's mean is 90 (written as
    # before); C's stays 45 (never written); B's mean after frames 6..10 is (3*45 + 90 + 90) / 5 =
    # 63 at frame 10 (after 9 it is 225 / 4 = 56.25): written from 10, and backfilled over the
    # delay = max(bridge_gap 2, min_hits 3) = 3 frames whose rows are not final yet: 7, 8, 9.
    plain = run_sequence(_doubtful_walkers(), setup_with(backend, backfill=True))
    gated = run_sequence(_doubtful_walkers(), setup_with(backend, backfill=True, write_evidence=60))
    assert [_rows_of(plain, n) for n in (1, 2, 3)] == [list(range(1, 13)), list(range(1, 13)), list(range(6, 13))]
    assert [_rows_of(gated, n) for n in (1, 2, 3)] == [list(range(1, 13)), [], list(range(7, 13))]
    assert [str(e) for e in gated.events] == [str(e) for e in plain.events]  # only the writing differs


def _ranked_walkers() -> DetectionSequence:
    """Walkers A (score 0.9) and D (0.8) in frames 1-40; from frame 31 C, a pole at 0.2: every
    detection at confidence 90, so only the scores' ranks differ."""
    frames = []
    for f in range(1, 41):
        boxes, scores = [[10.0 * f, 50.0, 40.0, 80.0], [800.0 - 10.0 * f, 300.0, 40.0, 80.0]], [0.9, 0.8]
        if f >= 31:
            boxes.append([900.0, 400.0, 40.0, 80.0])
            scores.append(0.2)
        n = len(boxes)
        frames.append(DetectionFrame(f, np.array(boxes), np.array(scores), np.full(n, 90), ("pedestrian",) * n))
    return DetectionSequence("ranked", tuple(frames), 1, (1000, 600), 25.0)


@pytest.mark.parametrize("backend", ["cpsat", "cpsat-full", "clingo"])
def test_write_peak_holds_back_a_track_the_detector_never_ranked_high(backend):
    if backend == "clingo":
        pytest.importorskip("clingo")
    # trk_1 = A, trk_2 = D, trk_3 = C.  A track's rank is its best score's among the scores seen so
    # far, judged anew every frame: floor(100 (k + 50) / (n + 50) + 1/2), k of the n scores at most
    # its own, RANK_PRIOR = 50 more below every one.  A (0.9) and D (0.8) rank high throughout (D
    # at frame 40: (50 + 50) / (50 + 90) -> 71).  C's 0.2 is the lowest: at frame f >= 31 it has
    # c = f - 30 scores, n = 2f + c, so C ranks (50 + c) / (50 + 2f + c): 44 at f = 34..37
    # ((50 + 4) / 122 = 44.3, ..., 57 / 131 = 43.5 rounds to 44), 43 from 38 (58 / 134 = 43.3).
    # C is confirmed at 34 (min_hits 3: its streak is 0 at birth, frame 31), backfilled to its
    # first frame.  Rows (with backfill the delay is max(bridge_gap 2, min_hits 3) = 3 frames):
    # * no option: C written 31..40;
    # * write_peak 55: C never written; A and D as before;
    # * write_peak 44: C written while it ranks 44: 31..37, held back again from 38;
    # * write_peak 55, peak_wait 5: C observed 5 frames in a row at 36, from then on written,
    #   backfilled over the 3 frames not final yet: 33..40.
    runs = [run_sequence(_ranked_walkers(), setup_with(backend, backfill=True, **o))
            for o in ({}, {"write_peak": 55}, {"write_peak": 44}, {"write_peak": 55, "peak_wait": 5})]
    every = list(range(1, 41))
    assert [[_rows_of(r, n) for n in (1, 2, 3)] for r in runs] == [
        [every, every, list(range(31, 41))], [every, every, []], [every, every, list(range(31, 38))],
        [every, every, list(range(33, 41))]]
    assert all([str(e) for e in r.events] == [str(e) for e in runs[0].events] for r in runs)  # only the writing differs


def test_peak_wait_counts_frames_in_a_row_and_once_reached_holds_across_a_miss():
    # _ranked_walkers with the pole C missed at frame 38.  C (trk_3) is born at 31 with streak 0,
    # so its streak is 5 at frame 36 and 6 at 37; the miss at 38 restarts it (1 at 39, 2 at 40).
    # * peak_wait 5: reached at 36 (written from then on, backfilled over the 3 frames not final:
    #   33..36, then 37); 38 bridged (resumed at 39 with confidence 90 >= bridge_conf 90, gap 1 <=
    #   bridge_gap 2) and interpolated; 39 and 40 written though C ranks below 55 and its streak is 1-2;
    # * peak_wait 9: never 9 frames in a row, and C ranks below 55 throughout: never written.
    seq = _ranked_walkers()
    frames = tuple(dataclasses.replace(fr, boxes=fr.boxes[:2], scores=fr.scores[:2], confidences=fr.confidences[:2],
                                       types=fr.types[:2]) if fr.frame == 38 else fr for fr in seq.frames)
    missed = dataclasses.replace(seq, frames=frames)
    runs = [run_sequence(missed, setup_with("cpsat", backfill=True, write_peak=55, peak_wait=w)) for w in (5, 9)]
    assert [_rows_of(r, 3) for r in runs] == [list(range(33, 41)), []]


def test_write_peak_reads_the_scores_order_not_their_scale():
    # any strictly increasing rescale of the scores gives the same ranks, so the same rows
    seq = _ranked_walkers()
    rescaled = dataclasses.replace(seq, frames=tuple(dataclasses.replace(fr, scores=3.0 * fr.scores ** 3 - 7.0)
                                                     for fr in seq.frames))
    setup = setup_with("cpsat", backfill=True, write_peak=55)
    assert run_sequence(rescaled, setup).rows.tolist() == run_sequence(seq, setup).rows.tolist()
    assert _rows_of(run_sequence(seq, setup), 3) == []  # the pole held back: the option did something


@pytest.mark.parametrize("keep_records", [False, True])
def test_rows_written_by_evidence_stream_to_the_same_file(keep_records):
    # confidences spread over 0..100 (37 (f + k) mod 101 for detection k of frame f): tracks reach
    # the mean of 60 at different times and are backfilled up to delay = fill_hidden 10 + min_hits 3
    # frames; the sink, holding a frame that long, writes the file written at the end
    seq = _walk(120, 8, seed=3)
    seq = dataclasses.replace(seq, frames=tuple(dataclasses.replace(
        fr, confidences=np.array([37 * (fr.frame + k) % 101 for k in range(len(fr.boxes))])) for fr in seq.frames))
    options = dict(backfill=True, fill_hidden=10, write_evidence=60)
    result = run_sequence(seq, setup_with("cpsat", **options))
    out = stdio.StringIO()
    run_sequence(seq, setup_with("cpsat", **options), sink=ResultWriter(out, first_frame=1), keep_records=keep_records)
    assert out.getvalue() == format_mot_results(result.rows, 1)
    plain = run_sequence(seq, setup_with("cpsat", backfill=True, fill_hidden=10)).rows
    assert 0 < len(result.rows) < len(plain)  # some tracks fall short of the evidence, some do not


def _turning_camera() -> DetectionSequence:
    """What a turning camera does to parked cars (KITTI 0007, frames 44-56): everything slides
    35 px/frame to the right.  Two big cars (100x60) are in view from frame 1; from frame 6 a row
    of four small cars (30x30, 40 px apart) slides through as well, car k at x = 100 - 40 k + 35 (f - 6).

    A track that starts at rest predicts car k where car k was; one frame later car k is 35 px
    further (no overlap with a 30 px box) and car k+1 is 5 px short of it (IoU 25/35 = 0.71): the
    track takes its neighbour, every frame.  Started with the big cars' velocity instead, it
    predicts car k where car k is."""
    frames = []
    for f in range(1, 13):
        boxes = [[20.0 + 35 * (f - 1), 40.0, 100.0, 60.0], [60.0 + 35 * (f - 1), 420.0, 100.0, 60.0]]
        if f >= 6:
            boxes += [[100.0 - 40 * k + 35 * (f - 6), 250.0, 30.0, 30.0] for k in range(4)]
        n = len(boxes)
        frames.append(DetectionFrame(f, np.array(boxes), np.ones(n), np.full(n, 90), ("car",) * n))
    return DetectionSequence("turning", tuple(frames), 1, (1400, 600), 10.0)


def _row_cars_per_track(result) -> list[set[int]]:
    """For every track of the row (y = 250), the set of row-car indices k it was assigned over time."""
    out = []
    for rec in result.tracks:
        ks = {round((100 + 35 * (f - 6) - box[0]) / 40) for f, box in rec.observed if box[1] == 250.0}
        if ks:
            out.append(ks)
    return out


def test_scene_velocity_keeps_each_car_of_a_sliding_row_on_its_own_track():
    kw = dict(written_box="detection", velocity_noise=10)
    plain = _row_cars_per_track(run_sequence(_turning_camera(), setup_with("cpsat", **kw)))
    scene = _row_cars_per_track(run_sequence(_turning_camera(),
                                             setup_with("cpsat", scene_velocity=True, **kw)))
    assert any(len(ks) > 1 for ks in plain)  # started at rest: tracks hop to the neighbouring car
    assert sorted(scene, key=min) == [{0}, {1}, {2}, {3}]  # one track per car, from frame 6 to 12


def test_a_new_track_starts_with_the_median_velocity_of_the_tracks_seen_last_frame():
    from refimpl.solvers import get_solver
    from refimpl.tracking.tracker import AbductionTracker
    seq = _turning_camera()
    tracker = AbductionTracker(get_solver("cpsat"), {"img_width": 1400, "img_height": 600},
                               options=TrackerOptions(scene_velocity=True))
    for fr in seq.frames[:5]:
        tracker.step(fr.frame, fr.boxes, fr.confidences, fr.types)
    big = [t.kalman.velocity for t in tracker.tracks.values()]  # both observed at frame 5, streak 4
    assert len(big) == 2 and all(v[0] > 20 for v in big)  # they learned the slide to the right
    expected = np.median(np.array(big), axis=0)  # of two values: their mean
    fr = seq.frames[5]
    tracker.step(fr.frame, fr.boxes, fr.confidences, fr.types)
    newborn = [t for t in tracker.tracks.values() if min(t.observed) == 6]
    assert len(newborn) == 4
    for t in newborn:
        np.testing.assert_allclose(t.kalman.velocity, expected)


def test_the_api_takes_options_by_name_and_hands_backfilled_rows_over_afterwards():
    from refimpl.api import Tracker
    tracker = Tracker("cpsat", img_size=(1000, 600), backfill=True, preset="none", history=True)
    reported = {}
    with pytest.warns(UserWarning, match="every detection has the score 0.9"):  # docs/model.md 3.19
        for fr in _late_pedestrian().frames:
            b = fr.boxes
            dets = np.column_stack([b[:, 0], b[:, 1], b[:, 0] + b[:, 2], b[:, 1] + b[:, 3], np.full(len(b), 0.9)])
            reported[fr.frame] = tracker.update(dets)[:, 4].tolist()
    # online, trk 2 is reported from its confirming frame 9 on, as without backfill; its frames 6-8
    # (written by the confirmation, 3 frames late) come with interpolated_rows()
    assert [f for f, ids in reported.items() if 2.0 in ids] == list(range(9, 13))
    late = tracker.interpolated_rows()
    assert sorted((int(f), int(i)) for f, i, *_ in late.tolist()) == [(6, 2), (7, 2), (8, 2)]
    with pytest.raises(ValueError, match="unknown tracker option"):
        Tracker("cpsat", backfil=True)


DEMO = __import__("pathlib").Path(__file__).resolve().parent.parent / "data" / "demo" / "TUD-Campus" / "det" / "det.txt"


def test_cli_backfill_flag_overrides_the_preset(tmp_path):
    from refimpl.cli import main
    # the mot/pedestrian preset backfills; --backfill no gives the same tracks without the frames
    # that confirmed them, so its rows are a strict subset of the preset's
    rows = {}
    for flag in ("yes", "no"):
        out = tmp_path / f"{flag}.txt"
        assert main(["track", "--dets", str(DEMO), "--backend", "cpsat", "--out", str(out), "--quiet",
                     "--backfill", flag]) == 0
        rows[flag] = set(out.read_text().splitlines())
    assert rows["no"] < rows["yes"]
    assert main(["track", "--dets", str(DEMO), "--backend", "cpsat", "--out", str(tmp_path / "p.txt"),
                 "--quiet"]) == 0
    assert set((tmp_path / "p.txt").read_text().splitlines()) == rows["yes"]


def test_cli_option_flags_are_refused_for_the_baseline_and_checked(tmp_path, capsys):
    from refimpl.cli import main
    out = str(tmp_path / "o.txt")
    assert main(["track", "--dets", str(DEMO), "--backend", "baseline", "--out", out, "--scene-velocity", "yes"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{option_flags('--img-size', '--fps')} need an abduction" in err
    with pytest.raises(SystemExit) as exc:
        main(["track", "--dets", str(DEMO), "--out", out, "--backfill", "maybe"])
    assert exc.value.code == 2 and "invalid choice: 'maybe'" in capsys.readouterr().err


def test_fill_hidden_writes_an_occlusion_episode_once_the_track_is_confirmed_again():
    # the car (trk_2) hides behind the bus at 9 (hides_behind right after its last frame, 8) and
    # comes out at 28 (unhides_from_behind): a 19-frame episode.  fill_hidden >= 19 fills it when the
    # resumed track is confirmed again at 30 (streak 3), with the frames 28 and 29 that confirmed it;
    # 18 is too short, so the rows are those of the plain tracker
    filled = run_sequence(_occlusion_sequence(), setup_with("cpsat", fill_hidden=19))
    short = run_sequence(_occlusion_sequence(), setup_with("cpsat", fill_hidden=18))
    assert _rows_of(filled, 2) == list(range(1, 33))
    assert _rows_of(short, 2) == list(range(1, 9)) + list(range(30, 33))
    car = {int(f): b for f, i, *b in filled.rows.tolist() if i == 2}
    # frame 18 lies 10/20 of the way from frame 8 to frame 28: x halfway between the two boxes
    np.testing.assert_allclose(car[18][0], (car[8][0] + car[28][0]) / 2)
    assert [str(e) for e in filled.events] == [str(e) for e in short.events]


def test_fill_hidden_needs_the_resumed_track_to_be_confirmed_again():
    # the car comes out at 28 for one frame only and is never seen again: the resume is not
    # confirmed (streak 1), so nothing of the episode is written
    seq = _occlusion_sequence()
    frames = tuple(fr if fr.frame <= 28 else DetectionFrame(fr.frame, fr.boxes[:1], fr.scores[:1],
                                                             fr.confidences[:1], fr.types[:1])
                   for fr in seq.frames)
    result = run_sequence(DetectionSequence(seq.name, frames, 1, seq.image_size, seq.fps),
                          setup_with("cpsat", fill_hidden=30))
    assert "occurs_at(unhides_from_behind(trk_2,trk_1),28)" in [str(e) for e in result.events]
    assert _rows_of(result, 2) == list(range(1, 9))


def _chained_occlusion_sequence() -> DetectionSequence:
    """_occlusion_sequence's car, seen at 28 alone as it comes out, hidden again in 29-30 (its box at
    28, x 640..720, still 60/80 behind the bus), then seen from 31 (x 700) to 40."""
    frames = []
    for f in range(1, 41):
        boxes, types = [[300.0, 200.0, 400.0, 300.0]], ["car"]
        if f <= 8 or f == 28 or f >= 31:
            boxes.append([100.0 + 20 * (f - 1), 300.0, 80.0, 60.0])
            types.append("car")
        n = len(boxes)
        frames.append(DetectionFrame(f, np.array(boxes), np.full(n, 0.9), np.full(n, 90), tuple(types)))
    return DetectionSequence("chained", tuple(frames), 1, (1000, 600), 25.0)


def test_fill_hidden_fills_a_chain_of_episodes_at_the_one_reconfirmation():
    # episodes 8 -> 28 and 28 -> 31 (hides_behind at 9 and 29, unhides_from_behind at 28 and 31);
    # at 28 the track is not confirmed again yet (streak 1), so the second episode joins the first
    # and both wait for the re-confirmation at 33 (streak 31, 32, 33 = min_hits 3).  fill_hidden 30:
    # rows are final 33 frames late, so at 33 nothing of either is final: every frame 1..40 written.
    # fill_hidden 19: 22 frames late: frames <= 33 - 1 - 22 = 10 are final, the first episode's rows
    # (9..27) among them, so only the second is filled: 28 (observed between the two), 29-30
    # interpolated, 31 on.  (Before chains, the second resume was no episode at all: 1-8, 33-40.)
    seq = _chained_occlusion_sequence()
    full = run_sequence(seq, setup_with("cpsat", fill_hidden=30))
    assert [str(e) for e in full.events if "trk_2" in str(e)] == [
        "occurs_at(enters_fov(trk_2),1)", "occurs_at(hides_behind(trk_2,trk_1),9)",
        "occurs_at(unhides_from_behind(trk_2,trk_1),28)", "occurs_at(hides_behind(trk_2,trk_1),29)",
        "occurs_at(unhides_from_behind(trk_2,trk_1),31)"]
    assert _rows_of(full, 2) == list(range(1, 41))
    late = run_sequence(seq, setup_with("cpsat", fill_hidden=19))
    assert _rows_of(late, 2) == list(range(1, 9)) + list(range(28, 41))
    car = {int(f): b for f, i, *b in full.rows.tolist() if i == 2}
    # frame 30 lies 2/3 of the way from frame 28 to frame 31
    np.testing.assert_allclose(car[30][0], car[28][0] + 2 / 3 * (car[31][0] - car[28][0]))
    for keep_records in (False, True):  # the streamed file is the result's, for either
        for fill in (30, 19):
            out = stdio.StringIO()
            run_sequence(seq, setup_with("cpsat", fill_hidden=fill), sink=ResultWriter(out, first_frame=1),
                         keep_records=keep_records)
            assert out.getvalue() == format_mot_results((full if fill == 30 else late).rows, 1)


def test_a_chain_of_three_episodes_streams_to_the_same_file():
    # a car at 20 px/frame behind a bus 700 px wide (x 300..1000): seen 1-8, 28-29, 32-33, 36-44,
    # so three episodes, 8 -> 28, 29 -> 32, 33 -> 36, each hides_behind right after the last frame
    # seen and unhides_from_behind at the resume; never two frames seen in a row between them
    # (min_hits 3), so the track is confirmed again only at 38 and fill_hidden 30 (rows final 33
    # frames late: 38 - 1 - 33 = 4 < 8) fills all three: every frame 1..44.  The streamed file, in
    # which the tracker forgets what no later frame reads, is the result's
    seen = {*range(1, 9), 28, 29, 32, 33, *range(36, 45)}
    frames = []
    for f in range(1, 45):
        boxes = [[300.0, 200.0, 700.0, 300.0]] + ([[100.0 + 20 * (f - 1), 300.0, 80.0, 60.0]] if f in seen else [])
        n = len(boxes)
        frames.append(DetectionFrame(f, np.array(boxes), np.full(n, 0.9), np.full(n, 90), ("car",) * n))
    seq = DetectionSequence("chain3", tuple(frames), 1, (2000, 600), 25.0)
    result = run_sequence(seq, setup_with("cpsat", fill_hidden=30))
    assert [str(e) for e in result.events if "trk_2" in str(e) and "hides" in str(e)] == [
        f"occurs_at({name}(trk_2,trk_1),{f})" for f, name in
        ((9, "hides_behind"), (28, "unhides_from_behind"), (30, "hides_behind"), (32, "unhides_from_behind"),
         (34, "hides_behind"), (36, "unhides_from_behind"))]
    assert _rows_of(result, 2) == list(range(1, 45))
    out = stdio.StringIO()
    run_sequence(seq, setup_with("cpsat", fill_hidden=30), sink=ResultWriter(out, first_frame=1), keep_records=False)
    assert out.getvalue() == format_mot_results(result.rows, 1)


@pytest.mark.parametrize("keep_records", [False, True])
def test_filled_episodes_stream_to_the_same_file(keep_records):
    # rows of a filled episode are final fill_hidden + min_hits frames late; the sink waits that long
    seq = _occlusion_sequence()
    result = run_sequence(seq, setup_with("cpsat", fill_hidden=19))
    out = stdio.StringIO()
    run_sequence(seq, setup_with("cpsat", fill_hidden=19), sink=ResultWriter(out, first_frame=1),
                 keep_records=keep_records)
    assert out.getvalue() == format_mot_results(result.rows, 1)


def test_motion_options_are_rows_of_the_table_parsed_like_the_others():
    # hold_hidden and reupdate_on_resume (docs/tracking.md, "Motion while hidden") are tracker
    # options: text values parse, a bad value or an unknown name is one ValueError naming it
    tracker = AbductionTracker(get_solver("cpsat"), {},
                               options=TrackerOptions(hold_hidden="yes", reupdate_on_resume="no"))
    assert tracker.options.hold_hidden is True and tracker.options.reupdate_on_resume is False
    with pytest.raises(ValueError, match="hold_hidden"):
        TrackerOptions(hold_hidden="maybe")
    with pytest.raises(ValueError, match="unknown tracker option"):
        run_sequence(_occlusion_sequence(), setup_with("cpsat", hold=True))
    assert _option("reupdate_on_resume").flag == "--reupdate-on-resume"


def _forward_camera() -> DetectionSequence:
    """What a camera driving forward does (refimpl decision, docs/model.md 3.20): the two cars in
    view from frame 1 are overtaken and slide 45 px/frame to the left (100 px wide: IoU 55/145 =
    0.38 with their place a frame before, enough to be followed from rest), while a car far ahead
    (40x40, from frame 6) stands still in the image.  Predicted d px to the left, that car overlaps
    its detection by (40 - d) / (40 + d), below SORT's 0.3 once d > 21.5 px."""
    frames = []
    for f in range(1, 13):
        boxes = [[1200.0 - 45 * (f - 1), 40.0, 100.0, 60.0], [1150.0 - 45 * (f - 1), 420.0, 100.0, 60.0]]
        if f >= 6:
            boxes.append([600.0, 250.0, 40.0, 40.0])
        n = len(boxes)
        frames.append(DetectionFrame(f, np.array(boxes), np.ones(n), np.full(n, 90), ("car",) * n))
    return DetectionSequence("forward", tuple(frames), 1, (1400, 600), 10.0)


def test_a_car_started_with_the_scene_motion_is_matched_where_it_stands():
    from refimpl.core.geometry import iou_matrix, scale_iou
    from refimpl.solvers import get_solver
    from refimpl.tracking.tracker import AbductionTracker
    seq = _forward_camera()
    tracker = AbductionTracker(get_solver("cpsat"), {"img_width": 1400, "img_height": 600},
                               options=TrackerOptions(scene_velocity=True))
    for fr in seq.frames[:6]:
        tracker.step(fr.frame, fr.boxes, fr.confidences, fr.types)
    (newborn,) = [t for t in tracker.tracks.values() if min(t.observed) == 6]
    fr = seq.frames[6]
    problem = tracker.frame_problem(fr.frame, fr.boxes, fr.confidences, fr.types)
    (pred,) = [p for p in problem.tracks if p.id == newborn.id]
    moved = scale_iou(iou_matrix(newborn.predicted[None], fr.boxes[2:3]))[0, 0]
    assert pred.box[0] < 600 - 22  # predicted with the scene's motion, more than 21.5 px to the left
    assert moved < 30000  # that prediction alone could not be assigned (iou_thresh 30000) ...
    assert (newborn.id, "det_2", 100000) in problem.iou  # ... the car where it stands: IoU 1
    # so one identity holds the standing car from frame 6 to 12 (7 frames, none restarted)
    result = run_sequence(seq, setup_with("cpsat", scene_velocity=True))
    standing = [[f for f, box in rec.observed if box[1] == 250.0] for rec in result.tracks]
    assert [f for f in standing if f] == [list(range(6, 13))]


def _speeding_car() -> DetectionSequence:
    """A 40 x 40 car moving right at 16 px per frame in frames 0-5, missed in frames 6-10, and seen
    again in frames 11-13 where a higher speed puts it: at frame 11 its centre 1.5 times as far from
    frame 5's as SORT's filter predicts (the filter's own prediction, computed here with
    refimpl.tracking.motion.BoxKalman as the tracker runs it: one predict per frame, an update per
    detection), then on at 16 px per frame."""
    from refimpl.tracking.motion import BoxKalman
    seen = [np.array([100.0 + 16 * f, 250.0, 40.0, 40.0]) for f in range(6)]
    kalman = BoxKalman(seen[0])
    for box in seen[1:]:
        kalman.predict()
        kalman.update(box)
    for _ in range(6):  # frames 6 to 11
        predicted = kalman.predict()
    start = seen[5][:2] + 20  # frame 5's centre
    moved = predicted[:2] + predicted[2:] / 2 - start
    again = np.array([*(start + 1.5 * moved - predicted[2:] / 2), *predicted[2:]])
    frames = [DetectionFrame(f, box[None], np.ones(1), np.full(1, 90), ("car",)) for f, box in enumerate(seen)]
    frames += [DetectionFrame(f, np.zeros((0, 4)), np.zeros(0), np.zeros(0, dtype=int), ()) for f in range(6, 11)]
    frames += [DetectionFrame(11 + k, (again + [16.0 * k, 0, 0, 0])[None], np.ones(1), np.full(1, 90), ("car",))
               for k in range(3)]  # then 16 px a frame again
    assert (again - predicted)[0] > 40  # the prediction lies more than a box width behind: IoU 0
    return DetectionSequence("speeding", tuple(frames), 1, (1400, 600), 10.0)


@pytest.mark.parametrize("backend", ["cpsat", "cpsat-full", "clingo"])
def test_a_car_seen_again_faster_than_predicted_resumes_with_uncertain_speed(backend):
    # docs/model.md 3.27.  The filter predicts the car at frame 11 some 96 px on from frame 5 (16 px
    # a frame, six predictions); it is 1.5 times as far, 48 px beyond the prediction, more than its
    # 40 px width, so the plain likelihood is 0 and only a new track can take it.  (Frame to frame
    # a new track, started at rest, overlaps its next box by (40 - 16) / (40 + 16) = 0.43 > 0.3.)
    # With uncertain_speed the halted track is also matched at 0.75, 1.25 and 1.5 times the
    # predicted motion: at 1.5 the box is the detection's, IoU 1 (100000), and the car resumes.
    if backend == "clingo":
        pytest.importorskip("clingo")
    seq = _speeding_car()
    constants = {"lost_after_missing": 8}  # halted at 6, not yet lost at 11
    with_rule = run_sequence(seq, setup_with(backend, constants, uncertain_speed=True))
    without = run_sequence(seq, setup_with(backend, constants))
    frames = [[f for f, _ in rec.observed] for rec in with_rule.tracks]
    assert frames == [[0, 1, 2, 3, 4, 5, 11, 12, 13]]
    assert [[f for f, _ in rec.observed] for rec in without.tracks] == [[0, 1, 2, 3, 4, 5], [11, 12, 13]]
    tracker = AbductionTracker(get_solver(backend), {"img_width": 1400, "img_height": 600, **constants},
                               options=TrackerOptions(uncertain_speed=True))
    for fr in seq.frames[:11]:
        tracker.step(fr.frame, fr.boxes, fr.confidences, fr.types)
    fr = seq.frames[11]
    problem = tracker.frame_problem(fr.frame, fr.boxes, fr.confidences, fr.types)
    ((trk, det, ml),) = problem.iou
    assert (trk, det) == ("trk_1", "det_0") and ml >= 99_999  # IoU 1 up to the float's last bit
