"""Benchmark runs and the paper's Table 6: baseline vs tracking with abduction, per dataset.

Datasets: MOT15 train (SORT's Faster R-CNN detections), KITTI train Car and Pedestrian
(PointRCNN detections), and MOT17 train / MOT20-01 with *simulated* detections (refimpl.io.simulate:
no public detections for them ship here), always labelled as such.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from typing import Callable

from ..evaluation.evaluate import evaluate_many
from ..io.datasets import TITLES, load_dataset
from ..solvers import BASELINE
from ..tracking.options import TrackerOptions
from ..tracking.pipeline import Setup, run_sequence


@dataclass(frozen=True)
class BenchmarkRun:
    dataset: str
    tracker: str
    per_sequence: dict
    overall: dict
    events: dict
    frames: int
    seconds: float
    """CPU seconds of the trackers' per-frame updates (evaluation and set-up excluded)."""
    latency: tuple = ()
    """(CPU seconds, sequence, frame, detections) of every frame tracked (refimpl.experiments.latency)."""


def run_tracker(seq, tracker: str, constants=None, options=None, frame_times: list | None = None,
                setup: Setup | None = None):
    """Results rows and events of one sequence with 'baseline' (SORT) or an abduction backend
    (with these model constants on top of model/constants.lp and these TrackerOptions, or as
    ``setup`` says: a preset's, refimpl.tracking.pipeline.setup_for), through the one pipeline
    (refimpl.tracking.pipeline)."""
    if setup is None:
        setup = Setup(tracker) if tracker == BASELINE else \
            Setup(tracker, tuple((constants or {}).items()), options or TrackerOptions())
    result = run_sequence(seq, setup, frame_times=frame_times)
    return result.rows, result.events


def run_benchmark(name: str, data_root: str, tracker: str, step: Callable[[str], None] | None = None,
                  dataset=None, constants=None, options=None, setup: Setup | None = None) -> BenchmarkRun:
    """Track and evaluate every sequence of a dataset; ``seconds`` is the CPU time of the tracker's
    per-frame updates alone (detections already in memory; set-up and evaluation excluded), the
    boundary the peers are timed at (refimpl.experiments.peers)."""
    dataset = dataset if dataset is not None else load_dataset(name, data_root)
    triples, events, frames = [], Counter(), 0
    latency: list = []
    for seq_name, dets, gt in dataset:
        times: list[float] = []
        rows, evs = run_tracker(dets, tracker, constants, options, frame_times=times, setup=setup)
        latency += [(t, seq_name, fr.frame, len(fr)) for t, fr in zip(times, dets.frames)]
        events.update(e.event.name for e in evs)
        frames += len(dets.frames)
        triples.append((seq_name, gt, rows))
        if step:
            step(seq_name)
    per_seq, overall = evaluate_many(triples)
    return BenchmarkRun(name, tracker, per_seq, overall, dict(events), frames, sum(t for t, *_ in latency),
                        tuple(latency))


def _pct(v: float) -> str:
    return "-" if v != v else f"{100 * v:.1f}"


def table6_row(label: str, o: dict) -> str:
    hota = " | ".join(_pct(o[k]) for k in ("hota", "deta", "assa"))
    return (f"| {label} | {hota} | {_pct(o['mota'])} | {_pct(o['motp'])} | {_pct(o['idf1'])} | {o['mt']} "
            f"| {o['ml']} | {o['fp']} | {o['fn']} | {o['idsw']} | {o['frag']} |")


PAPER_ID_SWITCHES: dict[str, tuple[str, int, int]] = {
    "kitti-car": ("KITTI tracking, Cars, YOLOv3 detections", 1097, 165),
    "kitti-ped": ("KITTI tracking, Pedestrians, YOLOv3 detections", 539, 115),
    "mot17-sim": ("MOT 2017, Faster R-CNN detections", 779, 800),
    "mot20-01-sim": ("MOT 2020, 4 sequences, Faster R-CNN detections", 36560, 17658),
}
"""The paper's Table 6, ID sw. column: dataset -> (the paper's row, baseline, with abduction), on the
paper's own detections (its evaluation section: YOLOv3 on KITTI, the provided Faster R-CNN on
MOT17 / MOT20), for the datasets of ours that stand for one of its rows."""


def change(before: int, after: int) -> str:
    """'1097 -> 165 (-85.0 %)': a count before and after, with the relative change (the paper's
    headline is the ID switches' change); no percentage from a count of 0."""
    if before == 0:
        return f"{before} -> {after}" + ("" if after == 0 else " (from none)")
    return f"{before} -> {after} ({100 * (after - before) / before:+.1f} %)"


def format_table6(runs: list[tuple[BenchmarkRun, BenchmarkRun]]) -> str:
    """Markdown in the shape of the paper's Table 6: one block per dataset, baseline vs abduction,
    then the verdicts: MOTA, IDF1 and HOTA up or not, and the change in ID switches (the paper's
    headline) and, separately, in fragmentations, with the paper's own ID switches beside."""
    head = ("| tracker | HOTA | DetA | AssA | MOTA | MOTP | IDF1 | MT | ML | FP | FN | ID sw. | Frag. |\n"
            "|---|" + "---:|" * 12)
    out = []
    for base, abd in runs:
        b, a = base.overall, abd.overall
        verdict = []
        verdict.append("MOTA " + ("up" if a["mota"] > b["mota"] else "NOT up"))
        verdict.append("IDF1 " + ("up" if a["idf1"] > b["idf1"] else "NOT up"))
        verdict.append("HOTA " + ("up" if a["hota"] > b["hota"] else "NOT up"))
        verdict.append(f"ID sw. {change(b['idsw'], a['idsw'])}")
        verdict.append(f"Frag. {change(b['frag'], a['frag'])}")
        out.append(f"**{TITLES[base.dataset]}** — {base.frames} frames, {b['num_unique_objects']} targets\n")
        out.append(head)
        out.append(table6_row("baseline (SORT)", b))
        out.append(table6_row(f"with abduction ({abd.tracker})", a))
        out.append("")
        paper = PAPER_ID_SWITCHES.get(base.dataset)
        if paper:
            verdict.append(f"the paper ({paper[0]}): ID sw. {change(paper[1], paper[2])}")
        out.append(f"{'; '.join(verdict)}. Events abduced: "
                   + ", ".join(f"{k} {v}" for k, v in sorted(abd.events.items(), key=lambda kv: -kv[1])) + ".")
        out.append("")
    return "\n".join(out)
