"""Latency summaries (refimpl.experiments.latency) and that every tracker of a comparison is timed per frame."""

from __future__ import annotations

import pytest

from refimpl.experiments.latency import summarise
from refimpl.tracking.pipeline import run_sequence, setup_for
from refimpl import io


def test_summary_of_four_frames():
    # CPU seconds 0.001, 0.003, 0.002, 0.010: median 2.5 ms; 99th percentile by linear
    # interpolation between 3 ms (index 2 of 0..3 sorted) and 10 ms at position 2.97: 3 + 0.97 * 7
    # = 9.79 ms; the slowest is frame 4 of b; 4 frames in 0.016 s: 250 fps
    lat = summarise([(0.001, "a", 1, 2), (0.003, "a", 2, 5), (0.002, "b", 3, 1), (0.010, "b", 4, 9)])
    assert lat.median_ms == pytest.approx(2.5) and lat.p99_ms == pytest.approx(9.79)
    assert lat.worst_ms == pytest.approx(10.0) and lat.worst == "b frame 4 (9 detections)"
    assert lat.fps == pytest.approx(250.0)
    assert summarise([]) is None


@pytest.mark.parametrize("backend", ["baseline", "cpsat"])
def test_run_sequence_times_every_frame(backend):
    seq = io.load_detections(io.demo_sequence_paths())
    times: list[float] = []
    run_sequence(seq, setup_for("mot", None, backend), frame_times=times)
    assert len(times) == len(seq.frames) and all(t >= 0 for t in times) and sum(times) > 0


def test_measure_latency_times_every_frame_with_each_heap_and_hands_the_heap_back(data_root_with_val):
    # KITTI Car val on a data root whose val split is 0012 and 0014 (78 + 106 frames: two sequences
    # of the bench's own dataset, its preset and its default budget, not the shared split's 3,900)
    import gc
    from refimpl.experiments.latency import latency_table, measure_latency
    from refimpl.io.datasets import load_dataset
    root = str(data_root_with_val("0012", "0014"))
    frames = sum(len(d.frames) for _, d, _ in load_dataset("kitti-car-val", root))
    assert frames == 78 + 106
    runs = measure_latency(["kitti-car-val"], root)
    assert [r.heap for r in runs] == ["as is", "frozen"]
    for r in runs:
        assert r.latency.frames == frames  # every frame of the two sequences, once per heap
        assert r.latency.median_ms <= r.latency.p99_ms <= r.latency.worst_ms
        assert r.frame_budget == 25.0 and r.budget_hits == 0  # the defaults; the fast path answers every frame
    assert gc.get_freeze_count() == 0 and gc.isenabled()
    assert not [c for c in gc.callbacks if type(c).__name__ == "_FullCollections"]
    table = latency_table(runs)
    assert table.count("\n") == 4 and f"| frozen | {frames} |" in table


def test_a_crowd_has_its_objects_in_every_frame_inside_the_image():
    import numpy as np
    from refimpl.experiments.crowds import IMAGE, crowd_truth
    gt = crowd_truth(50, 40, seed=3)
    assert np.bincount(gt.frames.astype(int))[1:].tolist() == [50] * 40
    x, y, w, h = gt.boxes.T
    assert x.min() >= 0 and y.min() >= 0 and (x + w).max() <= IMAGE[0] and (y + h).max() <= IMAGE[1]
    # an object keeps its size; it moves by at most its speed (a reflection only shortens a step)
    first, last = gt.boxes[gt.frames == 1], gt.boxes[gt.frames == 2]
    assert np.array_equal(first[:, 2:], last[:, 2:])
    assert crowd_truth(50, 40, seed=3).boxes.tobytes() == gt.boxes.tobytes()  # seeded


def test_the_exponent_of_a_power_law():
    from refimpl.experiments.crowds import exponent
    # cost 0.5 N^2 at N = 10, 100, 1000: slope of log cost against log N is 2; constant cost: 0
    assert exponent([10, 100, 1000], [50.0, 5000.0, 500000.0]) == pytest.approx(2.0)
    assert exponent([10, 50], [3.0, 3.0]) == pytest.approx(0.0, abs=1e-12)


def test_the_crowd_bench_times_every_tracker_on_every_size():
    from refimpl.experiments.crowds import bench_crowds, crowd_table
    result = bench_crowds([4, 8], frames=5, trackers=["baseline", "cpsat"], peers=[])
    assert [(c.tracker, c.objects, len(c.times)) for c in result.cells] == [
        ("baseline", 4, 5), ("cpsat", 4, 5), ("baseline", 8, 5), ("cpsat", 8, 5)]
    assert result.cell("cpsat", 8).flagged == 0 and result.cell("baseline", 8).flagged is None
    table = crowd_table(result)
    assert "| refimpl cpsat (frame budget 25 ms) |" in table and "| refimpl baseline (SORT) |" in table


def test_frame_times_count_the_clingo_worker_processes_cpu():
    # inline_solves=0: every solve runs in clingo's worker process, whose CPU time this process's
    # time.process_time does not see; each frame's time adds what the worker spent on it, so the
    # frames' sum holds at least all of the worker's time
    pytest.importorskip("clingo")
    from refimpl.solvers.clingo_backend import ClingoSolver
    seq = io.load_detections(io.demo_sequence_paths())
    solver = ClingoSolver(inline_solves=0)
    times: list[float] = []
    run_sequence(seq, setup_for("mot", None, "clingo"), solver=solver, frame_times=times)
    assert solver._worker.started == 1 and solver.child_cpu_seconds > 0
    assert len(times) == len(seq.frames) and sum(times) >= solver.child_cpu_seconds


class _Timed(Exception):
    """Raised by the stand-in for the peer comparison once it has looked at the heap."""


@pytest.mark.parametrize("flags", [["--peers", "sort"], ["--peers", "sort", "--shift", "none"]])
def test_benchmark_times_the_trackers_with_the_loaded_sets_frozen_as_track_does(data_root_with_val, monkeypatch, flags):
    # `benchmark --peers` (and --shift) time every tracker per frame; a full garbage collection over
    # the loaded sets landed in a frame and made it 90-150 ms (docs/benchmarks.md, "The slowest
    # frames").  The comparison runs with the heap frozen (gc.freeze, as `refimpl track` runs), and
    # the heap is handed back afterwards even when the comparison fails.
    import gc
    from refimpl.cli import benchmarks
    from refimpl.cli import main
    pytest.importorskip("trackers")
    seen = []

    def compare(*args, **kwargs):
        seen.append(gc.get_freeze_count())
        raise _Timed

    monkeypatch.setattr(benchmarks, "compare", compare)
    root = str(data_root_with_val("0012"))
    with pytest.raises(_Timed):
        main(["benchmark", "kitti-car-val", "--data", root, "--quiet", *flags])
    assert len(seen) == 1 and seen[0] > 0
    assert gc.get_freeze_count() == 0
