"""Dense crowds (issue 26, item 3): refimpl.experiments.synthetic.dense_frame is one component, the bench
reports it, and the full model's shortcut for the tie-break (solve_lexicographic's UNIQUE
chunks) gives the answers of clingo and of solving every chunk."""

from __future__ import annotations

import pytest

from refimpl.experiments.benchmarks import bench_scale, scale_table
from refimpl.solvers.check import check_answer
from refimpl.core.constants import resolve_constants
from refimpl.knowledge.events import EventState
from refimpl.solvers import get_solver
from refimpl.solvers.common import components
from refimpl.solvers.cpsat_model import build_model
from refimpl.solvers.cpsat_lexicographic import solve_lexicographic
from refimpl.core.spec import Detection, FrameProblem
from refimpl.experiments.synthetic import DENSE_TYPE, dense_frame, iou_facts


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
    problem = dense_frame(10, seed)
    # the speed-up is on: the pair part needs two objectives of its own, so the alternating
    # cycles decide it (cpsat_matching), or without them the uniqueness question is asked
    assert "MATCHED" in solve_lexicographic(_model(problem), problem).statuses
    assert "UNIQUE" in solve_lexicographic(_model(problem), problem, matching=False).statuses
    clingo = get_solver("clingo", isolate=False).solve(problem)
    full = get_solver("cpsat-full").solve(problem)
    assert clingo.optimal and full.optimal
    assert full.cost == clingo.cost
    assert full.answer == clingo.answer
    for h in (clingo, full):
        report = check_answer(problem, h)
        assert not report.violations and report.cost == h.cost


@pytest.mark.parametrize("n, seed", ((10, 0), (40, 1)))
def test_unique_pair_set_skips_the_chunks_and_keeps_the_answer(n, seed):
    problem = dense_frame(n, seed)
    quick = solve_lexicographic(_model(problem), problem, matching=False)
    slow = solve_lexicographic(_model(problem), problem, unique_pairs=False, matching=False)
    # dense frames have IoUs of 5 digits: no two pair sets tie on levels 10..1, so every chunk of
    # the pair part is UNIQUE
    assert "UNIQUE" in quick.statuses and "UNIQUE" not in slow.statuses
    assert quick.optimal and slow.optimal
    assert quick.values == slow.values and quick.cost == slow.cost


def test_a_small_component_is_solved_as_before_without_the_question():
    # 8 tracks, 72 iou/3 pairs: the pair part fits one objective, below UNIQUE_CHECK_CHUNKS, so
    # all levels are packed in one sequence and nothing is asked (2 objectives here; 3 before
    # docs/model.md 3.15 emptied level 5, whose range took a place of its own)
    problem = dense_frame(8, 0)
    res = solve_lexicographic(_model(problem), problem)
    assert res.optimal and not {"UNIQUE", "MATCHED"} & set(res.statuses) and len(res.statuses) == 2


def test_tied_pair_sets_are_still_broken_by_the_chunks():
    # a 10-track crowd plus det_99, a copy of det_0 (same box, same confidence): any answer that
    # uses one copy in a pair has a twin using the other at the same cost on levels 10..1, so
    # _only_pair_set finds another pair set, no chunk is UNIQUE, and the chunks decide; the
    # answer is the one of solving every chunk and clingo's (the tie-break of both encodings)
    pytest.importorskip("clingo")
    base = dense_frame(10, 0)
    d0 = base.detections[0]
    dets = base.detections + (Detection("det_99", d0.type, d0.conf, d0.box),)
    problem = FrameProblem(time=base.time, detections=dets, tracks=base.tracks,
                           iou=iou_facts(base.tracks, dets), constants=base.constants, history=base.history)
    res = solve_lexicographic(_model(problem), problem, matching=False)
    assert "UNIQUE" not in res.statuses and res.optimal
    assert any(v and a.startswith(("assign(", "resume(")) and a.endswith(("det_0)", "det_99)"))
               for a, v in res.values.items())  # a copy is in a pair: the tie is real
    assert res.values == solve_lexicographic(_model(problem), problem, unique_pairs=False, matching=False).values
    # the alternating cycles (cpsat_matching) break the tie the same way
    matched = solve_lexicographic(_model(problem), problem)
    assert "MATCHED" in matched.statuses and matched.values == res.values
    full = get_solver("cpsat-full").solve(problem)
    clingo = get_solver("clingo", isolate=False).solve(problem)
    assert full.optimal and clingo.optimal and full.answer == clingo.answer and full.cost == clingo.cost


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
