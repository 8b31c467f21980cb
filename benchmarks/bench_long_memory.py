"""Peak memory of `refimpl track` on a long sequence, every tracker, with /usr/bin/time -v.

    python benchmarks/bench_long_memory.py [--frames 20000] [--objects 20] [--seed 0]
                                      [--trackers baseline,cpsat,cpsat-full,clingo] [--dir DIR]

Writes the sequence of benchmarks/long_sequence.py (unless DIR already holds it), then runs, one
tracker after the other,

    /usr/bin/time -v python -m refimpl track --dets DIR/det/det.txt --backend B --out R --events E

and prints one markdown row per tracker (docs/robustness.md, "Memory: 20,000 frames x 20 objects").

What the memory columns mean.  `/usr/bin/time -v`'s "Maximum resident set size" is the peak
RSS of the LARGEST SINGLE process among the command and the children it waited for (Linux
wait4 rusage); it is not a sum.  The clingo backend solves in a worker child process
(refimpl/solvers/clingo_worker.py), replaced every so many solves, which runs beside the main
process.  So this tool also watches the process tree itself: every --interval seconds it reads
VmHWM (the kernel's exact peak RSS of that process so far) of every descendant, and its Pss (see below), from
/proc.  It reports
* `main peak`: VmHWM of the `refimpl track` process (its last reading, taken while it lived);
* `worker peak`: the largest VmHWM of any clingo worker (and how many workers ran);
* `bound`: main peak + worker peak.  At most one worker lives at a time, so this bounds the
  memory of the whole command from above, whatever the sampling missed;
* `tree PSS peak`: the largest sum over the tree, in one sample, of each process's proportional
  set size (Pss of /proc/PID/smaps_rollup: its private pages plus its share of the pages it
  shares).  A sum of RSS would count shared pages once per process: while a new worker is being
  started, its forked copy (before exec) shares every page of the main process and so shows the
  main process's RSS a second time without using any more memory.
The 1 GB criterion is checked on `max(time -v, bound)`; the tool exits 1 when a tracker exceeds
--limit-mib or does not exit 0.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from refimpl.experiments.walkers import write_sequence
from refimpl.solvers import TRACKERS

ROOT = Path(__file__).resolve().parents[1]  # the checkout (refimpl/ and model/ beside it)

WORKER_MODULE = "refimpl.solvers.clingo_worker"


def _status(pid: int) -> dict[str, int]:
    """VmHWM and VmRSS (kB) of a live process; {} when it is gone."""
    out: dict[str, int] = {}
    try:
        with open(f"/proc/{pid}/status", encoding="ascii", errors="replace") as fh:
            for line in fh:
                if line.startswith(("VmHWM:", "VmRSS:")):
                    key, value = line.split(":", 1)
                    out[key] = int(value.split()[0])
    except (FileNotFoundError, ProcessLookupError, PermissionError):
        return {}
    return out


def _pss(pid: int) -> int:
    """Proportional set size (kB) of a live process; 0 when it is gone or unreadable."""
    try:
        with open(f"/proc/{pid}/smaps_rollup", encoding="ascii", errors="replace") as fh:
            for line in fh:
                if line.startswith("Pss:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return 0


def _descendants(root: int) -> dict[int, str]:
    """pid -> command line of every process below ``root`` (by scanning /proc for parent ids)."""
    parent: dict[int, int] = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat", "rb") as fh:
                stat = fh.read().decode("ascii", "replace")
        except OSError:
            continue
        # pid (comm) state ppid ...: comm may hold spaces and parentheses, so split after the last ')'
        parent[int(entry)] = int(stat.rsplit(")", 1)[1].split()[1])
    found: dict[int, str] = {}
    frontier = [root]
    while frontier:
        p = frontier.pop()
        for child, pp in parent.items():
            if pp == p and child not in found:
                try:
                    cmd = Path(f"/proc/{child}/cmdline").read_bytes().replace(b"\0", b" ").decode("utf-8", "replace")
                except OSError:
                    cmd = ""
                found[child] = cmd
                frontier.append(child)
    return found


def _time_field(text: str, label: str) -> str:
    m = re.search(rf"^\s*{re.escape(label)}: (.*)$", text, re.M)
    return m.group(1).strip() if m else "?"


def measure(tracker: str, det: Path, out_dir: Path, interval: float) -> dict:
    """Run one `refimpl track` under /usr/bin/time -v and watch its process tree."""
    results, events = out_dir / f"{tracker}.txt", out_dir / f"{tracker}.lp"
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    cmd = ["/usr/bin/time", "-v", sys.executable, "-m", "refimpl", "track", "--dets", str(det),
           "--backend", tracker, "--out", str(results), "--events", str(events)]
    started = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    main_hwm = worker_hwm = tree_peak = 0
    workers: set[int] = set()
    while proc.poll() is None:
        tree = _descendants(proc.pid)
        total = 0
        for pid, cmdline in tree.items():
            st = _status(pid)
            if not st:
                continue
            total += _pss(pid)
            if WORKER_MODULE in cmdline:
                workers.add(pid)
                worker_hwm = max(worker_hwm, st.get("VmHWM", 0))
            elif " -m refimpl track" in cmdline:
                main_hwm = max(main_hwm, st.get("VmHWM", 0))
        tree_peak = max(tree_peak, total)
        time.sleep(interval)
    stdout, stderr = proc.communicate()
    wall = time.perf_counter() - started
    maxrss = _time_field(stderr, "Maximum resident set size (kbytes)")
    digest = hashlib.sha256(results.read_bytes()).hexdigest()[:12] if results.exists() else "-"
    return {
        "tracker": tracker,
        "exit": proc.returncode,
        "time_maxrss_kb": int(maxrss) if maxrss.isdigit() else 0,
        "elapsed": _time_field(stderr, "Elapsed (wall clock) time (h:mm:ss or m:ss)"),
        "user": _time_field(stderr, "User time (seconds)"),
        "main_hwm_kb": main_hwm,
        "worker_hwm_kb": worker_hwm,
        "workers": len(workers),
        "tree_peak_kb": tree_peak,
        "wall": wall,
        "results_sha": digest,
        "rows": sum(1 for _ in open(results, encoding="utf-8")) if results.exists() else 0,
        "tail": (stderr.strip().splitlines() or [""])[0] if proc.returncode else stdout.strip().splitlines()[-1:],
    }


def mib(kb: int) -> str:
    return f"{kb / 1024:,.0f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=20_000)
    ap.add_argument("--objects", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--trackers", default=",".join(TRACKERS),
                    help=f"comma-separated, from {', '.join(TRACKERS)} (default all)")
    ap.add_argument("--dir", help="folder for the sequence and the outputs (default: a temporary folder)")
    ap.add_argument("--interval", type=float, default=0.2, help="seconds between two /proc samples")
    ap.add_argument("--limit-mib", type=float, default=1000 * 1000**2 / 2**20,
                    help="fail above this many MiB (default 1 GB = 953.7 MiB)")
    a = ap.parse_args()
    trackers = [t for t in a.trackers.split(",") if t]
    unknown = [t for t in trackers if t not in TRACKERS]
    if unknown:
        ap.error(f"unknown tracker(s) {', '.join(unknown)} (choose from {', '.join(TRACKERS)})")
    if not Path("/usr/bin/time").exists():
        ap.error("/usr/bin/time is missing (GNU time; apt-get install time)")
    base = Path(a.dir) if a.dir else Path(tempfile.mkdtemp(prefix="refimpl-long-"))
    det = base / "det" / "det.txt"
    if not det.exists():
        write_sequence(base, a.frames, a.objects, a.seed)
    n_det = sum(1 for _ in open(det, encoding="utf-8"))
    print(f"sequence: {det} ({a.frames} frames x {a.objects} objects, seed {a.seed}, {n_det} detections)",
          flush=True)
    print("| tracker | exit | max RSS, time -v (MiB) | main peak (MiB) | worker peak (MiB) | workers "
          "| bound: main + worker (MiB) | tree PSS peak, sampled (MiB) | elapsed | user CPU (s) | results |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    failed = False
    for tracker in trackers:
        r = measure(tracker, det, base, a.interval)
        bound = r["main_hwm_kb"] + r["worker_hwm_kb"]
        over = max(r["time_maxrss_kb"], bound) / 1024 > a.limit_mib
        failed |= over or r["exit"] != 0
        worker = mib(r["worker_hwm_kb"]) if r["workers"] else "-"
        print(f"| {tracker} | {r['exit']} | {mib(r['time_maxrss_kb'])} | {mib(r['main_hwm_kb'])} | {worker} "
              f"| {r['workers']} | {mib(bound)}{' (over)' if over else ''} | {mib(r['tree_peak_kb'])} "
              f"| {r['elapsed']} | {r['user']} | {r['rows']} rows, sha256 {r['results_sha']} |", flush=True)
        if r["exit"] != 0:
            print(f"  {tracker}: {r['tail']}", flush=True)
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
