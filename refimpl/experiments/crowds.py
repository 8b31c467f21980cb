"""The crowd-scaling curve (issue 38, item 3): what a frame costs against how many objects it holds.

For every size N (objects per frame, default 10, 50, 100, 200, 400) one sequence is made: N
pedestrians walk in a 1920 x 1080 image at 30 fps (:func:`crowd_truth`: heights log-uniform
60-180 px, a standing person's aspect 0.41, centres uniform, velocities N(0, 2) px a frame,
reflected at the borders so that all N stay in the image; seeded), and the project's simulated
detector (refimpl.io.simulate, its default DetectorParams: misses, localisation noise, false
positives, scores) turns it into detections, whose confidences the default score rule computes,
as for ``mot17-sim``.  The image is the same at every size, so the crowd gets denser as it grows,
as a real one does.

Every tracker tracks the same detections, timed at one boundary (refimpl.experiments.latency: CPU
time of each frame's update): refimpl's trackers through the one pipeline with the defaults a user
gets (``setup_for``: the default preset, ``cpsat``'s default frame budget), the peers through
their ``update``.  The cost of a frame is the mean CPU ms; its growth with N is fitted as
``cost ~ N^k`` by least squares on the logarithms (``k``: the exponent).  A backend's CPU time
is this process's: clingo solves in-process (no time limit is set unless asked, so it never hands
a part to its worker process, whose CPU would not count).
"""

from __future__ import annotations

import gc
import math
from dataclasses import dataclass
from time import perf_counter
from typing import Callable, Sequence

import numpy as np

from ..io import GroundTruth
from ..io.detections import DEFAULT_SCORE_RULE, calibrated, resolve_rule
from ..io.simulate import simulate_detections
from ..solvers import BACKENDS, BASELINE, get_solver
from ..tracking.pipeline import run_sequence, setup_for
from .latency import summarise
from ..tracking.peer_table import PEERS
from .peers import run_peer

CROWD_SIZES = (10, 50, 100, 200, 400)
CROWD_FRAMES = 15
IMAGE = (1920, 1080)
FPS = 30.0
CROWD_TRACKERS = (BASELINE, *BACKENDS)
CROWD_PEERS = ("sort", "bytetrack", "ocsort")
CROWDS_BEGIN, CROWDS_END = "<!-- bench-crowds:begin -->", "<!-- bench-crowds:end -->"


def crowd_truth(n: int, frames: int, seed: int = 0, image: tuple[int, int] = IMAGE) -> GroundTruth:
    """Ground truth of n pedestrians in every one of ``frames`` frames (1-based), see the module doc."""
    if n < 1 or frames < 1:
        raise ValueError(f"a crowd needs at least one object and one frame, got {n} objects, {frames} frames")
    rng = np.random.default_rng(seed)
    width, height = image
    h = np.exp(rng.uniform(math.log(60.0), math.log(180.0), n))
    w = 0.41 * h
    x0 = rng.uniform(0.0, width - w)
    y0 = rng.uniform(0.0, height - h)
    v = rng.normal(0.0, 2.0, (n, 2))
    t = np.arange(frames, dtype=float)[:, None]
    x = _reflect(x0[None, :] + v[:, 0][None, :] * t, width - w[None, :])
    y = _reflect(y0[None, :] + v[:, 1][None, :] * t, height - h[None, :])
    f = np.repeat(np.arange(1, frames + 1), n)
    boxes = np.column_stack([x.ravel(), y.ravel(), np.tile(w, frames), np.tile(h, frames)])
    rows = len(f)
    return GroundTruth(f"crowd-{n}", f.astype(np.int64), np.tile(np.arange(1, n + 1), frames).astype(np.int64),
                       boxes, np.ones(rows, dtype=bool), np.zeros(rows, dtype=bool), np.zeros((0, 5)), 1, frames)


def _reflect(p: np.ndarray, top: np.ndarray) -> np.ndarray:
    """Positions moved back into [0, top] by reflection at both ends (a triangle wave)."""
    period = 2.0 * top
    q = np.mod(p, period)
    return np.where(q > top, period - q, q)


def crowd_sequence(n: int, frames: int = CROWD_FRAMES, seed: int = 0):
    """The simulated detections of :func:`crowd_truth`, confidences by the default score rule."""
    gt = crowd_truth(n, frames, seed)
    dets = simulate_detections(gt, seed=seed, image_size=IMAGE, fps=FPS, name=gt.name)
    return calibrated(dets, resolve_rule(DEFAULT_SCORE_RULE))


@dataclass(frozen=True)
class CrowdCell:
    """One tracker on one size: CPU seconds per frame, and how many frames were not proven optimal
    (refimpl's abduction: a time limit or the frame budget; None for a tracker without a solver)."""

    tracker: str
    objects: int
    detections: float
    """Mean detections per frame."""
    times: tuple[float, ...]
    flagged: int | None
    budget_hits: int | None
    over_budget: int | None = None
    """Frames that took longer than the frame budget (refimpl.tracking.tracker.TrackingResult)."""

    @property
    def mean_ms(self) -> float:
        return 1000.0 * sum(self.times) / len(self.times)

    @property
    def fps(self) -> float:
        return len(self.times) / sum(self.times) if sum(self.times) > 0 else float("nan")

    @property
    def p99_ms(self) -> float:
        return summarise([(t, "", 0, 0) for t in self.times]).p99_ms


@dataclass(frozen=True)
class CrowdResult:
    sizes: tuple[int, ...]
    frames: int
    trackers: tuple[str, ...]
    cells: tuple[CrowdCell, ...]
    seconds: float
    """Wall-clock seconds of the whole run."""

    def cell(self, tracker: str, n: int) -> CrowdCell:
        return next(c for c in self.cells if c.tracker == tracker and c.objects == n)


