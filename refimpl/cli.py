"""The `refimpl` command: argument parsing, exit codes and one-line errors; no logic of its own."""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path
from typing import Callable, Sequence

from .solvers import BACKENDS

EXIT_OK, EXIT_FAILURE, EXIT_USAGE = 0, 1, 2
TRACKERS = ("baseline",) + BACKENDS
BENCHMARKS = ("mot15", "mot15-sort6", "kitti-car", "kitti-ped", "mot17-sim", "mot20-01-sim")
CLASSES = {"car": "car", "pedestrian": "pedestrian", "cyclist": "cyclist"}


class UserError(Exception):
    """A mistake in the command line or its inputs: reported in one line, exit code 2."""


def _user_errors() -> tuple[type[BaseException], ...]:
    from .io import InputFormatError
    from .solvers import NoAdmissibleHypothesis, SolverUnavailable, SolveTimeout
    from .spec import ProblemFormatError
    from .scene import SceneError
    return (UserError, ProblemFormatError, InputFormatError, SolverUnavailable, NoAdmissibleHypothesis,
            SolveTimeout, SceneError)


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


def _time_limit(value):
    """A --time-limit value as the solvers' time-out contract takes it, else a UserError."""
    from .solvers import check_time_limit
    try:
        return check_time_limit(value)
    except ValueError as exc:
        raise UserError(f"--time-limit: {exc}") from None


def cmd_solve(args: argparse.Namespace) -> int:
    from .solvers import get_solver
    from .spec import ProblemFormatError, read_problem, with_constants

    from .constants import resolve_constants
    problem = read_problem(args.file)
    if args.const:
        problem = with_constants(problem, dict(args.const))
    try:
        resolve_constants(problem)  # an unknown #const name is the file's (or --const's) mistake
    except ProblemFormatError as exc:
        raise ProblemFormatError(exc.reason, args.file) from None
    hyp = get_solver(args.backend).solve(problem, time_limit=_time_limit(args.time_limit))
    violations = ()
    if args.check:
        from .check import check_answer
        report = check_answer(problem, hyp)
        violations = tuple(str(v) for v in report.violations)
        if report.cost != hyp.cost:
            violations += (f"[cost_vector] the answer's cost is {list(report.cost)}, not {list(hyp.cost)}",)
    if args.json:
        print(hyp.to_json())
    else:
        print(f"time {hyp.time}  backend {hyp.backend}  {'optimal' if hyp.optimal else 'NOT proven optimal'}"
              f"  {hyp.solve_ms:.1f} ms")
        print("actions: " + " ".join(hyp.actions))
        print("events:  " + (" ".join(hyp.events) or "-"))
        print("cost:    " + " ".join(f"{v}@{p}" for p, v in hyp.cost))
    if args.check:
        print("check:   " + ("; ".join(violations) if violations else "every rule holds, cost vector confirmed"),
              file=sys.stderr if args.json else sys.stdout)
    return EXIT_FAILURE if violations else EXIT_OK


def _load_sequence(args: argparse.Namespace):
    from . import io
    if args.format == "mot":
        return io.read_mot_detections(args.dets)
    if args.cls is None:
        raise UserError("--format kitti needs --class Car|Pedestrian|Cyclist")
    return io.read_kitti_detections(args.dets, args.cls)


def _run_tracker(seq, backend: str):
    from .table6 import run_tracker
    return run_tracker(seq, backend)


def cmd_track(args: argparse.Namespace) -> int:
    from . import io
    seq = _load_sequence(args)
    if args.backend == "baseline":
        if args.check or args.time_limit is not None or args.scene:
            raise UserError(f"--check, --time-limit and --scene need an abduction backend ({', '.join(BACKENDS)}); "
                            "the baseline abduces no events")
        rows, events = _run_tracker(seq, args.backend)
    else:
        rows, events = _track_abduction(seq, args)
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


