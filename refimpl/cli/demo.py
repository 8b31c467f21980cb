"""The `demo` command: the bundled sample sequence, tracked and scored."""

from __future__ import annotations

import argparse

from .. import io
from ..evaluation.evaluate import evaluate_many, format_table
from ..tracking.pipeline import run_sequence, setup_for
from .common import EXIT_OK, TRACKERS, UserError


def _run_tracker(seq, backend: str, frame_times: list | None = None):
    """What ``refimpl track --format mot`` runs: the MOTChallenge preset (refimpl.tracking.pipeline.setup_for);
    ``frame_times`` receives each frame's CPU seconds (run_sequence's)."""
    result = run_sequence(seq, setup_for("mot", None, backend), frame_times=frame_times)
    return result.rows, result.events


def speed_line(backend: str, times: list[float], events: int) -> str:
    """The demo's line about a tracker's speed: CPU frames/s of a second run over the sequence (the
    first also loads, once per process, what the tracker needs: SORT's assignment solver, say)."""
    total = sum(times)
    fps = f"{len(times) / total:.0f}" if total > 0 else "-"
    return f"### {backend}: {fps} frames/s (CPU of a second run; the first loads the tracker's libraries), {events} events\n"


def cmd_demo(args: argparse.Namespace) -> int:
    backends = [b.strip() for b in args.backends.split(",")]
    if not all(backends) or any(b not in TRACKERS for b in backends):
        raise UserError(f"--backends takes a comma-separated list out of {','.join(TRACKERS)}, got {args.backends!r}")
    seq = io.demo_sequence_paths()
    dets, gt = io.load_detections(seq), io.load_ground_truth(seq)
    print(f"refimpl demo: {seq.name} ({len(dets.frames)} frames, bundled MOT15 sample)\n")
    for backend in backends:
        rows, events = _run_tracker(dets, backend)
        times: list[float] = []
        _run_tracker(dets, backend, times)  # the same rows again, timed without the one-time loading
        per_seq, overall = evaluate_many([(seq.name, gt, rows)])
        print(speed_line(backend, times, len(events)))
        print(format_table(per_seq, overall))
        print()
    return EXIT_OK
