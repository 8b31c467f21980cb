"""The independent answer checker (refimpl.check): every rule it guards, caught on tampered answers."""

from __future__ import annotations

import pytest

from plain_tiebreak import event_index, largest_index, pair_index, shift
from refimpl.check import check_answer
from refimpl.hypothesis import Hypothesis
from refimpl.spec import read_problem

# the optimal answer of the paper's bus frame (Section 4.1.1), as both backends give it
BUS_ACTIONS = ("assign(trk_12,det_1)", "assign(trk_15,det_0)", "assign(trk_3,det_3)", "assign(trk_7,det_4)",
               "assign(trk_8,det_2)", "halt(trk_13)", "start(det_5)")
BUS_EVENTS = ("occurs_at(enters_fov(det_5),235)", "occurs_at(hides_behind(trk_13,trk_12),235)")
# @10: -(82426 + 88079 + 98532 + 94981 + 90457 + 5 assigns); @2: one start; @1: hides 1 + enters 1
# @0 (the canonical tie-break, refimpl/solvers/common.py): the five admissible pairs are five
# components (iou(trk_13,det_1) is below iou_thresh), each pair 2^0: pair part 5.  E: every node
# has the arity-1 events; only trk_12 and trk_13 overlap, adding each pair event of the other:
# largest indices, with today's table, 7 + 7 + 4 * 5 (other tracks) + 6 * 5 (dets) = 64, bit
# length 7.  Events: hides_behind(trk_13,trk_12) is trk_13's first pair event of its one candidate
# (6: after the six arity-1 events), enters_fov(det_5) index 2 (missing_detections, recover, enters_fov).
_E = shift(largest_index(1), largest_index(1), *[largest_index()] * (4 + 6))
BUS_COST = ((10, -(82426 + 88079 + 98532 + 94981 + 90457 + 5)), (5, 0), (3, 0), (2, 5), (1, 2),
            (0, (5 << _E) + pair_index("hides_behind", 0, 1) + event_index("enters_fov")))


@pytest.fixture
def bus(examples):
    return read_problem(str(examples / "bus_t235.lp"))


def _hyp(actions=BUS_ACTIONS, events=BUS_EVENTS, cost=BUS_COST):
    return Hypothesis(235, tuple(actions), tuple(events), cost, optimal=True)


def _rules(problem, hyp):
    return {v.rule for v in check_answer(problem, hyp).violations}


def test_the_optimal_answer_passes_and_its_cost_is_recomputed(bus):
    report = check_answer(bus, _hyp())
    assert report.ok and report.cost == BUS_COST


def _swap(old, new, seq=BUS_ACTIONS):
    return tuple(new if a == old else a for a in seq)


@pytest.mark.parametrize("actions, events, rule", [
    # a track with two actions, a detection with none
    (BUS_ACTIONS + ("assign(trk_13,det_1)",), BUS_EVENTS, "actions_per_track"),
    (_swap("start(det_5)", "halt(trk_15)"), BUS_EVENTS[1:], "actions_per_detection"),
    # IoU(trk_13, det_1) = 3022 <= iou_thresh 30000
    (_swap("halt(trk_13)", "assign(trk_13,det_1)", _swap("assign(trk_12,det_1)", "halt(trk_12)")),
     BUS_EVENTS[:1] + ("occurs_at(missing_detections(trk_12),235)",), "assignment_constraints"),
    # resume needs a halted track
    (_swap("assign(trk_15,det_0)", "resume(trk_15,det_0)"), BUS_EVENTS + ("occurs_at(recover(trk_15),235)",),
     "resume_constraints"),
    # end and ignore_trk need a halted track, halt an active one
    (_swap("halt(trk_13)", "end(trk_13)"), BUS_EVENTS[:1] + ("occurs_at(leaves_fov(trk_13),235)",), "end_constraints"),
    (_swap("halt(trk_13)", "ignore_trk(trk_13)"), BUS_EVENTS[:1], "ignore_trk_constraints"),
    # an event whose precondition fails: trk_13 does not overlap trk_3
    (BUS_ACTIONS, BUS_EVENTS[:1] + ("occurs_at(hides_behind(trk_13,trk_3),235)",), "poss_hides_behind"),
    # a halt with no explanation, and an explanation without its action
    (BUS_ACTIONS, BUS_EVENTS[:1], "explain_halt"),
    (BUS_ACTIONS, BUS_EVENTS + ("occurs_at(missing_detections(trk_13),235)",), "explain_halt"),
    (BUS_ACTIONS, BUS_EVENTS[1:], "explain_start"),
])
def test_each_rule_is_reported_by_its_label(bus, actions, events, rule):
    assert rule in _rules(bus, _hyp(actions, events))


def test_start_below_the_confidence_threshold_is_reported(examples):
    # det_5 of the bus frame has confidence 59: with conf_thresh_new_track 60 its start is inadmissible
    from refimpl.spec import with_constants
    p = with_constants(read_problem(str(examples / "bus_t235.lp")), {"conf_thresh_new_track": 60})
    assert "start_constraints" in _rules(p, _hyp())


@pytest.mark.parametrize("event", [
    "occurs_at(unhides_from_behind(trk_13,trk_99),235)",  # unknown track
    "occurs_at(unhides_from_behind(trk_13),235)",  # wrong arity
    "occurs_at(enters_fov,235)",
    "occurs_at(teleports(trk_13),235)",
])
def test_malformed_events_are_reported_not_crashed_on(bus, event):
    report = check_answer(bus, _hyp(events=BUS_EVENTS + (event,)))
    assert not report.ok


def test_an_event_at_another_time_is_reported(bus):
    events = ("occurs_at(enters_fov(det_5),235)", "occurs_at(hides_behind(trk_13,trk_12),234)")
    assert "event_time" in _rules(bus, _hyp(events=events))
