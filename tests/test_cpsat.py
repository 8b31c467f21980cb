"""CP-SAT backend specifics: the paper's example, lexicographic levels, determinism, time limits,
infeasible problems, the answer format."""

from __future__ import annotations

import random

import pytest

from framegen import random_frame
from refimpl.core.constants import resolve_constants
from refimpl.knowledge.events import EventState, poss
from refimpl.core.hypothesis import parse_action
from plain_tiebreak import event_index, largest_index, shift
from refimpl.solvers import NoAdmissibleHypothesis, SolveTimeout, get_solver
from refimpl.solvers.common import tiebreak_weights
from refimpl.solvers.cpsat import CpSatFailure, CpSatSolver, build_model, solve_lexicographic
from refimpl.core.spec import Detection, FrameProblem, HistoryEvent, TrackPrediction
from refimpl.core.facts import parse_term, read_problem


def H(event: str, t: int) -> HistoryEvent:
    return HistoryEvent(parse_term(event), t)


def check_admissible(problem: FrameProblem, hyp) -> None:
    """Exactly one action per track and detection, every event possible and explaining its action."""
    per: dict[str, int] = {}
    for a in hyp.actions:
        assert " " not in a
        _, args = parse_action(a)
        for x in args:
            per[x] = per.get(x, 0) + 1
    assert per == {x: 1 for x in [t.id for t in problem.tracks] + [d.id for d in problem.detections]}
    state = EventState.from_problem(problem)
    consts = resolve_constants(problem)
    for e in hyp.events:
        term = parse_term(e)
        assert term.name == "occurs_at" and term.args[1].as_int() == problem.time
        assert poss(term.args[0], problem, state, consts), e


# -- the paper's examples ----------------------------------------------------------------------

def test_bus_example_is_the_papers_answer(examples):
    p = read_problem(str(examples / "bus_t235.lp"))
    h = CpSatSolver().solve(p)
    assert h.optimal and h.backend == "cpsat" and h.solve_ms > 0
    assert {"halt(trk_13)", "assign(trk_15,det_0)", "assign(trk_12,det_1)", "assign(trk_8,det_2)",
            "assign(trk_3,det_3)", "assign(trk_7,det_4)"} <= set(h.actions)
    assert "occurs_at(hides_behind(trk_13,trk_12),235)" in h.events
    assert "start(det_5)" in h.actions and "occurs_at(enters_fov(det_5),235)" in h.events
    iou_sum = 82426 + 88079 + 98532 + 94981 + 90457
    # level 0 (refimpl/solvers/common.py): the assigned pairs' powers of two shifted by E, plus
    # the index of each explaining event among its first argument's events
    w = tiebreak_weights(p)
    tb = (sum(w.pair[tuple(parse_action(a)[1])] for a in h.actions if a.startswith("assign")) << w.shift) \
        + w.event["hides_behind(trk_13,trk_12)"] + w.event["enters_fov(det_5)"]
    assert len(h.events) == 2
    assert h.cost == ((10, -(iou_sum + 5)), (5, 0), (3, 0), (2, 5), (1, 2), (0, tb))
    check_admissible(p, h)


def test_kitti_example(examples):
    p = read_problem(str(examples / "kitti_0020_t79.lp"))
    h = get_solver("cpsat").solve(p)
    assert h.optimal
    check_admissible(p, h)
    assert [c[0] for c in h.cost] == [10, 5, 3, 2, 1, 0]


# -- lexicographic, not weighted -----------------------------------------------------------------

def _lex_problem() -> FrameProblem:
    """One active track, two detections it could take.  det_1 fits 1/100000 better, but taking it
    leaves det_0 (too unsure to start a track) ignored: 10@3.  Taking det_0 instead starts det_1:
    5@2 + 1@1.  Summed over levels the second is cheaper (-90001+6 < -90002+10); lexicographically
    level 10 decides."""
    return FrameProblem(
        time=7,
        detections=(Detection("det_0", "car", 30, (0, 0, 50, 50)), Detection("det_1", "car", 99, (60, 0, 50, 50))),
        tracks=(TrackPrediction("trk_1", "car", "active", (30, 0, 50, 50)),),
        iou=(("trk_1", "det_0", 90000), ("trk_1", "det_1", 90001)),
    )


