"""Calibration: choose the model's constants for a (format, object class) on sequences not reported.

``refimpl calibrate --benchmark kitti-car-train`` tracks every sequence of the benchmark with the
abduction tracker (cpsat) once per point of a small grid over the thresholds of
model/constants.lp and the tracker options (``DEFAULT_GRID``), scores each point with refimpl.evaluation.evaluate and ranks the
points by HOTA, then IDF1, then MOTA (over the benchmark's summed counts).  The best point is the
preset for the benchmark's (format, class); ``--write-presets`` stores it in model/presets.json.

Rules (docs/peers.md says them to the reader):

* KITTI: tuned on the 10 training sequences outside the val seqmap only (``kitti-*-train``);
  calibrating on a benchmark holding a val sequence is refused.
* The held-out datasets (``kitti-cyc``, ``mot15-acf``: refimpl.io.datasets ``held_out``) are never
  tuned on: calibrating on them is refused (and so is a sweep, refimpl.experiments.sweep).
* MOT15 (11 sequences, no separate split): leave-one-sequence-out is computed from the same grid
  runs: for every sequence, the point best on the other 10 is scored on it, and those held-out
  scores are combined into the LOSO row, the honest estimate for the preset, which is the point
  best on all 11.
* Until refimpl.evaluation.evaluate provides ``hota`` (branch ``eval``), the ranking falls back to IDF1 then
  MOTA, and the output says so.

Runs are independent, so ``workers`` > 1 spreads grid points over processes; the results are
put back in grid order, so the outcome does not depend on the number of workers.
"""

from __future__ import annotations

import itertools
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

from .. import io
from ..core.constants import default_constants
from ..core.errors import UserFacingError
from ..evaluation.evaluate import combine
from ..io import write_text_atomic
from ..io.datasets import BENCHMARKS, CATALOGUE, benchmark_sequences, dataset_kind, load_dataset, tuning_split
from ..solvers import DEFAULT_BACKEND
from ..tracking.options import TrackerOptions
from ..tracking.pipeline import NONE
from ..tracking.presets import DEFAULT_KEY, Preset, load_presets, preset_entry, preset_key, presets_path
from ..runs.scaleout import Plan, run_tasks
from .table6 import run_benchmark
from .benchmark_tasks import RunRequest, run_requests

DEFAULT_GRID: dict[str, tuple] = {
    "conf_thresh_new_track": (80, 90),
    "conf_thresh_assign": (40, 60),
    "iou_thresh": (20000, 30000),
    "conf_thresh_resume": (50,),
    "iou_thresh_resume": (10000,),
    "written_box": ("filtered", "detection"),
    "velocity_noise": ("1", "10"),
    "backfill": ("no", "yes"),
    "fill_hidden": ("0", "10", "30"),
}
"""The search space (confidences 0..100, IoU x 100000; ``written_box``, ``velocity_noise``,
``backfill`` and ``fill_hidden`` are tracker options, refimpl.tracking.options.TRACKER_OPTIONS): 192 points.  The option
``scene_velocity`` is not searched by default: chosen on kitti-car-train, it tripled the ID
switches on kitti-car-val (docs/peers.md); ``--grid scene_velocity=no,yes`` adds it.  The thresholds are where the earlier,
wider grids put the best points on all three tuning sets (new track 40/60/80/90 and assign 0/40/60
were searched there: the best sat at new track >= 80, assign >= 40; on MOT15 assign 0 and 40 tied
exactly), docs/peers.md.  The resume thresholds are held at their defaults: a wider grid (``--grid
conf_thresh_resume=50,70 --grid iou_thresh_resume=10000,20000``) is one option away but four times
as long on the shared 2-core machine the tables come from."""

CALIBRATE_BEGIN = "<!-- calibrate:{name}:begin -->"
CALIBRATE_END = "<!-- calibrate:{name}:end -->"


