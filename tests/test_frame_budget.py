"""The frame budget (issue 38): a frame that reaches it gets the best answer found so far, flagged
not proven optimal and counted, the run goes on and writes its rows; a frame the fast path answers
keeps its answer with any budget."""

from __future__ import annotations

import numpy as np
import pytest

import refimpl
from refimpl import io
from refimpl.cli import main
from refimpl.io import DetectionFrame, DetectionSequence
from refimpl.solvers import get_solver
from refimpl.solvers.check import check_answer
from refimpl.solvers.fast_path import FAST_PATH_MAX_COMPONENT
from refimpl.tracking.pipeline import DEFAULT_FRAME_BUDGET_MS, run_sequence, setup_for

PILE = 220
"""Boxes of the crowd at frames 1-2: at frame 2 its 220 tracks and 220 detections are one
component of 440 nodes, more than the fast path takes (FAST_PATH_MAX_COMPONENT, 400): the full
CP-SAT model answers it, which takes ~1.5 s here without a budget."""


def _walkers(f: int) -> list[list[float]]:
    """Three pedestrians far from the crowd, 100 px apart, walking 3 px a frame."""
    return [[1500.0 + 100 * k + 3 * f, 600.0, 40.0, 80.0] for k in range(3)]


def crowd_sequence() -> DetectionSequence:
    """7 frames: the three walkers in every frame, the crowd (220 boxes of 40 x 80 px, 7 px apart in
    rows of 22, 9 px between rows, every position jittered apart so no IoU ties) in frames 1 and 2;
    every confidence 95."""
    frames = []
    for f in range(1, 8):
        boxes = _walkers(f)
        if f <= 2:
            boxes += [[100.0 + (i % 22) * 7 + 0.37 * i + f, 100.0 + (i // 22) * 9 + 0.11 * i, 40.0, 80.0]
                      for i in range(PILE)]
        b = np.array(boxes)
        frames.append(DetectionFrame(f, b, np.full(len(b), 0.95), np.full(len(b), 95), ("pedestrian",) * len(b)))
    return DetectionSequence("crowd", tuple(frames), 1, (1920, 1080), 30.0)


def test_a_frame_over_its_budget_gets_the_best_answer_so_far_flagged_counted_and_the_rows_go_on():
    seq = crowd_sequence()
    solver = get_solver("cpsat")
    seen = []
    result = run_sequence(seq, setup_for("mot", None, "cpsat", frame_budget=5.0), solver=solver,
                          observer=lambda p, h: seen.append((p, h)))
    assert 2 * (PILE + 3) > FAST_PATH_MAX_COMPONENT  # frame 2's component: the full model's
    assert solver.stats["declined: component too large"] == 1 and solver.stats["fast"] == 6
    # frame 2 reached the budget: flagged, and still an admissible answer with its true cost
    assert [h.optimal for _, h in seen] == [True, False, True, True, True, True, True]
    problem, hyp = seen[1]
    report = check_answer(problem, hyp)
    assert report.ok and report.cost == hyp.cost
    assert result.budget_hits == 1 == result.not_optimal_frames
    assert result.over_budget >= 1
    # rows of every frame: frames 1-3 are the first min_hits (3) frames, written as observed; the
    # walkers are observed in every frame, so frames 4-7 write them too (3 rows each)
    rows = result.rows
    assert sorted(set(rows[:, 0].astype(int).tolist())) == [1, 2, 3, 4, 5, 6, 7]
    for f in range(4, 8):
        assert (rows[:, 0] == f).sum() == 3
        assert sorted(rows[rows[:, 0] == f][:, 2].tolist()) == pytest.approx(
            [b[0] for b in _walkers(f)], abs=5.0)


def test_the_budget_never_changes_an_answer_of_the_fast_path():
    # a budget of 0 ms: every frame of TUD-Campus takes longer (all 71 over budget), and every one
    # is answered by the fast path, whose answer is exact and kept however late: the same rows
    # and events as without a budget, no frame flagged
    seq = io.load_detections(io.demo_sequence_paths())
    free = run_sequence(seq, setup_for("mot", None, "cpsat", frame_budget=None))
    zero = run_sequence(seq, setup_for("mot", None, "cpsat", frame_budget=0.0))
    assert zero.rows.tobytes() == free.rows.tobytes() and zero.events == free.events
    assert (zero.budget_hits, zero.not_optimal_frames, zero.over_budget) == (0, 0, 71)
    assert (free.budget_hits, free.over_budget) == (0, 0)


def test_a_time_limit_stays_hard_where_the_budget_is_soft():
    # the same frame, the fast path answering it: a time limit of 1e-9 s replaces its late
    # answer by the obvious one (refimpl.solvers' contract, the audit of test_robust_inputs),
    # a budget of 0 s keeps it
    seq = io.load_detections(io.demo_sequence_paths())
    problems = []
    run_sequence(seq, setup_for("mot", None, "cpsat", frame_budget=None), observer=lambda p, h: problems.append(p))
    p = problems[10]
    exact = get_solver("cpsat").solve(p)
    late = get_solver("cpsat").solve(p, budget=0.0)
    assert late.optimal and (late.actions, late.events, late.cost) == (exact.actions, exact.events, exact.cost)
    hard = get_solver("cpsat").solve(p, time_limit=1e-9)
    assert not hard.optimal and hard.actions != exact.actions


def test_the_default_budget_is_the_real_time_backends():
    assert DEFAULT_FRAME_BUDGET_MS == 25.0
    assert refimpl.Tracker().setup.frame_budget == DEFAULT_FRAME_BUDGET_MS
    assert refimpl.Tracker("cpsat", frame_budget=None).setup.frame_budget is None
    assert refimpl.Tracker("cpsat", frame_budget=7).setup.frame_budget == 7.0
    for oracle in ("cpsat-full", "clingo"):
        assert setup_for("mot", None, oracle).frame_budget is None
        assert setup_for("mot", None, oracle, frame_budget=40).frame_budget == 40.0
    assert "frame budget 25 ms" in refimpl.Tracker().setup.describe()


@pytest.mark.parametrize("bad", [-1, float("nan"), float("inf"), "soon", True])
def test_a_bad_budget_is_one_sentence(bad):
    with pytest.raises(ValueError, match="frame budget must be a finite number of milliseconds >= 0"):
        refimpl.Tracker(frame_budget=bad)


def test_the_library_counts_the_frames_over_budget_in_its_result():
    seq = crowd_sequence()
    # the default tracker keeps no history: its counts say it; with history, result() says the same
    for history in (False, True):
        tracker = refimpl.Tracker("cpsat", img_size=(1920, 1080), fps=30.0, scores="probability", frame_budget=5.0,
                                  history=history)
        for fr in seq.frames:
            b = fr.boxes
            tracker.update(np.column_stack([b[:, 0], b[:, 1], b[:, 0] + b[:, 2], b[:, 1] + b[:, 3], fr.scores]))
        counts = tracker.counts
        assert counts.budget_hits == 1 == counts.not_optimal_frames and counts.frames == 7
        if history:
            result = tracker.result()
            assert (result.budget_hits, result.not_optimal_frames, result.frames) == (1, 1, 7)


def _write_mot(seq: DetectionSequence, path) -> None:
    lines = [f"{fr.frame},-1,{x:.3f},{y:.3f},{w:.3f},{h:.3f},95,-1,-1,-1"
             for fr in seq.frames for x, y, w, h in fr.boxes.tolist()]
    path.write_text("\n".join(lines) + "\n")


def test_track_says_how_many_frames_hit_the_budget_and_writes_every_row(tmp_path, capsys):
    dets, out = tmp_path / "crowd.txt", tmp_path / "out.txt"
    _write_mot(crowd_sequence(), dets)
    assert main(["track", "--dets", str(dets), "--out", str(out), "--scores", "raw", "--img-size", "1920,1080",
                 "--frame-budget", "5", "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "1 of 7 frames hit the frame budget of 5 ms (best answer found so far used, not proven optimal)" in err
    frames = sorted({int(line.split(",")[0]) for line in out.read_text().splitlines()})
    assert frames == [1, 2, 3, 4, 5, 6, 7]


@pytest.mark.parametrize("value", ["-1", "nan", "inf", "abc", ""])
def test_a_bad_frame_budget_is_one_line_and_exit_2(value, tmp_path, capsys):
    out = tmp_path / "r.txt"
    assert main(["track", "--dets", str(io.demo_sequence_paths().dets_path), "--out", str(out),
                 f"--frame-budget={value}"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"refimpl track: error: --frame-budget takes milliseconds >= 0, 'auto' or 'none', got {value!r}"
    assert not out.exists()


def test_the_baseline_refuses_a_frame_budget(capsys):
    assert main(["track", "--dets", str(io.demo_sequence_paths().dets_path), "--out", "o.txt", "--backend",
                 "baseline", "--frame-budget", "10"]) == 2
    assert "--frame-budget" in capsys.readouterr().err
