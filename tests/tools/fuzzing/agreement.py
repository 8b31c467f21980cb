"""Backend agreement on accepted inputs: every backend, the same answer, and the checker's approval.

    python tests/tools/fuzz_agreement.py --inputs 2000 --seed 0

The readers' fuzzer (tools.fuzzing) feeds broken files; this one feeds VALID ones, and the
property is the model's: on every input the fact parser and the range check
(refimpl/core/ranges.py) accept, every backend of the registry (refimpl.solvers.BACKENDS) proves the
same cost vector and the same answer (under the canonical tie-break the optimum is unique), or
they all find no admissible answer; and the independent checker (refimpl/solvers/check.py) finds no
violation in any answer and recomputes the cost vector each backend reported.

Input ``i`` comes from ``random.Random(f"{seed}/{i}")`` (``--only i`` regenerates it). Two targets:

* **frame** (4 inputs in 5): one frame problem, written as facts and read back
  (``parse_facts(write_facts(p)) == p``, so it is an accepted fact file), then ``check_ranges``.
  0-7 tracks (active or halted) and 0-7 detections (in 12 % of the inputs 8-18 of each, so that
  the frame is solved in parts, refimpl.solvers.decompose, and merged), ids and types from a pool of valid symbols
  (long ones, digits, ``_`` and capitals after the first letter), two or three types and
  sometimes a ``match_type``; boxes either in pixels (overlapping, jittered copies of each other,
  across the image border) or at the accepted limits (coordinates at +-2^28, widths and heights
  up to the area limits, 1x1 boxes); IoU facts from the boxes or at the edges (0, 1, the
  thresholds +-1, 100000); confidences 0, 100, the thresholds +-1; an event history from
  refimpl.knowledge.event_table.EVENT_TABLE (every event, right arity, on current and gone tracks, times at
  curr_time-1, mintime, +-2^30, repeated), plus now and then an unknown event; curr_time at 0,
  1, +-2^30; ``#const`` overrides at their edge values (0, +-1, the default +-1, +-2^30, the
  32-bit limits), each kept only when ``refimpl.core.ranges.check_constant`` accepts it.  An input
  the range check refuses, or one with a sub-problem beyond clingo's 32-bit sums (which only
  the CP-SAT backends solve: refimpl.solvers.clingo_backend.check_representable), is drawn
  again (up to 20 times; counted as ``refused``).
* **sequence** (1 in 5): a short detection sequence (3-14 frames, 1-6 walking objects or 10-16, misses,
  crossings, confidences at the edges, a small image or none) tracked with the first backend
  while every frame is solved again by the others (refimpl.runs.diff.diff_sequence: same history).

Outcomes: ``agree`` (all proven optimal, equal), ``infeasible`` (every backend: no admissible
answer), ``not-proven`` (some backend hit the time limit: answers checked, not compared),
``refused`` (no accepted input in 20 draws).  Failures: ``differs`` (cost or answer),
``violation`` (the checker), ``crash`` (any exception but NoAdmissibleHypothesis, or some
backends infeasible and others not).  A failing frame is minimised (``--minimise``): facts,
tracks, detections, history events and constants are dropped while the failure persists.
"""

from __future__ import annotations

import argparse
import random
import sys
import time
import traceback
from dataclasses import dataclass, field, replace
from typing import Callable, Sequence

import numpy as np

from refimpl.solvers.check import check_answer
from refimpl.core.constants import default_constants
from refimpl.knowledge.event_table import EVENT_TABLE, explaining
from refimpl.core.geometry import iou_matrix, scale_iou
from refimpl.core.hypothesis import Hypothesis
from refimpl.core.ranges import BOX_LIMIT, TIME_LIMIT, check_constant, check_ranges
from refimpl.solvers import BACKENDS, NoAdmissibleHypothesis, get_solver
from refimpl.solvers.clingo_backend import check_representable
from refimpl.core.spec import (ASP_INT_MAX, ASP_INT_MIN, IOU_SCALE, MAX_LIKELIHOOD_HALVING, Detection,
                               FrameProblem, HistoryEvent, ProblemFormatError, Term, TrackPrediction,
                               write_facts)