class CalibrationRefused(ValueError, UserFacingError):
    """Calibrating on these sequences would tune on data that is reported as held out."""


@dataclass(frozen=True)
class GridPoint:
    constants: tuple[tuple[str, int], ...]
    per_sequence: Mapping[str, Mapping]
    overall: Mapping
    seconds: float


@dataclass(frozen=True)
class Calibration:
    benchmark: str
    format: str
    object_class: str
    grid: Mapping[str, tuple[int, ...]]
    points: tuple[GridPoint, ...]
    """In grid order."""
    ranked: tuple[int, ...]
    """Indices into points, best first."""
    ranking: str
    """What the points were ranked by."""
    loso: Mapping | None
    """Leave-one-sequence-out: {'overall': combined held-out scores, 'chosen': {sequence: point index}}."""

    @property
    def best(self) -> GridPoint:
        return self.points[self.ranked[0]]


def grid_points(grid: Mapping[str, Sequence[int]]) -> list[tuple[tuple[str, int], ...]]:
    names = list(grid)
    return [tuple(zip(names, values)) for values in itertools.product(*(grid[n] for n in names))]


def _has_hota(overall: Mapping) -> bool:
    v = overall.get("hota")
    return v is not None and not (isinstance(v, float) and math.isnan(v))


def rank_key(overall: Mapping, use_hota: bool) -> tuple[float, ...]:
    """Larger is better: (HOTA, IDF1, MOTA), or (IDF1, MOTA) without HOTA; NaN counts as worst."""
    def f(k: str) -> float:
        v = overall.get(k)
        return -math.inf if v is None or v != v else float(v)
    return (f("hota"), f("idf1"), f("mota")) if use_hota else (f("idf1"), f("mota"))


def refuse_held_out(benchmark: str) -> None:
    """Refuse a held-out dataset (refimpl.io.datasets.Dataset.held_out: KITTI Cyclist, MOT15 with ACF):
    it is run only to report, never tuned on."""
    entry = CATALOGUE.get(benchmark)
    if entry is not None and entry.held_out:
        raise CalibrationRefused(f"{benchmark} is held out: never used for tuning (run it only to report: "
                                 f"refimpl benchmark {benchmark})")


def check_tunable(benchmark: str, data_root: str) -> None:
    """Refuse a held-out dataset, and a KITTI benchmark holding a sequence of the val split (they are
    reported, never tuned on)."""
    refuse_held_out(benchmark)
    seqs = benchmark_sequences(benchmark, data_root) if benchmark in BENCHMARKS else []
    val_split = io.get_format(seqs[0].format).val_split if seqs else None
    if val_split is not None:  # the format's benchmark has a held-out val split (KITTI's)
        held_out = sorted(set(s.name for s in seqs) & set(val_split(data_root)))
        if held_out:
            raise CalibrationRefused(
                f"{benchmark} holds the held-out val sequences {', '.join(held_out)}; calibrate on "
                f"{tuning_split(benchmark)}")


def split_point(point) -> tuple[dict[str, int], "TrackerOptions"]:
    """A grid point's (name, value) pairs as model constants and tracker options (TrackerOptions)."""
    names = set(TrackerOptions.names())
    constants = {k: int(v) for k, v in point if k not in names}
    return constants, TrackerOptions.from_mapping({k: v for k, v in point if k in names}, "--grid")


def _run_point(args) -> GridPoint:
    """One grid point: track and score the whole dataset with these settings (a Dask task)."""
    name, data_root, point, backend, dataset = args
    constants, options = split_point(point)
    run = run_benchmark(name, data_root, backend, dataset=dataset, constants=constants, options=options)
    return GridPoint(tuple(point), run.per_sequence, run.overall, run.seconds)


