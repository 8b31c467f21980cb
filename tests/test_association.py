"""Association tests: the same frames and the same expected answers for every backend.

The clingo backend (model/*.lp) and the CP-SAT backend (refimpl/solvers/cpsat.py) implement
one model (docs/model-spec.md); each test here runs on both and compares answers as sorted
atom strings (Hypothesis.answer = actions + events).

The rule tests build small frames where the answer that breaks the rule would otherwise be
optimal, and check that the rule holds.  Unless a test says otherwise: curr_time = 10, default
constants (model/constants.lp), boxes far from the image border (img_width = img_height = 0, so
only the left and top borders count), and IoU facts chosen freely (the model takes the
matching likelihood from iou/3, the spatial relations from box2d/5).
"""

from __future__ import annotations

import random
from pathlib import Path

import pytest

from refimpl.solvers.check import check_answer
from refimpl.core.constants import default_constants
from refimpl.core.hypothesis import Hypothesis, parse_action
from plain_tiebreak import event_index, largest_index, pair_index, plain_level0, shift
from refimpl.solvers import NoAdmissibleHypothesis, SolverUnavailable, get_solver
from refimpl.core.spec import Detection, FrameProblem, HistoryEvent, TrackPrediction, write_facts
from refimpl.core.facts import parse_facts, parse_term, read_problem

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "data" / "examples"
PRIORITIES = (10, 5, 3, 2, 1, 0)


def solver_for(backend: str):
    try:
        return get_solver(backend)
    except SolverUnavailable as exc:
        pytest.skip(str(exc))


def solve(backend: str, problem: FrameProblem, **kw) -> Hypothesis:
    """Solve, and pass the answer through the independent checker: no rule broken, cost as claimed."""
    hyp = solver_for(backend).solve(problem, **kw)
    report = check_answer(problem, hyp)
    assert report.ok, report.messages
    assert report.cost == hyp.cost
    return hyp


# --- frame building -------------------------------------------------------------------------

MID = (300, 300, 50, 50)  # a box far from every border
LEAVING = (-30, 300, 50, 50)  # at the left border, 20 of its 50 columns inside: 40 % <= leave_visible 75 %


def det(i: int, box=MID, typ: str = "car", conf: int = 90) -> Detection:
    return Detection(f"det_{i}", typ, conf, box)


def trk(i: int, state: str = "active", box=MID, typ: str = "car") -> TrackPrediction:
    return TrackPrediction(f"trk_{i}", typ, state, box)


def hist(event: str, t: int) -> HistoryEvent:
    return HistoryEvent(parse_term(event), t)


def frame(dets=(), trks=(), iou=(), history=(), constants=(), time=10, match_types=()) -> FrameProblem:
    return FrameProblem(time=time, detections=tuple(dets), tracks=tuple(trks), iou=tuple(iou),
                        constants=tuple(constants), history=tuple(history),
                        match_types=tuple(match_types))


def ev(event: str, t: int = 10) -> str:
    return f"occurs_at({event},{t})"


def check_well_formed(problem: FrameProblem, h: Hypothesis) -> None:
    """Exactly one action per track and per detection; the cost vector has every level of PRIORITIES."""
    assert tuple(p for p, _ in h.cost) == PRIORITIES
    per_trk = {t.id: 0 for t in problem.tracks}
    per_det = {d.id: 0 for d in problem.detections}
    for atom in h.actions:
        name, args = parse_action(atom)
        if name in ("assign", "resume"):
            per_trk[args[0]] += 1
            per_det[args[1]] += 1
        elif name in ("start", "ignore_det"):
            per_det[args[0]] += 1
        else:
            per_trk[args[0]] += 1
    assert set(per_trk.values()) <= {1} and set(per_det.values()) <= {1}
    assert all(e.startswith("occurs_at(") and e.endswith(f",{problem.time})") for e in h.events)
    assert " " not in "".join(h.answer)


# =============================================================================================
# 1-3. The paper's frames
# =============================================================================================

def test_bus_t235_car_hides_behind_bus(backend):
    problem = read_problem(str(EXAMPLES / "bus_t235.lp"))
    h = solve(backend, problem)
    check_well_formed(problem, h)
    assert h.optimal
    # The paper's answer, plus start(det_5): det_5 is a traffic light that overlaps no track
    # (no iou/3 fact), so it can be neither assigned nor resumed; conf 59 > conf_thresh_new_track
    # = 40 and area 21*44 = 924 > size_threshold = 100 allow a start, and a start (5@2 plus
    # enters_fov 1@1) is cheaper than ignore_det (10@3).
    assert h.actions == tuple(sorted([
        "halt(trk_13)", "assign(trk_15,det_0)", "assign(trk_12,det_1)", "assign(trk_8,det_2)",
        "assign(trk_3,det_3)", "assign(trk_7,det_4)", "start(det_5)"]))
    assert h.events == tuple(sorted([
        "occurs_at(hides_behind(trk_13,trk_12),235)", "occurs_at(enters_fov(det_5),235)"]))
    # @10: -(82426 + 88079 + 98532 + 94981 + 90457 + 5 assigns) = -(454475 + 5) = -454480
    # @3:  nothing ignored                                      = 0
    # @2:  start(det_5)                                         = 5
    # @1:  hides_behind 1 + enters_fov 1                        = 2
    # @0:  the canonical tie-break (refimpl/solvers/common.py): the five admissible pairs are
    #      five components ((trk_13,det_1) is below iou_thresh), each pair 2^0: 5, shifted by
    #      E = bit length of the largest indices: trk_12 and trk_13 overlap (their arity-1
    #      events and each pair event of the other), four other tracks and six detections their
    #      arity-1 events only (today: 7 + 7 + 4 * 5 + 6 * 5 = 64 -> 7: 640); hides_behind(trk_13,
    #      trk_12) is trk_13's first pair event of its one candidate (today 6), enters_fov(det_5)
    #      det_5's arity-1 event (today 2)                                   = 648 today
    e = shift(largest_index(1), largest_index(1), *[largest_index()] * (4 + 6))
    level0 = (5 << e) + pair_index("hides_behind", 0, 1) + event_index("enters_fov")
    assert h.cost == ((10, -454480), (5, 0), (3, 0), (2, 5), (1, 2), (0, level0))


def test_bus_t268_car_unhides_from_behind_bus(backend):
    problem = read_problem(str(EXAMPLES / "bus_t268.lp"))
    h = solve(backend, problem)
    check_well_formed(problem, h)
    assert h.optimal
    # exactly the paper's answer (Section 4.1.1)
    assert h.actions == tuple(sorted([
        "resume(trk_13,det_1)", "assign(trk_15,det_0)", "assign(trk_12,det_2)",
        "assign(trk_7,det_3)", "assign(trk_8,det_4)", "assign(trk_3,det_5)"]))
    assert h.events == ("occurs_at(unhides_from_behind(trk_13,trk_12),268)",)
    # @10: the five assigns and the resume (docs/model.md 3.15), each IoU + 1:
    #      -(89636 + 97815 + 95528 + 93506 + 94945 + 76713 + 6) = -548149
    # @5: empty; @2: nothing ended or started; @1: unhides_from_behind = 1
    # @0: the canonical tie-break by its plain definition (tests/plain_tiebreak.py)
    assert h.cost == ((10, -548149), (5, 0), (3, 0), (2, 0), (1, 1), (0, plain_level0(problem, h.actions, h.events)))


