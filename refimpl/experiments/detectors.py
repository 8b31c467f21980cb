"""Which detector, and how much abduction helps it (issue 18; the paper's "Online Performance" table).

Two reports, both behind ``refimpl detectors``:

**Real detectors side by side** (``compare_detectors``).  For every detector of a benchmark
(``REAL_DETECTORS``: MOT15 has the official ACF ``det/det.txt`` in 7 sequences and SORT's Faster
R-CNN ``det/det_sort_frcnn.txt`` in all 11; KITTI Car has PointRCNN), on the sequences where
*every* compared detector exists: recall and precision of the raw detections, then the SORT
baseline and the abduction tracker on them (HOTA, MOTA, MOTP, IDF1, IDs, tracking fps).

**Detector-quality sweep** (refimpl.experiments.detector_sweep, ``--sweep``).  refimpl's simulated detector
(refimpl.io.simulate) on ground truth, over a seeded grid of detection probability, false positives
per frame and localisation noise; baseline vs abduction at every point.  This module holds what
both share: the raw-detection counts, tracking and evaluating a detection set, the docs section.

Raw-detection recall and precision count the rows refimpl's evaluator counts
(``refimpl.evaluation.evaluate``'s own preprocessing, not a copy of it): detections matched (IoU >= 0.5)
to a distractor row or lying mostly inside a KITTI DontCare region are removed first; the rest
are matched one-to-one (Hungarian, IoU >= 0.5) to the *considered* ground-truth rows of their
frame.  recall = matches / considered rows, precision = matches / detections kept.  The column
``TP startable`` is the share of matched detections whose 0..100 confidence exceeds the model's
``conf_thresh_new_track`` (model/constants.lp): only those may start a track under abduction
(the SORT baseline ignores confidences).

HOTA: read from the evaluator's dicts (key ``hota``) when refimpl.evaluation.evaluate provides it, printed
as ``-`` otherwise.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from .. import io
from ..core.constants import default_constants
from ..evaluation.evaluate import _check_results, _frame_slices, _match, _preprocess, evaluate_many
from ..io.datasets import REAL_DETECTORS, benchmark_sequences  # noqa: F401  (benchmark -> (key, file beside its detections or None, label))
from ..io.outputs import write_section as write
from ..solvers import BASELINE, DEFAULT_BACKEND
from .table6 import run_tracker

IOU_THRESHOLD = 0.5

ProgressStep = Callable[[str], None]


# ---------------------------------------------------------------------------------------
# Raw detection quality


@dataclass(frozen=True)
class DetectionQuality:
    """Counts of raw detections against ground truth (see the module doc for what is counted)."""

    num_gt: int
    """considered ground-truth rows"""
    num_dets: int
    """detections kept after distractor / DontCare removal"""
    matches: int
    removed: int
    """detections removed by the evaluator's preprocessing"""
    matches_startable: int
    """matched detections with confidence > conf_thresh_new_track"""

    @property
    def recall(self) -> float:
        return self.matches / self.num_gt if self.num_gt else math.nan

    @property
    def precision(self) -> float:
        return self.matches / self.num_dets if self.num_dets else math.nan

    @property
    def startable(self) -> float:
        return self.matches_startable / self.matches if self.matches else math.nan

    def __add__(self, other: "DetectionQuality") -> "DetectionQuality":
        return DetectionQuality(*(getattr(self, f.name) + getattr(other, f.name)
                                  for f in dataclasses.fields(self)))


def new_track_threshold() -> int:
    return int(default_constants()["conf_thresh_new_track"])


