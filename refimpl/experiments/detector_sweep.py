"""The detector-quality sweep (issue 18): refimpl's simulated detector over a grid of qualities.

refimpl.io.simulate turns ground truth into detections of a chosen quality; here a seeded grid over
the detection probability ``p_max`` (1 - miss rate of a fully visible object), false positives per
frame and localisation noise (centre and log-size std. dev. as a fraction of the box), on MOT17
train and KITTI Car ground truth, serially.  At every point: the measured recall / precision of
the simulated detections (as refimpl.experiments.detectors counts them), and the SORT baseline vs the
abduction tracker (HOTA, MOTA, IDF1, IDs + Frag).  ``refimpl detectors --sweep`` runs it, and
``refimpl detectors`` runs either report through :func:`run_detectors` here (this module builds on
refimpl.experiments.detectors, never the other way round).

Limits of what it says: the simulator's false positives are drawn independently in every frame
(they never persist from one frame to the next, as a real detector's repeated false alarm on a
background object does), so both trackers filter them far more easily than real ones; and KITTI
ground truth carries no visibility, so a car is missed with the same probability 1 - p_max
whether it is occluded or not.
"""

from __future__ import annotations

import dataclasses
import math
import os
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from .. import io
from ..io.datasets import benchmark_sequences
from .detectors import (REAL_BEGIN, REAL_DETECTORS, REAL_END, SWEEP_BEGIN, SWEEP_END, DetectionQuality,
                        DetectorResult, ProgressStep, common_sequences, compare_detectors, detection_quality,
                        first_frames, fmt_pct, fmt_ratio, real_report, results_json, track_and_evaluate,
                        write_section)
from ..io.simulate import MOT17_GT_VARIANT, MOT17_TRAIN, DetectorParams, simulate_detections
from ..scene.plots import agg_figure, colormap
from ..solvers import BASELINE, DEFAULT_BACKEND




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
        listing = {s.name: s for s in benchmark_sequences("kitti-car", root)}
        for s in names:
            if s not in listing:
                raise ValueError(f"unknown KITTI sequence {s!r} (known: {', '.join(listing)})")
            fmt = io.get_format(listing[s].format)
            out.append((s, io.load_ground_truth(listing[s]), fmt.image_size, fmt.fps))
    else:
        raise ValueError(f"unknown sweep dataset {dataset!r} (choose from {', '.join(SWEEP_DATASETS)})")
    return out


def detector_params(dataset: str, p_max: float, fp_per_frame: float, noise: float):
    extra = KITTI_CAR_FALSE_POSITIVES if dataset == "kitti-car" else {}
    return DetectorParams(p_max=p_max, fp_per_frame=fp_per_frame, centre_sigma=noise, size_sigma=noise, **extra)


def sweep(dataset: str, data_root: str | os.PathLike, backend: str = DEFAULT_BACKEND,
          p_max: Sequence[float] = DEFAULT_P_MAX, fp_per_frame: Sequence[float] = DEFAULT_FP_PER_FRAME,
          noise: Sequence[float] = DEFAULT_NOISE, seed: int = 0, sequences: Sequence[str] | None = None,
          max_frames: int | None = None, step: ProgressStep | None = None) -> list[SweepPoint]:
    """Baseline vs abduction at every grid point (serially, in grid order; seed fixed per point)."""
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
                base = track_and_evaluate(triples, BASELINE)
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
                f"| {p.p_max:g} | {p.fp_per_frame:g} | {p.noise:g} | {fmt_ratio(p.quality.recall)} | "
                f"{fmt_ratio(p.quality.precision)} | {fmt_pct(b.get('hota'))} / {fmt_pct(a.get('hota'))} | "
                f"{fmt_pct(b['mota'])} / {fmt_pct(a['mota'])} | {_gain(a['mota'], b['mota'])} | "
                f"{fmt_pct(b['idf1'])} / {fmt_pct(a['idf1'])} | {_gain(a['idf1'], b['idf1'])} | "
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
    key = "hota" if _has_hota(points) else "mota"
    datasets = list(dict.fromkeys(p.dataset for p in points))
    fig = agg_figure((10, 3.8 * len(datasets)), 100)
    axes = fig.subplots(len(datasets), 2, squeeze=False)
    fps_levels = sorted({p.fp_per_frame for p in points})
    noise_levels = sorted({p.noise for p in points})
    colours = colormap("viridis")(np.linspace(0.0, 0.85, max(len(fps_levels), 1)))
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
    return key


def sweep_report(points: Sequence[SweepPoint], command: str, seconds: float, seed: int,
                 sequences: dict[str, Sequence[str]], max_frames: int | None, plot: str | None) -> str:
    used = "; ".join(f"{ds}: {', '.join(s)}" for ds, s in sequences.items())
    frames = f", first {max_frames} frames of each" if max_frames else " (all frames)"
    text = (f"Command: `{command}` (run took {seconds / 60:.1f} min)  \n"
            f"Sequences: {used}{frames}; simulated detector seed {seed}.\n\n" + sweep_table(points) + "\n"
            "p_max: detection probability of a fully visible object (1 - miss rate; MOT17 misses partly "
            "occluded people more, see refimpl.io.simulate); FP/frame: Poisson mean of false positives; noise: "
            "std. dev. of the centre offset and of the log-size error, as a fraction of the box. det recall / "
            "precision: measured on the simulated detections as in the real-detector table. b / a: baseline "
            "(SORT) / abduction (cpsat); gains in percentage points.\n")
    if plot:
        text += f"\n![abduction's gain against detector recall]({Path(plot).name})\n"
    return text

def run_detectors(*, data: str = "../shared/data", backend: str = DEFAULT_BACKEND, do_sweep: bool = False,
                  benchmarks: Sequence[str] = tuple(REAL_DETECTORS), sequences: Sequence[str] | None = None,
                  max_frames: int | None = None, sweep_datasets: Sequence[str] | None = None,
                  p_max: Sequence[float] | None = None, fp_per_frame: Sequence[float] | None = None,
                  noise: Sequence[float] | None = None, seed: int = 0, out: str | None = None,
                  plot: str | None = None, json_path: str | None = None, command: str = "refimpl detectors",
                  with_ungated: bool = False,
                  progress: Callable[[int, str], object] | None = None) -> str:
    """Run one of the two reports; write its section of ``out`` (and the sweep's plot); return the text.
    Sweep options left None take this module's defaults."""
    sweep_datasets = SWEEP_DATASETS if sweep_datasets is None else sweep_datasets
    p_max = DEFAULT_P_MAX if p_max is None else p_max
    fp_per_frame = DEFAULT_FP_PER_FRAME if fp_per_frame is None else fp_per_frame
    noise = DEFAULT_NOISE if noise is None else noise
    started = time.perf_counter()
    real: list[DetectorResult] = []
    points: list = []
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