def test_kitti_0020_t79(backend):
    problem = read_problem(str(EXAMPLES / "kitti_0020_t79.lp"))
    h = solve(backend, problem)
    check_well_formed(problem, h)
    assert h.optimal
    assert h.actions == tuple(sorted([
        "assign(trk_1,det_1)", "assign(trk_4,det_7)", "assign(trk_5,det_4)", "assign(trk_6,det_2)",
        "assign(trk_7,det_8)", "assign(trk_11,det_0)", "assign(trk_12,det_3)", "assign(trk_13,det_5)",
        # trk_0 (halted, clipped since 70): its only candidate det_0 (resume IoU 0.35) is worth
        # more assigned to trk_11 (IoU 0.83, @10). Ending (5@2) beats ignoring (10@3); its box
        # (-42, 227, 249, 159) starts at x=-42 (near the border) but 207 of its 249 columns are
        # inside (83 % > leave_visible 75 %: it has not left, docs/model.md 3.25), so lost
        # (79-70 = 9 >= lost_after_missing = 3, cost 3) explains it.
        "end(trk_0)",
        # trk_9 (halted, clipped since 69): resume IoU with det_2 is 0.076 <= 0.1; not near a
        # border; 79-69 = 10 >= lost_after_missing = 3, but trk_6's predicted box covers it from
        # the front (overlapping_top: docs/model.md 3.14), so it is kept in mind and ignored; being
        # clipped, its ignore is re-explained (explain_ignore, docs/model.md 3.16): trk_6's box
        # (245, 187, 182, 115) covers trk_9's (319, 184, 54, 41) over x 319..373, y 187..225:
        # 54 * 38 = 2052 of 2214 px (> 10 %), bottom 302 >= 225, so hides_behind(trk_9, trk_6).
        "ignore_trk(trk_9)",
        # det_10 (conf 40), det_11 (25), det_12 (22): conf <= conf_thresh_new_track = 40 and no
        # assignable track (IoUs <= 0.3), so they are ignored.
        "ignore_det(det_10)", "ignore_det(det_11)", "ignore_det(det_12)",
        # det_6 (conf 84; its IoU 0.307 with trk_7 loses to det_8's 0.863), det_9 (conf 46, area
        # 154), det_13 and det_14 (trucks: no car track may take them) start new tracks.
        "start(det_6)", "start(det_9)", "start(det_13)", "start(det_14)"]))
    assert h.events == tuple(sorted([
        "occurs_at(lost(trk_0),79)", "occurs_at(hides_behind(trk_9,trk_6),79)",
        "occurs_at(enters_fov(det_6),79)", "occurs_at(enters_fov(det_9),79)",
        "occurs_at(enters_fov(det_13),79)", "occurs_at(enters_fov(det_14),79)"]))
    # @10: -(96879 + 84365 + 94824 + 71071 + 86273 + 83400 + 90971 + 84391 + 8) = -692182
    # @3: (3 ignore_det + 1 ignore_trk) * 10 = 40;  @2: 1 end * 5 + 4 starts * 5 = 25
    # @1: lost 3 + hides_behind 1 + 4 enters_fov = 8
    # @0: the canonical tie-break by its plain definition (tests/plain_tiebreak.py)
    assert h.cost == ((10, -692182), (5, 0), (3, 40), (2, 25), (1, 8), (0, plain_level0(problem, h.actions, h.events)))


def test_bus_t268_file_is_canonical_and_its_ious_are_computed():
    import numpy as np

    from refimpl.core.geometry import iou_matrix, scale_iou

    path = EXAMPLES / "bus_t268.lp"
    text = path.read_text(encoding="utf-8")
    problem = read_problem(str(path))
    assert write_facts(problem) == text
    m = scale_iou(iou_matrix(np.array([t.box for t in problem.tracks]),
                             np.array([d.box for d in problem.detections])))
    expected = tuple((t.id, d.id, int(m[i, j])) for j, d in enumerate(problem.detections)
                     for i, t in enumerate(problem.tracks) if m[i, j] > 0)
    assert problem.iou == expected
    assert [str(h) for h in problem.history] == ["occurs_at(hides_behind(trk_13,trk_12),235)"]


# =============================================================================================
# 4. One frame per rule
# =============================================================================================

# --- assignment_constraints --------------------------------------------------------------------

@pytest.mark.parametrize("iou,assigned", [(29000, False), (30000, False), (30001, True)])
def test_assign_needs_iou_above_threshold(backend, iou, assigned):
    # assigning would raise @10 by iou+1, but iou must be > iou_thresh = 30000
    p = frame([det(1)], [trk(1)], [("trk_1", "det_1", iou)])
    h = solve(backend, p)
    check_well_formed(p, h)
    if assigned:
        assert h.answer == ("assign(trk_1,det_1)",)
        assert h.cost[0] == (10, -(iou + 1))
    else:
        assert h.answer == tuple(sorted([
            "halt(trk_1)", ev("missing_detections(trk_1)"), "start(det_1)", ev("enters_fov(det_1)")]))


def test_assign_needs_an_iou_fact(backend):
    # without iou/3 the pair has likelihood 0; assigning would still gain the @10 count
    p = frame([det(1)], [trk(1)])
    h = solve(backend, p)
    assert "assign(trk_1,det_1)" not in h.actions
    assert h.answer == tuple(sorted([
        "halt(trk_1)", ev("missing_detections(trk_1)"), "start(det_1)", ev("enters_fov(det_1)")]))


def test_halted_track_is_not_assigned(backend):
    # trk_1 halted (clipped at 9); det_1 has conf 20: no resume (<= 30), no start (<= 40);
    # assigning would gain @10 and save two ignores, but assign needs an active track
    p = frame([det(1, conf=20)], [trk(1, "halted")], [("trk_1", "det_1", 90000)],
              [hist("missing_detections(trk_1)", 9)])
    h = solve(backend, p)
    check_well_formed(p, h)
    assert h.answer == ("ignore_det(det_1)", "ignore_trk(trk_1)")
    assert h.cost == ((10, 0), (5, 0), (3, 20), (2, 0), (1, 0), (0, 0))


def test_assign_needs_matching_types(backend):
    p = frame([det(1, typ="person")], [trk(1, typ="car")], [("trk_1", "det_1", 90000)])
    h = solve(backend, p)
    assert h.answer == tuple(sorted([
        "halt(trk_1)", ev("missing_detections(trk_1)"), "start(det_1)", ev("enters_fov(det_1)")]))


def test_match_type_fact_allows_other_types_one_way(backend):
    p = frame([det(1, typ="truck")], [trk(1, typ="car")], [("trk_1", "det_1", 90000)],
              match_types=[("car", "truck")])
    assert solve(backend, p).answer == ("assign(trk_1,det_1)",)
    # match_type(TrkType, DetType) is not symmetric
    p = frame([det(1, typ="truck")], [trk(1, typ="car")], [("trk_1", "det_1", 90000)],
              match_types=[("truck", "car")])
    assert "assign(trk_1,det_1)" not in solve(backend, p).actions


def test_assign_needs_confidence_above_threshold(backend):
    # conf 0 is not > conf_thresh_assign = 0
    p = frame([det(1, conf=0)], [trk(1)], [("trk_1", "det_1", 90000)])
    h = solve(backend, p)
    assert h.answer == tuple(sorted(["halt(trk_1)", ev("missing_detections(trk_1)"), "ignore_det(det_1)"]))
    p = frame([det(1, conf=1)], [trk(1)], [("trk_1", "det_1", 90000)])
    assert solve(backend, p).answer == ("assign(trk_1,det_1)",)


# --- resume_constraints -------------------------------------------------------------------------

def _halted_clipped(det_conf=90, iou=50000, det_typ="car"):
    # trk_1 halted at 9 by missing_detections (clipped; lost needs 10-9 >= 3: not yet)
    return frame([det(1, typ=det_typ, conf=det_conf)], [trk(1, "halted")], [("trk_1", "det_1", iou)],
                 [hist("missing_detections(trk_1)", 9)])


