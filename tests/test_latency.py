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