def leave_one_sequence_out(points: Sequence[GridPoint], use_hota: bool) -> dict:
    """For each sequence the point best on the others, and the combined scores of those choices."""
    names = list(points[0].per_sequence)
    chosen, held_out = {}, []
    for s in names:
        others = [n for n in names if n != s]
        best = max(range(len(points)), key=lambda i: (
            rank_key(combine(points[i].per_sequence[n] for n in others), use_hota), -i))
        chosen[s] = best
        held_out.append(points[best].per_sequence[s])
    return {"overall": combine(held_out), "chosen": chosen}


def calibrate(benchmark: str, data_root: str, grid: Mapping[str, Sequence[int]] = DEFAULT_GRID,
              backend: str = DEFAULT_BACKEND, plan=None, quiet: bool = True,
              loso: bool | None = None) -> Calibration:
    """Run the grid on a benchmark and rank it; see the module docstring.  The grid points run as
    tasks on ``plan`` (refimpl.runs.scaleout.Plan: serial by default, or a Dask cluster), each with
    the dataset it tracks; results come back in grid order whatever the worker count."""

    check_tunable(benchmark, data_root)
    fmt, cls = dataset_kind(benchmark, data_root)
    data_format = io.get_format(fmt)
    combos = grid_points(grid)
    dataset = load_dataset(benchmark, data_root)
    points = run_tasks(_run_point, [(benchmark, data_root, c, backend, dataset) for c in combos],
                       plan or Plan(), label=f"calibrate {benchmark}", quiet=quiet,
                       describe=lambda item: " ".join(f"{k}={v}" for k, v in item[2]))
    use_hota = all(_has_hota(p.overall) for p in points)
    ranking = "HOTA, then IDF1, then MOTA" if use_hota else \
        "IDF1, then MOTA (HOTA not available from refimpl.evaluation.evaluate yet)"
    # ties broken by grid order: deterministic
    ranked = tuple(sorted(range(len(points)), key=lambda i: (rank_key(points[i].overall, use_hota), -i),
                          reverse=True))
    if loso is None:
        loso = data_format.val_split is None  # no held-out split: leave one sequence out
    loso_result = leave_one_sequence_out(points, use_hota) if loso and len(points[0].per_sequence) > 1 else None
    return Calibration(benchmark, data_format.preset_format, cls, {k: tuple(v) for k, v in grid.items()}, tuple(points), ranked,
                       ranking, loso_result)


def _pct(v) -> str:
    return "-" if v is None or v != v else f"{100 * float(v):.1f}"


def _row(cells) -> str:
    return "| " + " | ".join(str(c) for c in cells) + " |"


def calibration_table(cal: Calibration, top: int | None = None) -> str:
    """Markdown: every grid point (or the top ones), best first, with its scores."""
    names = list(cal.grid)
    head = ["rank", *names, "HOTA", "DetA", "AssA", "MOTA", "IDF1", "IDs", "FP", "FN"]
    lines = [_row(head), "|" + "---:|" * len(head)]
    for rank, i in enumerate(cal.ranked[:top] if top else cal.ranked, start=1):
        p = cal.points[i]
        o, c = p.overall, dict(p.constants)
        lines.append(_row([rank, *(c[n] for n in names), _pct(o.get("hota")), _pct(o.get("deta")),
                           _pct(o.get("assa")), _pct(o["mota"]), _pct(o["idf1"]), o["idsw"], o["fp"], o["fn"]]))
    return "\n".join(lines) + "\n"