def test_resume_of_a_clipped_halted_track_is_explained_by_recover(backend):
    p = _halted_clipped()
    h = solve(backend, p)
    assert h.answer == tuple(sorted(["resume(trk_1,det_1)", ev("recover(trk_1)")]))
    # @10: the resume, IoU + 1 = -50001 (docs/model.md 3.15); @1: recover 2; @0: the pair
    # (trk_1,det_1) is 2^0 of its component, shifted by E = bit length of the two nodes' largest
    # indices (no pair events: their arity-1 events only; 5 + 5 = 10 -> 4 with today's six), plus
    # recover's index at trk_1 (1: missing_detections, recover, ...)
    level0 = (1 << shift(largest_index(), largest_index())) + event_index("recover")
    assert h.cost == ((10, -50001), (5, 0), (3, 0), (2, 0), (1, 2), (0, level0))


@pytest.mark.parametrize("offset,resumed", [(0, False), (1, True)])
def test_resume_needs_confidence_above_threshold(backend, offset, resumed):
    # conf_thresh_resume (50) > conf_thresh_new_track (40): at conf 50 the detection starts a new
    # track (5@2) and the halted track is ignored (10@3), which the resume (1@2) would have beaten
    conf = default_constants()["conf_thresh_resume"] + offset
    h = solve(backend, _halted_clipped(det_conf=conf))
    if resumed:
        assert "resume(trk_1,det_1)" in h.actions
    else:
        assert "resume(trk_1,det_1)" not in h.actions
        assert {"start(det_1)", "ignore_trk(trk_1)"} <= set(h.actions)


@pytest.mark.parametrize("iou,resumed", [(10000, False), (10001, True)])
def test_resume_needs_iou_above_threshold(backend, iou, resumed):
    h = solve(backend, _halted_clipped(iou=iou))
    if resumed:
        assert h.answer == tuple(sorted(["resume(trk_1,det_1)", ev("recover(trk_1)")]))
    else:
        assert h.answer == tuple(sorted(["start(det_1)", ev("enters_fov(det_1)"), "ignore_trk(trk_1)"]))


def test_resume_needs_matching_types(backend):
    h = solve(backend, _halted_clipped(det_typ="person"))
    assert h.answer == tuple(sorted(["start(det_1)", ev("enters_fov(det_1)"), "ignore_trk(trk_1)"]))


def test_resume_needs_a_halted_track(backend):
    # trk_1 is active but clipped by a (hand-written) history, so it cannot be halted
    # (missing_detections needs clipped = false; nothing overlaps it for hides_behind).
    # resume(trk_1,det_1) explained by recover would be the only answer, but resume needs a
    # halted track and assign needs IoU > 0.3: no admissible hypothesis.
    p = frame([det(1)], [trk(1)], [("trk_1", "det_1", 20000)], [hist("missing_detections(trk_1)", 5)])
    with pytest.raises(NoAdmissibleHypothesis):
        solve(backend, p)


# --- resume_claimed (refimpl rule, docs/model.md 3.29) ---------------------------------------------

def _claimed_frame(halted_at: int, claim_iou: int = 60000, better: int | None = None):
    # trk_1 active, trk_2 halted at `halted_at` by missing_detections; det_0 overlaps trk_1 by
    # claim_iou and trk_2 by 0.9.  With `better`, det_1 overlaps trk_1 by that much (and nothing else).
    dets = [det(0)] + ([det(1, box=(600, 300, 50, 50))] if better is not None else [])
    iou = [("trk_1", "det_0", claim_iou), ("trk_2", "det_0", 90000)]
    iou += [("trk_1", "det_1", better)] if better is not None else []
    return frame(dets, [trk(1), trk(2, "halted")], iou, [hist("missing_detections(trk_2)", halted_at)])


@pytest.mark.parametrize("halted_at,claim_iou,better,resumed", [
    (7, 60000, None, False),   # 10 - 7 = 3 >= claim_after 3, det_0 is trk_1's best at 0.6 > 0.5: claimed
    (8, 60000, None, True),    # 10 - 8 = 2 < 3: a track just missed competes for it
    (7, 50000, None, True),    # exactly 0.5 is not above iou_thresh_claim 50000: not claimed
    (7, 60000, 80000, True),   # trk_1's best is det_1 (0.8): det_0 is not claimed
])
def test_a_detection_that_continues_an_active_track_is_not_taken_by_a_track_halted_a_while(
        backend, halted_at, claim_iou, better, resumed):
    # Level 10 sums IoU + 1 over the pair actions: resume(trk_2,det_0) with halt(trk_1) gives
    # 90001 against assign(trk_1,det_0)'s claim_iou + 1 (det_1, if any, goes to trk_1 either way),
    # so wherever the resume is admissible it is taken; where [resume_claimed] forbids it, trk_1
    # keeps det_0 and trk_2 does not resume.
    h = solve(backend, _claimed_frame(halted_at, claim_iou, better))
    assert ("resume(trk_2,det_0)" in h.actions) is resumed
    if resumed:
        assert ("halt(trk_1)" in h.actions) is (better is None)
    else:
        assert "assign(trk_1,det_0)" in h.actions
    if better is not None:
        assert "assign(trk_1,det_1)" in h.actions


# --- stale_likelihood (refimpl decision, docs/model.md 3.31) -------------------------------------

@pytest.mark.parametrize("halving,halted_at,resumed,level10", [
    (0, 4, True, -90001),     # not weighed (the paper): resume 90000 + 1 against assign 60000 + 1
    (10, 9, True, -81819),    # 1 frame since the halt: 90000 x 10 // 11 = 81818 > 60000
    (10, 6, True, -64286),    # 4 frames: 90000 x 10 // 14 = 64285 > 60000
    (10, 4, False, -60001),   # 6 frames: 90000 x 10 // 16 = 56250 < 60000: the active track keeps det_0
])
def test_a_resume_weighs_less_the_longer_its_track_went_unseen(backend, halving, halted_at, resumed, level10):
    # trk_1 active overlaps det_0 by 0.6, trk_2 halted (missing_detections at halted_at) by 0.9;
    # resume_claimed is off (iou_thresh_claim 100000), so only level 10 decides: each answer has one
    # pair action (count 1), and its matching likelihood is the IoU, a halted track's times
    # H / (H + 10 - halted_at) with H = likelihood_halving
    p = frame([det(0)], [trk(1), trk(2, "halted")], [("trk_1", "det_0", 60000), ("trk_2", "det_0", 90000)],
              [hist("missing_detections(trk_2)", halted_at)],
              constants=[("likelihood_halving", halving), ("iou_thresh_claim", 100000)])
    h = solve(backend, p)
    assert ("resume(trk_2,det_0)" in h.actions) is resumed
    assert ("assign(trk_1,det_0)" in h.actions) is not resumed
    assert dict(h.cost)[10] == level10


# --- glimpse (refimpl decision, docs/model.md 3.32) ----------------------------------------------

@pytest.mark.parametrize("glimpse_frames,started_at,resumed", [
    (1, 8, False),   # halted at 9, 9 - 8 = 1 <= 1: seen in one frame, a glimpse
    (1, 7, True),    # 9 - 7 = 2 > 1: seen in two frames, resumed as before
    (2, 7, False),   # 2 <= 2: a glimpse at the larger bound
    (0, 8, True),    # 0: no glimpse, the paper's resume
])
def test_a_track_seen_in_one_frame_is_not_resumed_and_leaves_its_place_to_a_start(
        backend, glimpse_frames, started_at, resumed):
    # trk_2 entered at started_at, was missed at 9 and det_0 (conf 90) overlaps its prediction by
    # 0.9.  Where it may resume, the resume is taken (level 10: 90000 + 1 against 0).  Where it is a
    # glimpse it may neither resume nor, by [start_occupied] (0.9 > iou_thresh_occupied 0.5), keep
    # det_0 from starting: det_0 starts (enters_fov, level 2) rather than being ignored (10 at level 3).
    p = frame([det(0)], [trk(2, "halted")], [("trk_2", "det_0", 90000)],
              [hist("enters_fov(trk_2)", started_at), hist("missing_detections(trk_2)", 9)],
              constants=[("glimpse_frames", glimpse_frames)])
    h = solve(backend, p)
    assert ("resume(trk_2,det_0)" in h.actions) is resumed
    assert ("start(det_0)" in h.actions) is not resumed
    assert dict(h.cost)[10] == (-90001 if resumed else 0)


