"""Dense crowds (issue 26, item 3): refimpl.synthetic.dense_frame is one component, the bench
reports it, and the full model's shortcut for the tie-break (solve_lexicographic's UNIQUE
chunks) gives the answers of clingo and of solving every chunk."""

from __future__ import annotations

import pytest

from refimpl.benchmarks import bench_scale, scale_table
from refimpl.check import check_answer
from refimpl.constants import resolve_constants
from refimpl.events import EventState
from refimpl.solvers import get_solver
from refimpl.solvers.common import components, tiebreak_weights
from refimpl.solvers.cpsat_model import build_model, solve_lexicographic
from refimpl.spec import Detection, FrameProblem, TrackPrediction
from refimpl.synthetic import DENSE_TYPE, dense_frame, iou_facts


def _model(problem):
    return build_model(problem, EventState.from_problem(problem), resolve_constants(problem))


@pytest.mark.parametrize("n", (1, 5, 20, 60))
@pytest.mark.parametrize("seed", (0, 1, 2))
def test_dense_frame_is_one_component_of_every_track_and_detection(n, seed):
    problem = dense_frame(n, seed)
    assert len(problem.tracks) == n
    comps = components(problem)
    assert len(comps) == 1
    (comp,) = comps
    assert set(comp.tracks) == {t.id for t in problem.tracks}
    assert set(comp.detections) == {d.id for d in problem.detections}
    assert {t.type for t in problem.tracks} | {d.type for d in problem.detections} == {DENSE_TYPE}
    # a crowd, not a chain: a 60-track frame has several candidate pairs per track (two boxes of
    # a track's ~30 overlapping neighbours' size standing this close have IoU > 0.3)
    if n == 60:
        assert len(comp.pairs) >= 3 * n


def test_dense_frame_is_deterministic_and_depends_on_the_seed():
    assert dense_frame(30, 4) == dense_frame(30, 4)
    assert dense_frame(30, 4) != dense_frame(30, 5)


def test_dense_frame_rejects_no_tracks():
    with pytest.raises(ValueError, match="n_tracks"):
        dense_frame(0, 0)


@pytest.mark.parametrize("seed", (0, 1))
def test_a_small_dense_frame_is_solved_identically_by_clingo_and_cpsat_full(seed):
    pytest.importorskip("clingo")
    problem = dense_frame(8, seed)
    clingo = get_solver("clingo", isolate=False).solve(problem)
    full = get_solver("cpsat-full").solve(problem)
    assert clingo.optimal and full.optimal
    assert full.cost == clingo.cost
    assert full.answer == clingo.answer
    for h in (clingo, full):
        report = check_answer(problem, h)
        assert not report.violations and report.cost == h.cost


@pytest.mark.parametrize("n, seed", ((8, 0), (40, 1)))
def test_unique_pair_set_skips_the_chunks_and_keeps_the_answer(n, seed):
    problem = dense_frame(n, seed)
    quick = solve_lexicographic(_model(problem), problem)
    slow = solve_lexicographic(_model(problem), problem, unique_pairs=False)
    # dense frames have IoUs of 5 digits: no two pair sets tie on levels 10..1, so every chunk of
    # the pair part is UNIQUE (the levels 10..1 are two packed objectives; the explanation one)
    assert "UNIQUE" in quick.statuses and "UNIQUE" not in slow.statuses
    assert quick.optimal and slow.optimal
    assert quick.values == slow.values and quick.cost == slow.cost


def test_tied_pair_sets_are_still_broken_by_the_chunks():
    # one active track and two detections with the same box and confidence: assigning either
    # ties on levels 10..1 (the other one starts a track either way), so _only_pair_set finds
    # the other pair set and the chunk is solved: the pair of rank 0, (trk_0, det_0), weighs
    # 2^0 < 2^1 of (trk_0, det_1), so the answer assigns det_0
    trk = (TrackPrediction("trk_0", DENSE_TYPE, "active", (100, 100, 40, 80)),)
    dets = tuple(Detection(f"det_{j}", DENSE_TYPE, 90, (102, 101, 40, 80)) for j in range(2))
    problem = FrameProblem(time=10, detections=dets, tracks=trk, iou=iou_facts(trk, dets))
    assert tiebreak_weights(problem).pair == {("trk_0", "det_0"): 1, ("trk_0", "det_1"): 2}
    res = solve_lexicographic(_model(problem), problem)
    assert "UNIQUE" not in res.statuses and res.optimal
    assert res.values["assign(trk_0,det_0)"] == 1 and res.values["assign(trk_0,det_1)"] == 0
    assert res.values == solve_lexicographic(_model(problem), problem, unique_pairs=False).values


def test_bench_scale_dense_reports_the_component_it_solves():
    pytest.importorskip("clingo")
    result = bench_scale(sizes=[6], seeds=2, backends=["cpsat-full", "clingo"], time_limit=60, dense=True)
    assert result.dense and result.overlaps == [0.0]
    for seed in range(2):
        p = dense_frame(6, seed)
        nodes = len(p.tracks) + len(p.detections)
        runs = [r for r in result.runs if r.seed == seed]
        assert {r.largest for r in runs} == {nodes}
        assert all(r.optimal for r in runs) and len({r.answer_hash for r in runs}) == 1
    sizes = sorted(len(dense_frame(6, s).tracks) + len(dense_frame(6, s).detections) for s in range(2))
    row = scale_table(result).splitlines()[2]
    want = str(sizes[0]) if sizes[0] == sizes[1] else f"{sizes[0]}-{sizes[1]}"
    assert row.startswith(f"| 6 | dense | {want} |")
    assert row.endswith("| 2/2 |")