def test_levels_are_lexicographic():
    h = CpSatSolver().solve(_lex_problem())
    assert h.actions == ("assign(trk_1,det_1)", "ignore_det(det_0)")
    assert h.events == ()
    # level 0: pairs (trk_1,det_0) -> 2^0, (trk_1,det_1) -> 2^1 (natural order in the one
    # component); E = bit length of the largest index sum: each of the 3 nodes has the arity-1
    # events only (no other track; with today's six, indices 0..5, so 3 * 5 = 15 -> E = 4);
    # assign(trk_1,det_1): 2 << E (32 today)
    e = shift(largest_index(), largest_index(), largest_index())
    assert h.cost == ((10, -90002), (5, 0), (3, 10), (2, 0), (1, 0), (0, 2 << e))
    assert h.optimal


def test_lower_levels_break_ties_of_higher_ones():
    # both halted tracks could end (5@2) or be ignored (10@3): level 3 decides for end; the end's
    # explanation is the cheapest possible event at level 1 (leaves_fov 1 < noise 2 < lost 3);
    # trk_1 is at the left border with 10 of its 20 columns inside (50 % <= leave_visible 75 %)
    p = FrameProblem(
        time=10,
        tracks=(TrackPrediction("trk_1", "car", "halted", (-10, 50, 20, 20)),
                TrackPrediction("trk_2", "car", "halted", (50, 50, 20, 20))),
        history=(H("enters_fov(trk_1)", 8), H("missing_detections(trk_1)", 2),
                 H("enters_fov(trk_2)", 8), H("missing_detections(trk_2)", 2)))
    h = CpSatSolver().solve(p)
    assert h.actions == ("end(trk_1)", "end(trk_2)")
    assert h.events == ("occurs_at(leaves_fov(trk_1),10)", "occurs_at(noise(trk_2),10)")
    # level 0: no pairs; event indices among the arity-1 events in EVENT_NAMES order
    # (missing_detections 0, recover 1, enters_fov 2, leaves_fov 3, lost 4, noise 5): 3 + 5
    assert h.cost == ((10, 0), (5, 0), (3, 0), (2, 10), (1, 3), (0, event_index("leaves_fov") + event_index("noise")))


# -- determinism -------------------------------------------------------------------------------

def _tie_problem() -> FrameProblem:
    """trk_1 hid behind trk_2 and trk_3 (a hand-written history): unhiding from either explains
    the resume equally well on levels 10..1; only the level-0 tie-break separates them."""
    return FrameProblem(
        time=20,
        detections=(Detection("det_0", "car", 90, (0, 0, 40, 40)),),
        tracks=(TrackPrediction("trk_1", "car", "halted", (0, 0, 40, 40)),
                TrackPrediction("trk_2", "car", "active", (200, 0, 40, 40)),
                TrackPrediction("trk_3", "car", "active", (300, 0, 40, 40))),
        iou=(("trk_1", "det_0", 80000),),
        history=(H("hides_behind(trk_1,trk_2)", 10), H("hides_behind(trk_1,trk_3)", 11)))


def test_deterministic_including_a_tie():
    p = _tie_problem()
    answers = {CpSatSolver().solve(p).answer for _ in range(3)}
    solver = CpSatSolver(seed=0)
    answers |= {solver.solve(p).answer for _ in range(2)}
    assert len(answers) == 1
    (ans,) = answers
    assert "resume(trk_1,det_0)" in ans
    # neither overlaps trk_1, both are named by its history: natural order, so
    # unhides_from_behind(trk_1,trk_2) has the smaller index: unhide from trk_2
    assert "occurs_at(unhides_from_behind(trk_1,trk_2),20)" in ans
    # without level 0 the two explanations tie: forcing either gives the same levels 10..1
    costs = {}
    for t2 in ("trk_2", "trk_3"):
        state = EventState.from_problem(p)
        am = build_model(p, state, resolve_constants(p))
        am.model.add(am.events[f"unhides_from_behind(trk_1,{t2})"] == 1)
        costs[t2] = solve_lexicographic(am, p).cost
    assert costs["trk_2"][:5] == costs["trk_3"][:5]
    assert costs["trk_3"][5][1] - costs["trk_2"][5][1] == 2 - 1


@pytest.mark.parametrize("seed", range(5))
def test_deterministic_on_random_frames(seed):
    rng = random.Random(seed)
    for _ in range(10):
        p = random_frame(rng)
        a = CpSatSolver().solve(p)
        b = CpSatSolver().solve(p)
        assert (a.answer, a.cost, a.optimal) == (b.answer, b.cost, b.optimal)


# -- time limits -------------------------------------------------------------------------------

@pytest.mark.parametrize("limit", [0.0, 1e-6, 1e-4, 1e-3, 0.01])
def test_time_limit_never_crashes(limit):
    rng = random.Random(7)
    solver = CpSatSolver()
    for _ in range(15):
        p = random_frame(rng, n_trk=(4, 6), n_det=(4, 6))
        ref = solver.solve(p)
        h = solver.solve(p, time_limit=limit)
        check_admissible(p, h)
        if h.optimal:
            assert (h.answer, h.cost) == (ref.answer, ref.cost)
        else:
            assert h.cost >= ref.cost  # lexicographically no better than the optimum