# --- start_constraints ---------------------------------------------------------------------------

@pytest.mark.parametrize("conf,started", [(40, False), (41, True)])
def test_start_needs_confidence_above_threshold(backend, conf, started):
    p = frame([det(1, conf=conf)])
    h = solve(backend, p)
    if started:
        assert h.answer == ("occurs_at(enters_fov(det_1),10)", "start(det_1)")
        # @0: enters_fov's index at det_1 (2: missing_detections, recover, enters_fov, ...)
        assert h.cost == ((10, 0), (5, 0), (3, 0), (2, 5), (1, 1), (0, event_index("enters_fov")))
    else:
        assert h.answer == ("ignore_det(det_1)",)
        assert h.cost == ((10, 0), (5, 0), (3, 10), (2, 0), (1, 0), (0, 0))


@pytest.mark.parametrize("box,started", [((300, 300, 10, 10), False), ((300, 300, 101, 1), True),
                                         ((300, 300, 1, 100), False)])
def test_start_needs_area_above_size_threshold(backend, box, started):
    p = frame([det(1, box=box)])
    h = solve(backend, p)
    assert h.answer == (("occurs_at(enters_fov(det_1),10)", "start(det_1)") if started
                        else ("ignore_det(det_1)",))


@pytest.mark.parametrize("typ,iou_value,started", [
    ("car", 66667, False),         # (110,100,50,50) on trk_1's (100,100,50,50): 2000 / 3000 > 0.5
    ("car", 50000, True),          # exactly 0.5 is not more than iou_thresh_occupied 50000
    ("car", 33333, True),          # (125,100,50,50): 1250 / 3750, a car beside it may be new
    ("pedestrian", 66667, True),   # no track of its type is there (match_type)
])
def test_a_new_track_does_not_start_where_a_track_of_its_type_is(backend, typ, iou_value, started):
    # refimpl rule [start_occupied] (docs/model.md 3.21).  trk_1 takes det_0, its own box (IoU 1);
    # det_1 (conf 90 > 40, area 2500 > 100) overlaps trk_1 by iou_value: above 0.5 it is trk_1
    # seen twice and is ignored (10@3), else it starts (5@2, enters_fov 1@1).
    p = frame([det(0, box=(100, 100, 50, 50)), det(1, box=(110, 100, 50, 50), typ=typ)],
              [trk(1, box=(100, 100, 50, 50))],
              [("trk_1", "det_0", 100000), ("trk_1", "det_1", iou_value)])
    h = solve(backend, p)
    assert "assign(trk_1,det_0)" in h.actions
    assert ("start(det_1)" in h.actions) is started
    assert ("ignore_det(det_1)" in h.actions) is not started
    assert [c for p_, c in h.cost if p_ in (3, 2)] == ([0, 5] if started else [10, 0])


# --- end_constraints, ignore_trk_constraints, halt_constraints -------------------------------------

def test_active_track_is_neither_ended_nor_ignored(backend):
    # trk_1 is active, clipped by history (cannot be halted: missing_detections needs
    # clipped = false), near the left border (leaves_fov could explain an end) and has no
    # detection. end + leaves_fov, or ignore_trk, would be admissible without end_constraints /
    # ignore_trk_constraints; with them there is no admissible hypothesis.
    p = frame([], [trk(1, box=LEAVING)], [], [hist("missing_detections(trk_1)", 5)])
    with pytest.raises(NoAdmissibleHypothesis):
        solve(backend, p)


def test_halted_track_is_not_halted_again(backend):
    # halt + missing_detections (0@2, 2@1) would beat end + leaves_fov (5@2, 1@1)
    p = frame([], [trk(1, "halted", box=LEAVING)])
    h = solve(backend, p)
    assert h.answer == tuple(sorted(["end(trk_1)", ev("leaves_fov(trk_1)")]))
    # @0: leaves_fov's index at trk_1 (3: missing_detections, recover, enters_fov, leaves_fov)
    assert h.cost == ((10, 0), (5, 0), (3, 0), (2, 5), (1, 1), (0, event_index("leaves_fov")))


def test_unexplainable_end_does_not_happen_so_the_track_is_ignored(backend):
    # halted, not near a border, never started or halted in the history: no leaves_fov, lost or
    # noise can explain an end (5@2), so the track is ignored (10@3)
    p = frame([], [trk(1, "halted")])
    h = solve(backend, p)
    assert h.answer == ("ignore_trk(trk_1)",)
    assert h.cost == ((10, 0), (5, 0), (3, 10), (2, 0), (1, 0), (0, 0))


# --- explain_halt, poss_hides_behind, poss_missing_detections -----------------------------------

def _occlusion(front_box, history=(), constants=()):
    # trk_1 has no detection; trk_2 (front_box) is assigned det_2
    return frame([det(2, box=front_box)], [trk(1, box=(100, 100, 50, 50)), trk(2, box=front_box)],
                 [("trk_2", "det_2", 90000)], history, constants)


def test_halt_is_explained_by_hides_behind_an_overlapping_top_track(backend):
    # trk_2 (110,110,60,60) covers 40*40 = 1600 > 10% of trk_1's 2500 px^2, bottom 170 >= 150
    p = _occlusion((110, 110, 60, 60))
    h = solve(backend, p)
    assert h.answer == tuple(sorted(["assign(trk_2,det_2)", "halt(trk_1)",
                                     ev("hides_behind(trk_1,trk_2)")]))
    # @0: trk_1 and trk_2 overlap, so each has its arity-1 events and each pair event of the other
    # (largest index 7 with today's table), det_2 its arity-1 events (5): E = bit length of 19 = 5;
    # the pair (trk_2,det_2) is 2^0 << E = 32; hides_behind(trk_1,trk_2) is trk_1's first pair
    # event of its one candidate (6: after the six arity-1 events)
    e = shift(largest_index(1), largest_index(1), largest_index())
    assert h.cost == ((10, -90001), (5, 0), (3, 0), (2, 0), (1, 1), (0, (1 << e) + pair_index("hides_behind", 0, 1)))


@pytest.mark.parametrize("front_box", [
    (200, 200, 60, 60),   # no overlap
    (110, 60, 60, 60),    # overlaps, but its bottom edge 120 is above trk_1's 150: it is behind
    (145, 100, 50, 60),   # overlap 5*50 = 250: 100*250 = 25000 is not > 10*2500
])
def test_hides_behind_needs_overlapping_top(backend, front_box):
    h = solve(backend, _occlusion(front_box))
    assert h.answer == tuple(sorted(["assign(trk_2,det_2)", "halt(trk_1)",
                                     ev("missing_detections(trk_1)")]))


def test_hides_behind_needs_a_visible_occluder(backend):
    # trk_2 hid behind a track that no longer exists (history may name departed tracks): it is
    # not_visible, so trk_1 cannot hide behind it
    p = _occlusion((110, 110, 60, 60), [hist("hides_behind(trk_2,trk_9)", 5)])
    h = solve(backend, p)
    assert h.answer == tuple(sorted(["assign(trk_2,det_2)", "halt(trk_1)",
                                     ev("missing_detections(trk_1)")]))


def test_missing_detections_needs_an_unclipped_track(backend):
    # with cost_hides_behind = 5, missing_detections (2) would be the cheaper explanation...
    p = _occlusion((110, 110, 60, 60), constants=[("cost_hides_behind", 5)])
    assert ev("missing_detections(trk_1)") in solve(backend, p).events
    # ...but not for a track clipped by the history
    p = _occlusion((110, 110, 60, 60), [hist("missing_detections(trk_1)", 5)],
                   constants=[("cost_hides_behind", 5)])
    h = solve(backend, p)
    assert h.answer == tuple(sorted(["assign(trk_2,det_2)", "halt(trk_1)",
                                     ev("hides_behind(trk_1,trk_2)")]))


