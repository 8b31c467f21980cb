"""Start-up of `refimpl track`: process start to the first frame solved (issue 27, item 1).

    python benchmarks/bench_startup.py [--data ../shared/data] [--dets FILE]
                                                [--format kitti] [--class Car] [--runs 5]

Runs the command a user runs, ``python -m refimpl track --dets FILE ... --out TMP --quiet``, in a
fresh interpreter ``--runs`` times on the *first frame* of the detections (by default KITTI tracking
train Car 0011, written to a temporary file), and prints per run and as medians its wall-clock
seconds (from just before the process starts to its exit) and its CPU seconds (user + system,
``resource.getrusage(RUSAGE_CHILDREN)``).  A one-frame run is start-up, reading, one frame
problem and its solve, writing the output and the exit: an upper bound of "process start to the
first frame solved" that needs no hook in the command.  The first run also writes the
interpreter's bytecode cache (the later runs read it), as the first `refimpl track` after an
install does; the median is over the later runs.

A second table measures the bar itself on the *whole* file: each fresh interpreter runs the same
``main`` the console script runs, with the chosen backend class's ``solve`` wrapped (in that child
process only) so that the first return writes the wall-clock time to a file; the figure is that
time minus the time just before the process was started.  It includes the interpreter's start,
every import, reading and parsing the whole detections file, building the first frame problem
and solving it.
"""

from __future__ import annotations

import argparse
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from refimpl.io import get_format

REPO = Path(__file__).resolve().parents[1]  # the checkout
DEFAULT_DETS = "KITTI/tracking/training/det_02_pointrcnn/Car/0011.txt"


def first_frame(path: str, out: Path) -> int:
    """Write the lines of the file's first frame (its first comma-separated field) to ``out``."""
    lines = [ln for ln in Path(path).read_text().splitlines() if ln.strip()]
    if not lines:
        raise SystemExit(f"bench_startup: {path} has no detections")
    frame = lines[0].split(",")[0]
    kept = [ln for ln in lines if ln.split(",")[0] == frame]
    out.write_text("\n".join(kept) + "\n")
    return len(kept)


def run_once(args: list[str]) -> dict[str, float]:
    """One fresh `python -m refimpl ARGS`: its wall-clock and CPU seconds."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    out = subprocess.run([sys.executable, "-m", "refimpl", *args], cwd=REPO, capture_output=True, text=True)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if out.returncode != 0:
        raise SystemExit(f"bench_startup: the command failed ({out.returncode}): {out.stderr.strip()[-500:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"wall": wall, "cpu": cpu}


_FIRST_SOLVE = """
import sys, time
from refimpl.tracking.baseline import SortTracker
from refimpl.tracking.tracker import AbductionTracker
stamp = sys.argv[1]

def first(cls, name):
    inner = getattr(cls, name)
    def wrapped(*a, **k):
        out = inner(*a, **k)
        if not first.done:
            first.done = True
            with open(stamp, "w") as f:
                f.write(repr(time.time()))
        return out
    setattr(cls, name, wrapped)
first.done = False
first(AbductionTracker, "step")  # one frame: its problem built, solved, the answer applied
first(SortTracker, "update")     # the baseline's frame
from refimpl.cli import main
sys.exit(main(sys.argv[2:]))
"""
"""The measured command in a child interpreter, its first frame stamped.  The hook is set before
``refimpl.cli`` is imported, so refimpl's tracking modules load a little earlier than in the plain
command; the set of modules and the work done are the same."""


def run_to_first_solve(args: list[str], stamp: Path) -> float:
    """Wall-clock seconds from just before a fresh `refimpl ARGS` starts to its first frame solved."""
    stamp.unlink(missing_ok=True)
    started = time.time()
    out = subprocess.run([sys.executable, "-c", _FIRST_SOLVE, str(stamp), *args], cwd=REPO, capture_output=True,
                         text=True)
    if out.returncode != 0 or not stamp.is_file():
        raise SystemExit(f"bench_startup: the command failed ({out.returncode}): {out.stderr.strip()[-500:]}")
    return float(stamp.read_text()) - started


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(REPO.parent / "shared" / "data"))
    ap.add_argument("--dets", help=f"detections file (default: DATA/{DEFAULT_DETS})")
    ap.add_argument("--format", default="kitti")
    ap.add_argument("--class", dest="cls", default="Car")
    ap.add_argument("--backend", default="cpsat")
    ap.add_argument("--runs", type=int, default=5)
    a = ap.parse_args(argv)
    if a.runs < 1:
        ap.error("--runs must be >= 1")
    dets = a.dets or str(Path(a.data) / DEFAULT_DETS)
    if not Path(dets).is_file():
        ap.error(f"no detections file {dets}")
    with tempfile.TemporaryDirectory() as tmp:
        one = Path(tmp) / Path(dets).name
        n = first_frame(dets, one)
        args = ["track", "--dets", str(one), "--format", a.format, "--backend", a.backend, "--out",
                str(Path(tmp) / "out.txt"), "--quiet"]
        if get_format(a.format).needs_class:
            args += ["--class", a.cls]
        with open("/proc/loadavg") as f:
            load = f.read().split()[0]
        runs = [run_once(args) for _ in range(a.runs)]
        whole = ["track", "--dets", dets, *args[3:]]
        firsts = [run_to_first_solve(whole, Path(tmp) / "stamp") for _ in range(a.runs)]
    print(f"`refimpl track` on the first frame of {dets} ({n} detections; --format {a.format}"
          f"{' --class ' + a.cls if get_format(a.format).needs_class else ''} --backend {a.backend} --quiet), {a.runs} fresh "
          f"processes, load average {load} before the first\n")
    print("| run | wall s | CPU s |\n|---:|---:|---:|")
    for k, r in enumerate(runs, 1):
        print(f"| {k}{' (writes the bytecode cache where there is none)' if k == 1 else ''} | {r['wall']:.2f} | {r['cpu']:.2f} |")
    cached = runs[1:] or runs
    print(f"| median of runs {2 if len(runs) > 1 else 1}-{len(runs)} | {statistics.median(r['wall'] for r in cached):.2f} "
          f"| {statistics.median(r['cpu'] for r in cached):.2f} |")
    print(f"\nThe whole file ({dets}): wall-clock seconds from just before the process starts to its first frame"
          f" solved and applied, {a.runs} fresh processes\n")
    print("| run | to the first frame s |\n|---:|---:|")
    for k, t in enumerate(firsts, 1):
        print(f"| {k} | {t:.2f} |")
    print(f"| median of runs {2 if len(firsts) > 1 else 1}-{len(firsts)} | {statistics.median(firsts[1:] or firsts):.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
