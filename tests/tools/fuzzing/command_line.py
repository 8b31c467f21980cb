"""Every ``--cli-every``-th fuzz input also run through the command line (``refimpl.cli.main``)."""

from __future__ import annotations

import contextlib
import io as _stdio
import re
import time
import traceback
import warnings
from dataclasses import dataclass
from pathlib import Path

from refimpl import io as rio

from .cases import Case, Result, _time_limit, _Timeout, case_files
from .seeds import Seeds


@dataclass
class CliFixtures:
    mot_results: Path
    mot_gt: Path
    kitti_results: Path
    kitti_gt: Path


def cli_fixtures(seeds: Seeds, root: Path) -> CliFixtures:
    root.mkdir(parents=True, exist_ok=True)
    fx = CliFixtures(root / "mot_results.txt", seeds.mot_gt_path, root / "kitti_results.txt", root / "kitti_gt.txt")
    fx.mot_results.write_text(seeds.mot_results_text, encoding="utf-8")
    fx.kitti_results.write_text(seeds.kitti_results_text, encoding="utf-8")
    fx.kitti_gt.write_text(seeds.kitti_car_label_text, encoding="utf-8")
    return fx


def cli_argv(case: Case, path: Path, out: Path, fx: CliFixtures) -> list[str] | None:
    cls = "Pedestrian" if case.seed_name.startswith("ped") else "Car"
    if case.target == "facts":
        backend = "clingo" if case.backend == "cpsat" else "cpsat"  # half the runs each
        return ["solve", str(path), "--backend", backend, "--time-limit", "10"]
    if case.target == "mot_det":
        return ["track", "--dets", str(path), "--format", "mot", "--backend", case.backend, "--out", str(out)]
    if case.target == "kitti_det":
        return ["track", "--dets", str(path), "--format", "kitti", "--class", cls, "--backend", case.backend,
                "--out", str(out)]
    if case.target == "mot_gt":
        return ["eval", str(fx.mot_results), "--gt", str(path)]
    if case.target == "mot_results":
        if case.seed_name.startswith("kitti"):
            return ["eval", str(path), "--gt", str(fx.kitti_gt), "--format", "kitti", "--class", "Car"]
        return ["eval", str(path), "--gt", str(fx.mot_gt)]
    if case.target == "kitti_gt":
        return ["eval", str(fx.kitti_results), "--gt", str(path), "--format", "kitti", "--class", cls]
    return None


def run_cli(case: Case, root: Path, fx: CliFixtures, timeout: float) -> Result:
    from refimpl import cli

    path, files = case_files(case, root)
    outdir = root / "out"
    outdir.mkdir()
    out = outdir / "results.txt"
    argv = cli_argv(case, path, out, fx)
    stdout, stderr = _stdio.StringIO(), _stdio.StringIO()
    t0 = time.perf_counter()
    saved = warnings.showwarning
    try:
        with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr), warnings.catch_warnings():
            with _time_limit(timeout):
                code = cli.main(argv)
    except _Timeout:
        return Result(case, "cli", "timeout", f"refimpl {' '.join(argv)}: no answer within {timeout:g} s",
                      time.perf_counter() - t0)
    except BaseException as exc:  # noqa: BLE001
        if isinstance(exc, KeyboardInterrupt):
            raise
        return Result(case, "cli", "traceback", f"refimpl {' '.join(argv)}\n" + "".join(
            traceback.format_exception(exc))[-4000:], time.perf_counter() - t0)
    finally:
        warnings.showwarning = saved
    secs = time.perf_counter() - t0
    err_lines = [l for l in stderr.getvalue().splitlines() if not l.startswith("refimpl: warning: ")]
    leftovers = sorted(p.name for p in outdir.iterdir())
    cmd = f"refimpl {' '.join(argv)}"
    if code == 0:
        if argv[0] == "track":
            try:
                rio.read_mot_results(out, allow_empty=True, first_frame=0 if "kitti" in argv else 1)
            except Exception as exc:  # noqa: BLE001
                return Result(case, "cli", "bad-accept", f"{cmd}: results file unreadable: {exc}", secs)
            if leftovers != ["results.txt"]:
                return Result(case, "cli", "leftover", f"{cmd}: files after success: {leftovers}", secs)
        return Result(case, "cli", "accepted", "", secs)
    if code != 2 or len(err_lines) != 1 or not err_lines[0].startswith("refimpl "):
        return Result(case, "cli", "traceback",
                      f"{cmd}: exit {code}, stderr {stderr.getvalue()[-2000:]!r}", secs)
    if leftovers:
        return Result(case, "cli", "leftover", f"{cmd}: failed but left {leftovers} behind", secs)
    msg = err_lines[0]
    m = re.match(r"refimpl \S+: error: (.*)$", msg)
    if not m:
        return Result(case, "cli", "bad-error", f"{cmd}: {msg}", secs)
    named = [f for f in files if m.group(1).startswith(f)] + \
            [str(p) for p in (fx.mot_results, fx.mot_gt, fx.kitti_results, fx.kitti_gt) if m.group(1).startswith(str(p))]
    if not named:
        return Result(case, "cli", "bad-error", f"{cmd}: error names none of the input files: {msg}", secs)
    return Result(case, "cli", "error", msg, secs)