def detection_quality(gt: io.GroundTruth, dets: io.DetectionSequence,
                      iou_threshold: float = IOU_THRESHOLD, conf_thresh: int | None = None) -> DetectionQuality:
    """Recall / precision counts of a detection sequence against its ground truth (module doc)."""
    conf_thresh = new_track_threshold() if conf_thresh is None else conf_thresh
    boxes = [np.asarray(f.boxes, dtype=float).reshape(-1, 4) for f in dets.frames]
    n = sum(len(b) for b in boxes)
    conf = np.concatenate([np.asarray(f.confidences, dtype=float).reshape(-1) for f in dets.frames]) if n else np.zeros(0)
    rows = np.zeros((n, 6))
    k = 0
    for f, b in zip(dets.frames, boxes):
        rows[k:k + len(b), 0] = f.frame
        rows[k:k + len(b), 2:6] = b
        k += len(b)
    rows[:, 1] = np.arange(n)  # the row index as id: unique per frame, and it finds the confidence again
    res = _check_results(rows)
    first, last = gt.first_frame, gt.first_frame + gt.num_frames - 1
    extra = res[:, 0][(res[:, 0] < first) | (res[:, 0] > last)].astype(np.int64)
    numbers = np.union1d(np.arange(first, last + 1), extra)
    keep, removed_distractor, removed_dontcare = _preprocess(gt, res, iou_threshold, numbers)
    res = res[keep]
    cons = np.flatnonzero(gt.considered)
    cons = cons[np.argsort(gt.frames[cons], kind="stable")]
    o0, o1 = _frame_slices(gt.frames[cons], numbers)
    h0, h1 = _frame_slices(res[:, 0], numbers)
    matches = startable = 0
    for j in range(len(numbers)):
        if o0[j] == o1[j] or h0[j] == h1[j]:
            continue
        _, hi = _match(gt.boxes[cons[o0[j]:o1[j]]], res[h0[j]:h1[j], 2:6], iou_threshold)
        matches += len(hi)
        startable += int(np.count_nonzero(conf[res[h0[j] + hi, 1].astype(np.int64)] > conf_thresh))
    return DetectionQuality(len(cons), len(res), matches, removed_distractor + removed_dontcare, startable)


# ---------------------------------------------------------------------------------------
# Tracking one detection set with both trackers


@dataclass(frozen=True)
class TrackerRun:
    tracker: str
    overall: dict
    frames: int
    seconds: float
    """wall-clock seconds of tracking (files read beforehand; evaluation excluded)"""

    @property
    def fps(self) -> float:
        return self.frames / self.seconds if self.seconds > 0 else math.nan


def track_and_evaluate(triples: Sequence[tuple[str, io.DetectionSequence, io.GroundTruth]],
                       tracker: str, step: ProgressStep | None = None) -> TrackerRun:
    """Track every sequence with 'baseline' (SORT) or an abduction backend; the overall scores."""
    scored, seconds, frames = [], 0.0, 0
    for name, dets, gt in triples:
        t0 = time.perf_counter()
        rows, _ = run_tracker(dets, tracker)
        seconds += time.perf_counter() - t0
        frames += len(dets.frames)
        scored.append((name, gt, rows))
        if step:
            step(f"{tracker} {name}")
    _, overall = evaluate_many(scored, IOU_THRESHOLD)
    return TrackerRun(tracker, overall, frames, seconds)


def warm_up(triples, tracker: str, frames: int = 5) -> None:
    """Track the first few frames once, untimed (lazy imports, solver start-up)."""
    if triples:
        _, dets, _ = triples[0]
        run_tracker(dataclasses.replace(dets, frames=dets.frames[:frames]), tracker)


def first_frames(dets: io.DetectionSequence, gt: io.GroundTruth, n: int | None
                 ) -> tuple[io.DetectionSequence, io.GroundTruth]:
    """The first n frames of a sequence (detections and ground truth alike); None: all of them."""
    if n is None or n >= len(dets.frames):
        return dets, gt
    if n < 1:
        raise ValueError("max_frames must be >= 1")
    last = dets.first_frame + n - 1
    sel = gt.frames <= last
    dc = np.asarray(gt.dontcare, dtype=float).reshape(-1, 5)
    gt2 = dataclasses.replace(
        gt, frames=gt.frames[sel], ids=gt.ids[sel], boxes=gt.boxes[sel], considered=gt.considered[sel],
        distractor=gt.distractor[sel], visibility=np.asarray(gt.visibility)[sel],
        dontcare=dc[dc[:, 0] <= last], num_frames=max(0, min(gt.num_frames, last - gt.first_frame + 1)))
    return dataclasses.replace(dets, frames=dets.frames[:n]), gt2


# ---------------------------------------------------------------------------------------
# Real detectors side by side


@dataclass(frozen=True)
class DetectorResult:
    """One real detector on one benchmark: its detections' quality and every tracker run on them."""

    benchmark: str
    """A dataset of refimpl.io.datasets with real detectors (REAL_DETECTORS)."""
    detector: str
    label: str
    sequences: tuple[str, ...]
    """The sequences every detector of the benchmark covers (scored on exactly these)."""
    frames: int
    quality: DetectionQuality
    runs: tuple[TrackerRun, ...]
    score_range: tuple[float, float]


