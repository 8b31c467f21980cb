"""Which detector, and how much abduction helps it (issue 18; the paper's "Online Performance" table).

Two reports, both behind ``refimpl detectors``:

**Real detectors side by side** (``compare_detectors``).  For every detector of a benchmark
(``REAL_DETECTORS``: MOT15 has the official ACF ``det/det.txt`` in 7 sequences and SORT's Faster
R-CNN ``det/det_sort_frcnn.txt`` in all 11; KITTI Car has PointRCNN), on the sequences where
*every* compared detector exists: recall and precision of the raw detections, then the SORT
baseline and the abduction tracker on them (HOTA, MOTA, MOTP, IDF1, IDs, tracking fps).

**Detector-quality sweep** (``sweep``).  refimpl's simulated detector (refimpl.simulate) on
ground truth, over a seeded grid of detection probability (``p_max``: 1 - miss rate of a fully
visible object), false positives per frame and localisation noise; baseline vs abduction at
every point.

Raw-detection recall and precision count the rows refimpl's evaluator counts
(``refimpl.evaluate``'s own preprocessing, not a copy of it): detections matched (IoU >= 0.5)
to a distractor row or lying mostly inside a KITTI DontCare region are removed first; the rest
are matched one-to-one (Hungarian, IoU >= 0.5) to the *considered* ground-truth rows of their
frame.  recall = matches / considered rows, precision = matches / detections kept.  The column
``TP startable`` is the share of matched detections whose 0..100 confidence exceeds the model's
``conf_thresh_new_track`` (model/constants.lp): only those may start a track under abduction
(the SORT baseline ignores confidences).

HOTA: read from the evaluator's dicts (key ``hota``) when refimpl.evaluate provides it, printed
as ``-`` otherwise.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import tempfile
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from . import io
from .evaluate import _check_results, _frame_slices, _match, _preprocess, evaluate_many

IOU_THRESHOLD = 0.5

REAL_DETECTORS: dict[str, tuple[tuple[str, str | None, str], ...]] = {
    "mot15": (("acf", "det.txt", "ACF (official MOT15 public detections)"),
              ("frcnn", "det_sort_frcnn.txt", "Faster R-CNN (SORT's detections)")),
    "kitti-car": (("pointrcnn", None, "PointRCNN (AB3DMOT's detections)"),),
}
"""benchmark -> (detector key, file name beside the benchmark's detection file or None for that
file itself, label).  Benchmarks are those of refimpl.io.benchmark_sequences."""

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
    from .constants import default_constants
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
    from .table6 import run_tracker
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
    from .table6 import run_tracker
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
    benchmark: str
    detector: str
    label: str
    sequences: tuple[str, ...]
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
        for s in io.benchmark_sequences(benchmark, root):
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


def compare_detectors(benchmark: str, data_root: str | os.PathLike, backend: str = "cpsat",
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
        for t in ("baseline", backend):  # imports and solver set-up must not count against the first timing
            warm_up(triples, t)
        runs = tuple(track_and_evaluate(triples, t, step) for t in ("baseline", backend))
        frames = sum(len(d.frames) for _, d, _ in triples)
        out.append(DetectorResult(benchmark, key, label, tuple(names), frames, quality, runs, (lo, hi)))
        if with_ungated:
            flat = [(n, ungated(d), g) for n, d, g in triples]
            q100 = dataclasses.replace(quality, matches_startable=quality.matches)
            out.append(DetectorResult(benchmark, f"{key}, conf=100", f"{label} with every confidence set to 100",
                                      tuple(names), frames, q100, (track_and_evaluate(flat, backend, step),),
                                      (lo, hi)))
    return out


def _pct(v) -> str:
    return "-" if v is None or not np.isfinite(v) else f"{100.0 * v:.1f}"


def _ratio(v: float) -> str:
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
                det = ([f"{r.detector}", str(q.num_dets), _ratio(q.recall), _ratio(q.precision), _pct(q.startable)]
                       if k == 0 else ["", "", "", "", ""])
                tracker = "baseline (SORT)" if run.tracker == "baseline" else f"abduction ({run.tracker})"
                cells = det + [tracker, _pct(o.get("hota")), _pct(o["mota"]), _pct(o["motp"]), _pct(o["idf1"]),
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
# The simulated detector-quality sweep


SWEEP_DATASETS = ("mot17", "kitti-car")
SWEEP_SUBSETS = {
    "mot17": ("MOT17-05", "MOT17-09", "MOT17-11"),
    "kitti-car": ("0001", "0006", "0008", "0010", "0018"),
}
"""Default sequences of the sweep (minutes on 2 cores): three MOT17 train sequences of different
kinds (moving low camera 640x480, static camera, moving camera), and five KITTI Car sequences of
the validation split (evaluate_tracking.seqmap.val) holding most of its cars."""
DEFAULT_P_MAX = (0.5, 0.7, 0.9)
DEFAULT_FP_PER_FRAME = (0.5, 2.0, 5.0)
DEFAULT_NOISE = (0.03, 0.10)
KITTI_CAR_FALSE_POSITIVES = {"fp_aspect": 1.5, "fp_min_height": 18.0, "fp_max_height_frac": 0.5}
"""Car-shaped image-wide false positives on KITTI: median Car box aspect w/h 1.5, 5th percentile
height 18 px over the 21 training sequences (the simulator's defaults are for pedestrians)."""


@dataclass(frozen=True)
class SweepPoint:
    dataset: str
    p_max: float
    fp_per_frame: float
    noise: float
    """centre_sigma = size_sigma"""
    quality: DetectionQuality
    baseline: dict
    abduction: dict


def sweep_data(dataset: str, data_root: str | os.PathLike, sequences: Sequence[str] | None = None
               ) -> list[tuple[str, io.GroundTruth, tuple[int, int] | None, float | None]]:
    """(name, ground truth, image size, fps) of the sweep's sequences."""
    from .simulate import MOT17_GT_VARIANT, MOT17_TRAIN
    names = list(sequences) if sequences else list(SWEEP_SUBSETS[dataset])
    root = Path(data_root)
    out = []
    if dataset == "mot17":
        for s in names:
            if s not in MOT17_TRAIN:
                raise ValueError(f"unknown MOT17 train sequence {s!r} (known: {', '.join(MOT17_TRAIN)})")
            folder = root / "MOT17" / "train" / f"{s}-{MOT17_GT_VARIANT}"
            info = io.read_seqinfo(folder / "seqinfo.ini")
            gt = dataclasses.replace(io.read_mot_ground_truth(folder / "gt" / "gt.txt", seqinfo=info), name=s)
            out.append((s, gt, (int(info["imWidth"]), int(info["imHeight"])), float(info["frameRate"])))
    elif dataset == "kitti-car":
        listing = {s.name: s for s in io.benchmark_sequences("kitti-car", root)}
        for s in names:
            if s not in listing:
                raise ValueError(f"unknown KITTI sequence {s!r} (known: {', '.join(listing)})")
            out.append((s, io.load_ground_truth(listing[s]), io.KITTI_IMAGE_SIZE, io.KITTI_FPS))
    else:
        raise ValueError(f"unknown sweep dataset {dataset!r} (choose from {', '.join(SWEEP_DATASETS)})")
    return out


def detector_params(dataset: str, p_max: float, fp_per_frame: float, noise: float):
    from .simulate import DetectorParams
    extra = KITTI_CAR_FALSE_POSITIVES if dataset == "kitti-car" else {}
    return DetectorParams(p_max=p_max, fp_per_frame=fp_per_frame, centre_sigma=noise, size_sigma=noise, **extra)


def sweep(dataset: str, data_root: str | os.PathLike, backend: str = "cpsat",
          p_max: Sequence[float] = DEFAULT_P_MAX, fp_per_frame: Sequence[float] = DEFAULT_FP_PER_FRAME,
          noise: Sequence[float] = DEFAULT_NOISE, seed: int = 0, sequences: Sequence[str] | None = None,
          max_frames: int | None = None, step: ProgressStep | None = None) -> list[SweepPoint]:
    """Baseline vs abduction at every grid point (serially, in grid order; seed fixed per point)."""
    from .simulate import simulate_detections
    data = sweep_data(dataset, data_root, sequences)
    otype = "car" if dataset == "kitti-car" else "pedestrian"
    points = []
    for pm in p_max:
        for fp in fp_per_frame:
            for nz in noise:
                params = detector_params(dataset, pm, fp, nz)
                triples, quality = [], DetectionQuality(0, 0, 0, 0, 0)
                for name, gt, size, fps in data:
                    dets = simulate_detections(gt, seed=seed, params=params, image_size=size, fps=fps,
                                               name=name, object_type=otype)
                    dets, g = first_frames(dets, gt, max_frames)
                    quality = quality + detection_quality(g, dets)
                    triples.append((name, dets, g))
                base = track_and_evaluate(triples, "baseline")
                abd = track_and_evaluate(triples, backend)
                points.append(SweepPoint(dataset, pm, fp, nz, quality, base.overall, abd.overall))
                if step:
                    step(f"{dataset} p_max={pm:g} fp={fp:g} noise={nz:g}")
    return points


def _gain(a, b) -> str:
    if a is None or b is None or not (np.isfinite(a) and np.isfinite(b)):
        return "-"
    return f"{100.0 * (a - b):+.1f}"


def sweep_table(points: Sequence[SweepPoint]) -> str:
    """Markdown: one row per grid point, baseline / abduction side by side (b / a)."""
    head = ("| p_max | FP/frame | noise | det recall | det precision | HOTA b / a | MOTA b / a | MOTA gain "
            "| IDF1 b / a | IDF1 gain | IDs+Frag b / a |\n"
            "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    blocks = []
    for ds in dict.fromkeys(p.dataset for p in points):
        lines = [f"**{ds}** (simulated detections)\n", head]
        for p in (q for q in points if q.dataset == ds):
            b, a = p.baseline, p.abduction
            lines.append(
                f"| {p.p_max:g} | {p.fp_per_frame:g} | {p.noise:g} | {_ratio(p.quality.recall)} | "
                f"{_ratio(p.quality.precision)} | {_pct(b.get('hota'))} / {_pct(a.get('hota'))} | "
                f"{_pct(b['mota'])} / {_pct(a['mota'])} | {_gain(a['mota'], b['mota'])} | "
                f"{_pct(b['idf1'])} / {_pct(a['idf1'])} | {_gain(a['idf1'], b['idf1'])} | "
                f"{b['idsw'] + b['frag']} / {a['idsw'] + a['frag']} |")
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks) + "\n"


def _has_hota(points: Sequence[SweepPoint]) -> bool:
    return all(np.isfinite(p.baseline.get("hota", math.nan)) and np.isfinite(p.abduction.get("hota", math.nan))
               for p in points)


def plot_sweep(points: Sequence[SweepPoint], path: str | os.PathLike) -> str:
    """Abduction's gain (HOTA if the evaluator gives it, else MOTA; and IDF1) against the measured
    detector recall, one line per FP rate and noise level, one row of panels per dataset.
    Written atomically (a temporary file in the same folder, then renamed).  Returns the metric
    used for the first column."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    key = "hota" if _has_hota(points) else "mota"
    datasets = list(dict.fromkeys(p.dataset for p in points))
    fig, axes = plt.subplots(len(datasets), 2, figsize=(10, 3.8 * len(datasets)), dpi=100, squeeze=False)
    fps_levels = sorted({p.fp_per_frame for p in points})
    noise_levels = sorted({p.noise for p in points})
    colours = plt.get_cmap("viridis")(np.linspace(0.0, 0.85, max(len(fps_levels), 1)))
    styles = ["-", "--", ":", "-."]
    for row, ds in enumerate(datasets):
        for col, metric in enumerate((key, "idf1")):
            ax = axes[row][col]
            for ci, fp in enumerate(fps_levels):
                for si, nz in enumerate(noise_levels):
                    pts = sorted((p.quality.recall, 100.0 * (p.abduction[metric] - p.baseline[metric]))
                                 for p in points if p.dataset == ds and p.fp_per_frame == fp and p.noise == nz)
                    if pts:
                        ax.plot([x for x, _ in pts], [y for _, y in pts], styles[si % len(styles)],
                                color=colours[ci], marker="o", markersize=4,
                                label=f"{fp:g} FP/frame, noise {nz:g}")
            ax.axhline(0.0, color="grey", linewidth=0.8)
            ax.set_xlabel("detector recall (measured, IoU 0.5)")
            ax.set_ylabel(f"{metric.upper()} abduction - baseline (points)")
            ax.set_title(f"{ds} (simulated detections): {metric.upper()} gain")
            ax.grid(True, alpha=0.3)
        axes[row][0].legend(fontsize=7)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".png")
    os.close(fd)
    try:
        fig.savefig(tmp, format="png")
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    finally:
        plt.close(fig)
    return key


# ---------------------------------------------------------------------------------------
# docs/detectors.md sections, JSON


REAL_BEGIN, REAL_END = "<!-- detectors-real:begin -->", "<!-- detectors-real:end -->"
SWEEP_BEGIN, SWEEP_END = "<!-- detectors-sweep:begin -->", "<!-- detectors-sweep:end -->"


def write_section(path: str | os.PathLike, begin: str, end: str, body: str) -> None:
    """Replace the text between the markers of a markdown file (appended if absent), atomically."""
    p = Path(path)
    text = p.read_text(encoding="utf-8") if p.exists() else "# Detectors\n"
    block = f"{begin}\n{body.rstrip()}\n{end}"
    if begin in text and end in text:
        head, rest = text.split(begin, 1)
        _, tail = rest.split(end, 1)
        text = head + block + tail
    else:
        text = text.rstrip() + "\n\n" + block + "\n"
    io.write_text_atomic(p, text)


def _quality_json(q: DetectionQuality) -> dict:
    return {**dataclasses.asdict(q), "recall": q.recall, "precision": q.precision}


def _scores_json(overall: dict) -> dict:
    """The overall scores without the per-alpha HOTA fields (they only serve to combine sequences)."""
    return {k: v for k, v in overall.items() if not isinstance(v, (dict, list))}


def results_json(real: Sequence[DetectorResult], points: Sequence[SweepPoint]) -> str:
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
            "evaluator counts (distractor and DontCare removal as in refimpl.evaluate). TP startable: share of "
            f"matched detections with confidence > conf_thresh_new_track = {thr} (only they can start a track "
            "under abduction; SORT ignores confidences). fps: frames / wall-clock seconds of tracking "
            "(files read beforehand, evaluation excluded). HOTA: '-' where the evaluator does not provide it.\n")


def sweep_report(points: Sequence[SweepPoint], command: str, seconds: float, seed: int,
                 sequences: dict[str, Sequence[str]], max_frames: int | None, plot: str | None) -> str:
    used = "; ".join(f"{ds}: {', '.join(s)}" for ds, s in sequences.items())
    frames = f", first {max_frames} frames of each" if max_frames else " (all frames)"
    text = (f"Command: `{command}` (run took {seconds / 60:.1f} min)  \n"
            f"Sequences: {used}{frames}; simulated detector seed {seed}.\n\n" + sweep_table(points) + "\n"
            "p_max: detection probability of a fully visible object (1 - miss rate; MOT17 misses partly "
            "occluded people more, see refimpl.simulate); FP/frame: Poisson mean of false positives; noise: "
            "std. dev. of the centre offset and of the log-size error, as a fraction of the box. det recall / "
            "precision: measured on the simulated detections as in the real-detector table. b / a: baseline "
            "(SORT) / abduction (cpsat); gains in percentage points.\n")
    if plot:
        text += f"\n![abduction's gain against detector recall]({Path(plot).name})\n"
    return text


def run_detectors(*, data: str = "../shared/data", backend: str = "cpsat", do_sweep: bool = False,
                  benchmarks: Sequence[str] = tuple(REAL_DETECTORS), sequences: Sequence[str] | None = None,
                  max_frames: int | None = None, sweep_datasets: Sequence[str] = SWEEP_DATASETS,
                  p_max: Sequence[float] = DEFAULT_P_MAX, fp_per_frame: Sequence[float] = DEFAULT_FP_PER_FRAME,
                  noise: Sequence[float] = DEFAULT_NOISE, seed: int = 0, out: str | None = None,
                  plot: str | None = None, json_path: str | None = None, command: str = "refimpl detectors",
                  with_ungated: bool = False,
                  progress: Callable[[int, str], object] | None = None) -> str:
    """Run one of the two reports; write its section of ``out`` (and the sweep's plot); return the text."""
    started = time.perf_counter()
    real: list[DetectorResult] = []
    points: list[SweepPoint] = []
    if not do_sweep:
        for bench in benchmarks:
            n = len(common_sequences(bench, data, sequences)) * len(REAL_DETECTORS[bench]) * (3 if with_ungated else 2)
            bar = progress(n, f"detectors {bench}") if progress else None
            real += compare_detectors(bench, data, backend, sequences, max_frames, bar.step if bar else None,
                                      with_ungated)
        report = real_report(real, command, time.perf_counter() - started)
        if out:
            write_section(out, REAL_BEGIN, REAL_END, report)
    else:
        used = {}
        for ds in sweep_datasets:
            names = [name for name, *_ in sweep_data(ds, data, sequences)]
            used[ds] = names
            n = len(p_max) * len(fp_per_frame) * len(noise)
            bar = progress(n, f"sweep {ds}") if progress else None
            points += sweep(ds, data, backend, p_max, fp_per_frame, noise, seed, sequences, max_frames,
                            bar.step if bar else None)
        plot_path = plot or (str(Path(out).with_name("detectors-sweep.png")) if out else None)
        if plot_path:
            metric = plot_sweep(points, plot_path)
        report = sweep_report(points, command, time.perf_counter() - started, seed, used, max_frames,
                              plot_path if out else None)
        if out:
            write_section(out, SWEEP_BEGIN, SWEEP_END, report)
        if plot_path:
            report += f"\nplot ({metric.upper()} and IDF1 gain against detector recall): {plot_path}\n"
    if json_path:
        io.write_text_atomic(json_path, results_json(real, points))
    if out:
        report += f"written: {out}\n"
    return report