from refimpl.core.facts import parse_facts

TARGETS = ("frame", "sequence")
OUTCOMES = ("agree", "infeasible", "not-proven", "refused", "differs", "violation", "crash")
FAILURES = ("differs", "violation", "crash")
TIME_LIMIT_S = 20.0
"""Per solve; a backend that does not prove its answer in time makes the input ``not-proven``."""

_SYMBOLS = ("a", "t", "trk_1", "trk_12", "det_3", "x9", "aB", "zZ_9_", "o_" + "long" * 12, "car", "person",
            "p", "van", "mIxEd_Case", "n0t", "nota")
_TYPES = ("car", "person", "van", "p", "zZ_9_")


# ---------------------------------------------------------------------------------------------
# Generating an accepted frame problem
# ---------------------------------------------------------------------------------------------

def _ids(rng: random.Random, n: int, used: set[str]) -> list[str]:
    out = []
    while len(out) < n:
        base = rng.choice(_SYMBOLS)
        ident = base if rng.random() < 0.3 else f"{base}{rng.randint(0, 99)}"
        if ident not in used:
            used.add(ident)
            out.append(ident)
    return out


def _constants(rng: random.Random) -> dict[str, int]:
    """Some #const overrides at edge values the range check accepts one by one."""
    defaults = default_constants()
    out: dict[str, int] = {}
    if rng.random() < 0.2:  # the glimpse rule (docs/model.md 3.32) on; _history makes glimpses
        out["glimpse_frames"] = rng.choice((1, 1, 2))
    if rng.random() < 0.35:
        return out
    for name in rng.sample(list(defaults), rng.randint(1, 5)):
        d = defaults[name]
        pool = [0, 1, -1, d - 1, d + 1, 2 * d, TIME_LIMIT, -TIME_LIMIT, TIME_LIMIT - 1, ASP_INT_MAX, ASP_INT_MIN,
                BOX_LIMIT, rng.randint(-50, 400)]
        if name.startswith(("iou_thresh",)):
            pool += [IOU_SCALE, IOU_SCALE - 1, rng.randint(0, IOU_SCALE)]
        if name.startswith("conf_thresh"):
            pool += [100, 99, rng.randint(0, 100)]
        if name == "likelihood_conf":  # 0..100 (refimpl.core.ranges); the presets' 100
            pool += [100, 50, rng.randint(0, 100)]
        if name == "likelihood_halving":  # 0..MAX_LIKELIHOOD_HALVING (refimpl.core.ranges); kitti/car's 10
            pool += [10, 25, MAX_LIKELIHOOD_HALVING, rng.randint(1, 100)]
        if name == "glimpse_frames":  # >= 0 (refimpl.core.ranges); kitti/pedestrian's 1
            pool += [1, 1, 2, 3, rng.randint(1, 10)]
        rng.shuffle(pool)
        for value in pool:
            try:
                check_constant(name, value)
            except ProblemFormatError:
                continue
            out[name] = value
            break
    return out


def _box_pixels(rng: random.Random, others: list, width: int) -> tuple[int, int, int, int]:
    if others and rng.random() < 0.45:
        b = rng.choice(others)
        s = rng.choice((0, 1, 3, 8, 20))
        return (b[0] + rng.randint(-s, s), b[1] + rng.randint(-s, s),
                max(1, b[2] + rng.randint(-s, s)), max(1, b[3] + rng.randint(-s, s)))
    w, h = rng.randint(1, 80), rng.randint(1, 120)
    x = rng.choice((rng.randint(-30, width), -w, width - w, width, 0, 10, width - 10))
    return (x, rng.randint(-30, 220), w, h)