def test_hides_behind_prefers_the_occluder_covering_most(backend):
    # trk_2 and trk_3 both overlap-top trk_1; trk_3 covers more of it (tie-break r = 0)
    p = frame([det(2, box=(110, 110, 60, 60)), det(3, box=(90, 95, 70, 70))],
              [trk(1, box=(100, 100, 50, 50)), trk(2, box=(110, 110, 60, 60)), trk(3, box=(90, 95, 70, 70))],
              [("trk_2", "det_2", 90000), ("trk_3", "det_3", 90000)])
    h = solve(backend, p)
    assert h.events == (ev("hides_behind(trk_1,trk_3)"),)


# --- explain_resume, poss_unhides_from_behind, poss_recover ---------------------------------------

def _hidden(history, extra_tracks=()):
    # trk_1 (halted) has det_1 (IoU 0.5); trk_2 and trk_3 are active with their own detections
    tracks = [trk(1, "halted"), trk(2, box=(280, 290, 100, 100)), trk(3, box=(600, 600, 40, 40))]
    dets = [det(1), det(2, box=(280, 290, 100, 100)), det(3, box=(600, 600, 40, 40))]
    return frame(dets, tracks, [("trk_1", "det_1", 50000), ("trk_2", "det_2", 90000),
                                ("trk_3", "det_3", 90000)], history)


def test_resume_after_hiding_is_explained_by_unhides_from_behind_the_occluder(backend):
    h = solve(backend, _hidden([hist("hides_behind(trk_1,trk_2)", 5)]))
    assert "resume(trk_1,det_1)" in h.actions
    # hidden_by(trk_1,trk_2) = true: unhides (1) from trk_2, not from trk_3, rather than recover (2)
    assert h.events == (ev("unhides_from_behind(trk_1,trk_2)"),)


def test_unhides_needs_hidden_by(backend):
    # trk_1 was clipped, never hidden: the resume is explained by recover
    h = solve(backend, _hidden([hist("missing_detections(trk_1)", 8)]))
    assert "resume(trk_1,det_1)" in h.actions
    assert h.events == (ev("recover(trk_1)"),)


def test_unhides_needs_a_visible_occluder(backend):
    # trk_1 hid behind trk_2, then trk_2 hid behind trk_3: trk_2 is not_visible
    h = solve(backend, _hidden([hist("hides_behind(trk_1,trk_2)", 5), hist("hides_behind(trk_2,trk_3)", 6)]))
    assert "resume(trk_1,det_1)" in h.actions
    assert h.events == (ev("recover(trk_1)"),)


def test_unhides_and_recover_reset_the_fluents(backend):
    # hidden at 3, unhidden at 5, clipped at 7: hidden_by is false again, so only recover
    h = solve(backend, _hidden([hist("hides_behind(trk_1,trk_2)", 3), hist("unhides_from_behind(trk_1,trk_2)", 5),
                                hist("missing_detections(trk_1)", 7)]))
    assert h.events == (ev("recover(trk_1)"),)
    # hidden at 3, recovered at 5: visible, unclipped, not hidden_by: no explanation of a
    # resume; det_1 starts a new track (it cannot be assigned: trk_1 is halted). trk_1, halted at
    # 3 and visible, has 10 - 3 >= lost_after_missing = 3, but trk_2 (280,290,100,100) covers its
    # box (300,300,50,50) from the front (bottom 390 >= 350): kept in mind, so ignored, not lost
    h = solve(backend, _hidden([hist("hides_behind(trk_1,trk_2)", 3), hist("recover(trk_1)", 5)]))
    assert "resume(trk_1,det_1)" not in h.actions
    assert {"start(det_1)", "ignore_trk(trk_1)"} <= set(h.actions)
    assert set(h.events) == {ev("enters_fov(det_1)")}


def test_recover_needs_a_clipped_or_hidden_track(backend):
    # a halted track with no history is neither clipped nor not_visible: the resume (1@2)
    # cannot be explained, so det_1 starts (5@2) and trk_1 is ignored (10@3)
    p = frame([det(1)], [trk(1, "halted")], [("trk_1", "det_1", 50000)])
    h = solve(backend, p)
    assert h.answer == tuple(sorted(["start(det_1)", ev("enters_fov(det_1)"), "ignore_trk(trk_1)"]))


# --- explain_end, poss_leaves_fov, poss_lost, poss_noise -------------------------------------------

def _ended(box=MID, history=(), constants=(), time=10):
    return frame([], [trk(1, "halted", box=box)], [], history, constants, time)


ALONE = (("leave_visible", 100),)  # the border alone: every box counts as out of view (3.25)


@pytest.mark.parametrize("box,constants,leaves", [
    ((300, 300, 50, 50), ALONE, False),
    ((10, 300, 50, 50), ALONE, True),        # x <= border_margin
    ((300, 11, 50, 50), ALONE, False),       # y = 11 > border_margin
    ((300, 10, 50, 50), ALONE, True),
    ((1180, 300, 52, 50), ALONE, False),     # image width unknown: the right border is not tested
    ((1180, 300, 52, 50), (("img_width", 1242),) + ALONE, True),   # 1232 >= 1242 - 10
    ((1180, 300, 51, 50), (("img_width", 1242),) + ALONE, False),  # 1231 < 1232
    ((300, 300, 50, 50), (("img_height", 360),) + ALONE, True),    # 350 >= 360 - 10
    # docs/model.md 3.25, leave_visible 75: at most 75 % of the box inside the image
    ((10, 300, 50, 50), (), False),          # near the border, but all of it inside
    ((-13, 300, 50, 50), (), True),          # 37 of 50 columns inside: 100 * 37 * 50 <= 75 * 50 * 50
    ((-12, 300, 50, 50), (), False),         # 38 of 50: 76 % > 75 %
    ((1205, 300, 50, 50), (("img_width", 1242),), True),   # columns 1205..1241 inside: 37 of 50
    ((1204, 300, 50, 50), (("img_width", 1242),), False),  # 38 of 50
    ((1205, 300, 50, 50), (), False),        # image width unknown: the right border does not clip
    ((-13, -13, 50, 50), (), True),          # 37 x 37 of 50 x 50 inside: 54.8 %
    ((-13, 300, 50, 50), (("leave_visible", 0),), False),  # 0: only a box wholly outside
])
def test_leaves_fov_needs_near_border(backend, box, constants, leaves):
    h = solve(backend, _ended(box, constants=constants))
    if leaves:
        assert h.answer == tuple(sorted(["end(trk_1)", ev("leaves_fov(trk_1)")]))
    else:
        assert h.answer == ("ignore_trk(trk_1)",)


def test_leaves_fov_needs_in_fov(backend):
    near = LEAVING
    h = solve(backend, _ended(near, [hist("leaves_fov(trk_1)", 4)]))
    assert h.answer == ("ignore_trk(trk_1)",)
    # entering again makes in_fov true (enters_fov at 7 also starts it: noise needs 10-7 <= 3,
    # but leaves_fov is cheaper)
    h = solve(backend, _ended(near, [hist("leaves_fov(trk_1)", 4), hist("enters_fov(trk_1)", 7)]))
    assert h.answer == tuple(sorted(["end(trk_1)", ev("leaves_fov(trk_1)")]))


@pytest.mark.parametrize("event,halted,lost", [
    ("missing_detections(trk_1)", 37, True),   # 40 - 37 = 3 >= lost_after_missing = 3
    ("missing_detections(trk_1)", 38, False),
    ("hides_behind(trk_1,trk_2)", 37, False),  # not_visible: needs lost_after_hidden = 30
    ("hides_behind(trk_1,trk_2)", 10, True),   # 40 - 10 = 30
    ("hides_behind(trk_1,trk_2)", 11, False),
])
def test_lost_needs_enough_time_since_halting(backend, event, halted, lost):
    # trk_2 is an active track far away, with its own detection: it never covers trk_1, so a hidden
    # trk_1 is not kept in mind and lost_after_hidden applies
    p = frame([det(2, box=(600, 600, 40, 40))], [trk(1, "halted"), trk(2, box=(600, 600, 40, 40))],
              [("trk_2", "det_2", 90000)], [hist(event, halted)], time=40)
    h = solve(backend, p)
    if lost:
        assert h.answer == tuple(sorted(["assign(trk_2,det_2)", "end(trk_1)", ev("lost(trk_1)", 40)]))
        assert h.cost[1:5] == ((5, 0), (3, 0), (2, 5), (1, 3))
    else:
        assert h.answer == ("assign(trk_2,det_2)", "ignore_trk(trk_1)")