def _track_abduction(seq, args: argparse.Namespace):
    """Algorithm 1 with the chosen backend, optionally checking every frame's answer."""
    from .tracker import track_sequence
    checked = violations = 0

    def check(problem, hyp) -> None:
        nonlocal checked, violations
        from .check import check_answer
        report = check_answer(problem, hyp)
        checked += 1
        if report.violations or report.cost != hyp.cost:
            violations += 1
            found = "; ".join(str(v) for v in report.violations) or "the cost vector differs"
            print(f"refimpl track: frame {problem.time}: {found}", file=sys.stderr)

    result = track_sequence(seq, backend=args.backend, time_limit=_time_limit(args.time_limit),
                            observer=check if args.check else None)
    if result.not_optimal_frames:
        print(f"refimpl track: {result.not_optimal_frames} of {result.frames} frames not proven optimal "
              f"within the time limit (best answer found used)", file=sys.stderr)
    if args.check:
        print(f"check: {checked} answers checked, {violations} with violations")
        if violations:
            raise CheckFailed(f"{violations} answers break a rule of the model")
    if args.scene:
        from .scene import save_scene, scene_from_result
        save_scene(args.scene, scene_from_result(seq, result))
    return result.rows, result.events


class CheckFailed(Exception):
    """The independent checker found answers that break the model (a backend bug): exit 1."""


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


def cmd_benchmark(args: argparse.Namespace) -> int:
    from .evaluate import format_table
    from .table6 import TITLES, load_dataset, run_benchmark
    report = {}
    for name in args.names:
        dataset = load_dataset(name, args.data)
        progress = Progress(len(dataset), f"{name}/{args.backend}", enabled=not args.quiet)
        run = run_benchmark(name, args.data, args.backend, progress.step, dataset=dataset)
        print(f"## {TITLES[name]} — {args.backend}\n")
        print(format_table(run.per_sequence, run.overall))
        print()
        report[name] = {"per_sequence": run.per_sequence, "overall": run.overall, "events": run.events}
    if args.json:
        from .io import write_text_atomic
        write_text_atomic(args.json, json.dumps({"backend": args.backend, "benchmarks": report}, indent=2,
                                                default=float))
    return EXIT_OK


def cmd_table6(args: argparse.Namespace) -> int:
    from .table6 import format_table6, run_table6
    datasets = tuple(d.strip() for d in args.datasets.split(",")) if args.datasets else None
    kwargs = {"datasets": datasets} if datasets else {}
    runs = run_table6(args.data, args.backend,
                      step_factory=None if args.quiet else (lambda label, n: Progress(n, label).step), **kwargs)
    text = format_table6(runs)
    print(text)
    if args.out:
        from .io import write_text_atomic
        write_text_atomic(args.out, text + "\n")
    return EXIT_OK


def cmd_diff(args: argparse.Namespace) -> int:
    from . import io
    from .diff import DiffReport, diff_sequence
    backends = tuple(b.strip() for b in args.backends.split(","))
    if len(backends) not in (2, 3) or any(b not in BACKENDS for b in backends) or len(set(backends)) != len(backends):
        raise UserError(f"--backends takes two or three different backends out of {','.join(BACKENDS)}, "
                        f"got {args.backends!r}")
    time_limit = _time_limit(args.time_limit)
    if args.benchmark:
        from .table6 import load_dataset  # real and simulated (*-sim) benchmarks alike
        seqs = [seq for _, seq, _ in load_dataset(args.benchmark, args.data)]
    elif args.dets:
        seqs = [_load_sequence(args)]
    else:
        raise UserError("give --dets PATH (one sequence) or --benchmark NAME (every sequence of a benchmark)")
    total = DiffReport(backends)
    progress = Progress(len(seqs), f"diff {','.join(backends)}", enabled=not args.quiet)
    for seq in seqs:
        report = diff_sequence(seq, backends, time_limit=time_limit)
        total.add(report)
        print(f"{seq.name}: {report.summary()}")
        if report.first_divergence:
            print(report.first_divergence.describe())
        progress.step(seq.name)
    if len(seqs) > 1:
        print(f"TOTAL: {total.summary()}")
    return EXIT_OK if total.ok else EXIT_FAILURE


def cmd_query(args: argparse.Namespace) -> int:
    from .scene import load_scene, query, reasoning_config
    config = reasoning_config(args.anticipation_threshold, args.ego_region)
    answer = query(load_scene(args.scene), " ".join(args.query), config)
    print(answer.to_json() if args.json else "\n".join(answer.lines))
    return EXIT_OK


