"""Parameter sweeps: a benchmark tracked and scored for every combination of model constants.

Each (setting, sequence) pair is one task (refimpl.experiments.benchmark_tasks.benchmark_job), so a sweep spreads
over a Dask cluster like any many-sequence command (refimpl.runs.scaleout); the table lists the
settings in grid order (the first constant varies slowest), whatever order tasks finish in.

Tuning on KITTI uses ``split="tune"``: the 10 training sequences outside
``evaluate_tracking.seqmap.val``; ``split="val"`` reports on the 11 in it.  A held-out dataset
(refimpl.io.datasets ``held_out``: ``kitti-cyc``, ``mot15-acf``) is refused.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from .. import io
from ..core.constants import default_constants
from ..io.datasets import BENCHMARKS, benchmark_sequences, load_dataset
from .calibrate import refuse_held_out
from .benchmark_tasks import RunRequest, RunSummary, run_requests

SPLITS = ("all", "tune", "val")
VAL_SEQMAP = Path("KITTI") / "tracking" / "training" / "evaluate_tracking.seqmap.val"


def grid_settings(grid: Sequence[tuple[str, Sequence[int]]]) -> tuple[tuple[str, ...], tuple[tuple[int, ...], ...]]:
    """Constant names and every combination of their values, in grid order; names are checked."""
    known = default_constants()
    names = tuple(name for name, _ in grid)
    for name in names:
        if name not in known:
            raise ValueError(f"unknown model constant {name!r} (known: {', '.join(sorted(known))})")
        if name in ("img_width", "img_height", "mintime"):
            raise ValueError(f"{name} is set per sequence, not swept")
    if len(set(names)) != len(names):
        raise ValueError("a constant appears in two --grid options")
    if any(not values for _, values in grid):
        raise ValueError("every --grid needs at least one value")
    return names, tuple(itertools.product(*(tuple(values) for _, values in grid)))


def val_sequences(data_root: str | Path) -> tuple[str, ...]:
    """The KITTI tracking validation sequences listed in evaluate_tracking.seqmap.val."""
    path = Path(data_root) / VAL_SEQMAP
    lines = [line.split() for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]
    return tuple(parts[0] for parts in lines)


def split_dataset(benchmark: str, dataset, data_root: str | Path, split: str):
    """The sequences of a split (all, or KITTI's tuning / validation halves)."""
    if split == "all":
        return list(dataset)
    if split not in SPLITS:
        raise ValueError(f"split must be one of {', '.join(SPLITS)}")
    kitti = benchmark in BENCHMARKS and all(  # a format with KITTI's held-out val split
        io.get_format(s.format).val_split is not None for s in benchmark_sequences(benchmark, data_root))
    if not kitti:
        raise ValueError(f"--split {split} is defined for the KITTI benchmarks only (its seqmap.val)")
    val = set(val_sequences(data_root))
    return [item for item in dataset if (item[0] in val) == (split == "val")]


@dataclass(frozen=True)
class SweepPlan:
    """What a sweep will run: checked, with its data read, before any task starts."""

    names: tuple[str, ...]
    """The swept model constants, in --grid order."""
    settings: tuple[tuple[int, ...], ...]
    """Every combination of their values (one per row of the table), in grid order."""
    benchmark: str
    split: str
    """all, tune or val (SPLITS)."""
    sequences: tuple[str, ...]
    """The sequences of the split."""
    backend: str
    requests: tuple[RunRequest, ...]
    """One tracking run of the split per setting."""


@dataclass(frozen=True)
class SweepResult:
    """A sweep plan and, in the order of its settings, what every setting scored over the split."""

    plan: SweepPlan
    runs: tuple[RunSummary, ...]


def plan_sweep(benchmark: str, data_root: str, backend: str, grid: Sequence[tuple[str, Sequence[int]]],
               split: str = "all") -> SweepPlan:
    """Check the grid and read the data: ValueError (or io.InputFormatError) for a user's mistake."""
    refuse_held_out(benchmark)  # a held-out dataset is never tuned on (CalibrationRefused, a ValueError)
    names, settings = grid_settings(grid)
    split_dataset(benchmark, [], data_root, split)  # a split that does not apply, before reading the data
    dataset = split_dataset(benchmark, load_dataset(benchmark, data_root), data_root, split)
    requests = tuple(RunRequest(benchmark, dataset, backend, tuple(zip(names, values))) for values in settings)
    return SweepPlan(names, settings, benchmark, split, tuple(n for n, _, _ in dataset), backend, requests)


def run_sweep(sweep: SweepPlan, plan, quiet: bool = False) -> SweepResult:
    """Every setting x sequence as a task on the plan's workers (refimpl.runs.scaleout)."""
    runs = run_requests(sweep.requests, plan, label="sweep", quiet=quiet)
    return SweepResult(sweep, tuple(runs))


def _pct(v) -> str:
    return "-" if v is None or not math.isfinite(float(v)) else f"{100.0 * float(v):.1f}"


def format_sweep(result: SweepResult) -> str:
    """A markdown table, one row per setting: the constants, then HOTA (when the evaluation
    provides it), MOTA, IDF1, IDs, FP, FN over all sequences of the split."""
    hota = all("hota" in r.overall for r in result.runs)
    p = result.plan
    head = [*p.names, *(["HOTA"] if hota else []), "MOTA", "IDF1", "IDs", "FP", "FN"]
    lines = [f"Sweep: {p.benchmark} ({p.split}, {len(p.sequences)} sequences), {p.backend}; "
             f"{len(p.settings)} settings x {len(p.sequences)} sequences = "
             f"{len(p.settings) * len(p.sequences)} tasks\n",
             "| " + " | ".join(head) + " |",
             "|" + "---:|" * len(head)]
    for values, run in zip(p.settings, result.runs):
        o = run.overall
        cells = [*(str(v) for v in values), *([_pct(o["hota"])] if hota else []), _pct(o["mota"]), _pct(o["idf1"]),
                 str(o["idsw"]), str(o["fp"]), str(o["fn"])]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def sweep_json(result: SweepResult) -> dict:
    p = result.plan
    return {"benchmark": p.benchmark, "split": p.split, "backend": p.backend, "sequences": list(p.sequences),
            "settings": [{"constants": dict(zip(p.names, values)), "overall": run.overall}
                         for values, run in zip(p.settings, result.runs)]}
