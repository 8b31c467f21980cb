"""The property checks of tests/properties.py, run longer and counted (docs/robustness.md, issue 37).

    python tests/tools/properties.py --examples 3000 --seed 0

For each surface (a MOTChallenge file, a KITTI file, the pipe, ``Tracker.update``) hypothesis
generates that many inputs; each is tracked or refused in one line.  The table counts them, with
the inputs that raised anything else (tracebacks) and those that took longer than --hang seconds.
Exit 1 on any traceback or hang.
"""

from __future__ import annotations

import argparse
import collections
import sys
import tempfile
import time
from pathlib import Path

from hypothesis import HealthCheck, given, seed, settings

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # tests/, for properties
import properties as prop  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--examples", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--hang", type=float, default=10.0, help="seconds after which an input counts as a hang")
    args = ap.parse_args(argv)
    folder = Path(tempfile.mkdtemp())
    surfaces = {
        "MOTChallenge file": (prop.MOT_TEXT, lambda x: prop.check_file(x, folder, "mot")),
        "KITTI file": (prop.KITTI_TEXT, lambda x: prop.check_file(x, folder, "kitti")),
        "pipe (--dets -)": (prop.MOT_TEXT, prop.check_pipe),
        "Tracker.update": (prop.FRAMES, prop.check_api),
    }
    print("| surface | inputs | tracked | refused (one line) | tracebacks | hangs | slowest s |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    failed = 0
    for name, (strategy, check) in surfaces.items():
        counts: collections.Counter = collections.Counter()
        slowest = [0.0]

        @seed(args.seed)
        @settings(max_examples=args.examples, deadline=None, database=None,
                  suppress_health_check=list(HealthCheck))
        @given(strategy)
        def run(x):
            t = time.perf_counter()
            try:
                counts[check(x)] += 1
            except Exception as exc:  # noqa: BLE001  (what the table counts)
                counts["traceback"] += 1
                print(f"{name}: {type(exc).__name__}: {exc!s:.200} on {x!r:.300}", file=sys.stderr)
            took = time.perf_counter() - t
            slowest[0] = max(slowest[0], took)
            counts["hang"] += took > args.hang

        run()
        total = counts["tracked"] + counts["refused"] + counts["traceback"]
        failed += counts["traceback"] + counts["hang"]
        print(f"| {name} | {total} | {counts['tracked']} | {counts['refused']} | {counts['traceback']} | "
              f"{counts['hang']} | {slowest[0]:.2f} |")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
