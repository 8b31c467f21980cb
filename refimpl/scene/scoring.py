"""The anticipation rule scored against the actual reappearances of real sequences, by hidden
duration, and its command ``python -m refimpl.scene anticipation-eval`` (docs/reasoning.md)."""

from __future__ import annotations

import json
import math
import os
import statistics
import sys
from dataclasses import dataclass
from typing import Iterable, Sequence

from .. import io
from ..io.datasets import THROUGHPUT_DATASETS, benchmark_sequences
from ..io.outputs import write_atomic
from ..knowledge.event_table import EVENT_TABLE
from ..solvers import DEFAULT_BACKEND
from ..tracking.pipeline import Setup, run_sequence
from .anticipation import DEFAULT_CONFIG, Anticipation, ReasoningConfig, anticipate
from .episodes import hiding_episodes
from .files import load_scene, save_scene
from .model import Scene, scene_from_result


# ---------------------------------------------------------------------------------------

@dataclass(frozen=True)
class EpisodeOutcome:
    """One hides_behind -> unhides_from_behind episode scored against the actual reappearance."""

    sequence: str
    track: str
    hider: str
    hidden_at: int
    reappeared_at: int
    anticipation: Anticipation | None
    """The anticipation made at the hiding time (now = hidden_at)."""
    first: Anticipation | None
    """The earliest anticipation made at any now in hidden_at .. reappeared_at - 1."""
    actual_position: tuple[float, float]
    last_seen_position: tuple[float, float]


def _centre(b: Sequence[float]) -> tuple[float, float]:
    return b[0] + b[2] / 2, b[1] + b[3] / 2


def score_scene(scene: Scene, config: ReasoningConfig = DEFAULT_CONFIG) -> list[EpisodeOutcome]:
    """Anticipations for every actual hides_behind(T1,T2) -> unhides_from_behind(T1,T2) episode."""
    out = []
    for ep in hiding_episodes(scene):
        if not getattr(EVENT_TABLE.get(ep.how), "unhides", False) or ep.resumed_at is None:
            continue
        t1 = scene.track(ep.track)
        actual = t1.observed_box(ep.resumed_at)
        seen = t1.observed_until(ep.hidden_at - 1, 1)
        if actual is None or not seen:
            continue
        at_hiding = anticipate(scene, ep.track, ep.hidden_at, config, ep.hider)
        first = at_hiding
        now = ep.hidden_at + 1
        while first is None and now < ep.resumed_at:
            first = anticipate(scene, ep.track, now, config, ep.hider)
            now += 1
        out.append(EpisodeOutcome(scene.name, ep.track, ep.hider, ep.hidden_at, ep.resumed_at, at_hiding, first,
                                  _centre(actual), _centre(seen[-1][1])))
    return out


def _stats(values: Sequence[float]) -> dict:
    if not values:
        return {"n": 0, "mean": None, "median": None}
    return {"n": len(values), "mean": statistics.fmean(values), "median": statistics.median(values)}


def summarise_outcomes(outcomes: Sequence[EpisodeOutcome]) -> dict:
    """Rates and error statistics of scored episodes (frames, px).

    ``at_hiding``: the anticipations made at the hiding time; ``earliest``: the first made at any
    time of the hiding; ``baseline``: on the same episodes as ``at_hiding``, the naive guess
    "reappears at the next frame where it was last seen" (frame hidden_at + 1, the centre of the
    last observed box).
    """
    made = [o for o in outcomes if o.anticipation is not None]
    first = [o for o in outcomes if o.first is not None]

    def errs(sel, pick):
        return {
            "lead": _stats([o.reappeared_at - pick(o).now for o in sel]),
            "frame_error": _stats([pick(o).at - o.reappeared_at for o in sel]),
            "abs_frame_error": _stats([abs(pick(o).at - o.reappeared_at) for o in sel]),
            "position_error": _stats([math.dist(pick(o).position, o.actual_position) for o in sel]),
            "exact_frame": sum(1 for o in sel if pick(o).at == o.reappeared_at),
            "within_5_frames": sum(1 for o in sel if abs(pick(o).at - o.reappeared_at) <= 5),
            "warnings": sum(1 for o in sel if pick(o).warning),
        }
    return {
        "episodes": len(outcomes),
        "hidden_frames": _stats([o.reappeared_at - o.hidden_at for o in outcomes]),
        "at_hiding": {"made": len(made), **errs(made, lambda o: o.anticipation)},
        "earliest": {"made": len(first), **errs(first, lambda o: o.first)},
        "baseline": {
            "abs_frame_error": _stats([o.reappeared_at - o.hidden_at - 1 for o in made]),
            "position_error": _stats([math.dist(o.last_seen_position, o.actual_position) for o in made]),
        },
    }


DURATION_BUCKETS = ((1, 1), (2, 4), (5, 9), (10, None))
"""Hidden frames (reappeared_at - hidden_at) by which the evaluation is broken down."""


