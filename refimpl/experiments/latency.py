"""Latency: the CPU time of each frame's update, per tracker (an online tracker in a vehicle has a
deadline per frame, so the tail matters beside the mean).

Every tracker of a comparison is timed at the same boundary: ``time.process_time`` around one
frame's update, detections already in memory, scoring excluded (refimpl: ``run_sequence`` with
``frame_times``; the peers: their ``update`` call).  A :class:`Latency` summarises the frames of
one tracker on one dataset: frames per CPU second, the median and the 99th percentile per frame,
and the slowest frame with its size.

:func:`measure_latency` (``refimpl bench-latency``) times every frame of KITTI Car val and MOT15
with the defaults a user gets, with the heap left as the run leaves it and frozen as ``refimpl
track`` freezes it, and counts the full garbage collections that land in the timed frames (the
slowest frames were those, docs/benchmarks.md "The slowest frames").
"""

from __future__ import annotations

import gc
import time
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from .. import io
from ..io.datasets import dataset_kind, load_dataset
from ..solvers import DEFAULT_BACKEND
from ..tracking.pipeline import run_sequence, setup_for


@dataclass(frozen=True)
class Latency:
    frames: int
    seconds: float
    """CPU seconds of all frames' updates."""
    median_ms: float
    p99_ms: float
    worst_ms: float
    worst: str
    """Where the slowest frame is: ``sequence frame N (k detections)``."""

    @property
    def fps(self) -> float:
        return self.frames / self.seconds if self.seconds > 0 else float("nan")


def summarise(frames: Sequence[tuple[float, str, int, int]]) -> Latency | None:
    """(CPU seconds, sequence, frame, detections) per frame -> a Latency (None without frames).
    Percentiles by numpy's default (linear) rule; ties for the slowest frame go to the first."""
    if not frames:
        return None
    t = np.array([f[0] for f in frames], dtype=float)
    k = int(np.argmax(t))
    seconds, seq, frame, dets = frames[k]
    return Latency(len(t), float(t.sum()), 1000 * float(np.median(t)), 1000 * float(np.percentile(t, 99)),
                   1000 * float(seconds), f"{seq} frame {frame} ({dets} detections)")


# ---------------------------------------------------------------------------------------
# The per-frame latency of the defaults a user gets (issue 38): `refimpl bench-latency`
# ---------------------------------------------------------------------------------------

LATENCY_DATASETS = ("kitti-car-val", "mot15")
LATENCY_BEGIN, LATENCY_END = "<!-- bench-latency:begin -->", "<!-- bench-latency:end -->"
HEAPS = ("as is", "frozen")
"""How the process's heap is left while the frames are timed: as the run leaves it (every
sequence loaded, the results of the sequences before kept), or frozen after loading (gc.freeze:
what `refimpl track` does, refimpl.cli.common.frozen_heap), so that full collections walk only the
objects made while tracking."""


@dataclass(frozen=True)
class LatencyRun:
    """One backend with its defaults on some datasets, the heap left one way."""

    datasets: tuple[str, ...]
    heap: str
    latency: Latency
    full_collections: int
    """Full (generation 2) garbage collections while the sequences were tracked."""
    longest_collection_ms: float
    budget_hits: int
    over_budget: int
    frame_budget: float | None


class _FullCollections:
    """Counts and times the full garbage collections while it is entered (a gc callback, removed
    on exit): which frames a collection landed in is what makes the slowest ones slow."""

    def __init__(self) -> None:
        self.times: list[float] = []
        self._start = 0.0

    def __call__(self, phase: str, info: dict) -> None:
        if info.get("generation") != 2:
            return
        if phase == "start":
            self._start = time.process_time()
        else:
            self.times.append(time.process_time() - self._start)

    def __enter__(self) -> "_FullCollections":
        gc.callbacks.append(self)
        return self

    def __exit__(self, *exc) -> None:
        gc.callbacks.remove(self)