@pytest.mark.parametrize("history,lost", [
    # missing at 35, re-explained as hidden at 37 (3.16): still clipped (docs/model.md 3.18), so
    # the bound is lost_after_missing: 40 - 37 = 3 >= 3
    ((("missing_detections(trk_1)", 35), ("hides_behind(trk_1,trk_2)", 37)), True),
    ((("missing_detections(trk_1)", 36), ("hides_behind(trk_1,trk_2)", 38)), False),  # 2 < 3
    # the same, but it came back (unhides_from_behind at 5 resets clipped; so does recover) and
    # hid again directly at 37: not clipped, lost_after_hidden = 30 > 40 - 37
    ((("missing_detections(trk_1)", 3), ("hides_behind(trk_1,trk_2)", 4),
      ("unhides_from_behind(trk_1,trk_2)", 5), ("hides_behind(trk_1,trk_2)", 37)), False),
    ((("missing_detections(trk_1)", 3), ("hides_behind(trk_1,trk_2)", 4),
      ("recover(trk_1)", 5), ("hides_behind(trk_1,trk_2)", 37)), False),
    # ... and came back by unhides, then went missing at 37: clipped again, 3 >= 3
    ((("missing_detections(trk_1)", 3), ("hides_behind(trk_1,trk_2)", 4),
      ("unhides_from_behind(trk_1,trk_2)", 5), ("missing_detections(trk_1)", 37)), True),
])
def test_a_missing_track_re_explained_as_hidden_keeps_the_missing_bound(backend, history, lost):
    # as above: trk_2 is far away with its own detection, so trk_1 is not kept in mind
    p = frame([det(2, box=(600, 600, 40, 40))], [trk(1, "halted"), trk(2, box=(600, 600, 40, 40))],
              [("trk_2", "det_2", 90000)], [hist(e, t) for e, t in history], time=40)
    h = solve(backend, p)
    if lost:
        assert h.answer == tuple(sorted(["assign(trk_2,det_2)", "end(trk_1)", ev("lost(trk_1)", 40)]))
    else:
        assert h.answer == ("assign(trk_2,det_2)", "ignore_trk(trk_1)")


@pytest.mark.parametrize("halted,lost", [(-20, True), (-19, False)])
def test_history_naming_a_departed_track_and_before_mintime_still_applies(backend, halted, lost):
    # trk_1 hid behind trk_5, which no longer exists: visibility(trk_1) is still not_visible
    # (so lost needs lost_after_hidden = 30), and an event at or before mintime = -1 still
    # takes effect: 10 - (-20) = 30 >= 30, 10 - (-19) = 29 < 30
    h = solve(backend, _ended(history=[hist("hides_behind(trk_1,trk_5)", halted)]))
    if lost:
        assert h.answer == tuple(sorted(["end(trk_1)", ev("lost(trk_1)")]))
    else:
        assert h.answer == ("ignore_trk(trk_1)",)


def test_lost_counts_from_the_latest_halt(backend):
    # halted at 2, recovered at 3, halted again at 8: 10 - 8 = 2 < 3
    h = solve(backend, _ended(history=[hist("missing_detections(trk_1)", 2), hist("recover(trk_1)", 3),
                                       hist("missing_detections(trk_1)", 8)]))
    assert h.answer == ("ignore_trk(trk_1)",)


@pytest.mark.parametrize("started,noise", [(7, True), (6, False)])
def test_noise_only_for_young_tracks(backend, started, noise):
    # started at `started`, clipped at 9 (too recent for lost)
    history = [hist("enters_fov(trk_1)", started), hist("missing_detections(trk_1)", 9)]
    h = solve(backend, _ended(history=history))
    if noise:  # 10 - 7 = 3 <= noise_max_age = 3
        assert h.answer == tuple(sorted(["end(trk_1)", ev("noise(trk_1)")]))
        # @0: noise's index at trk_1 (5: missing_detections, recover, enters_fov, leaves_fov, lost, noise)
        assert h.cost == ((10, 0), (5, 0), (3, 0), (2, 5), (1, 2), (0, event_index("noise")))
    else:
        assert h.answer == ("ignore_trk(trk_1)",)


def test_end_takes_the_cheapest_explanation(backend):
    # leaves_fov (1), noise (2) and lost (3) are all possible
    history = [hist("enters_fov(trk_1)", 8), hist("missing_detections(trk_1)", 8)]
    p = _ended(LEAVING, history, time=11)
    h = solve(backend, p)
    assert h.answer == tuple(sorted(["end(trk_1)", ev("leaves_fov(trk_1)", 11)]))
    p = _ended(MID, history, time=11)
    assert solve(backend, p).events == (ev("noise(trk_1)", 11),)


# --- explain_start -------------------------------------------------------------------------------

def test_every_start_is_explained_by_enters_fov(backend):
    p = frame([det(i, box=(100 * i, 300, 50, 50)) for i in range(1, 4)])
    h = solve(backend, p)
    assert h.actions == ("start(det_1)", "start(det_2)", "start(det_3)")
    assert h.events == tuple(ev(f"enters_fov(det_{i})") for i in range(1, 4))
    # @0: enters_fov's index at each of the three detections (2): 3 * 2
    assert h.cost == ((10, 0), (5, 0), (3, 0), (2, 15), (1, 3), (0, 3 * event_index("enters_fov")))


# --- optimisation ----------------------------------------------------------------------------------

def test_iou_of_one_counts_likelihood_and_assignment_separately(backend):
    # @10 = -(sum of IoU + number of assignments), the two terms never merged
    p = frame([det(1)], [trk(1)], [("trk_1", "det_1", 100000)])
    assert solve(backend, p).cost[0] == (10, -100001)
    # a likelihood of exactly 1 (the weight of the count term) still counts twice: -(1 + 1)
    p = frame([det(1)], [trk(1)], [("trk_1", "det_1", 1)], [], [("iou_thresh", 0)])
    assert solve(backend, p).cost[0] == (10, -2)


def test_more_assignments_beat_a_higher_likelihood_sum_only_by_the_count(backend):
    # two tracks, two detections: the diagonal (0.5 + 0.5 + 2) beats a single 0.99 + 1
    p = frame([det(1), det(2)], [trk(1), trk(2)],
              [("trk_1", "det_1", 50000), ("trk_2", "det_2", 50000), ("trk_1", "det_2", 99000)])
    h = solve(backend, p)
    assert h.actions == ("assign(trk_1,det_1)", "assign(trk_2,det_2)")
    assert h.cost[0] == (10, -100002)


def test_empty_frame_reports_all_levels(backend):
    h = solve(backend, frame())
    assert h.answer == ()
    assert h.cost == ((10, 0), (5, 0), (3, 0), (2, 0), (1, 0), (0, 0))
    assert h.optimal