def cmd_explain(args: argparse.Namespace) -> int:
    from .scene import explain, load_scene
    print("\n".join(explain(load_scene(args.scene), args.track)))
    return EXIT_OK


def cmd_plot(args: argparse.Namespace) -> int:
    from .plots import plot_scene_file
    print(plot_scene_file(args.scene, args.out, frame=args.frame, tracks=args.tracks, frames=args.frames))
    return EXIT_OK


def cmd_demo(args: argparse.Namespace) -> int:
    from . import io
    from .evaluate import evaluate_many, format_table
    backends = [b.strip() for b in args.backends.split(",")]
    unknown = [b for b in backends if b not in TRACKERS]
    if unknown:
        raise UserError(f"--backends takes trackers out of {','.join(TRACKERS)}, got {','.join(unknown)!r}")
    seq = io.demo_sequence_paths()
    dets, gt = io.load_detections(seq), io.load_ground_truth(seq)
    print(f"refimpl demo: {seq.name} ({len(dets.frames)} frames, bundled MOT15 sample)\n")
    for backend in backends:
        t0 = time.perf_counter()
        rows, events = _run_tracker(dets, backend)
        secs = time.perf_counter() - t0
        per_seq, overall = evaluate_many([(seq.name, gt, rows)])
        print(f"### {backend}: {len(dets.frames) / max(secs, 1e-9):.0f} frames/s, {len(events)} events\n")
        print(format_table(per_seq, overall))
        print()
    return EXIT_OK