def _detector_files(benchmark: str, data_root: str | os.PathLike) -> list[tuple[str, str, dict]]:
    """(detector, label, {sequence name: BenchmarkSequence with that detector's file}) per detector,
    keeping only the sequences whose detection file exists."""
    if benchmark not in REAL_DETECTORS:
        raise ValueError(f"no real detectors registered for {benchmark!r} "
                         f"(known: {', '.join(REAL_DETECTORS)})")
    root = Path(data_root)
    if not root.is_dir():
        raise io.InputFormatError("data root not found", root)
    # the benchmark's own listing fixes sequences, gt and format; only the detection file varies
    out = []
    for key, filename, label in REAL_DETECTORS[benchmark]:
        seqs = {}
        for s in benchmark_sequences(benchmark, root):
            path = s.dets_path if filename is None else s.dets_path.with_name(filename)
            if path.is_file() and s.gt_path.is_file():
                seqs[s.name] = dataclasses.replace(s, dets_path=path)
        out.append((key, label, seqs))
    return out


def common_sequences(benchmark: str, data_root: str | os.PathLike,
                     only: Sequence[str] | None = None) -> list[str]:
    """The sequences (in the benchmark's order) where every registered detector has a file."""
    per = _detector_files(benchmark, data_root)
    names = [s for s in per[0][2] if all(s in seqs for _, _, seqs in per)]
    if only:
        unknown = [s for s in only if s not in names]
        if unknown:
            raise ValueError(f"{', '.join(unknown)}: not among the sequences of {benchmark} that every "
                             f"detector covers ({', '.join(names)})")
        names = [s for s in names if s in only]
    return names


def ungated(dets: io.DetectionSequence) -> io.DetectionSequence:
    """The same detections with every confidence set to 100: abduction without confidence gating."""
    return dataclasses.replace(dets, frames=tuple(
        dataclasses.replace(f, confidences=np.full(len(f), 100, dtype=np.int64)) for f in dets.frames))


def compare_detectors(benchmark: str, data_root: str | os.PathLike, backend: str = DEFAULT_BACKEND,
                      sequences: Sequence[str] | None = None, max_frames: int | None = None,
                      step: ProgressStep | None = None, with_ungated: bool = False) -> list[DetectorResult]:
    """Every registered detector of a benchmark on the common sequences: quality + both trackers.

    with_ungated: also, per detector, abduction on the same boxes with every confidence 100 (a
    diagnostic: how much of the result the confidence thresholds decide; SORT ignores confidences)."""
    names = common_sequences(benchmark, data_root, sequences)
    out = []
    for key, label, seqs in _detector_files(benchmark, data_root):
        triples, quality, lo, hi = [], DetectionQuality(0, 0, 0, 0, 0), math.inf, -math.inf
        for name in names:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", io.InputFormatWarning)  # KITTI zero-area boxes, recorded
                dets = io.load_detections(seqs[name])
            gt = io.load_ground_truth(seqs[name])
            dets, gt = first_frames(dets, gt, max_frames)
            scores = np.concatenate([f.scores for f in dets.frames])
            if len(scores):
                lo, hi = min(lo, float(scores.min())), max(hi, float(scores.max()))
            quality = quality + detection_quality(gt, dets)
            triples.append((name, dets, gt))
        for t in (BASELINE, backend):  # imports and solver set-up must not count against the first timing
            warm_up(triples, t)
        runs = tuple(track_and_evaluate(triples, t, step) for t in (BASELINE, backend))
        frames = sum(len(d.frames) for _, d, _ in triples)
        out.append(DetectorResult(benchmark, key, label, tuple(names), frames, quality, runs, (lo, hi)))
        if with_ungated:
            flat = [(n, ungated(d), g) for n, d, g in triples]
            q100 = dataclasses.replace(quality, matches_startable=quality.matches)
            out.append(DetectorResult(benchmark, f"{key}, conf=100", f"{label} with every confidence set to 100",
                                      tuple(names), frames, q100, (track_and_evaluate(flat, backend, step),),
                                      (lo, hi)))
    return out


def fmt_pct(v) -> str:
    return "-" if v is None or not np.isfinite(v) else f"{100.0 * v:.1f}"


def fmt_ratio(v: float) -> str:
    return "-" if not np.isfinite(v) else f"{v:.3f}"


