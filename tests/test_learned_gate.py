"""The association gate learned from the sequence's own matches (tracker option learned_gate,
refimpl.tracking.gate, docs/model.md 3.33)."""

from __future__ import annotations

import numpy as np
import pytest

from refimpl.core.constants import resolve_constants
from refimpl.solvers import get_solver
from refimpl.tracking.gate import GATE_MIN_MATCHES, MatchGate
from refimpl.tracking.options import TrackerOptions
from refimpl.tracking.tracker import AbductionTracker


def test_the_gate_is_the_preset_until_enough_matches_then_a_share_of_their_median():
    gate = MatchGate(40, 30000)
    gate.add([60000] * (GATE_MIN_MATCHES - 1))
    assert gate.median is None and gate.gate() == 30000  # 49 matches: not learned yet
    gate.add([61234])
    # 50 matches, all in the bin 60000..60999: median 60500, 40 % of it 24200, between the floor
    # (two thirds of 30000 = 20000) and the preset
    assert gate.median == 60500 and gate.gate() == 24200


def test_a_precise_detector_keeps_the_preset_and_a_wandering_one_stops_at_the_floor():
    precise, wandering = MatchGate(40, 30000), MatchGate(40, 30000)
    precise.add([84000] * 30 + [50000] * 29)  # median (30th of 59) in bin 84: 84500, 40 % = 33800 > 30000
    wandering.add([40000] * 50 + [90000] * 49)  # median (50th of 99) in bin 40: 40500, 40 % = 16200 < 20000
    assert precise.gate() == 30000 and not precise.lowered()
    assert wandering.gate() == 20000 and wandering.lowered()  # what wander_noise goes by
    assert MatchGate(0, 30000).gate() == 30000  # ratio 0: the option off


def test_the_median_is_the_lower_one_of_an_even_count():
    gate = MatchGate(40, 30000)
    gate.add([55000] * 25 + [70000] * 25)  # 50 matches: the 25th is in bin 55 -> 55500, 40 % = 22200
    assert gate.median == 55500 and gate.gate() == 22200


def _wandering_walker(frames: int, last_dx: float):
    """One person standing still, centred at (120, 140), whose detected box alternates between 40 x
    80 px and a square of the same area (IoU of the two 1200 / 5200 = 0.23; the filter's prediction,
    its aspect ratio smoothed, overlaps either by about 0.55 to 0.75), the last frame's 40 x 80 box
    moved ``last_dx`` px to the right."""
    for f in range(frames):
        w, h = (40.0, 80.0) if f % 2 == 0 else (3200 ** 0.5, 3200 ** 0.5)
        x = 120 - w / 2 + (last_dx if f == frames - 1 else 0.0)
        yield f, np.array([[x, 140 - h / 2, w, h]]), np.array([95]), ("pedestrian",)


def _run(backend: str, gate: int, frames: int, last_dx: float):
    tracker = AbductionTracker(get_solver(backend), {"img_width": 640, "img_height": 480},
                               options=TrackerOptions(learned_gate=gate))
    seen = []
    for f, boxes, conf, types in _wandering_walker(frames, last_dx):
        tracker.step(f, boxes, conf, types, observer=lambda p, h: seen.append((p, h)))
    return seen


def test_a_wandering_detection_is_kept_on_its_track_with_the_learned_gate(backend):
    if backend == "clingo":
        pytest.importorskip("clingo")
    frames = GATE_MIN_MATCHES + 12
    learned = _run(backend, 40, frames, 27.0)
    fixed = _run(backend, 0, frames, 27.0)
    # Every frame but the first (the start) and the last the walker's box is assigned to trk_1,
    # its likelihood above 0.5: both runs the same there.
    for (p, h), (q, k) in zip(learned[:-1], fixed[:-1]):
        assert h.answer == k.answer and h.assignments == (("trk_1", "det_0"),) * bool(h.time)
    # The gate each problem carries is 40 % of the median likelihood of the assignments before it
    # (recomputed here from the problems' own iou/3 facts), at least 20000, at most 30000, once 50
    # assignments were made; the fixed run keeps 30000 throughout.
    made = []
    for p, h in learned:
        expected = 30000
        if len(made) >= GATE_MIN_MATCHES:
            median = sorted(made)[(len(made) + 1) // 2 - 1] // 1000 * 1000 + 500
            expected = min(30000, max(20000, 40 * median // 100))
        assert resolve_constants(p)["iou_thresh"] == expected
        ml = dict(((t, d), v) for t, d, v in p.iou)
        made += [ml[a] for a in h.assignments]
    assert all(resolve_constants(p)["iou_thresh"] == 30000 for p, _ in fixed)
    last, answer = learned[-1]
    gate = resolve_constants(last)["iou_thresh"]
    assert gate < 30000
    # The median likelihood is about 0.675 (the squares' and the tall boxes' alternate), so the
    # learned gate is about 27000.  At the last frame the tall box is 27 px to the right: its
    # likelihood with the prediction (read from the problem) lies between the learned gate and 0.3.  The learned gate lets trk_1 take it; the fixed one does not, and
    # the walker is halted and a second track started on the same person.
    ((_, _, ml),) = last.iou
    assert gate < ml <= 30000
    assert answer.assignments == (("trk_1", "det_0"),)
    assert fixed[-1][1].assignments == () and fixed[-1][1].starts == ("det_0",)


def test_the_option_is_parsed_as_a_percent():
    assert TrackerOptions.from_mapping({"learned_gate": "40"}).learned_gate == 40
    with pytest.raises(ValueError, match="learned_gate must be a confidence 0..100"):
        TrackerOptions.from_mapping({"learned_gate": 140})


def test_refimpl_diff_re_solves_the_learned_gates_frames_with_clingo_alike():
    # The diff tracks with a preset's setup (diff_sequence(setup=...)); every frame problem carries
    # its gate as #const iou_thresh, and clingo gives the CP-SAT tracker's answer on every frame,
    # the last one (assigned only under the learned gate) included.
    pytest.importorskip("clingo")
    from refimpl.io import DetectionFrame, DetectionSequence
    from refimpl.runs.diff import diff_sequence
    from refimpl.tracking.pipeline import run_sequence
    from tracking_helpers import setup_with

    frames = tuple(DetectionFrame(f, b, np.array([0.95]), c, t)
                   for f, b, c, t in _wandering_walker(GATE_MIN_MATCHES + 12, 27.0))
    seq = DetectionSequence(name="walker", frames=frames, first_frame=0, image_size=(640, 480), fps=None)
    setup = setup_with("cpsat", learned_gate=40)
    report = diff_sequence(seq, ("cpsat", "clingo"), setup=setup)
    assert (report.frames, report.disagreements, report.divergences) == (GATE_MIN_MATCHES + 12, 0, [])
    assert len(run_sequence(seq, setup).tracks) == 1  # one person, one track (without the gate: two)
    assert len(run_sequence(seq, setup_with("cpsat")).tracks) == 2