def test_time_limit_without_any_answer_is_reported_clearly():
    # feasible (each clipped active track takes its own detection) but nothing obvious to fall
    # back on, and no time at all to search: a clear CpSatFailure, not a crash or a wrong answer
    p = FrameProblem(
        time=5,
        detections=(Detection("det_0", "car", 90, (50, 50, 20, 20)), Detection("det_1", "car", 90, (150, 50, 20, 20))),
        tracks=(TrackPrediction("trk_1", "car", "active", (50, 50, 20, 20)),
                TrackPrediction("trk_2", "car", "active", (150, 50, 20, 20))),
        iou=(("trk_1", "det_0", 100000), ("trk_2", "det_1", 90000)),
        history=(H("missing_detections(trk_1)", 3), H("missing_detections(trk_2)", 3)))
    # no time: the obvious answer (halt both) would be the fallback, but clipped tracks cannot be
    # halted by missing_detections: SolveTimeout, one line
    with pytest.raises(SolveTimeout) as err:
        CpSatSolver().solve(p, time_limit=0.0)
    assert "time limit" in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(SolveTimeout):
        CpSatSolver(fast_path=False).solve(p, time_limit=0.0)
    h = CpSatSolver().solve(p)
    assert h.optimal and h.actions == ("assign(trk_1,det_0)", "assign(trk_2,det_1)")


def test_generous_time_limit_is_optimal(examples):
    p = read_problem(str(examples / "kitti_0020_t79.lp"))
    h = CpSatSolver().solve(p, time_limit=30.0)
    assert h.optimal and h.answer == CpSatSolver().solve(p).answer


# -- infeasible problems -----------------------------------------------------------------------

def test_no_admissible_hypothesis_for_a_clipped_active_track():
    p = FrameProblem(time=5, tracks=(TrackPrediction("trk_1", "car", "active", (50, 50, 20, 20)),),
                     history=(H("missing_detections(trk_1)", 3),))
    with pytest.raises(NoAdmissibleHypothesis) as err:
        CpSatSolver().solve(p)
    assert "\n" not in str(err.value) and "trk_1" in str(err.value)


def test_no_admissible_hypothesis_found_by_the_solver():
    # each clipped active track could take det_0, but not both: only search finds it infeasible
    p = FrameProblem(
        time=5,
        detections=(Detection("det_0", "car", 90, (50, 50, 20, 20)),),
        tracks=(TrackPrediction("trk_1", "car", "active", (50, 50, 20, 20)),
                TrackPrediction("trk_2", "car", "active", (150, 50, 20, 20))),  # apart: no hides_behind
        iou=(("trk_1", "det_0", 100000), ("trk_2", "det_0", 90000)),
        history=(H("missing_detections(trk_1)", 3), H("missing_detections(trk_2)", 3)))
    with pytest.raises(NoAdmissibleHypothesis) as err:
        CpSatSolver().solve(p)
    assert "INFEASIBLE" in str(err.value) and "\n" not in str(err.value)


# -- format and edge cases ---------------------------------------------------------------------

def test_empty_problem():
    h = CpSatSolver().solve(FrameProblem(time=3))
    assert h.actions == () and h.events == () and h.optimal
    assert h.cost == ((10, 0), (5, 0), (3, 0), (2, 0), (1, 0), (0, 0))


def test_answers_are_admissible_on_random_frames():
    rng = random.Random(11)
    n = 0
    for _ in range(60):
        p = random_frame(rng, with_history=True)
        try:
            h = CpSatSolver().solve(p)
        except NoAdmissibleHypothesis:
            continue
        n += 1
        check_admissible(p, h)
        assert h.optimal
    assert n > 20


def test_options():
    s = CpSatSolver(workers=2, seed=3, fast_path=True)
    assert (s.workers, s.seed, s.fast_path, s.name) == (2, 3, True, "cpsat")
    assert s.solve(_lex_problem()).answer == CpSatSolver().solve(_lex_problem()).answer
    with pytest.raises(ValueError):
        CpSatSolver(workers=0)


def test_state_argument_replaces_the_history():
    p = _tie_problem()
    empty = EventState([], [t.id for t in p.tracks])
    h = CpSatSolver().solve(p, state=empty)  # no history: trk_1 cannot be resumed
    assert not any(a.startswith("resume") for a in h.actions)
    assert "resume(trk_1,det_0)" in CpSatSolver().solve(p).actions
