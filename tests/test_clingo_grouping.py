"""How the clingo backend groups a frame's independent components into clingo calls (issue 38):
as few calls as the grounding cost allows (context tracks counted), a group closed before its sums
leave clingo's 32-bit range, and no frame refused that the grouping before (16 own nodes) solved."""

from __future__ import annotations

import pytest

from refimpl.core.ranges import OutOfClingoRange
from refimpl.core.spec import Detection, FrameProblem, TrackPrediction, with_constants
from refimpl.experiments.synthetic import synthetic_frame
from refimpl.solvers import get_solver
from refimpl.solvers.decompose import split

pytest.importorskip("clingo")
from refimpl.solvers.clingo_backend import (  # noqa: E402
    LEGACY_PART_NODES, PART_NODES, ClingoSolver, check_representable, clingo_parts)


def _apart(n: int) -> FrameProblem:
    """n active tracks, each with one detection on top of it, 200 px apart: n components of one
    track and one detection, no two boxes overlap, no history, so no context track anywhere."""
    tracks = tuple(TrackPrediction(f"trk_{k}", "car", "active", (200 * k, 100, 50, 50)) for k in range(n))
    dets = tuple(Detection(f"det_{k}", "car", 90, (200 * k, 100, 50, 50)) for k in range(n))
    iou = tuple((f"trk_{k}", f"det_{k}", 100_000) for k in range(n))
    return FrameProblem(5, dets, tracks, iou)


def _answer(h):
    return sorted(h.actions), sorted(h.events), h.cost, h.optimal


def test_small_components_are_one_clingo_call():
    # 10 components of 2 nodes: 20 nodes, context none, <= PART_NODES (48): one sub-problem, the
    # frame itself.  The grouping before counted 16 own nodes: 8 components, then the other 2
    p = _apart(10)
    assert PART_NODES == 48 and LEGACY_PART_NODES == 16
    assert len(split(p, LEGACY_PART_NODES)) == 2
    parts = clingo_parts(p)
    assert len(parts) == 1 and parts[0].problem is p
    solver = ClingoSolver(isolate=False)
    h = solver.solve(p)
    assert solver._calls == 1
    assert _answer(h) == _answer(get_solver("cpsat-full").solve(p))
    assert sorted(h.actions) == sorted(f"assign(trk_{k},det_{k})" for k in range(10))


def test_context_tracks_count_toward_the_size():
    # 25 apart: 50 own nodes > 48, so two calls; every sub-problem holds at most 48 nodes
    # (its tracks, context included, and its detections) unless it is one unit alone
    p = _apart(25)
    parts = clingo_parts(p)
    assert [len(x.problem.tracks) + len(x.problem.detections) for x in parts] == [48, 2]
    crowd = synthetic_frame(100, 0.8, seed=1)
    parts = clingo_parts(crowd)
    assert len(parts) > 1
    for part in parts:
        size = len(part.problem.tracks) + len(part.problem.detections)
        alone = len(split(part.problem, 0)) == 1  # one component (or unit): never split further
        assert size <= PART_NODES or alone


def test_a_group_closes_before_its_sums_leave_clingos_range():
    # Level 1 is bounded by the largest event cost C times nt*nt + 3*nt + nd
    # (refimpl.core.ranges.count_sum_bounds).  One component (1 track, 1 detection): 5 C; both in
    # one sub-problem (2 tracks, 2 detections): 12 C.  With C = 300,000,000: 1.5e9 <= 2^31 - 1 =
    # 2,147,483,647 < 3.6e9.  So the two components are two clingo calls, and the frame is solved;
    # the grouping before put both in one sub-problem (4 nodes <= 16) and refused the frame
    p = with_constants(_apart(2), {"cost_lost": 300_000_000})
    parts = clingo_parts(p)
    assert len(parts) == 2
    with pytest.raises(OutOfClingoRange):
        check_representable(p, split(p, LEGACY_PART_NODES))
    h = ClingoSolver(isolate=False).solve(p)
    assert _answer(h) == _answer(get_solver("cpsat-full").solve(p))
    # one component alone beyond the range (5 C > 2^31 - 1 with C = 500,000,000): refused with the
    # line it was refused with before, that of the grouping before (one sub-problem: 12 C = 6e9)
    big = with_constants(_apart(2), {"cost_lost": 500_000_000})
    with pytest.raises(OutOfClingoRange, match="cannot represent the frame: the level-1 cost can reach 6000000000"):
        clingo_parts(big)


@pytest.mark.parametrize("n", [10, 40, 120])
def test_nothing_the_grouping_before_solved_is_refused(n):
    # costs around where 16-node sub-problems stop fitting: whenever every sub-problem of the
    # grouping before fits, clingo_parts finds sub-problems that fit (it falls back to that
    # grouping at worst), and every one of them fits
    for cost in (1, 10 ** 5, 10 ** 6, 3 * 10 ** 6, 10 ** 7, 3 * 10 ** 7):
        p = with_constants(synthetic_frame(n, 0.6, seed=n), {"cost_lost": cost})
        try:
            check_representable(p, split(p, LEGACY_PART_NODES))
        except OutOfClingoRange:
            continue
        check_representable(p, clingo_parts(p))