def cmd_bench_scale(args: argparse.Namespace) -> int:
    from . import benchmarks as bm
    try:
        sizes = bm.parse_list(args.sizes, int)
        overlaps = bm.parse_list(args.overlaps, float)
    except ValueError as exc:
        raise UserError(f"--sizes takes integers and --overlaps numbers, comma-separated ({exc})") from None
    backends = bm.parse_list(args.backends, str)
    trackers = bm.parse_list(args.trackers, str)
    for name, given, known in (("--backends", backends, bm.SCALE_BACKENDS),
                               ("--trackers", trackers, bm.THROUGHPUT_TRACKERS)):
        unknown = [b for b in given if b not in known]
        if unknown or not given:
            raise UserError(f"{name} takes a comma-separated list out of {','.join(known)}, got {','.join(given)!r}")
    if args.seeds < 1 or args.time_limit <= 0 or not sizes or not overlaps:
        raise UserError("--seeds must be >= 1, --time-limit > 0, --sizes and --overlaps not empty")
    progress = lambda total, label: Progress(total, label, enabled=not args.quiet)  # noqa: E731
    print(bm.run_bench_scale(
        sizes=sizes, overlaps=overlaps, seeds=args.seeds, backends=backends, time_limit=args.time_limit,
        out=None if args.out == "-" else args.out, plot=args.plot, json_path=args.json,
        from_json=args.from_json, throughput=args.throughput, trackers=trackers, data=args.data,
        command=bm.format_command(sys.argv[1:]), progress=progress))
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
    s.add_argument("--backend", choices=BACKENDS, default="cpsat")
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.add_argument("--time-limit", type=float, default=None, metavar="SECONDS")
    s.add_argument("--const", type=_parse_const, action="append", metavar="NAME=VALUE",
                   help="override a model constant (repeatable)")
    s.add_argument("--check", action="store_true",
                   help="verify the answer with the independent checker; exit 1 on any violation")
    s.set_defaults(func=cmd_solve)

    t = sub.add_parser("track", help="track a detection file and write MOTChallenge results")
    t.add_argument("--dets", required=True, help="detections: MOTChallenge det.txt or KITTI PointRCNN file")
    t.add_argument("--format", choices=("mot", "kitti"), default="mot")
    t.add_argument("--class", dest="cls", type=_class_name, help="object class for KITTI: Car|Pedestrian|Cyclist")
    t.add_argument("--backend", choices=TRACKERS, default="baseline")
    t.add_argument("--out", required=True, help="results file (MOTChallenge format)")
    t.add_argument("--events", help="write the abduced event log in the paper's syntax")
    t.add_argument("--events-json", help="write the event log as JSON lines")
    t.add_argument("--time-limit", type=float, default=None, metavar="SECONDS",
                   help="per-frame solver limit; the best answer found in time is used and counted")
    t.add_argument("--check", action="store_true",
                   help="verify every frame's answer with the independent checker; exit 1 on any violation")
    t.add_argument("--scene", metavar="SCENE.json", help="write the scene (tracks, events, fluent timelines) "
                   "for query / explain / plot (cpsat or clingo backend)")
    t.set_defaults(func=cmd_track)

    e = sub.add_parser("eval", help="CLEAR MOT and IDF1 of a results file against ground truth")
    e.add_argument("results", help="results file (MOTChallenge format)")
    e.add_argument("--gt", required=True, help="ground truth: MOTChallenge gt.txt or KITTI label_02 file")
    e.add_argument("--format", choices=("mot", "kitti"), default="mot")
    e.add_argument("--class", dest="cls", type=_class_name, help="object class for KITTI: Car|Pedestrian")
    e.set_defaults(func=cmd_eval)

    b = sub.add_parser("benchmark", help="track and evaluate every sequence of a benchmark")
    b.add_argument("names", nargs="+", choices=BENCHMARKS, metavar="NAME",
                   help=f"one or more of {', '.join(BENCHMARKS)}; *-sim use simulated detections (refimpl.simulate)")
    b.add_argument("--data", default="../shared/data", help="benchmark data root (default ../shared/data)")
    b.add_argument("--backend", choices=TRACKERS, default="baseline")
    b.add_argument("--json", help="also write the metrics as JSON")
    b.add_argument("--quiet", action="store_true", help="no progress bar")
    b.set_defaults(func=cmd_benchmark)

    t6 = sub.add_parser("table6", help="the paper's Table 6 on our data: baseline vs abduction on every dataset")
    t6.add_argument("--data", default="../shared/data", help="benchmark data root (default ../shared/data)")
    t6.add_argument("--backend", choices=BACKENDS, default="cpsat")
    t6.add_argument("--datasets", help="comma-separated subset of mot15,kitti-car,kitti-ped,mot17-sim,mot20-01-sim")
    t6.add_argument("--out", help="also write the markdown table to this file")
    t6.add_argument("--quiet", action="store_true", help="no progress bar")
    t6.set_defaults(func=cmd_table6)

    x = sub.add_parser("diff", help="track with one backend and re-solve every frame with the other; "
                                     "exit 1 on any cost disagreement")
    x.add_argument("--dets", help="detections of one sequence")
    x.add_argument("--format", choices=("mot", "kitti"), default="mot")
    x.add_argument("--class", dest="cls", type=_class_name, help="object class for KITTI")
    x.add_argument("--benchmark", choices=BENCHMARKS, help="diff every sequence of a benchmark instead")
    x.add_argument("--data", default="../shared/data", help="benchmark data root (with --benchmark)")
    x.add_argument("--backends", default="cpsat-full,clingo",
                   help=f"FIRST,SECOND[,THIRD] out of {','.join(BACKENDS)}: track with the first, re-solve every "
                        "frame with the others (default cpsat-full,clingo)")
    x.add_argument("--time-limit", type=float, default=20.0, metavar="SECONDS",
                   help="per-frame limit of every backend (default 20); a frame not proven optimal in time "
                        "is reported as such")
    x.add_argument("--quiet", action="store_true", help="no progress bar")
    x.set_defaults(func=cmd_diff)

    d = sub.add_parser("demo", help="track the bundled sample sequence and print its metrics")
    d.add_argument("--backends", default="baseline,cpsat",
                   help=f"comma-separated trackers to run out of {', '.join(TRACKERS)} (default baseline,cpsat)")
    d.set_defaults(func=cmd_demo)

    sc = sub.add_parser("bench-scale", help="time the backends on synthetic frames (or, with --throughput, "
                                             "the tracking loop on MOT15 and KITTI Car); writes docs/benchmarks.md")
    sc.add_argument("--sizes", default="5,10,20,50,100,200", help="tracks per frame (default 5,10,20,50,100,200)")
    sc.add_argument("--overlaps", default="0.2,0.5,0.8", help="overlap shares (default 0.2,0.5,0.8)")
    sc.add_argument("--seeds", type=int, default=10, help="frames per size and overlap (default 10)")
    sc.add_argument("--backends", default="cpsat,cpsat-full,clingo",
                    help="solvers to time (default cpsat,cpsat-full,clingo; cpsat-full = CP-SAT without the fast path)")
    sc.add_argument("--time-limit", type=float, default=20.0, metavar="SECONDS",
                    help="per-frame time limit of every backend (default 20)")
    sc.add_argument("--out", default="docs/benchmarks.md",
                    help="markdown file whose generated section is replaced (default docs/benchmarks.md; - for none)")
    sc.add_argument("--plot", help="PNG plot of a scalability run (default scalability.png beside --out)")
    sc.add_argument("--json", help="also save the raw per-frame (per-sequence) results as JSON")
    sc.add_argument("--from-json", metavar="PATH", help="redraw tables and plot from saved JSON, solving nothing")
    sc.add_argument("--throughput", action="store_true",
                    help="instead: frames/s of the tracking loop per tracker on MOT15 and KITTI Car")
    sc.add_argument("--trackers", default="baseline,cpsat,clingo",
                    help="trackers for --throughput (default baseline,cpsat,clingo; also cpsat-full)")
    sc.add_argument("--data", default="../shared/data", help="benchmark data root for --throughput")
    sc.add_argument("--quiet", action="store_true", help="no progress bar")
    sc.set_defaults(func=cmd_bench_scale)

    q = sub.add_parser("query", help="ask a scene a question (docs/reasoning.md): tracks | track T | hidden_by T | "
                                      "holds_at T FRAME | events FROM TO [T] | relation T REL | "
                                      "anticipate T FRAME | situations")
    q.add_argument("scene", help="scene file written by 'refimpl track --scene'")
    q.add_argument("query", nargs="+", help="the query, e.g. hidden_by trk_12")
    q.add_argument("--json", action="store_true", help="print the answer as JSON")
    q.add_argument("--anticipation-threshold", type=int, default=None, metavar="FRAMES",
                   help="warn when a hidden track reappears in front within this many frames (default 30)")
    q.add_argument("--ego-region", default=None, metavar="X0,X1,Y0,Y1",
                   help="the region in front of the ego vehicle, fractions of the image (default 0.333,0.667,0.5,1)")
    q.set_defaults(func=cmd_query)

    xp = sub.add_parser("explain", help="the event log of a scene as plain English sentences")
    xp.add_argument("scene", help="scene file written by 'refimpl track --scene'")
    xp.add_argument("--track", help="only the episodes of this track (13 or trk_13)")
    xp.set_defaults(func=cmd_explain)

    pl = sub.add_parser("plot", help="a space-time picture of a scene, or its boxes and relations at one frame")
    pl.add_argument("scene", help="scene file written by 'refimpl track --scene'")
    pl.add_argument("--out", required=True, help="PNG file to write")
    pl.add_argument("--frame", type=int, help="draw the boxes and relations of this frame instead")
    pl.add_argument("--tracks", help="comma-separated tracks to draw (default: those observed in 3+ frames)")
    pl.add_argument("--frames", metavar="FROM:TO", help="frame range of the space-time picture")
    pl.set_defaults(func=cmd_plot)
    return p


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"refimpl: warning: {message}", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    warnings.showwarning = _one_line_warning
    try:
        return args.func(args)
    except _user_errors() as exc:
        print(f"refimpl {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except BrokenPipeError:
        sys.stderr.close()  # the reader went away (e.g. `| head`): not an error of ours
        return EXIT_OK
    except OSError as exc:
        where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        print(f"refimpl {args.command}: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return EXIT_USAGE
    except CheckFailed as exc:
        print(f"refimpl {args.command}: check failed: {exc}", file=sys.stderr)
        return EXIT_FAILURE
    except KeyboardInterrupt:
        print("refimpl: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