def detectors_table(results: Sequence[DetectorResult]) -> str:
    """Markdown: per benchmark, one row per detector x tracker."""
    head = ("| detector | detections | recall | precision | TP startable | tracker | HOTA | MOTA | MOTP | IDF1 "
            "| FP | FN | IDs | fps |\n|---|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    blocks = []
    for bench in dict.fromkeys(r.benchmark for r in results):
        mine = [r for r in results if r.benchmark == bench]
        seqs = mine[0].sequences
        lines = [f"**{bench}** — {len(seqs)} sequences where every detector exists: {', '.join(seqs)} "
                 f"({mine[0].frames} frames, {mine[0].quality.num_gt} ground-truth boxes)\n", head]
        for r in mine:
            q = r.quality
            for k, run in enumerate(r.runs):
                o = run.overall
                det = ([f"{r.detector}", str(q.num_dets), fmt_ratio(q.recall), fmt_ratio(q.precision), fmt_pct(q.startable)]
                       if k == 0 else ["", "", "", "", ""])
                tracker = "baseline (SORT)" if run.tracker == BASELINE else f"abduction ({run.tracker})"
                cells = det + [tracker, fmt_pct(o.get("hota")), fmt_pct(o["mota"]), fmt_pct(o["motp"]), fmt_pct(o["idf1"]),
                               str(o["fp"]), str(o["fn"]), str(o["idsw"]), f"{run.fps:.0f}"]
                lines.append("| " + " | ".join(cells) + " |")
        lines.append("")
        lines.append("Detectors: " + "; ".join(
            f"{r.detector} = {r.label}, raw scores {r.score_range[0]:.2f} .. {r.score_range[1]:.2f}" for r in mine
            if ", conf=100" not in r.detector) + ".")
        if any(", conf=100" in r.detector for r in mine):
            lines.append("'<detector>, conf=100': the same boxes with every confidence set to 100, tracked by "
                         "abduction only (SORT ignores confidences): what the confidence thresholds decide.")
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks) + "\n"


# ---------------------------------------------------------------------------------------
# docs/detectors.md sections, JSON


REAL_BEGIN, REAL_END = "<!-- detectors-real:begin -->", "<!-- detectors-real:end -->"
SWEEP_BEGIN, SWEEP_END = "<!-- detectors-sweep:begin -->", "<!-- detectors-sweep:end -->"


def write_section(path: str | os.PathLike, begin: str, end: str, body: str) -> None:
    """Replace the text between the markers of a markdown file (appended if absent), atomically."""
    write(path, begin, end, body, title="# Detectors")


def _quality_json(q: DetectionQuality) -> dict:
    return {**dataclasses.asdict(q), "recall": q.recall, "precision": q.precision}


def _scores_json(overall: dict) -> dict:
    """The overall scores without the per-alpha HOTA fields (they only serve to combine sequences)."""
    return {k: v for k, v in overall.items() if not isinstance(v, (dict, list))}


def results_json(real: Sequence[DetectorResult], points: Sequence) -> str:
    """Both reports' numbers (points: detector_sweep.SweepPoint) as JSON."""
    return json.dumps({
        "real": [{"benchmark": r.benchmark, "detector": r.detector, "sequences": list(r.sequences),
                  "frames": r.frames, "quality": _quality_json(r.quality), "score_range": list(r.score_range),
                  "runs": [{"tracker": t.tracker, "fps": t.fps, "seconds": t.seconds, "overall": _scores_json(t.overall)}
                           for t in r.runs]} for r in real],
        "sweep": [{"dataset": p.dataset, "p_max": p.p_max, "fp_per_frame": p.fp_per_frame, "noise": p.noise,
                   "quality": _quality_json(p.quality), "baseline": _scores_json(p.baseline), "abduction": _scores_json(p.abduction)}
                  for p in points]}, indent=1, default=float)


# ---------------------------------------------------------------------------------------
# What `refimpl detectors` does (the CLI only parses its options)


def real_report(results: Sequence[DetectorResult], command: str, seconds: float) -> str:
    thr = new_track_threshold()
    return (f"Command: `{command}` (run took {seconds / 60:.1f} min)\n\n" + detectors_table(results) + "\n"
            "recall / precision: raw detections matched one-to-one at IoU >= 0.5 to the ground-truth rows the "
            "evaluator counts (distractor and DontCare removal as in refimpl.evaluation.evaluate). TP startable: share of "
            f"matched detections with confidence > conf_thresh_new_track = {thr} (only they can start a track "
            "under abduction; SORT ignores confidences). fps: frames / wall-clock seconds of tracking "
            "(files read beforehand, evaluation excluded). HOTA: '-' where the evaluator does not provide it.\n")
