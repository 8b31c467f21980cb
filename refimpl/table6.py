"""Benchmark runs and the paper's Table 6: baseline vs tracking with abduction, per dataset.

Datasets: MOT15 train (SORT's Faster R-CNN detections), KITTI train Car and Pedestrian
(PointRCNN detections), and MOT17 train / MOT20-01 with *simulated* detections (refimpl.simulate:
no public detections for them ship here), always labelled as such.
"""

from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .datasets import TABLE6_DATASETS, TITLES, load_dataset
from .evaluate import evaluate_many
from .solvers import BASELINE, DEFAULT_BACKEND


@dataclass(frozen=True)
class BenchmarkRun:
    dataset: str
    tracker: str
    per_sequence: dict
    overall: dict
    events: dict
    frames: int
    seconds: float


def run_tracker(seq, tracker: str, constants=None, options=None):
    """Results rows and events of one sequence with 'baseline' (SORT) or an abduction backend
    (with these model constants on top of model/constants.lp and these TrackerOptions), through
    the one pipeline (refimpl.pipeline)."""
    from .pipeline import Setup, run_sequence
    from .options import TrackerOptions
    setup = Setup(tracker) if tracker == BASELINE else \
        Setup(tracker, tuple((constants or {}).items()), options or TrackerOptions())
    result = run_sequence(seq, setup)
    return result.rows, result.events


def run_benchmark(name: str, data_root: str, tracker: str, step: Callable[[str], None] | None = None,
                  dataset=None, constants=None, options=None) -> BenchmarkRun:
    """Track and evaluate every sequence of a dataset; ``seconds`` is the time of the tracking
    loops alone (evaluation excluded)."""
    dataset = dataset if dataset is not None else load_dataset(name, data_root)
    triples, events, frames = [], Counter(), 0
    tracking = 0.0
    for seq_name, dets, gt in dataset:
        t0 = time.perf_counter()
        rows, evs = run_tracker(dets, tracker, constants, options)
        tracking += time.perf_counter() - t0
        events.update(e.event.name for e in evs)
        frames += len(dets.frames)
        triples.append((seq_name, gt, rows))
        if step:
            step(seq_name)
    per_seq, overall = evaluate_many(triples)
    return BenchmarkRun(name, tracker, per_seq, overall, dict(events), frames, tracking)


def _pct(v: float) -> str:
    return "-" if v != v else f"{100 * v:.1f}"


def table6_row(label: str, o: dict) -> str:
    hota = " | ".join(_pct(o[k]) for k in ("hota", "deta", "assa"))
    return (f"| {label} | {hota} | {_pct(o['mota'])} | {_pct(o['motp'])} | {_pct(o['idf1'])} | {o['mt']} "
            f"| {o['ml']} | {o['fp']} | {o['fn']} | {o['idsw']} | {o['frag']} |")


def format_table6(runs: list[tuple[BenchmarkRun, BenchmarkRun]]) -> str:
    """Markdown in the shape of the paper's Table 6: one block per dataset, baseline vs abduction."""
    head = ("| tracker | HOTA | DetA | AssA | MOTA | MOTP | IDF1 | MT | ML | FP | FN | ID sw. | Frag. |\n"
            "|---|" + "---:|" * 12)
    out = []
    for base, abd in runs:
        b, a = base.overall, abd.overall
        verdict = []
        verdict.append("MOTA " + ("up" if a["mota"] > b["mota"] else "NOT up"))
        verdict.append("IDF1 " + ("up" if a["idf1"] > b["idf1"] else "NOT up"))
        verdict.append("HOTA " + ("up" if a["hota"] > b["hota"] else "NOT up"))
        cut = (a["idsw"] + a["frag"]) < (b["idsw"] + b["frag"])
        verdict.append("ID sw. + Frag. " + ("cut" if cut else "NOT cut")
                       + f" ({b['idsw'] + b['frag']} -> {a['idsw'] + a['frag']})")
        out.append(f"**{TITLES[base.dataset]}** — {base.frames} frames, {b['num_unique_objects']} targets\n")
        out.append(head)
        out.append(table6_row("baseline (SORT)", b))
        out.append(table6_row(f"with abduction ({abd.tracker})", a))
        out.append("")
        out.append(f"{'; '.join(verdict)}. Events abduced: "
                   + ", ".join(f"{k} {v}" for k, v in sorted(abd.events.items(), key=lambda kv: -kv[1])) + ".")
        out.append("")
    return "\n".join(out)


def run_table6(data_root: str, tracker: str = DEFAULT_BACKEND, datasets=TABLE6_DATASETS,
               step_factory: Callable[[str, int], Callable[[str], None]] | None = None):
    """(baseline, abduction) runs for every dataset of Table 6, on the same detections."""
    runs = []
    for name in datasets:
        dataset = load_dataset(name, data_root)
        pair = []
        for t in (BASELINE, tracker):
            step = step_factory(f"{name}/{t}", len(dataset)) if step_factory else None
            pair.append(run_benchmark(name, data_root, t, step, dataset=dataset))
        runs.append(tuple(pair))
    return runs