def calibration_report(cal: Calibration, command: str, top: int | None = None) -> str:
    space = "; ".join(f"{k} in {{{', '.join(map(str, v))}}}" for k, v in cal.grid.items())
    best = ", ".join(f"{k}={v}" for k, v in cal.best.constants)
    secs = sum(p.seconds for p in cal.points)
    out = [f"Command: `{command}`  ",
           f"Tuned on: {cal.benchmark} ({len(cal.best.per_sequence)} sequences: "
           f"{', '.join(cal.best.per_sequence)}); preset for {cal.format}/{cal.object_class}.  ",
           f"Search space ({len(cal.points)} points): {space}.  ",
           f"Ranked by {cal.ranking}; tracking took {secs / 60:.1f} min of CPU in total.  ",
           f"Chosen: {best}.", ""]
    if cal.loso:
        o = cal.loso["overall"]
        picks = {}
        for s, i in cal.loso["chosen"].items():
            picks.setdefault(i, []).append(s)
        out.append(f"Leave-one-sequence-out (each sequence scored with the point best on the others): "
                   f"HOTA {_pct(o.get('hota'))}, IDF1 {_pct(o['idf1'])}, MOTA {_pct(o['mota'])}, "
                   f"IDs {o['idsw']}, FP {o['fp']}, FN {o['fn']}; points chosen: "
                   + "; ".join(f"rank {cal.ranked.index(i) + 1} for {', '.join(ss)}" for i, ss in sorted(picks.items()))
                   + ".\n")
    out.append(calibration_table(cal, top))
    return "\n".join(out)


def chosen_preset(cal: Calibration):
    procedure = (f"grid of {len(cal.points)} points over {', '.join(cal.grid)} (refimpl calibrate), "
                 f"best by {cal.ranking} over {cal.benchmark}")
    if cal.loso:
        procedure += "; leave-one-sequence-out estimate in docs/peers.md"
    constants, options = split_point(cal.best.constants)
    stored = load_presets().get(preset_key(cal.format, cal.object_class))  # its durations' frame rate stays
    return Preset(cal.format, cal.object_class, constants, cal.benchmark, procedure, options,
                  stored.fps if stored else None)


def parse_grid(specs: Sequence[str] | None) -> dict[str, tuple]:
    """DEFAULT_GRID with NAME=V1,V2,... replacing a dimension (or adding one of the known constants
    or tracker options)."""
    grid = dict(DEFAULT_GRID)
    for spec in specs or ():
        name, sep, values = spec.partition("=")
        name = name.strip()
        if sep and name in TrackerOptions.names():
            vals = tuple(v.strip() for v in values.split(",") if v.strip())
            for v in vals:
                TrackerOptions.from_mapping({name: v}, "--grid")  # ValueError naming the choices
            if not vals:
                raise ValueError(f"--grid {name} has no values")
            grid[name] = vals
            continue
        if not sep or name not in default_constants():
            raise ValueError(f"--grid takes NAME=V1,V2,... with NAME a model constant or a tracker option "
                             f"({', '.join(TrackerOptions.names())}), got {spec!r}")
        try:
            vals = tuple(int(v) for v in values.split(",") if v.strip())
        except ValueError:
            raise ValueError(f"--grid values must be integers, got {spec!r}") from None
        if not vals:
            raise ValueError(f"--grid {name} has no values")
        grid[name] = vals
    return grid


# ---------------------------------------------------------------------------------------
# The robust default: the preset a (format, class) without its own runs with


@dataclass(frozen=True)
class RobustChoice:
    """Every candidate (each stored preset, and none) on every tuning benchmark, and the one chosen."""

    benchmarks: tuple[str, ...]
    candidates: tuple[str, ...]
    """Preset names, "none" last."""
    hota: tuple[tuple[float, ...], ...]
    """hota[c][b]: candidate c's HOTA on benchmark b."""
    chosen: int

    def ranks(self) -> list[list[int]]:
        """ranks[c][b]: 1 for the best HOTA on benchmark b (ties share the better rank)."""
        return [[1 + sum(other[b] > mine[b] for other in self.hota) for b in range(len(self.benchmarks))]
                for mine in self.hota]


def choose_robust(benchmarks: Sequence[str], candidates: Sequence[str], hota) -> RobustChoice:
    """The candidate with the best mean rank of HOTA over the benchmarks; ties: the higher
    worst-case HOTA, then candidate order (deterministic)."""
    choice = RobustChoice(tuple(benchmarks), tuple(candidates), tuple(tuple(float(v) for v in row) for row in hota), 0)
    ranks = choice.ranks()
    best = min(range(len(candidates)),
               key=lambda c: (sum(ranks[c]) / len(benchmarks), -min(choice.hota[c]), c))
    return RobustChoice(choice.benchmarks, choice.candidates, choice.hota, best)