def _setup(name: str, data_root: str, backend: str):
    """The Setup a user gets for this dataset: the preset of its format and class (setup_for)."""
    fmt, cls = dataset_kind(name, data_root)
    return setup_for(io.get_format(fmt).preset_format, cls, backend)


def measure_latency(datasets: Sequence[str] = LATENCY_DATASETS, data_root: str = "../shared/data",
                    backend: str = DEFAULT_BACKEND, heaps: Sequence[str] = HEAPS,
                    step: Callable[[str], None] | None = None) -> list[LatencyRun]:
    """The CPU time of every frame of the datasets, tracked with the defaults a user gets
    (``setup_for``: the dataset's preset, the backend's default frame budget) through the one
    pipeline (``run_sequence(frame_times=)``, the boundary of this module), once per heap mode."""
    loaded = [(name, _setup(name, data_root, backend), load_dataset(name, data_root)) for name in datasets]
    runs = []
    for heap in heaps:
        if heap not in HEAPS:
            raise ValueError(f"heap must be one of {', '.join(HEAPS)}, got {heap!r}")
        frames, hits, over = [], 0, 0
        gc.collect()
        if heap == "frozen":
            gc.freeze()
        try:
            with _FullCollections() as collections:
                for name, setup, sequences in loaded:
                    for seq_name, seq, _gt in sequences:
                        times: list[float] = []
                        result = run_sequence(seq, setup, frame_times=times)
                        frames += [(t, seq_name, fr.frame, len(fr)) for t, fr in zip(times, seq.frames)]
                        hits += result.budget_hits
                        over += result.over_budget
                        if step:
                            step(f"{heap} {seq_name}")
        finally:
            if heap == "frozen":
                gc.unfreeze()
        longest = 1000.0 * max(collections.times, default=0.0)
        runs.append(LatencyRun(tuple(datasets), heap, summarise(frames), len(collections.times), longest, hits,
                               over, loaded[0][1].frame_budget if loaded else None))
    return runs


def latency_table(runs: Sequence[LatencyRun]) -> str:
    """Markdown: one row per heap mode."""
    lines = ["| heap | frames | CPU fps | p50 ms | p99 ms | worst ms | slowest frame | full collections "
             "(longest ms) | frames over the budget | budget hits |",
             "|---|---:|---:|---:|---:|---:|---|---:|---:|---:|"]
    for r in runs:
        lat = r.latency
        lines.append(f"| {r.heap} | {lat.frames} | {lat.fps:.0f} | {lat.median_ms:.2f} | {lat.p99_ms:.2f} | "
                     f"{lat.worst_ms:.1f} | {lat.worst} | {r.full_collections} ({r.longest_collection_ms:.1f}) | "
                     f"{r.over_budget} | {r.budget_hits} |")
    return "\n".join(lines) + "\n"


def latency_report(runs: Sequence[LatencyRun], command: str, machine: str, backend: str) -> str:
    budget = runs[0].frame_budget if runs else None
    return (f"Command: `{command}`  \n"
            f"`{backend}` with the defaults a user gets (each dataset's preset"
            + (f", the frame budget of {budget:g} ms" if budget is not None else ", no frame budget")
            + f") over {' and '.join(runs[0].datasets) if runs else '-'}, every sequence in one process.  \n"
            f"Machine: {machine}.\n\n{latency_table(runs)}\n"
            "CPU ms per frame: time.process_time around each frame's whole step (building the frame problem, "
            "solving, applying the answer; the detections already read), the boundary of "
            "refimpl.experiments.latency. Heap \"as is\": every sequence loaded and nothing frozen, so a full "
            "garbage collection walks all of it; \"frozen\": gc.freeze() after loading, as `refimpl track` "
            "runs (refimpl.cli.common.frozen_heap). Full collections: those while the sequences were tracked, and "
            "the longest. Over the budget: frames whose step took longer than the frame budget, wall-clock; budget "
            "hits: frames whose search it stopped (flagged not proven optimal).\n")
