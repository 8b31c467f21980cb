"""Scalability and throughput benchmarks (the paper's Section 4.2.2 "Online Performance and Scalability").

``refimpl bench-scale`` (``bench_scale``): synthetic frames (refimpl.experiments.synthetic) with n tracks and an
overlap share, several seeds each; every backend solves the *same* frames in the same run, one
after another (in an order rotated from frame to frame), each with a per-frame time limit.  Per
(n, overlap) and backend: median and max wall-clock ms per frame (model building included: the
whole ``solve`` call), the share of frames proven optimal, and whether the backends' cost vectors
agree on the frames that two or more of them proved optimal.  The timings of one run on a shared
machine are noisy; the ratio of two backends on the same frames is what to read.

``refimpl bench-scale --throughput`` (``bench_throughput``): frames per second of the whole
tracking loop (``refimpl track``: Kalman prediction, problem building, abduction, update; not
reading the files) per tracker on MOT15 (11 train sequences) and KITTI Car (21 sequences).

Both write their markdown tables between marker comments of docs/benchmarks.md (the rest of
the file is prose and is kept), a PNG plot (docs/scalability.png) and optionally the raw
per-frame results as JSON, from which ``--from-json`` redraws tables and plot without solving.

Backends: every name of the registry refimpl.solvers.BACKENDS (``cpsat``: the fast exact path,
the full CP-SAT model where it declines; ``cpsat-full``: every frame through the full CP-SAT
model; ``clingo``: the ASP encoding).  Throughput also has ``baseline`` (SORT).
"""

from __future__ import annotations

import gc
import hashlib
import json
import os
import platform
import statistics
import time
import warnings
from importlib import metadata
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable, Iterable, Sequence

from .. import io
from ..core import bigint
from ..core.errors import UserFacingError
from ..core.records import RecordTooLong, read_text
from ..io.datasets import THROUGHPUT_DATASETS as THROUGHPUT_BENCHMARKS, benchmark_sequences
from ..io.outputs import OutputSet, section_text, write_section  # noqa: F401  (section_text, write_section: re-exported for the report writers)
from ..solvers import BACKENDS as SCALE_BACKENDS, BASELINE, COLOURS, DEFAULT_BACKEND, REFERENCE_BACKEND, TRACKERS, get_solver
from ..scene.plots import agg_figure
from ..solvers.common import components
from ..tracking.pipeline import Setup, run_sequence
from .synthetic import dense_frame, synthetic_frame

THROUGHPUT_TRACKERS = TRACKERS
DEFAULT_SIZES = (5, 10, 20, 50, 100, 200)
DENSE_SIZES = (50, 100, 200, 400)
"""``bench-scale --dense``: tracks of the dense crowds (refimpl.experiments.synthetic.dense_frame), one component each."""
DEFAULT_OVERLAPS = (0.2, 0.5, 0.8)
DEFAULT_SEEDS = 10
DEFAULT_TIME_LIMIT = 20.0

PAPER_MS_PER_FRAME = {5: 23.33, 10: 31.36, 20: 62.08, 50: 511.83, 100: 3996.38}
"""The paper's Fig. "Scalability" (clingo, synthetic frames; overlap share not stated)."""

SCALE_BEGIN, SCALE_END = "<!-- bench-scale:begin -->", "<!-- bench-scale:end -->"
DENSE_BEGIN, DENSE_END = "<!-- bench-scale-dense:begin -->", "<!-- bench-scale-dense:end -->"
THROUGHPUT_BEGIN, THROUGHPUT_END = "<!-- bench-throughput:begin -->", "<!-- bench-throughput:end -->"

ProgressFactory = Callable[[int, str], "object"]
"""(total, label) -> an object with step(what); the CLI passes its progress bar."""


class _NoProgress:
    def __init__(self, total: int, label: str):
        pass

    def step(self, what: str) -> None:
        pass