def exponent(sizes: Sequence[int], costs: Sequence[float]) -> float:
    """k of cost ~ N^k: the least-squares slope of log(cost) against log(N)."""
    k, _ = np.polyfit(np.log(np.asarray(sizes, dtype=float)), np.log(np.asarray(costs, dtype=float)), 1)
    return float(k)


def _refimpl_cell(seq, tracker: str, n: int, time_limit: float | None) -> CrowdCell:
    setup = setup_for("mot", "pedestrian", tracker, time_limit=time_limit)
    solver = None if tracker == BASELINE else get_solver(tracker)
    times: list[float] = []
    gc.collect()  # every tracker starts from the same heap (the previous one's garbage is not its cost)
    result = run_sequence(seq, setup, solver=solver, frame_times=times)
    abduction = tracker != BASELINE
    return CrowdCell(tracker, n, _mean_detections(seq), tuple(times),
                     result.not_optimal_frames if abduction else None, result.budget_hits if abduction else None,
                     result.over_budget if setup.frame_budget is not None else None)


def _peer_cell(seq, peer: str, n: int) -> CrowdCell:
    gc.collect()
    return CrowdCell(peer, n, _mean_detections(seq), tuple(run_peer(seq, peer).frame_times), None, None)


def _mean_detections(seq) -> float:
    return sum(len(f) for f in seq.frames) / len(seq.frames)


def bench_crowds(sizes: Sequence[int] = CROWD_SIZES, frames: int = CROWD_FRAMES,
                 trackers: Sequence[str] = CROWD_TRACKERS, peers: Sequence[str] = CROWD_PEERS,
                 time_limit: float | None = None, seed: int = 0,
                 step: Callable[[str], None] | None = None) -> CrowdResult:
    """Every tracker and peer on the crowd sequence of every size (see the module doc)."""
    started = perf_counter()
    warm = crowd_sequence(min(sizes), min(frames, 3), seed)
    for tracker in trackers:  # a library a tracker imports on first use (scipy, OR-Tools, clingo): not timed
        _refimpl_cell(warm, tracker, 0, time_limit)
    for p in peers:
        _peer_cell(warm, p, 0)
    cells = []
    for n in sizes:
        seq = crowd_sequence(n, frames, seed)
        for tracker in trackers:
            cells.append(_refimpl_cell(seq, tracker, n, time_limit))
            if step:
                step(f"{tracker} {n}")
        for p in peers:
            cells.append(_peer_cell(seq, p, n))
            if step:
                step(f"{p} {n}")
    return CrowdResult(tuple(sizes), frames, (*trackers, *peers), tuple(cells), perf_counter() - started)


def _label(tracker: str) -> str:
    if tracker == BASELINE:
        return "refimpl baseline (SORT)"
    if tracker in PEERS:
        return f"`{PEERS[tracker].package}` {tracker}"
    budget = setup_for("mot", "pedestrian", tracker).frame_budget
    return f"refimpl {tracker}" + (f" (frame budget {budget:g} ms)" if budget is not None else "")


def crowd_table(result: CrowdResult) -> str:
    """Markdown: a row per tracker, a column per size (CPU fps / p99 ms), the fitted exponent and
    the frames flagged not proven optimal."""
    head = ("| tracker | " + " | ".join(f"{n} objects" for n in result.sizes)
            + " | exponent k (cost ~ N^k) | k over the two largest | frames not proven optimal "
            "| frames over the budget |")
    lines = [head, "|---|" + "---:|" * (len(result.sizes) + 4)]
    dets = " | ".join(f"{result.cell(result.trackers[0], n).detections:.0f}" for n in result.sizes)
    lines.append(f"| detections per frame | {dets} | | | | |")
    for tracker in result.trackers:
        cells = [result.cell(tracker, n) for n in result.sizes]
        k = exponent(result.sizes, [c.mean_ms for c in cells]) if len(cells) > 1 else float("nan")
        tail = exponent(result.sizes[-2:], [c.mean_ms for c in cells[-2:]]) if len(cells) > 1 else float("nan")
        flagged = "-" if cells[0].flagged is None else str(sum(c.flagged for c in cells))
        hits = sum(c.budget_hits or 0 for c in cells)
        if hits:
            flagged += f" ({hits} by the frame budget)"
        over = "-" if cells[0].over_budget is None else str(sum(c.over_budget for c in cells))
        row = " | ".join(f"{_num(c.fps)} / {_num(c.p99_ms)}" for c in cells)
        lines.append(f"| {_label(tracker)} | {row} | {k:.2f} | {tail:.2f} | {flagged} | {over} |")
    return "\n".join(lines) + "\n"


def _num(x: float) -> str:
    """A figure for the table: whole above 100, three significant digits below."""
    return f"{x:.0f}" if x >= 100 else f"{x:.3g}"


def crowd_report(result: CrowdResult, command: str, machine: str) -> str:
    return (f"Command: `{command}`  \n"
            f"{result.frames} frames per size, one sequence per size (refimpl.experiments.crowds: N pedestrians "
            f"walking in a 1920 x 1080 image, detections from refimpl.io.simulate); run took "
            f"{result.seconds / 60:.1f} min.  \nMachine: {machine}.\n\n{crowd_table(result)}\n"
            "Cells: CPU frames per second / 99th-percentile CPU ms per frame (time.process_time around each "
            "frame's update: refimpl's whole step, the peers' `update` call; refimpl.experiments.latency). "
            "Exponent: least-squares slope of log(mean CPU ms per frame) against log(objects), over every "
            "size and over the two largest (where fixed costs no longer weigh). Frames not "
            "proven optimal: by a time limit or the frame budget (a frame the fast path answers is proven, "
            "however long it took); over the budget: frames whose step took longer than it, wall-clock.\n")