EQUAL_LIKELIHOOD_FACTS = """\
#const curr_time=1.
det(det_0, person, 90).
box2d(det_0, 100, 100, 50, 100).
trk(trk_a, person).
trk_state(trk_a, active).
box2d(trk_a, 100, 50, 50, 100).
trk(trk_b, person).
trk_state(trk_b, active).
box2d(trk_b, 100, 150, 50, 100).
trk(trk_c, person).
trk_state(trk_c, active).
box2d(trk_c, 60, 60, 50, 100).
iou(trk_a, det_0, 33333).
iou(trk_b, det_0, 33333).
iou(trk_c, det_0, 6383).
"""
"""Two tracks equally likely for one detection: trk_a 50 px above it, trk_b 50 px below (each
overlaps it 50 x 50 = 2500 px^2 of a union of 7500: IoU 33333), touching but not overlapping
each other.  trk_c (x 60-110, y 60-160) covers 10 x 90 = 900 px^2 of trk_a (18 % > hide_overlap
10 %) from the front (its bottom 160 >= trk_a's 150), none of trk_b worth counting (100 px^2), and
its IoU with det_0 (600 / 9400) is below iou_thresh."""


def test_equal_likelihoods_go_to_the_track_whose_halt_is_explained_cheaper(backend):
    # Above the event level both answers cost the same (one assignment of IoU 33333, two halts);
    # at the event level halting trk_a costs hides_behind(trk_a,trk_c) = 1, halting trk_b only
    # missing_detections = 2 (nothing covers it).  So trk_b takes the detection; trk_c has no
    # candidate detection and nothing in front of it: it halts as missing_detections (2).
    h = solve(backend, parse_facts(EQUAL_LIKELIHOOD_FACTS))
    assert h.actions == ("assign(trk_b,det_0)", "halt(trk_a)", "halt(trk_c)")
    assert h.events == ("occurs_at(hides_behind(trk_a,trk_c),1)", "occurs_at(missing_detections(trk_c),1)")
    assert dict(h.cost)[1] == 1 + 2
    assert h.optimal


# =============================================================================================
# 5. Constants from the problem
# =============================================================================================

_OVERRIDE_FACTS = """\
#const curr_time=10.
det(det_1, car, 90).
box2d(det_1, 300, 300, 50, 50).
trk(trk_1, car).
trk_state(trk_1, active).
box2d(trk_1, 305, 300, 50, 50).
iou(trk_1,det_1,25000).
"""


def test_const_in_the_fact_text_overrides_the_default(backend):
    default = solve(backend, parse_facts(_OVERRIDE_FACTS))
    assert "assign(trk_1,det_1)" not in default.actions  # 25000 <= 30000
    lowered = parse_facts(_OVERRIDE_FACTS.replace(
        "#const curr_time=10.\n", "#const curr_time=10.\n#const iou_thresh=20000.\n"))
    h = solve(backend, lowered)
    assert h.answer == ("assign(trk_1,det_1)",)
    assert h.cost[0] == (10, -25001)


# =============================================================================================
# 6. Time limits and inadmissible problems
# =============================================================================================