def evaluate_anticipation(scenes: Iterable[Scene], config: ReasoningConfig = DEFAULT_CONFIG) -> dict:
    """Score the anticipation rule on every hides -> unhides episode of the scenes.

    Returns {"summary": all episodes, "by_hidden_frames": {"1": ..., "2-4": ..., "5-9": ..., "10+": ...},
    "outcomes": [EpisodeOutcome, ...]}.
    """
    outcomes = [o for s in scenes for o in score_scene(s, config)]
    buckets = {}
    for lo, hi in DURATION_BUCKETS:
        label = f"{lo}+" if hi is None else (f"{lo}" if lo == hi else f"{lo}-{hi}")
        sel = [o for o in outcomes if lo <= o.reappeared_at - o.hidden_at and (hi is None or o.reappeared_at - o.hidden_at <= hi)]
        buckets[label] = summarise_outcomes(sel)
    return {"summary": summarise_outcomes(outcomes), "by_hidden_frames": buckets, "outcomes": outcomes}


def _num(v, fmt: str = "{:.1f}") -> str:
    return "-" if v is None else fmt.format(v)


def format_evaluation(rows: Sequence[tuple[str, str, str, dict]]) -> str:
    """A markdown table, one row per (data, motion, hidden frames, summary)."""
    head = ("| data | motion | hidden frames | episodes | anticipated at hiding | median lead (frames) | "
            "frame error, median (signed) | abs frame error, median / mean | within 5 frames | "
            "position error (px), median | baseline: abs frame error median / position error median | "
            "anticipated at any time while hidden | warnings |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for data, motion, bucket, s in rows:
        a, e, b = s["at_hiding"], s["earliest"], s["baseline"]
        n = max(s["episodes"], 1)
        lines.append(
            f"| {data} | {motion} | {bucket} | {s['episodes']} | {a['made']} ({100 * a['made'] / n:.0f}%) | "
            f"{_num(a['lead']['median'], '{:.0f}')} | {_num(a['frame_error']['median'], '{:+.0f}')} | "
            f"{_num(a['abs_frame_error']['median'], '{:.0f}')} / {_num(a['abs_frame_error']['mean'])} | "
            f"{a['within_5_frames']} ({100 * a['within_5_frames'] / max(a['made'], 1):.0f}%) | "
            f"{_num(a['position_error']['median'])} | {_num(b['abs_frame_error']['median'], '{:.0f}')} / "
            f"{_num(b['position_error']['median'])} | {e['made']} ({100 * e['made'] / n:.0f}%) | {a['warnings']} |")
    return "\n".join(lines)


def _benchmark_scenes(name: str, data_root: str, cache: str | None, progress: bool) -> list[Scene]:
    out = []
    for s in benchmark_sequences(name, data_root):
        path = os.path.join(cache, f"{name}-{s.name}.scene.json") if cache else None
        if path and os.path.isfile(path):
            out.append(load_scene(path))
        else:
            dets = io.load_detections(s)
            scene = scene_from_result(dets, run_sequence(dets, Setup(DEFAULT_BACKEND)))
            if path:
                os.makedirs(cache, exist_ok=True)
                save_scene(path, scene)
            out.append(scene)
        if progress:
            print(f"  {name}/{s.name}: {len(out[-1].events)} events", file=sys.stderr)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m refimpl.scene anticipation-eval``: the anticipation evaluation of docs/reasoning.md."""
    import argparse
    p = argparse.ArgumentParser(prog="python -m refimpl.scene",
                                description="Evaluate hidden-entity anticipation on benchmark sequences "
                                            "(tracked with the cpsat backend).")
    p.add_argument("command", choices=("anticipation-eval",))
    p.add_argument("--data", default="../shared/data", help="benchmark data root (default ../shared/data)")
    p.add_argument("--benchmarks", default=",".join(THROUGHPUT_DATASETS),
                   help=f"comma-separated (default {','.join(THROUGHPUT_DATASETS)})")
    p.add_argument("--cache", help="folder to keep / reuse the tracked scenes (NAME-SEQ.scene.json)")
    p.add_argument("--json", help="also write the summaries as JSON")
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args(argv)
    rows = []
    for name in args.benchmarks.split(","):
        name = name.strip()
        scenes = _benchmark_scenes(name, args.data, args.cache, not args.quiet)
        for motion in ("velocity", "kalman"):
            result = evaluate_anticipation(scenes, ReasoningConfig(motion=motion))
            rows.append((name, motion, "all", result["summary"]))
            rows += [(name, motion, k, v) for k, v in result["by_hidden_frames"].items()]
    print(format_evaluation(rows))
    if args.json:
        write_atomic(args.json, json.dumps([{"data": d, "motion": m, "bucket": b, **s} for d, m, b, s in rows],
                                           indent=2))
    return 0