def machine_note() -> str:
    """One line naming the machine the numbers come from."""
    versions = {}
    for package in ("ortools", "clingo"):  # the installed distributions' versions: nothing is imported
        try:
            versions[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            versions[package] = "not installed"
    cpus = os.cpu_count()
    model = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (f"{platform.system()} {platform.machine()}, {cpus} cores{' (' + model + ')' if model else ''}, "
            f"Python {platform.python_version()}, OR-Tools {versions['ortools']}, clingo {versions['clingo']}; "
            f"every solver single-threaded")


# ---------------------------------------------------------------------------------------
# Scalability on synthetic frames
# ---------------------------------------------------------------------------------------

@dataclass
class FrameRun:
    """One backend on one synthetic frame."""

    backend: str
    n: int
    overlap: float
    seed: int
    ms: float
    """Wall-clock time of the whole solve call (building the model included)."""
    optimal: bool
    cost: list[list[int]] | None
    answer_hash: int | None = None
    error: str | None = None
    cpu_ms: float | None = None
    """CPU time of the solve (this process plus clingo's worker process): on a shared machine the
    wall-clock time includes waiting for a core, the CPU time does not."""
    largest: int | None = None
    """Tracks plus detections of the frame's largest independent component (solvers.common)."""


@dataclass
class ScaleResult:
    runs: list[FrameRun]
    sizes: list[int]
    overlaps: list[float]
    seeds: int
    backends: list[str]
    time_limit: float
    machine: str
    fast_path: dict[str, int] = field(default_factory=dict)
    """How the cpsat backend answered (CpSatSolver.stats): fast path vs full model."""
    seconds: float = 0.0
    dense: bool = False
    """The frames are dense crowds (synthetic.dense_frame, one component each; overlaps is [0.0])."""


def bench_scale(sizes: Sequence[int] = DEFAULT_SIZES, overlaps: Sequence[float] = DEFAULT_OVERLAPS,
                seeds: int = DEFAULT_SEEDS, backends: Sequence[str] = SCALE_BACKENDS,
                time_limit: float = DEFAULT_TIME_LIMIT, progress: ProgressFactory = _NoProgress,
                dense: bool = False) -> ScaleResult:
    """Solve every synthetic frame (n, overlap, seed) with every backend; see the module docstring.
    ``dense``: the frames are synthetic.dense_frame(n, seed) instead (``overlaps`` is ignored)."""

    if dense:
        overlaps = [0.0]

    for b in backends:
        if b not in SCALE_BACKENDS:
            raise ValueError(f"unknown backend {b!r} (choose from {', '.join(SCALE_BACKENDS)})")
    solvers = {b: get_solver(b) for b in backends}
    for solver in solvers.values():  # untimed warm-up: imports, clingo's worker process start
        solver.solve(synthetic_frame(2, 0.2, 0))
        if hasattr(solver, "stats"):
            solver.stats.clear()
    runs: list[FrameRun] = []
    bar = progress(len(sizes) * len(overlaps) * seeds, "bench-scale")
    started = time.perf_counter()
    k = 0
    for n in sizes:
        for ov in overlaps:
            for seed in range(seeds):
                problem = dense_frame(n, seed) if dense else synthetic_frame(n, ov, seed)
                largest = max(len(c.tracks) + len(c.detections) for c in components(problem)) if n else 0
                order = list(backends[k % len(backends):]) + list(backends[:k % len(backends)])
                k += 1
                for b in order:
                    run = _run_one(solvers[b], b, problem, n, ov, seed, time_limit)
                    run.largest = largest
                    runs.append(run)
                bar.step(f"n={n} overlap={ov} seed={seed}")
    stats = next((s.stats for s in solvers.values() if getattr(s, "fast_path", False)), {})
    return ScaleResult(runs, list(sizes), list(overlaps), seeds, list(backends), time_limit, machine_note(),
                       dict(stats), time.perf_counter() - started, dense)


def _run_one(solver, backend: str, problem, n: int, ov: float, seed: int, time_limit: float) -> FrameRun:
    gc.collect()  # the previous solve's garbage is not this one's time
    c0 = time.process_time() + getattr(solver, "child_cpu_seconds", 0.0)
    t0 = time.perf_counter()
    try:
        h = solver.solve(problem, time_limit=time_limit)
    except Exception as exc:  # a time limit without any answer: reported, not fatal
        ms = (time.perf_counter() - t0) * 1000.0
        return FrameRun(backend, n, ov, seed, ms, False, None, None, f"{type(exc).__name__}: {exc}")
    ms = (time.perf_counter() - t0) * 1000.0
    cpu = (time.process_time() + getattr(solver, "child_cpu_seconds", 0.0) - c0) * 1000.0
    digest = int(hashlib.sha1("\n".join(h.answer).encode()).hexdigest()[:12], 16)
    return FrameRun(backend, n, ov, seed, ms, bool(h.optimal), [list(c) for c in h.cost], digest, None, cpu)


@dataclass
class ScaleRow:
    n: int
    overlap: float
    per_backend: dict[str, dict]
    """backend -> {median, max, optimal (share), frames, errors}."""
    compared: int
    """Frames that at least two backends proved optimal."""
    agree: int
    """Of those, frames on which all proven-optimal cost vectors are equal."""
    same_answer: int
    """Of those, frames on which the proven-optimal answers are equal too."""
    ratio: dict[str, float]
    """backend -> median over frames of (clingo ms / backend ms), when clingo ran."""
    largest: tuple[int, int] | None = None
    """Smallest and largest over the frames of the largest component's nodes (None: not recorded)."""


def summarise_scale(result: ScaleResult) -> list[ScaleRow]:
    rows = []
    for n in result.sizes:
        for ov in result.overlaps:
            runs = [r for r in result.runs if r.n == n and r.overlap == ov]
            per: dict[str, dict] = {}
            for b in result.backends:
                mine = [r for r in runs if r.backend == b]
                if not mine:
                    continue
                ms = [r.ms for r in mine]
                cpu = [r.cpu_ms for r in mine if r.cpu_ms is not None]
                per[b] = {"median": statistics.median(ms), "max": max(ms),
                          "cpu_median": statistics.median(cpu) if cpu else None,
                          "optimal": sum(r.optimal for r in mine) / len(mine), "frames": len(mine),
                          "errors": sum(r.error is not None for r in mine)}
            compared = agree = same = 0
            ratios: dict[str, list[float]] = {b: [] for b in result.backends if b != REFERENCE_BACKEND}
            for seed in range(result.seeds):
                frame = {r.backend: r for r in runs if r.seed == seed}
                proven = [r for r in frame.values() if r.optimal and r.cost is not None]
                if len(proven) >= 2:
                    compared += 1
                    agree += len({bigint.dumps(r.cost) for r in proven}) == 1
                    same += len({r.answer_hash for r in proven}) == 1
                if REFERENCE_BACKEND in frame:
                    for b in ratios:
                        if b in frame and frame[b].ms > 0:
                            ratios[b].append(frame[REFERENCE_BACKEND].ms / frame[b].ms)
            sizes = [r.largest for r in runs if r.largest is not None]
            rows.append(ScaleRow(n, ov, per, compared, agree, same,
                                 {b: statistics.median(v) for b, v in ratios.items() if v},
                                 (min(sizes), max(sizes)) if sizes else None))
    return rows


def _ms(x: float) -> str:
    return f"{x:.1f}" if x < 100 else f"{x:.0f}"


def scale_table(result: ScaleResult) -> str:
    """The markdown table of a scalability run (one row per n and overlap, backends side by side)."""
    rows = summarise_scale(result)
    bs = result.backends
    head = ["tracks", "frames" if result.dense else "overlap", "largest component"]
    for b in bs:
        head += [f"{b} median ms", f"{b} median CPU ms", f"{b} max ms", f"{b} optimal"]
    if REFERENCE_BACKEND in bs:
        head += [f"{REFERENCE_BACKEND} / {b} (median)" for b in bs if b != REFERENCE_BACKEND]
    head += ["cost vectors agree"] + ([] if result.dense else ["paper (clingo) ms"])
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for row in rows:
        big = "-" if row.largest is None else (str(row.largest[0]) if row.largest[0] == row.largest[1]
                                               else f"{row.largest[0]}-{row.largest[1]}")
        cells = [str(row.n), "dense" if result.dense else f"{row.overlap:g}", big]
        for b in bs:
            s = row.per_backend.get(b)
            if s is None:
                cells += ["-", "-", "-", "-"]
                continue
            opt = f"{100 * s['optimal']:.0f} %"
            if s["optimal"] < 1:
                opt = f"**{opt}**"
            cpu = "-" if s.get("cpu_median") is None else _ms(s["cpu_median"])
            cells += [_ms(s["median"]), cpu, _ms(s["max"]), opt]
        if REFERENCE_BACKEND in bs:
            cells += [f"{row.ratio[b]:.1f}x" if b in row.ratio else "-" for b in bs if b != REFERENCE_BACKEND]
        cells.append(f"{row.agree}/{row.compared}" + ("" if row.same_answer == row.compared else
                                                       f" (answers {row.same_answer}/{row.compared})"))
        if not result.dense:
            cells.append(_ms(PAPER_MS_PER_FRAME[row.n]) if row.n in PAPER_MS_PER_FRAME else "-")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def scale_report(result: ScaleResult, command: str) -> str:
    """The generated section of docs/benchmarks.md for a scalability run."""
    fp = result.fast_path
    total = sum(v for k, v in fp.items() if k in ("fast", "full"))
    fast_note = ""
    if total:
        declined = ", ".join(f"{k[len('declined: '):]}: {v}" for k, v in sorted(fp.items()) if k.startswith("declined"))
        fast_note = (f"\ncpsat answered {fp.get('fast', 0)} of {total} frames by the fast exact path and "
                     f"{fp.get('full', 0)} by the full CP-SAT model" + (f" (fast path declined: {declined})" if declined else "")
                     + ".\n")
    frames = ("dense crowds (`refimpl.experiments.synthetic.dense_frame`: every track and detection one component)"
              if result.dense else "overlap " + ", ".join(f"{o:g}" for o in result.overlaps))
    return (f"Command: `{command}`  \n"
            f"Frames: sizes {', '.join(map(str, result.sizes))} x {frames}"
            f" x {result.seeds} seeds, every backend on the same frames; per-frame time limit "
            f"{result.time_limit:g} s; run took {result.seconds / 60:.1f} min.  \n"
            f"Machine: {result.machine}.\n{fast_note}\n"
            + scale_table(result) + "\n\n"
            "largest component: tracks plus detections of the frame's largest independent component "
            "(the part a backend solves in one piece), smallest-largest over the seeds. "
            "ms: wall-clock time of one `solve` call (building the model included; garbage collected before it), "
            "median and max over the seeds; CPU ms: its CPU time (this process and clingo's worker process), "
            "which waiting for a busy machine's cores does not inflate. "
            "optimal: share of frames whose every cost level was proven optimal within the time limit "
            "(bold: not all). clingo / X: median over the frames of clingo's time divided by X's on the same frame. "
            "cost vectors agree: frames on which all backends that proved optimality report the same cost "
            "vector, out of the frames that at least two of them proved.\n")


def plot_scale(result: ScaleResult, path: str | os.PathLike) -> None:
    """Log-scale ms/frame vs tracks: one line per backend x overlap, the paper's clingo as reference."""
    rows = summarise_scale(result)
    colours = COLOURS
    styles = {0.2: ":", 0.5: "--", 0.8: "-"}
    fig = agg_figure((8.5, 5.5), 110)
    ax = fig.subplots()
    for b in result.backends:
        for ov in result.overlaps:
            pts = [(r.n, r.per_backend[b]["median"], r.per_backend[b]["optimal"]) for r in rows
                   if r.overlap == ov and b in r.per_backend]
            if not pts:
                continue
            ax.plot([p[0] for p in pts], [p[1] for p in pts], styles.get(ov, "-"), color=colours.get(b),
                    marker="o", markersize=4, label=f"{b}, overlap {ov:g}")
            bad = [p for p in pts if p[2] < 1]
            if bad:
                ax.plot([p[0] for p in bad], [p[1] for p in bad], "x", color="black", markersize=9,
                        markeredgewidth=2)
    paper = sorted(PAPER_MS_PER_FRAME.items())
    ax.plot([n for n, _ in paper], [ms for _, ms in paper], "k-", linewidth=2.5, alpha=0.35, marker="s",
            label="paper (clingo, Fig. Scalability)")
    ax.axhline(1000 / 30, color="grey", linewidth=0.8)
    ax.text(result.sizes[0], 1000 / 30 * 1.08, "30 fps", color="grey", fontsize=8)
    if any(r.per_backend.get(b, {}).get("optimal", 1) < 1 for r in rows for b in result.backends):
        ax.plot([], [], "x", color="black", markersize=9, markeredgewidth=2,
                label="not every frame proven optimal")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ticks = sorted(set(result.sizes) | set(PAPER_MS_PER_FRAME))
    ax.set_xticks(ticks)
    ax.set_xticklabels([str(n) for n in ticks])
    ax.minorticks_off()
    ax.set_xlabel("tracks per frame")
    ax.set_ylabel("ms per frame (median over seeds)")
    ax.set_title(f"Abduction time per synthetic frame ({result.seeds} seeds; time limit {result.time_limit:g} s)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, format="png")


# ---------------------------------------------------------------------------------------
# End-to-end throughput of the tracking loop
# ---------------------------------------------------------------------------------------

@dataclass
class SequenceRun:
    benchmark: str
    sequence: str
    tracker: str
    frames: int
    seconds: float
    not_optimal: int = 0
    fast_frames: int | None = None
    """cpsat: frames answered by the fast path."""


@dataclass
class ThroughputResult:
    runs: list[SequenceRun]
    benchmarks: list[str]
    trackers: list[str]
    machine: str
    seconds: float = 0.0


def bench_throughput(data_root: str | os.PathLike, benchmarks: Sequence[str] = THROUGHPUT_BENCHMARKS,
                     trackers: Sequence[str] = (BASELINE, DEFAULT_BACKEND, REFERENCE_BACKEND),
                     progress: ProgressFactory = _NoProgress) -> ThroughputResult:
    """Frames per second of the whole tracking loop per tracker and sequence (files read beforehand;
    every sequence is tracked by every tracker in turn, in an order rotated from sequence to sequence)."""

    for tr in trackers:
        if tr not in THROUGHPUT_TRACKERS:
            raise ValueError(f"unknown tracker {tr!r} (choose from {', '.join(THROUGHPUT_TRACKERS)})")
    plan = []
    for bench in benchmarks:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # KITTI files: dropped zero-area boxes are warned about
            seqs = io.calibrated_together([io.load_detections(s) for s in benchmark_sequences(bench, data_root)],
                                          io.resolve_rule(io.DEFAULT_SCORE_RULE))  # as load_dataset reads them
            plan += [(bench, seq.name, seq) for seq in seqs]
    bar = progress(len(plan) * len(trackers), "bench-throughput")
    runs: list[SequenceRun] = []
    started = time.perf_counter()
    for k, (bench, name, seq) in enumerate(plan):
        order = list(trackers[k % len(trackers):]) + list(trackers[:k % len(trackers)])
        for tr in order:
            solver = None if tr == BASELINE else get_solver(tr)
            t0 = time.perf_counter()
            not_optimal = run_sequence(seq, Setup(tr), solver=solver).not_optimal_frames
            secs = time.perf_counter() - t0
            fast = solver.stats.get("fast") if getattr(solver, "fast_path", False) else None
            runs.append(SequenceRun(bench, name, tr, len(seq.frames), secs, not_optimal, fast))
            bar.step(f"{tr} {bench} {name}")
    return ThroughputResult(runs, list(benchmarks), list(trackers), machine_note(), time.perf_counter() - started)


def throughput_table(result: ThroughputResult) -> str:
    head = ["benchmark", "sequences", "frames"]
    head += [f"{tr} fps" for tr in result.trackers]
    head += ["slowest sequence (fps)"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for bench in result.benchmarks:
        runs = [r for r in result.runs if r.benchmark == bench]
        seqs = sorted({r.sequence for r in runs})
        frames = sum(r.frames for r in runs if r.tracker == result.trackers[0])
        cells = [bench, str(len(seqs)), str(frames)]
        slowest = []
        for tr in result.trackers:
            mine = [r for r in runs if r.tracker == tr]
            fps = sum(r.frames for r in mine) / max(sum(r.seconds for r in mine), 1e-9)
            cell = f"{fps:.0f}"
            nopt = sum(r.not_optimal for r in mine)
            if nopt:
                cell += f" ({nopt} frames not optimal)"
            cells.append(cell)
            worst = min(mine, key=lambda r: r.frames / max(r.seconds, 1e-9))
            slowest.append(f"{tr} {worst.frames / max(worst.seconds, 1e-9):.0f} ({worst.sequence})")
        cells.append("; ".join(slowest))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def throughput_report(result: ThroughputResult, command: str) -> str:
    fast = [r for r in result.runs if r.fast_frames is not None]
    note = ""
    if fast:
        f, t = sum(r.fast_frames or 0 for r in fast), sum(r.frames for r in fast)
        note = f"{fast[0].tracker} answered {f} of {t} frames by the fast exact path and {t - f} by the full CP-SAT model.\n"
    return (f"Command: `{command}`  \n"
            f"Run took {result.seconds / 60:.1f} min. Machine: {result.machine}.\n{note}\n"
            + throughput_table(result) + "\n\n"
            "fps: frames of all sequences / wall-clock seconds of tracking them (`refimpl track`'s loop: "
            "Kalman prediction, building each frame problem, abduction, applying the hypothesis; "
            "reading the files and Python start-up excluded), every tracker on the same sequences "
            "in one run.\n")


# ---------------------------------------------------------------------------------------
# docs/benchmarks.md, JSON
# ---------------------------------------------------------------------------------------


class BenchmarkFileError(UserFacingError):
    """A saved benchmark JSON file (``--from-json``) that is not one this module wrote: one line, exit 2."""


def json_text(result: ScaleResult | ThroughputResult) -> str:
    kind = "scale" if isinstance(result, ScaleResult) else "throughput"
    return bigint.dumps({"kind": kind, **asdict(result)}, indent=1)  # a level 0 of any size


def _is(value, kind) -> bool:
    """A JSON value of a field's declared type (bool is not a number here, ints are floats)."""
    if kind == "int":
        return isinstance(value, int) and not isinstance(value, bool)
    if kind == "float":
        return isinstance(value, (int, float)) and not isinstance(value, bool) and value == value \
            and abs(value) != float("inf")
    if kind == "bool":
        return isinstance(value, bool)
    if kind == "str":
        return isinstance(value, str)
    return True


_FIELD_KINDS = {  # what load_json checks (the other fields are optional extras, checked by shape)
    FrameRun: {"backend": "str", "n": "int", "overlap": "float", "seed": "int", "ms": "float", "optimal": "bool"},
    SequenceRun: {"benchmark": "str", "sequence": "str", "tracker": "str", "frames": "int", "seconds": "float"},
    ScaleResult: {"seeds": "int", "time_limit": "float", "machine": "str"},
    ThroughputResult: {"machine": "str"},
}


def _build(cls, data, where: str):
    if not isinstance(data, dict):
        raise BenchmarkFileError(f"{where}: expected a JSON object, got {type(data).__name__}")
    try:
        obj = cls(**data)
    except TypeError as exc:
        raise BenchmarkFileError(f"{where}: {exc}") from None
    for name, kind in _FIELD_KINDS[cls].items():
        if not _is(getattr(obj, name), kind):
            raise BenchmarkFileError(f"{where}: field {name!r} must be {kind}, got {getattr(obj, name)!r:.40}")
    return obj


def load_json(path: str | os.PathLike) -> ScaleResult | ThroughputResult:
    """A file of json_text's; anything else is a BenchmarkFileError naming the file."""
    try:
        data = bigint.loads(read_text(path))
    except FileNotFoundError:
        raise BenchmarkFileError(f"{path}: file not found") from None
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError, RecordTooLong) as exc:
        raise BenchmarkFileError(f"{path}: not a benchmark JSON file ({str(exc).splitlines()[0][:80]})") from None
    except OSError as exc:
        raise BenchmarkFileError(f"{path}: cannot read ({exc.strerror or exc})") from None
    if not isinstance(data, dict) or data.get("kind") not in ("scale", "throughput"):
        raise BenchmarkFileError(f"{path}: not a benchmark JSON file (no \"kind\": \"scale\" or \"throughput\")")
    data = dict(data)
    kind = data.pop("kind")
    run_cls, cls = (FrameRun, ScaleResult) if kind == "scale" else (SequenceRun, ThroughputResult)
    runs = data.get("runs")
    if not isinstance(runs, list) or not runs:
        raise BenchmarkFileError(f"{path}: \"runs\" must be a non-empty list")
    data["runs"] = [_build(run_cls, r, f"{path}: runs[{i}]") for i, r in enumerate(runs)]
    result = _build(cls, data, str(path))
    lists = ("sizes", "overlaps", "backends") if kind == "scale" else ("benchmarks", "trackers")
    for name in lists:
        value = getattr(result, name)
        if not isinstance(value, list) or not value:
            raise BenchmarkFileError(f"{path}: {name!r} must be a non-empty list")
    try:  # the report is what the file is for: any inconsistency it trips over is the file's
        (scale_report if kind == "scale" else throughput_report)(result, "check")
    except (TypeError, ValueError, KeyError, AttributeError, ZeroDivisionError, IndexError,
            statistics.StatisticsError) as exc:
        raise BenchmarkFileError(f"{path}: inconsistent benchmark JSON ({type(exc).__name__}: "
                                 f"{str(exc).splitlines()[0][:80] if str(exc) else ''})") from None
    return result


def parse_list(text: str, cast: Callable[[str], object]) -> list:
    """'5,10,20' -> [5, 10, 20] (for the CLI's list options)."""
    return [cast(x.strip()) for x in text.split(",") if x.strip()]


def format_command(argv: Iterable[str]) -> str:
    return "refimpl " + " ".join(argv)


# ---------------------------------------------------------------------------------------
# What `refimpl bench-scale` does (the CLI only parses its options)
# ---------------------------------------------------------------------------------------

def run_bench_scale(*, sizes: Sequence[int] = DEFAULT_SIZES, overlaps: Sequence[float] = DEFAULT_OVERLAPS,
                    seeds: int = DEFAULT_SEEDS, backends: Sequence[str] = SCALE_BACKENDS,
                    time_limit: float = DEFAULT_TIME_LIMIT, out: str | None = "docs/benchmarks.md",
                    plot: str | None = None, json_path: str | None = None, from_json: str | None = None,
                    throughput: bool = False, trackers: Sequence[str] = (BASELINE, DEFAULT_BACKEND, REFERENCE_BACKEND),
                    data: str = "../shared/data", command: str = "refimpl bench-scale",
                    progress: ProgressFactory = _NoProgress, dense: bool = False) -> str:
    """Run (or, with from_json, reload) a benchmark, write its section of ``out`` (markdown; None:
    don't), the plot (scalability runs; default scalability.png beside ``out``) and the JSON,
    and return the report text to print."""
    if from_json:
        result: ScaleResult | ThroughputResult = load_json(from_json)
    elif throughput:
        result = bench_throughput(data, trackers=trackers, progress=progress)
    else:
        result = bench_scale(sizes, overlaps, seeds, backends, time_limit, progress, dense)
    with OutputSet() as outs:  # every output of the run lands together, or none does
        if json_path:
            outs.write(json_path, json_text(result))
        if isinstance(result, ScaleResult):
            report = scale_report(result, command)
            begin, end = (DENSE_BEGIN, DENSE_END) if result.dense else (SCALE_BEGIN, SCALE_END)
            if out:
                outs.write(out, section_text(out, begin, end, report))
            # the plot is of the overlap frames (the paper's figure); dense runs plot on request
            plot_path = plot or (str(Path(out).with_name("scalability.png")) if out and not result.dense else None)
            if plot_path:
                plot_scale(result, outs.open(plot_path, binary=True))
                report += f"\nplot: {plot_path}\n"
        else:
            report = throughput_report(result, command)
            if out:
                outs.write(out, section_text(out, THROUGHPUT_BEGIN, THROUGHPUT_END, report))
    if out:
        report += f"written: {out}\n"
    return report
