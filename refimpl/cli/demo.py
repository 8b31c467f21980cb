"""The `demo` command: the bundled sample sequence, tracked and scored."""

from __future__ import annotations

import argparse
import time

from .. import io
from ..evaluation.evaluate import evaluate_many, format_table
from ..tracking.pipeline import run_sequence, setup_for
from .common import EXIT_OK, TRACKERS, UserError


def _run_tracker(seq, backend: str):
    """What ``refimpl track --format mot`` runs: the MOTChallenge preset (refimpl.tracking.pipeline.setup_for)."""
    result = run_sequence(seq, setup_for("mot", None, backend))
    return result.rows, result.events


def cmd_demo(args: argparse.Namespace) -> int:
    backends = [b.strip() for b in args.backends.split(",")]
    if not all(backends) or any(b not in TRACKERS for b in backends):
        raise UserError(f"--backends takes a comma-separated list out of {','.join(TRACKERS)}, got {args.backends!r}")
    seq = io.demo_sequence_paths()
    dets, gt = io.load_detections(seq), io.load_ground_truth(seq)
    print(f"refimpl demo: {seq.name} ({len(dets.frames)} frames, bundled MOT15 sample)\n")
    for backend in backends:
        t0 = time.perf_counter()
        rows, events = _run_tracker(dets, backend)
        secs = time.perf_counter() - t0
        per_seq, overall = evaluate_many([(seq.name, gt, rows)])
        print(f"### {backend}: {len(dets.frames) / max(secs, 1e-9):.0f} frames/s, {len(events)} events\n")
        print(format_table(per_seq, overall))
        print()
    return EXIT_OK
