"""Seeded, bounded fuzzing of the fact-format parser and the MOTChallenge / KITTI readers.

The run over many inputs, its summary table and the command line of ``python tests/tools/fuzz.py``
(the full description: the package doc of tools.fuzzing).
"""

from __future__ import annotations

import argparse
import re
import shutil
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from .cases import FAILURES, OUTCOMES, Case, Result, generate, run_reader
from .command_line import cli_fixtures, run_cli
from .seeds import load_seeds


@dataclass
class Summary:
    counts: dict[tuple[str, str], int] = field(default_factory=dict)
    failures: list[Result] = field(default_factory=list)
    inputs: int = 0
    cli_runs: int = 0
    seconds: float = 0.0
    slowest: tuple[float, str] = (0.0, "")
    messages: dict[str, int] = field(default_factory=dict)  # clean errors, paths and numbers masked

    def add(self, r: Result) -> None:
        key = (r.case.target if r.kind == "reader" else f"cli:{r.case.target}", r.outcome)
        self.counts[key] = self.counts.get(key, 0) + 1
        if r.outcome in FAILURES:
            self.failures.append(r)
        if r.outcome == "error":
            key = re.sub(r"/\S*?/case\d+/\S*?(?=[:\s])", "FILE", r.detail)
            key = re.sub(r"'[^']*'|\"[^\"]*\"", "'…'", key)
            key = re.sub(r"-?\d[\d.e+-]*", "N", key)[:110]
            self.messages[key] = self.messages.get(key, 0) + 1
        if r.seconds > self.slowest[0]:
            self.slowest = (r.seconds, f"input {r.case.index} ({r.kind} {r.case.target})")

    @property
    def tracebacks(self) -> int:
        return sum(v for (_, o), v in self.counts.items() if o == "traceback")

    def rows(self) -> list[str]:
        return sorted({k for k, _ in self.counts}, key=lambda k: (k.startswith("cli:"), k))

    def table(self) -> str:
        head = "| target | " + " | ".join(OUTCOMES) + " | total |"
        lines = [head, "|---|" + "---:|" * (len(OUTCOMES) + 1)]
        totals = [0] * len(OUTCOMES)
        for row in self.rows():
            vals = [self.counts.get((row, o), 0) for o in OUTCOMES]
            totals = [a + b for a, b in zip(totals, vals)]
            lines.append(f"| {row} | " + " | ".join(str(v) for v in vals) + f" | {sum(vals)} |")
        lines.append("| **all** | " + " | ".join(str(v) for v in totals) + f" | {sum(totals)} |")
        return "\n".join(lines)


def describe(case: Case, limit: int = 300) -> str:
    return (f"input {case.index} (target {case.target}, seed {case.seed_name}, layout {case.layout}); "
            f"mutations: {'; '.join(case.mutations)}\n    bytes[:{limit}]: {case.data[:limit]!r}"
            + (f" ... ({len(case.data)} bytes)" if len(case.data) > limit else ""))


def run(inputs: int, seed: int = 0, cli_every: int = 20, timeout: float = 60.0, only: list[int] | None = None,
        save: Path | None = None, progress: Callable[[int, Summary], None] | None = None,
        keep_going: bool = True) -> Summary:
    seeds = load_seeds()
    summary = Summary()
    t0 = time.perf_counter()
    base = Path(tempfile.mkdtemp(prefix="refimpl-fuzz-"))
    try:
        fx = cli_fixtures(seeds, base / "fixtures")
        indices = only if only is not None else range(inputs)
        for n, i in enumerate(indices):
            case = generate(seeds, seed, i, cli_every)
            if only is not None:
                case.cli = cli_every > 0
            root = base / f"case{i}"
            root.mkdir()
            try:
                (root / "reader").mkdir()
                summary.add(run_reader(case, root / "reader", timeout))
                if case.cli:
                    (root / "cli").mkdir()
                    summary.add(run_cli(case, root / "cli", fx, timeout))
                    summary.cli_runs += 1
            finally:
                shutil.rmtree(root, ignore_errors=True)
            summary.inputs += 1
            if save is not None and summary.failures and summary.failures[-1].case is case:
                save.mkdir(parents=True, exist_ok=True)
                (save / f"input{i}.{case.target}").write_bytes(case.data)
            if progress:
                progress(n + 1, summary)
            if not keep_going and summary.failures:
                break
    finally:
        shutil.rmtree(base, ignore_errors=True)
    summary.seconds = time.perf_counter() - t0
    return summary


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--inputs", type=int, default=10_000, help="number of generated inputs (default 10000)")
    ap.add_argument("--seed", type=int, default=0, help="generator seed (default 0)")
    ap.add_argument("--cli-every", type=int, default=20,
                    help="also run every Nth input through refimpl.cli.main (default 20; 0: never)")
    ap.add_argument("--timeout", type=float, default=60.0, help="per-input time limit in seconds (default 60)")
    ap.add_argument("--only", type=lambda s: [int(v) for v in s.split(",")],
                    help="regenerate and run only these input indices (comma-separated), CLI included")
    ap.add_argument("--show", type=int, default=5, help="failures to print in full (default 5)")
    ap.add_argument("--save", type=Path, help="write failing inputs into this folder")
    ap.add_argument("--quiet", action="store_true", help="no progress line")
    ap.add_argument("--messages", type=int, default=0, metavar="N",
                    help="also print the N most frequent clean error messages (paths and numbers masked)")
    args = ap.parse_args(argv)

    def progress(n: int, s: Summary) -> None:
        if not args.quiet and (n % 500 == 0):
            print(f"fuzz: {n} inputs, {len(s.failures)} failures, {time.perf_counter() - start:.0f} s",
                  file=sys.stderr, flush=True)

    start = time.perf_counter()
    s = run(args.inputs, args.seed, args.cli_every, args.timeout, args.only, args.save, progress)
    print(f"refimpl fuzz: {s.inputs} inputs (seed {args.seed}), {s.cli_runs} CLI runs, "
          f"{s.seconds:.1f} s; slowest {s.slowest[0]:.2f} s ({s.slowest[1]})\n")
    print(s.table())
    if args.messages:
        print(f"\nmost frequent clean errors ({len(s.messages)} distinct after masking):")
        for msg, n in sorted(s.messages.items(), key=lambda kv: -kv[1])[:args.messages]:
            print(f"{n:6d}  {msg}")
    failed = len(s.failures)
    print(f"\nfailures: {failed} (tracebacks: {s.tracebacks})")
    for r in s.failures[:args.show]:
        print(f"\n--- {r.outcome} ({r.kind}) {describe(r.case)}\n{r.detail.rstrip()}")
    if failed > args.show:
        print(f"\n... {failed - args.show} more; failing inputs: "
              + ",".join(str(r.case.index) for r in s.failures[:200]))
    return 1 if failed else 0