def _crowded(n: int = 40, seed: int = 7) -> FrameProblem:
    """n tracks and n detections in a tight crowd: many candidate pairs, many near-ties."""
    rng = random.Random(seed)
    tracks, dets, ious = [], [], []
    for i in range(n):
        x, y = 100 + rng.randrange(0, 400), 100 + rng.randrange(0, 200)
        tracks.append(trk(i, "active" if i % 5 else "halted", (x, y, 60, 60)))
        dets.append(det(i, (x + rng.randrange(-15, 16), y + rng.randrange(-15, 16), 60, 60),
                        conf=rng.randrange(20, 100)))
    from refimpl.core.geometry import intersection_area
    for t in tracks:
        for d in dets:
            inter = intersection_area(t.box, d.box)
            if inter > 0:
                ious.append((t.id, d.id, inter * 100000 // (2 * 3600 - inter)))
    history = [hist(f"missing_detections(trk_{i})", 5) for i in range(0, n, 5)]
    return frame(dets, tracks, ious, history)


def test_time_limit_returns_best_so_far_or_a_proven_answer(backend):
    p = _crowded()
    # no time at all: the best answer found in no time (e.g. CP-SAT's), or, when none was
    # found (clingo: grounding alone takes longer), NoAdmissibleHypothesis naming the limit
    try:
        h = solve(backend, p, time_limit=0.0)
        check_well_formed(p, h)
    except NoAdmissibleHypothesis as exc:
        assert "time limit" in str(exc)
    # 0.3 s is enough to find answers, not (for clingo) to prove one optimal
    h = solve(backend, p, time_limit=0.3)
    check_well_formed(p, h)
    assert isinstance(h.optimal, bool)
    assert h.solve_ms < 5000
    # a smaller crowd is solved to proven optimality (a dense 40 x 40 crowd takes clingo's
    # branch-and-bound some 30 s to prove, CP-SAT well under a second)
    small = _crowded(25)
    full = solve(backend, small, time_limit=60)
    assert full.optimal
    check_well_formed(small, full)


def test_unsatisfiable_problem_raises(backend):
    # an active track clipped by the history, with no detection and nothing to hide behind:
    # it cannot be assigned, halted (missing_detections needs clipped = false), ended or ignored
    p = frame([], [trk(1)], [], [hist("missing_detections(trk_1)", 5)])
    with pytest.raises(NoAdmissibleHypothesis) as info:
        solve(backend, p)
    assert "\n" not in str(info.value)


# --- level10_likelihood of a resume: evidence-based resume (docs/model.md 3.15) ----------------

@pytest.mark.parametrize("exact", [0, 1])
def test_resume_prefers_the_likelier_detection(backend, exact):
    # trk_1 halted at 9 (clipped). Two detections could resume it: det_<exact> lies exactly on its
    # prediction (IoU 1.0 = 100000), the other overlaps it at IoU 0.38. Levels 10..1 tie (one resume
    # + recover, one start + enters_fov) but for the likelihood, which level 10 maximises over the
    # resumes as over the assigns: the likelier pair wins whatever the id order.
    other = 1 - exact
    p = frame([det(0), det(1)], [trk(1, "halted")],
              [("trk_1", f"det_{exact}", 100000), ("trk_1", f"det_{other}", 38000)],
              [hist("missing_detections(trk_1)", 9)])
    h = solve(backend, p)
    assert h.answer == tuple(sorted([f"resume(trk_1,det_{exact})", ev("recover(trk_1)"),
                                     f"start(det_{other})", ev(f"enters_fov(det_{other})")]))
    # @10: -(100000 + 1); @2: start 5; @1: recover 2 + enters_fov 1;
    # @0 (the canonical tie-break): one component, pairs in natural order (trk_1,det_0) 2^0 and
    # (trk_1,det_1) 2^1, shifted by E = bit length of the three nodes' largest indices (arity-1
    # events only: 5 + 5 + 5 -> 4 with today's table); recover's index at trk_1 (1) and
    # enters_fov's at the other detection (2)
    e = shift(largest_index(), largest_index(), largest_index())
    level0 = ((1 << exact) << e) + event_index("recover") + event_index("enters_fov")
    assert h.cost == ((10, -100001), (5, 0), (3, 0), (2, 5), (1, 3), (0, level0))


def test_a_halted_track_on_a_detection_takes_it_from_a_track_that_overlaps_it_less(backend):
    # docs/model.md 3.15 (kitti-car-train 0009 under bursty misses, frames 79-83): trk_1, active,
    # overlaps det_1 at IoU 0.46; trk_2, halted (clipped at 9), is predicted on it at 0.70.  Level 10
    # weighs both pairs alike (IoU + 1): the resume, 70001, beats the assign, 46001 (the two cannot
    # both take det_1), so trk_2 resumes (recover) and trk_1 halts; with the resume's likelihood
    # below the assignments' (level 5, before 3.15) trk_1 kept det_1 and trk_2 stayed halted.
    p = frame([det(1, box=(115, 100, 50, 50))],
              [trk(1, box=(100, 100, 50, 50)), trk(2, "halted", box=(120, 100, 50, 50))],
              [("trk_1", "det_1", 46000), ("trk_2", "det_1", 70000)],
              [hist("missing_detections(trk_2)", 9)])
    h = solve(backend, p)
    check_well_formed(p, h)
    assert h.optimal
    assert {"resume(trk_2,det_1)", "halt(trk_1)"} == set(h.actions)
    assert ev("recover(trk_2)") in h.events
    assert dict(h.cost)[10] == -70001


# --- the matching likelihood weighed by the detection's confidence (docs/model.md 3.30) --------

@pytest.mark.parametrize("weight, taken, level10", [
    # likelihood_conf = 100: ML = IoU x conf / 100: det_1 62000 x 98 / 100 = 60760 beats
    # det_2 63000 x 64 / 100 = 40320; level 10 -(60760 + 1)
    (100, "det_1", -60761),
    # likelihood_conf = 0 (the paper's IoU alone, model/constants.lp): 63000 beats 62000; -(63000 + 1)
    (0, "det_2", -63001),
])
def test_of_two_detections_a_track_overlaps_alike_it_takes_the_surer_one(backend, weight, taken, level10):
    # kitti-car-train 0009 frame 34 under bursty misses: the track overlaps a confident detection
    # of its car (conf 98) at IoU 0.62 and a faint one of nothing labelled (conf 64) at 0.63.  The
    # detection the track does not take overlaps it above iou_thresh_occupied (0.5): it cannot
    # start ([start_occupied]) and is ignored (10 at level 3) either way; only level 10 differs.
    p = frame([det(1, conf=98), det(2, conf=64)], [trk(1)],
              [("trk_1", "det_1", 62000), ("trk_1", "det_2", 63000)],
              constants=[("likelihood_conf", weight)])
    h = solve(backend, p)
    other = "det_2" if taken == "det_1" else "det_1"
    assert h.actions == tuple(sorted([f"assign(trk_1,{taken})", f"ignore_det({other})"]))
    assert h.optimal and dict(h.cost)[10] == level10 and dict(h.cost)[3] == 10


def test_the_weighed_likelihood_is_computed_in_integers_as_clingo_divides(backend):
    # likelihood_conf = 50, conf 77, IoU 33333: 33333 x (10000 - 50 x (100 - 77)) / 10000
    # = 33333 x 8850 / 10000 = 294997050 / 10000 = 29499.705, truncated (every operand >= 0) to
    # 29499; level 10: -(29499 + 1)
    p = frame([det(1, conf=77)], [trk(1)], [("trk_1", "det_1", 33333)], constants=[("likelihood_conf", 50)])
    h = solve(backend, p)
    assert h.actions == ("assign(trk_1,det_1)",)
    assert dict(h.cost)[10] == -29500


# --- explain_ignore (docs/model.md 3.16) and anticipated_unhide (3.17) ------------------------

BUS = (200, 250, 300, 150)  # x 200..500, y 250..400: bottom edge 400


def test_an_ignored_missing_track_covered_from_the_front_is_re_explained_as_hidden(backend):
    # trk_1 halted at 9 by missing_detections (clipped), box (460, 320, 50, 60): bottom 380; the
    # active bus trk_2 (no detection: it halts too) covers x 460..500, y 320..380 = 2400 of 3000 px
    # (80 % > hide_overlap 10 %) and its bottom 400 >= 380: overlapping_top(trk_1, trk_2).
    # 10 - 9 = 1 < lost_after_missing: trk_1 cannot end, so it is ignored, and its ignore must be
    # re-explained: hides_behind(trk_1, trk_2).  trk_2 halts by missing_detections (nothing covers it).
    p = frame([], [trk(1, "halted", box=(460, 320, 50, 60)), trk(2, box=BUS)], [],
              [hist("missing_detections(trk_1)", 9)])
    h = solve(backend, p)
    assert h.answer == tuple(sorted(["ignore_trk(trk_1)", "halt(trk_2)", ev("hides_behind(trk_1,trk_2)"),
                                     ev("missing_detections(trk_2)")]))
    # @3: ignore_trk 10;  @1: hides_behind 1 + missing_detections 2 = 3
    assert [c for p_, c in h.cost if p_ in (3, 2, 1)] == [10, 0, 3]


def test_no_re_explanation_without_cover_or_for_a_hidden_track(backend):
    # the same track beside the bus (x 510..560: no overlap): ignored, nothing to explain
    p = frame([], [trk(1, "halted", box=(510, 320, 50, 60)), trk(2, box=BUS)], [],
              [hist("missing_detections(trk_1)", 9)])
    assert ev("hides_behind(trk_1,trk_2)") not in solve(backend, p).events
    # covered, but already re-explained at 9 (hides_behind made it not_visible; it stays clipped,
    # 3.18): hides_behind is not possible, so nothing is explained again
    p = frame([], [trk(1, "halted", box=(460, 320, 50, 60)), trk(2, box=BUS)], [],
              [hist("missing_detections(trk_1)", 8), hist("hides_behind(trk_1,trk_2)", 9)])
    h = solve(backend, p)
    assert "ignore_trk(trk_1)" in h.actions and ev("hides_behind(trk_1,trk_2)") not in h.events


@pytest.mark.parametrize("x,conf,resumed", [(480, 45, True), (480, 40, False), (470, 45, False), (470, 51, True)])
def test_a_track_anticipated_to_unhide_resumes_with_new_track_confidence(backend, x, conf, resumed):
    # trk_1 hid behind the bus trk_2 at 5; its predicted box (x, 320, 50, 60) against the bus
    # (x 200..500): x=480 leaves 20 of 50 px behind it, 2 * 1200 = 2400 <= 3000: at least half
    # is out, anticipated_unhide(trk_1); x=470: 30 px behind, 2 * 1800 = 3600 > 3000: not yet.
    # det_1 (conf 45 > conf_thresh_new_track 40, <= conf_thresh_resume 50) where trk_1 is predicted
    # (IoU 0.8): anticipated, it resumes trk_1 (unhides_from_behind); otherwise it cannot start a
    # track either, since trk_1 is where it is (IoU 0.8 > iou_thresh_occupied 0.5, [start_occupied],
    # 3.21): it is ignored.  conf 51 resumes in either case (conf_thresh_resume).  The bus keeps
    # its own detection det_2.
    p = frame([det(1, box=(x, 320, 50, 60), conf=conf), det(2, box=BUS)],
              [trk(1, "halted", box=(x, 320, 50, 60)), trk(2, box=BUS)],
              [("trk_1", "det_1", 80000), ("trk_2", "det_2", 100000)],
              [hist("hides_behind(trk_1,trk_2)", 5)])
    h = solve(backend, p)
    assert "assign(trk_2,det_2)" in h.actions
    if resumed:
        assert "resume(trk_1,det_1)" in h.actions and ev("unhides_from_behind(trk_1,trk_2)") in h.events
    else:  # not anticipated: neither resumed nor started (conf 40 could not start anyway)
        assert {"ignore_det(det_1)", "ignore_trk(trk_1)"} <= set(h.actions)


def test_the_checker_names_a_missing_re_explanation_and_an_unanticipated_weak_resume():
    p = frame([], [trk(1, "halted", box=(460, 320, 50, 60)), trk(2, box=BUS)], [],
              [hist("missing_detections(trk_1)", 9)])
    bare = Hypothesis(10, ("ignore_trk(trk_1)", "halt(trk_2)"), (ev("missing_detections(trk_2)"),), (), True)
    assert [v.rule for v in check_answer(p, bare).violations] == ["explain_ignore"]
    # a weak (conf 45) resume while trk_1 is still mostly behind the bus (x=470, see above)
    p = frame([det(1, box=(470, 320, 50, 60), conf=45)], [trk(1, "halted", box=(470, 320, 50, 60)), trk(2, box=BUS)],
              [("trk_1", "det_1", 80000)], [hist("hides_behind(trk_1,trk_2)", 5)])
    weak = Hypothesis(10, ("resume(trk_1,det_1)", "halt(trk_2)"),
                      (ev("unhides_from_behind(trk_1,trk_2)"), ev("missing_detections(trk_2)")), (), True)
    assert [v.rule for v in check_answer(p, weak).violations] == ["resume_constraints"]
