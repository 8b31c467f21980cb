"""The `refimpl` command: argument parsing, exit codes and one-line errors; no logic of its own."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Callable, Sequence

EXIT_OK, EXIT_FAILURE, EXIT_USAGE = 0, 1, 2
TRACKERS = ("baseline", "cpsat", "clingo")
BENCHMARKS = ("mot15", "mot15-sort6", "kitti-car", "kitti-ped")
CLASSES = {"car": "car", "pedestrian": "pedestrian", "cyclist": "cyclist"}


class UserError(Exception):
    """A mistake in the command line or its inputs: reported in one line, exit code 2."""


def _user_errors() -> tuple[type[BaseException], ...]:
    from .io import InputFormatError
    from .solvers import NoAdmissibleHypothesis, SolverUnavailable
    from .spec import ProblemFormatError
    return (UserError, ProblemFormatError, InputFormatError, SolverUnavailable, NoAdmissibleHypothesis)


# ---------------------------------------------------------------------------------------
# Progress
# ---------------------------------------------------------------------------------------

class Progress:
    """A progress bar on stderr (a line per step when stderr is not a terminal)."""

    def __init__(self, total: int, label: str, enabled: bool = True):
        self.total, self.label, self.done, self.enabled = total, label, 0, enabled
        self.tty = sys.stderr.isatty()
        self.start = time.perf_counter()

    def step(self, what: str) -> None:
        self.done += 1
        if not self.enabled:
            return
        width = 24
        filled = int(width * self.done / max(self.total, 1))
        bar = "#" * filled + "." * (width - filled)
        secs = time.perf_counter() - self.start
        line = f"{self.label} [{bar}] {self.done}/{self.total} {what} ({secs:.1f}s)"
        if self.tty:
            sys.stderr.write("\r\x1b[2K" + line + ("\n" if self.done == self.total else ""))
        else:
            sys.stderr.write(line + "\n")
        sys.stderr.flush()


# ---------------------------------------------------------------------------------------
# Commands
# ---------------------------------------------------------------------------------------

def _parse_const(text: str) -> tuple[str, int]:
    name, sep, value = text.partition("=")
    try:
        if not sep or not name.strip():
            raise ValueError
        return name.strip(), int(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected NAME=INTEGER, got {text!r}") from None


def cmd_solve(args: argparse.Namespace) -> int:
    from .solvers import get_solver
    from .spec import read_problem, with_constants

    problem = read_problem(args.file)
    if args.const:
        problem = with_constants(problem, dict(args.const))
    hyp = get_solver(args.backend).solve(problem, time_limit=args.time_limit)
    if args.json:
        print(hyp.to_json())
    else:
        print(f"time {hyp.time}  backend {hyp.backend}  {'optimal' if hyp.optimal else 'NOT proven optimal'}"
              f"  {hyp.solve_ms:.1f} ms")
        print("actions: " + " ".join(hyp.actions))
        print("events:  " + (" ".join(hyp.events) or "-"))
        print("cost:    " + " ".join(f"{v}@{p}" for p, v in hyp.cost))
    return EXIT_OK


def _load_sequence(args: argparse.Namespace):
    from . import io
    if args.format == "mot":
        return io.read_mot_detections(args.dets)
    if args.cls is None:
        raise UserError("--format kitti needs --class Car|Pedestrian|Cyclist")
    return io.read_kitti_detections(args.dets, args.cls)


def _run_tracker(seq, backend: str, progress: Progress | None = None, **options):
    """Results rows (frame, id, x, y, w, h) and the event log (possibly empty) of one sequence."""
    if backend == "baseline":
        from .baseline import track_sequence
        return track_sequence(seq), ()
    from .tracker import track_sequence as abduce_sequence  # the paper's Algorithm 1
    result = abduce_sequence(seq, backend=backend, **options)
    return result.rows, result.events


def cmd_track(args: argparse.Namespace) -> int:
    from . import io
    seq = _load_sequence(args)
    rows, events = _run_tracker(seq, args.backend)
    io.write_mot_results(args.out, rows, first_frame=seq.first_frame)
    print(f"{seq.name}: {len(seq.frames)} frames, {len(set(rows[:, 1].tolist())) if len(rows) else 0} tracks"
          f" -> {args.out}")
    if args.events:
        from .tracker import write_event_log
        write_event_log(args.events, events)
    if args.events_json:
        from .tracker import write_event_log_json
        write_event_log_json(args.events_json, events)
    return EXIT_OK


def cmd_eval(args: argparse.Namespace) -> int:
    from . import io
    from .evaluate import evaluate_many, format_table
    if args.format == "mot":
        gt = io.read_mot_ground_truth(args.gt)
    else:
        if args.cls is None:
            raise UserError("--format kitti needs --class Car|Pedestrian")
        gt = io.read_kitti_ground_truth(args.gt, args.cls)
    results = io.read_mot_results(args.results, first_frame=gt.first_frame)
    per_seq, overall = evaluate_many([(gt.name, gt, results)])
    print(format_table(per_seq, overall))
    return EXIT_OK


def run_benchmark(name: str, data_root: str, backend: str, show_progress: bool = True):
    """Track and evaluate every sequence of a benchmark: (per_sequence, overall) metrics."""
    from . import io
    from .evaluate import evaluate_many
    seqs = io.benchmark_sequences(name, data_root)
    progress = Progress(len(seqs), f"{name}/{backend}", enabled=show_progress)
    triples = []
    for s in seqs:
        dets = io.load_detections(s)
        rows, _ = _run_tracker(dets, backend)
        triples.append((s.name, io.load_ground_truth(s), rows))
        progress.step(s.name)
    return evaluate_many(triples)


def cmd_benchmark(args: argparse.Namespace) -> int:
    from .evaluate import format_table
    per_seq, overall = run_benchmark(args.name, args.data, args.backend, show_progress=not args.quiet)
    print(f"## {args.name} — {args.backend}\n")
    print(format_table(per_seq, overall))
    if args.json:
        Path(args.json).write_text(json.dumps({"benchmark": args.name, "backend": args.backend,
                                               "per_sequence": per_seq, "overall": overall}, indent=2))
    return EXIT_OK


def cmd_diff(args: argparse.Namespace) -> int:
    from . import io
    from .diff import DiffReport, diff_sequence
    backends = tuple(b.strip() for b in args.backends.split(","))
    if len(backends) != 2 or any(b not in ("cpsat", "clingo") for b in backends) or backends[0] == backends[1]:
        raise UserError(f"--backends takes two different backends out of cpsat,clingo, got {args.backends!r}")
    if args.benchmark:
        seqs = [io.load_detections(s) for s in io.benchmark_sequences(args.benchmark, args.data)]
    elif args.dets:
        seqs = [_load_sequence(args)]
    else:
        raise UserError("give --dets PATH (one sequence) or --benchmark NAME (every sequence of a benchmark)")
    total = DiffReport(backends)  # type: ignore[arg-type]
    progress = Progress(len(seqs), f"diff {backends[0]},{backends[1]}", enabled=not args.quiet)
    for seq in seqs:
        report = diff_sequence(seq, backends)  # type: ignore[arg-type]
        total.add(report)
        print(f"{seq.name}: {report.summary()}")
        if report.first_divergence:
            print(report.first_divergence.describe())
        progress.step(seq.name)
    if len(seqs) > 1:
        print(f"TOTAL: {total.summary()}")
    return EXIT_OK if total.ok else EXIT_FAILURE


def cmd_demo(args: argparse.Namespace) -> int:
    from . import io
    from .evaluate import evaluate_many, format_table
    seq = io.demo_sequence_paths()
    dets, gt = io.load_detections(seq), io.load_ground_truth(seq)
    print(f"refimpl demo: {seq.name} ({len(dets.frames)} frames, bundled MOT15 sample)\n")
    for backend in args.backends.split(","):
        t0 = time.perf_counter()
        rows, events = _run_tracker(dets, backend)
        secs = time.perf_counter() - t0
        per_seq, overall = evaluate_many([(seq.name, gt, rows)])
        print(f"### {backend}: {len(dets.frames) / max(secs, 1e-9):.0f} frames/s, {len(events)} events\n")
        print(format_table(per_seq, overall))
        print()
    return EXIT_OK


# ---------------------------------------------------------------------------------------
# Parser
# ---------------------------------------------------------------------------------------

def _class_name(text: str) -> str:
    key = text.lower()
    if key not in CLASSES:
        raise argparse.ArgumentTypeError(f"unknown class {text!r} (choose Car, Pedestrian or Cyclist)")
    return CLASSES[key]


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="refimpl",
        description="Online visual abduction for multi-object tracking: the paper's ASP model "
                    "and an equivalent CP-SAT model.")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    s = sub.add_parser("solve", help="abduce the best hypothesis for one frame problem (fact file)")
    s.add_argument("file", help="fact file in the paper's syntax (det/3, box2d/5, trk/2, trk_state/2, iou/3, ...)")
    s.add_argument("--backend", choices=("cpsat", "clingo"), default="cpsat")
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.add_argument("--time-limit", type=float, default=None, metavar="SECONDS")
    s.add_argument("--const", type=_parse_const, action="append", metavar="NAME=VALUE",
                   help="override a model constant (repeatable)")
    s.set_defaults(func=cmd_solve)

    t = sub.add_parser("track", help="track a detection file and write MOTChallenge results")
    t.add_argument("--dets", required=True, help="detections: MOTChallenge det.txt or KITTI PointRCNN file")
    t.add_argument("--format", choices=("mot", "kitti"), default="mot")
    t.add_argument("--class", dest="cls", type=_class_name, help="object class for KITTI: Car|Pedestrian|Cyclist")
    t.add_argument("--backend", choices=TRACKERS, default="baseline")
    t.add_argument("--out", required=True, help="results file (MOTChallenge format)")
    t.add_argument("--events", help="write the abduced event log in the paper's syntax")
    t.add_argument("--events-json", help="write the event log as JSON lines")
    t.set_defaults(func=cmd_track)

    e = sub.add_parser("eval", help="CLEAR MOT and IDF1 of a results file against ground truth")
    e.add_argument("results", help="results file (MOTChallenge format)")
    e.add_argument("--gt", required=True, help="ground truth: MOTChallenge gt.txt or KITTI label_02 file")
    e.add_argument("--format", choices=("mot", "kitti"), default="mot")
    e.add_argument("--class", dest="cls", type=_class_name, help="object class for KITTI: Car|Pedestrian")
    e.set_defaults(func=cmd_eval)

    b = sub.add_parser("benchmark", help="track and evaluate every sequence of a benchmark")
    b.add_argument("name", choices=BENCHMARKS)
    b.add_argument("--data", default="../shared/data", help="benchmark data root (default ../shared/data)")
    b.add_argument("--backend", choices=TRACKERS, default="baseline")
    b.add_argument("--json", help="also write the metrics as JSON")
    b.add_argument("--quiet", action="store_true", help="no progress bar")
    b.set_defaults(func=cmd_benchmark)

    x = sub.add_parser("diff", help="track with one backend and re-solve every frame with the other; "
                                     "exit 1 on any cost disagreement")
    x.add_argument("--dets", help="detections of one sequence")
    x.add_argument("--format", choices=("mot", "kitti"), default="mot")
    x.add_argument("--class", dest="cls", type=_class_name, help="object class for KITTI")
    x.add_argument("--benchmark", choices=BENCHMARKS, help="diff every sequence of a benchmark instead")
    x.add_argument("--data", default="../shared/data", help="benchmark data root (with --benchmark)")
    x.add_argument("--backends", default="cpsat,clingo", help="FIRST,SECOND (default cpsat,clingo)")
    x.add_argument("--quiet", action="store_true", help="no progress bar")
    x.set_defaults(func=cmd_diff)

    d = sub.add_parser("demo", help="track the bundled sample sequence and print its metrics")
    d.add_argument("--backends", default="baseline", help="comma-separated trackers to run (default baseline)")
    d.set_defaults(func=cmd_demo)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except _user_errors() as exc:
        print(f"refimpl {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as exc:
        where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        print(f"refimpl {args.command}: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("refimpl: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