def robust_default(benchmarks: Sequence[str], data_root: str, backend: str = DEFAULT_BACKEND, plan=None,
                   quiet: bool = True) -> RobustChoice:
    """Run every stored preset (and none) on every tuning benchmark, each with its own reader's
    score rule, and choose the default by :func:`choose_robust`."""
    for name in benchmarks:
        check_tunable(name, data_root)
    presets = {k: p for k, p in sorted(load_presets().items()) if k != DEFAULT_KEY}
    names = [*presets, NONE]
    data = {name: load_dataset(name, data_root) for name in benchmarks}
    requests = []
    for cand in names:
        p = presets.get(cand)
        for name in benchmarks:
            requests.append(RunRequest(name, data[name], backend, tuple(p.constants.items()) if p else (),
                                       p.tracker if p else TrackerOptions(), cand, p.fps if p else None))
    runs = run_requests(requests, plan or Plan(), label="calibrate default", quiet=quiet)
    hota = [[runs[c * len(benchmarks) + b].overall["hota"] for b in range(len(benchmarks))] for c in range(len(names))]
    return choose_robust(benchmarks, names, hota)


def robust_report(choice: RobustChoice, command: str) -> str:
    ranks = choice.ranks()
    head = "| candidate | " + " | ".join(f"{b} HOTA (rank)" for b in choice.benchmarks) + " | mean rank | worst HOTA |"
    lines = [f"Command: `{command}`  ",
             f"The default preset (model/presets.json `default`): what a (format, class) without a preset of its "
             f"own runs with (refimpl.tracking.presets.resolve_preset). Every stored preset and none were run on every "
             f"tuning benchmark ({', '.join(choice.benchmarks)}), each with its reader's score rule; the default "
             f"is the candidate with the best mean rank of HOTA, ties broken by the higher worst-case HOTA.  ",
             f"Chosen: {choice.candidates[choice.chosen]}.", "", head,
             "|---|" + "---:|" * (len(choice.benchmarks) + 2)]
    for c, name in enumerate(choice.candidates):
        cells = [f"{100 * v:.1f} ({r})" for v, r in zip(choice.hota[c], ranks[c])]
        mark = f"**{name}**" if c == choice.chosen else name
        lines.append(f"| {mark} | " + " | ".join(cells) + f" | {sum(ranks[c]) / len(ranks[c]):.2f} | "
                     f"{100 * min(choice.hota[c]):.1f} |")
    return "\n".join(lines) + "\n"


def default_preset(choice: RobustChoice):
    """The chosen candidate as the stored `default` preset (its values, the procedure said)."""
    name = choice.candidates[choice.chosen]
    source = load_presets().get(name)
    procedure = (f"the stored preset with the best mean rank of HOTA over {', '.join(choice.benchmarks)} "
                 f"(refimpl calibrate --default): {name}")
    return Preset("*", "*", dict(source.constants) if source else {}, "+".join(choice.benchmarks), procedure,
                  source.tracker if source else TrackerOptions(), source.fps if source else None)


def write_preset(preset: Preset, path: str | os.PathLike | None = None) -> Path:
    """Add or replace one preset in the presets file (model/presets.json unless ``path``; keys
    sorted; written atomically): what ``refimpl calibrate --write-presets`` writes."""
    p = Path(path) if path is not None else presets_path()
    data = json.loads(p.read_text(encoding="utf-8")) if p.is_file() else {}
    data[preset.name] = preset_entry(preset)
    write_text_atomic(p, json.dumps(dict(sorted(data.items())), indent=2) + "\n")
    return p