def _box_limits(rng: random.Random, others: list, max_area: int) -> tuple[int, int, int, int]:
    """A box at the accepted limits: edges at +-2^28, areas up to ``max_area``."""
    if others and rng.random() < 0.4:
        b = rng.choice(others)
        s = rng.choice((0, 1, max(1, b[2] // 3)))
        w = max(1, b[2] + rng.randint(-s, s))
        h = max(1, min(b[3] + rng.randint(-s, s), max_area // w))
        x = min(BOX_LIMIT - w, max(-BOX_LIMIT, b[0] + rng.randint(-s, s)))
        y = min(BOX_LIMIT - h, max(-BOX_LIMIT, b[1] + rng.randint(-s, s)))
        return (x, y, w, h)
    w = rng.choice((1, 2, rng.randint(1, 5000), min(BOX_LIMIT, max_area), int(max_area ** 0.5) or 1))
    w = max(1, min(w, BOX_LIMIT, max_area))
    h = max(1, min(rng.choice((1, max_area // w, rng.randint(1, 5000))), BOX_LIMIT, max_area // w))
    x = rng.choice((BOX_LIMIT - w, -BOX_LIMIT, -BOX_LIMIT + 1, 0, rng.randint(-BOX_LIMIT, BOX_LIMIT - w)))
    y = rng.choice((BOX_LIMIT - h, -BOX_LIMIT, 0, rng.randint(-BOX_LIMIT, BOX_LIMIT - h)))
    return (x, y, w, h)


_RECOVER = next(e.name for e in explaining("resume") if e.arity == 1)
"""The one-track resume (recover), which resets every fluent a halt set."""


def _history(rng: random.Random, track_ids: list[str], det_ids: list[str], now: int, mintime: int,
             active: set[str]) -> list[HistoryEvent]:
    gone = ["gone_1", "gone_trk"]
    out: list[HistoryEvent] = []
    times = [now - 1, now - 2, now - rng.randint(1, 40), mintime, mintime - 1, mintime + 1, -TIME_LIMIT,
             -TIME_LIMIT + 1, 0, -1]
    times = [t for t in times if t < now and abs(t) <= TIME_LIMIT]
    names = list(EVENT_TABLE)
    for a in track_ids + (gone if rng.random() < 0.3 else []):
        for _ in range(rng.choice((0, 1, 1, 2, 3, 5))):
            if rng.random() < 0.03:
                ev = Term("unknown_event", (Term(a),))
            else:
                spec = EVENT_TABLE[rng.choice(names)]
                args = [Term(a)]
                if spec.arity == 2:
                    args.append(Term(rng.choice([x for x in track_ids + gone + det_ids if x != a] or gone)))
                ev = Term(spec.name, tuple(args))
            out.append(HistoryEvent(ev, rng.choice(times)))
    for a in track_ids:  # most active tracks' histories end tracker-like: recovered (else often no answer)
        mine = [h.time for h in out if h.event.args[0].name == a]
        if a in active and mine and rng.random() < 0.6:
            out.append(HistoryEvent(Term(_RECOVER, (Term(a),)), rng.choice((max(mine), now - 1))))
    for a in track_ids:  # some halted tracks lived briefly, as the tracker logs it: entered, missed k frames
        # later (a glimpse where k <= glimpse_frames, docs/model.md 3.32)
        if a not in active and rng.random() < 0.5:
            k, halt = rng.choice((1, 1, 2, 3)), rng.choice((now - 1, now - rng.randint(1, 10)))
            if abs(halt - k) <= TIME_LIMIT:
                out += [HistoryEvent(Term("enters_fov", (Term(a),)), halt - k),
                        HistoryEvent(Term("missing_detections", (Term(a),)), halt)]
    rng.shuffle(out)
    return out


def random_problem(rng: random.Random) -> FrameProblem:
    """One frame problem (it may still be refused by check_ranges: the caller draws again)."""
    consts = _constants(rng)
    merged = {**default_constants(), **consts}
    limits = rng.random() < 0.3
    now = rng.choice((40, 40, 40, 5, 0, 1, -3, TIME_LIMIT, TIME_LIMIT - 1, -TIME_LIMIT + 50, rng.randint(2, 10_000)))
    used: set[str] = set()
    if rng.random() < 0.12:  # beyond clingo's part size (16 nodes): the frame is solved in parts and merged
        nt, nd = rng.randint(8, 18), rng.randint(8, 18)
    else:
        nt, nd = rng.choice((0, 1, 2, 3, 4, 5, 6, 7)), rng.choice((0, 1, 2, 3, 4, 5, 6, 7))
    tids, dids = _ids(rng, nt, used), _ids(rng, nd, used)
    types = rng.sample(_TYPES, rng.randint(1, 3))
    width = merged["img_width"] if 0 < merged["img_width"] < 5000 else rng.choice((200, 640))
    hide = max(100, merged["hide_overlap"])
    tboxes: list = []
    for _ in range(nt):
        tboxes.append(_box_limits(rng, tboxes, ASP_INT_MAX // hide) if limits else _box_pixels(rng, tboxes, width))
    dboxes: list = []
    for _ in range(nd):
        src = tboxes + dboxes
        dboxes.append(_box_limits(rng, src, ASP_INT_MAX) if limits else _box_pixels(rng, src, width))
    thresholds = [merged[k] for k in ("conf_thresh_assign", "conf_thresh_resume", "conf_thresh_new_track")]
    conf_pool = [0, 100, 1, 99] + [c + d for c in thresholds for d in (-1, 0, 1)]
    dets = tuple(Detection(d, rng.choice(types), min(100, max(0, rng.choice(conf_pool + [rng.randint(0, 100)]))), b)
                 for d, b in zip(dids, dboxes))
    tracks = tuple(TrackPrediction(t, rng.choice(types), rng.choice(("active", "active", "halted")), b)
                   for t, b in zip(tids, tboxes))
    iou: list[tuple[str, str, int]] = []
    if nt and nd:
        geo = scale_iou(iou_matrix(np.array(tboxes, float), np.array(dboxes, float)))
        edges = [0, 1, IOU_SCALE, IOU_SCALE - 1] + [min(IOU_SCALE, max(0, merged[k] + d))
                                                    for k in ("iou_thresh", "iou_thresh_resume") for d in (-1, 0, 1)]
        mode = rng.choice(("geometry", "geometry", "edges", "mixed"))
        for i, t in enumerate(tids):
            for j, d in enumerate(dids):
                v = int(geo[i, j])
                if mode == "edges" or (mode == "mixed" and rng.random() < 0.4):
                    v = rng.choice(edges) if rng.random() < 0.8 else -1
                if v > 0 or (v == 0 and rng.random() < 0.2):
                    iou.append((t, d, v))
        rng.shuffle(iou)
    history = _history(rng, tids, dids, now, merged["mintime"], {t.id for t in tracks if t.state == "active"}) \
        if rng.random() < 0.7 else []
    match = ()
    if len(types) > 1 and rng.random() < 0.3:
        match = tuple({(rng.choice(types), rng.choice(types)) for _ in range(rng.randint(1, 3))})
    return FrameProblem(time=now, detections=dets, tracks=tracks, iou=tuple(iou), constants=tuple(consts.items()),
                        history=tuple(history), match_types=match)


def accepted_problem(rng: random.Random, tries: int = 20) -> tuple[FrameProblem | None, int]:
    """(an accepted problem read back from its facts, draws refused before it) or (None, tries)."""
    for k in range(tries):
        try:
            p = random_problem(rng)
            text = write_facts(p)
            back = parse_facts(text, "<fuzz>")
            check_ranges(back, "<fuzz>")
            check_representable(back)  # OutOfClingoRange is a ProblemFormatError
        except ProblemFormatError:
            continue
        if back != p:
            raise AssertionError(f"the fact round trip changed the problem:\n{text}")
        return back, k
    return None, tries


# ---------------------------------------------------------------------------------------------
# Generating a short detection sequence
# ---------------------------------------------------------------------------------------------

def random_sequence(rng: random.Random):
    from refimpl.io import DetectionFrame, DetectionSequence
    n_frames, n_obj = rng.randint(3, 14), rng.randint(1, 6) if rng.random() < 0.85 else rng.randint(10, 16)
    size = rng.choice((None, (200, 150), (640, 480)))
    w_img, h_img = size or (640, 480)
    pos = [[rng.uniform(-20, w_img), rng.uniform(-20, h_img)] for _ in range(n_obj)]
    vel = [[rng.choice((-25, -8, -2, 0, 2, 8, 25)), rng.choice((-6, 0, 6))] for _ in range(n_obj)]
    dims = [(rng.choice((1.0, 12.0, 30.0, 60.0)), rng.choice((1.0, 40.0, 90.0))) for _ in range(n_obj)]
    miss = rng.choice((0.0, 0.1, 0.3, 0.6))
    conf_pool = (0, 100, 39, 40, 41, 49, 50, 51, 95)
    types_pool = rng.sample(_TYPES, rng.randint(1, 2))
    types = [rng.choice(types_pool) for _ in range(n_obj)]
    frames = []
    for f in range(1, n_frames + 1):
        boxes, confs, tys = [], [], []
        for k in range(n_obj):
            pos[k][0] += vel[k][0]
            pos[k][1] += vel[k][1]
            if rng.random() >= miss:
                boxes.append([round(pos[k][0] + rng.uniform(-2, 2), 2), round(pos[k][1] + rng.uniform(-2, 2), 2),
                              dims[k][0], dims[k][1]])
                confs.append(rng.choice(conf_pool))
                tys.append(types[k])
        if rng.random() < 0.1:  # a clutter detection
            boxes.append([rng.uniform(0, w_img), rng.uniform(0, h_img), 20.0, 40.0])
            confs.append(rng.choice(conf_pool))
            tys.append(rng.choice(types_pool))
        arr = np.array(boxes, float).reshape(-1, 4)
        frames.append(DetectionFrame(f, arr, np.array(confs, float) / 100.0, np.array(confs, np.int64), tuple(tys)))
    return DetectionSequence("fuzz", tuple(frames), 1, size, rng.choice((None, 10.0, 30.0)))


# ---------------------------------------------------------------------------------------------
# Judging
# ---------------------------------------------------------------------------------------------

@dataclass
class Result:
    index: int
    target: str
    outcome: str
    detail: str = ""
    problem: FrameProblem | None = None
    seconds: float = 0.0
    draws_refused: int = 0
    """Frame problems the range check refused before this input's accepted one."""


def judge_frame(problem: FrameProblem, solvers: Sequence, time_limit: float = TIME_LIMIT_S) -> tuple[str, str]:
    """(outcome, detail) of one frame problem solved by every solver."""
    answers: list[Hypothesis | None] = []
    for s in solvers:
        try:
            answers.append(s.solve(problem, time_limit=time_limit))
        except NoAdmissibleHypothesis:
            answers.append(None)
    names = _names(solvers)
    if all(a is None for a in answers):
        return "infeasible", ""
    if any(a is None for a in answers):
        return "crash", "no admissible answer for " + ", ".join(n for n, a in zip(names, answers) if a is None) + \
            " only"
    bad = []
    for n, h in zip(names, answers):
        rep = check_answer(problem, h)
        if rep.violations:
            bad.append(f"{n}: {'; '.join(rep.messages[:3])}")
        elif rep.cost != h.cost:
            bad.append(f"{n}: reported cost {list(h.cost)}, checker {list(rep.cost)}")
    if bad:
        return "violation", " | ".join(bad)
    if not all(h.optimal for h in answers):
        return "not-proven", ", ".join(n for n, h in zip(names, answers) if not h.optimal)
    ref = answers[0]
    for n, h in zip(names[1:], answers[1:]):
        if h.cost != ref.cost or h.answer != ref.answer:
            only_ref = sorted(set(ref.answer) - set(h.answer))
            only_h = sorted(set(h.answer) - set(ref.answer))
            return "differs", (f"{names[0]} cost {list(ref.cost)} vs {n} {list(h.cost)}; only {names[0]}: "
                               f"{' '.join(only_ref) or '-'}; only {n}: {' '.join(only_h) or '-'}")
    return "agree", ""


def make_solvers(backends: Sequence[str] = BACKENDS) -> list:
    solvers = [get_solver(b) for b in backends]
    for b, s in zip(backends, solvers):
        s.registry_name = b  # for the messages (cpsat and cpsat-full share a class and a name)
    return solvers


def _names(solvers) -> list[str]:
    return [getattr(s, "registry_name", s.name) for s in solvers]


def run_one(index: int, seed: int, solvers: Sequence, time_limit: float = TIME_LIMIT_S) -> Result:
    rng = random.Random(f"{seed}/{index}")
    target = "sequence" if rng.random() < 0.2 else "frame"
    t0 = time.perf_counter()
    try:
        if target == "frame":
            problem, refused = accepted_problem(rng)
            if problem is None:
                return Result(index, target, "refused", f"{refused} draws refused", seconds=time.perf_counter() - t0,
                              draws_refused=refused)
            outcome, detail = judge_frame(problem, solvers, time_limit)
            return Result(index, target, outcome, detail, problem, time.perf_counter() - t0, refused)
        from refimpl.runs.diff import diff_sequence
        seq = random_sequence(rng)
        rep = diff_sequence(seq, _names(solvers), solvers=solvers, time_limit=time_limit)
        if rep.first_divergence is not None:
            d = rep.first_divergence
            outcome = "violation" if "breaks" in d.explanation else "differs"
            return Result(index, target, outcome, d.describe(), d.problem, time.perf_counter() - t0)
        outcome = "agree" if rep.not_proven == 0 else "not-proven"
        return Result(index, target, outcome, f"{rep.frames} frames", seconds=time.perf_counter() - t0)
    except Exception:
        return Result(index, target, "crash", traceback.format_exc(limit=6), seconds=time.perf_counter() - t0)


# ---------------------------------------------------------------------------------------------
# Minimising a failing frame
# ---------------------------------------------------------------------------------------------

def minimise(problem: FrameProblem, fails: Callable[[FrameProblem], bool]) -> FrameProblem:
    """A smaller problem that still fails: drop constants, history events, iou facts, match types,
    detections and tracks one at a time while ``fails`` holds (greedy, to a fixed point)."""
    def variants(p: FrameProblem):
        for k in range(len(p.constants)):
            yield replace(p, constants=p.constants[:k] + p.constants[k + 1:])
        for k in range(len(p.history)):
            yield replace(p, history=p.history[:k] + p.history[k + 1:])
        for k in range(len(p.match_types)):
            yield replace(p, match_types=p.match_types[:k] + p.match_types[k + 1:])
        for k in range(len(p.iou)):
            yield replace(p, iou=p.iou[:k] + p.iou[k + 1:])
        for k, d in enumerate(p.detections):
            yield replace(p, detections=p.detections[:k] + p.detections[k + 1:],
                          iou=tuple(x for x in p.iou if x[1] != d.id))
        for k, t in enumerate(p.tracks):
            yield replace(p, tracks=p.tracks[:k] + p.tracks[k + 1:], iou=tuple(x for x in p.iou if x[0] != t.id))

    current = problem
    changed = True
    while changed:
        changed = False
        for cand in variants(current):
            try:
                check_ranges(cand, "<minimise>")
                check_representable(cand)
            except ProblemFormatError:
                continue
            if fails(cand):
                current, changed = cand, True
                break
    return current


# ---------------------------------------------------------------------------------------------
# The run
# ---------------------------------------------------------------------------------------------

@dataclass
class Summary:
    counts: dict[tuple[str, str], int] = field(default_factory=dict)
    failures: list[Result] = field(default_factory=list)
    seconds: float = 0.0
    draws_refused: int = 0

    def add(self, r: Result) -> None:
        self.counts[(r.target, r.outcome)] = self.counts.get((r.target, r.outcome), 0) + 1
        self.draws_refused += r.draws_refused
        if r.outcome in FAILURES:
            self.failures.append(r)

    def table(self) -> str:
        lines = ["| target | " + " | ".join(OUTCOMES) + " | total |", "|---|" + "---:|" * (len(OUTCOMES) + 1)]
        totals = [0] * len(OUTCOMES)
        for t in TARGETS:
            vals = [self.counts.get((t, o), 0) for o in OUTCOMES]
            totals = [a + b for a, b in zip(totals, vals)]
            lines.append(f"| {t} | " + " | ".join(map(str, vals)) + f" | {sum(vals)} |")
        lines.append("| **all** | " + " | ".join(map(str, totals)) + f" | {sum(totals)} |")
        return "\n".join(lines)


def run(inputs: int, seed: int = 0, only: Sequence[int] | None = None, time_limit: float = TIME_LIMIT_S,
        backends: Sequence[str] = BACKENDS, progress: Callable[[int, Summary], None] | None = None) -> Summary:
    solvers = make_solvers(backends)
    summary = Summary()
    t0 = time.perf_counter()
    for n, i in enumerate(only if only is not None else range(inputs)):
        summary.add(run_one(i, seed, solvers, time_limit))
        if progress:
            progress(n + 1, summary)
    summary.seconds = time.perf_counter() - t0
    return summary


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--inputs", type=int, default=2000, help="number of generated inputs (default 2000)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--only", type=lambda s: [int(v) for v in s.split(",")], help="only these input indices")
    ap.add_argument("--time-limit", type=float, default=TIME_LIMIT_S, help="seconds per solve (default 20)")
    ap.add_argument("--minimise", action="store_true", help="minimise the first failing frame and print its facts")
    ap.add_argument("--show", type=int, default=5)
    ap.add_argument("--quiet", action="store_true")
    args = ap.parse_args(argv)
    start = time.perf_counter()

    def progress(n: int, s: Summary) -> None:
        if not args.quiet and n % 100 == 0:
            print(f"agreement: {n} inputs, {len(s.failures)} failures, {time.perf_counter() - start:.0f} s",
                  file=sys.stderr, flush=True)

    s = run(args.inputs, args.seed, args.only, args.time_limit, progress=progress)
    print(f"refimpl agreement fuzz: {sum(s.counts.values())} inputs (seed {args.seed}), backends "
          f"{', '.join(BACKENDS)}, {s.seconds:.0f} s; {s.draws_refused} drawn frame problems refused by the range "
          "check and drawn again\n")
    print(s.table())
    print(f"\nfailures: {len(s.failures)}")
    for r in s.failures[:args.show]:
        print(f"\n--- {r.outcome}: input {r.index} ({r.target})\n{r.detail.rstrip()}")
    if args.minimise:
        frames = [r for r in s.failures if r.problem is not None]
        if frames:
            r = frames[0]
            solvers = make_solvers()
            small = minimise(r.problem, lambda p: judge_frame(p, solvers, args.time_limit)[0] in FAILURES)
            print(f"\nminimised input {r.index}: {judge_frame(small, solvers, args.time_limit)}\n{write_facts(small)}")
    if len(s.failures) > args.show:
        print("\nfailing inputs: " + ",".join(str(r.index) for r in s.failures[:200]))
    return 1 if s.failures else 0
