"""The `refimpl` command: argument parsing, exit codes and one-line errors; no logic of its own."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
import warnings
from pathlib import Path
from typing import Callable, Sequence

from .progress import Progress

EXIT_OK, EXIT_FAILURE, EXIT_USAGE = 0, 1, 2
TRACKERS = ("baseline", "cpsat", "clingo")
from .table6 import DATASETS as BENCHMARKS  # noqa: E402  (refimpl.io's benchmarks + simulated ones)
CLASSES = {"car": "car", "pedestrian": "pedestrian", "cyclist": "cyclist"}


class UserError(Exception):
    """A mistake in the command line or its inputs: reported in one line, exit code 2."""


def _user_errors() -> tuple[type[BaseException], ...]:
    from .calibrate import CalibrationRefused
    from .io import InputFormatError
    from .peers import PeersUnavailable
    from .solvers import NoAdmissibleHypothesis, SolverUnavailable
    from .spec import ProblemFormatError
    from .scene import SceneError
    from .scaleout import ClusterError
    from .outputs import OutputError
    from .benchmarks import BenchmarkFileError
    return (UserError, OutputError, BenchmarkFileError, ProblemFormatError, InputFormatError, SolverUnavailable,
            NoAdmissibleHypothesis, SceneError, ClusterError, PeersUnavailable, CalibrationRefused)


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
    from .spec import ProblemFormatError, read_problem, with_constants

    from .constants import resolve_constants
    from .ranges import check_constant, check_ranges
    problem = read_problem(args.file)
    if args.const:
        for name, value in args.const:
            check_constant(name, value, f"--const {name}={value}")
        problem = with_constants(problem, dict(args.const))
    try:
        resolve_constants(problem)  # an unknown #const name is the file's (or --const's) mistake
    except ProblemFormatError as exc:
        raise ProblemFormatError(exc.reason, args.file) from None
    check_ranges(problem, args.file)
    hyp = get_solver(args.backend).solve(problem, time_limit=args.time_limit)
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


def _load_sequence(args: argparse.Namespace, path: str | None = None):
    from . import io
    path = args.dets if path is None else path
    if args.format == "mot":
        return io.read_mot_detections(path, scores_rule=getattr(args, "scores", "auto"))
    if args.cls is None:
        raise UserError("--format kitti needs --class Car|Pedestrian|Cyclist")
    return io.read_kitti_detections(path, args.cls)


def _run_tracker(seq, backend: str):
    from .table6 import run_tracker
    return run_tracker(seq, backend)


def _abduction_constants(fmt: str, cls: str | None, consts, no_preset: bool) -> dict[str, int]:
    """The preset of (format, class) unless --no-preset, then --const overrides (refimpl.presets)."""
    from .presets import constants_for
    overrides = dict(consts or [])
    try:
        return constants_for(fmt, cls or "pedestrian", overrides, use_preset=not no_preset)
    except ValueError as exc:
        raise UserError(f"--const: {exc}") from None


def _plan(args: argparse.Namespace):
    """Where the tasks of a many-sequence command run (refimpl.scaleout)."""
    from .scaleout import Plan
    if args.workers is not None and args.workers < 1:
        raise UserError(f"--workers must be >= 1, got {args.workers}")
    if args.workers is not None and args.scheduler is not None:
        raise UserError("give --workers N (a local cluster) or --scheduler ADDRESS (an existing one), not both")
    return Plan(workers=args.workers or 1, scheduler=args.scheduler)


def _track_outputs(args: argparse.Namespace) -> list[Path | str]:
    """Where each --dets goes: --out for one, or DIR/<sequence>.txt with --out-dir."""
    from .tasks import results_file_name
    if (args.out is None) == (args.out_dir is None):
        raise UserError("give --out FILE (one --dets) or --out-dir DIR (one results file per --dets)")
    if args.out is not None:
        if len(args.dets) > 1:
            raise UserError(f"{len(args.dets)} --dets need --out-dir DIR (one results file per sequence), not --out")
        return [args.out]
    if args.events or args.events_json or args.scene:
        raise UserError("--events, --events-json and --scene write one sequence's file: use them with --out")
    seen: dict[str, str] = {}
    for path in args.dets:
        name = results_file_name(path)
        if name in seen:
            raise UserError(f"{seen[name]} and {path} would both write {Path(args.out_dir) / name}")
        seen[name] = path
    return [Path(args.out_dir) / name for name in seen]


def _time_limit(text: str) -> float:
    """--time-limit: a positive finite number of seconds."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a positive finite number of seconds, got {text!r}")
    return value


def _track_inputs(args: argparse.Namespace) -> dict[str, str | None]:
    """The files `track` reads: the detections and the sequence files found beside them."""
    inputs: dict[str, str | None] = {}
    for k, path in enumerate(args.dets):
        dets = Path(path)
        label = "--dets" if len(args.dets) == 1 else f"--dets #{k + 1}"
        inputs[label] = path
        if args.format == "mot":
            inputs[f"{label} seqinfo.ini"] = str(dets.parent.parent / "seqinfo.ini")
        else:
            inputs[f"{label} label_02"] = str(dets.parent.parent.parent / "label_02" / dets.name)
    return inputs


def _parse_img_size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.split(","))
        if w <= 0 or h <= 0:
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected W,H (two positive integers, pixels), got {text!r}") from None
    return w, h


def _track_constants(args: argparse.Namespace) -> dict[str, int]:
    """--const overrides, checked against the model's constants before any frame is tracked."""
    from .constants import default_constants
    consts = dict(args.const or [])
    known = default_constants()
    unknown = sorted(set(consts) - set(known))
    if unknown:
        raise UserError(f"unknown constant(s) {', '.join(unknown)} (known: {', '.join(sorted(known))})")
    if args.img_size is not None and {"img_width", "img_height"} & set(consts):
        raise UserError("give the image size once: --img-size W,H or --const img_width=/img_height=")
    from .ranges import check_constant
    for name, value in consts.items():
        check_constant(name, value, f"--const {name}={value}")
    return consts


def cmd_track(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from . import io
    from .outputs import STDOUT, OutputSet, check_outputs
    from .scaleout import run_tasks
    from .tasks import TrackJob, track_job
    if args.out_format == "kitti" and args.format != "kitti":
        raise UserError("--out-format kitti writes KITTI tracking results (0-based frames, a KITTI class): "
                        "it needs --format kitti")
    if args.backend == "baseline" and (args.check or args.time_limit is not None or args.scene or args.const
                                       or args.img_size):
        raise UserError("--check, --time-limit, --scene, --const and --img-size need an abduction backend "
                        "(cpsat or clingo); the baseline abduces no events")
    outs = _track_outputs(args)
    outputs = {("--out" if args.out is not None else f"--out-dir {Path(p).name}"): str(p) for p in outs}
    outputs.update({"--events": args.events, "--events-json": args.events_json, "--scene": args.scene})
    check_outputs(outputs, _track_inputs(args))  # before any work: never an input, never each other
    plan = _plan(args)
    constants = tuple(_abduction_constants(args.format, args.cls, _track_constants(args), args.no_preset).items()) \
        if args.backend != "baseline" else ()
    seqs = [_load_sequence(args, path) for path in args.dets]  # every input read before any tracking
    if args.img_size is not None:
        seqs = [replace(seq, image_size=args.img_size) for seq in seqs]
    for seq, path in zip(seqs, args.dets):
        if args.format == "mot" and seq.image_size is None and "img_width" not in dict(constants):
            warnings.warn(f"{path}: no seqinfo.ini beside it (../seqinfo.ini) and no --img-size: the image size "
                          "is unknown, so the right and bottom field-of-view borders are not tested "
                          "(enters_fov, leaves_fov, clipped)")
    summary = sys.stderr if STDOUT in outputs.values() else sys.stdout
    if len(seqs) == 1 and not plan.distributed:
        _track_streaming(seqs[0], args, outs[0], dict(constants), summary)
        return EXIT_OK
    jobs = [TrackJob(seq, args.backend, args.time_limit, args.check, False, constants) for seq in seqs]
    results = run_tasks(track_job, jobs, plan, label="track", quiet=args.quiet, describe=lambda job: job.seq.name)
    failed = 0
    with OutputSet() as files:  # every results file lands together, after the last sequence
        for seq, out, path in zip(seqs, results, outs):  # input order: the same bytes however tasks ran
            if out.not_optimal_frames:
                print(f"refimpl track: {_prefix(seqs, seq)}{out.not_optimal_frames} of {out.frames} frames not "
                      f"proven optimal within the time limit (best answer found used)", file=sys.stderr)
            for line in out.violations:
                print(f"refimpl track: {_prefix(seqs, seq)}{line}", file=sys.stderr)
            if args.check:
                print(f"check: {_prefix(seqs, seq)}{out.checked} answers checked, {len(out.violations)} with "
                      "violations")
                if out.violations:
                    failed += len(out.violations)
                    continue  # a backend that broke the model writes no results
            files.write(path, io.results_formatter(args.out_format, seq.first_frame, args.cls)(out.rows))
            print(f"{seq.name}: {len(seq.frames)} frames, "
                  f"{len(set(out.rows[:, 1].tolist())) if len(out.rows) else 0} tracks -> {path}", file=summary)
    if failed:
        raise CheckFailed(f"{failed} answers break a rule of the model")
    return EXIT_OK


def _track_streaming(seq, args: argparse.Namespace, out_path, constants: dict[str, int], summary) -> None:
    """One sequence in this process: results and event logs streamed to staged files as frames are
    decided (bounded memory, docs/robustness.md), committed together at the end."""
    from .io import ResultWriter, results_formatter
    from .outputs import OutputSet
    with OutputSet() as outs:
        sink = ResultWriter(outs.open(out_path), outs.open(args.events) if args.events else None,
                            outs.open(args.events_json) if args.events_json else None, seq.first_frame,
                            results_formatter(args.out_format, seq.first_frame, args.cls))
        if args.backend == "baseline":
            from .baseline import stream_sequence
            for rows in stream_sequence(seq):
                sink.rows(rows)
        else:
            bar = Progress(len(seq.frames), seq.name, enabled=not args.quiet, unit="frame")
            with bar:
                _track_abduction(seq, args, sink, outs, constants, bar.step, summary)
    print(f"{seq.name}: {len(seq.frames)} frames, {len(sink.track_ids)} tracks -> {out_path}", file=summary)


def _track_abduction(seq, args: argparse.Namespace, sink, outs, constants: dict[str, int], on_frame, summary) -> None:
    """Algorithm 1 with the chosen backend, streaming to ``sink``, optionally checking every frame's answer."""
    from .tracker import track_sequence
    checked = violations = 0

    def observe(problem, hyp) -> None:
        nonlocal checked, violations
        on_frame()
        if not args.check:
            return
        from .check import check_answer
        report = check_answer(problem, hyp)
        checked += 1
        if report.violations or report.cost != hyp.cost:
            violations += 1
            found = "; ".join(str(v) for v in report.violations) or "the cost vector differs"
            print(f"refimpl track: frame {problem.time}: {found}", file=sys.stderr)

    result = track_sequence(seq, backend=args.backend, constants=constants, time_limit=args.time_limit,
                            observer=observe, sink=sink, keep_records=bool(args.scene))
    if result.not_optimal_frames:
        print(f"refimpl track: {result.not_optimal_frames} of {result.frames} frames not proven optimal "
              f"within the time limit (best answer found used)", file=sys.stderr)
    if args.check:
        print(f"check: {checked} answers checked, {violations} with violations", file=summary)
        if violations:
            raise CheckFailed(f"{violations} answers break a rule of the model")
    if args.scene:
        from .scene import scene_from_result, scene_to_json
        outs.write(args.scene, json.dumps(scene_to_json(scene_from_result(seq, result)), separators=(",", ":")) + "\n")


def _prefix(seqs, seq) -> str:
    return f"{seq.name}: " if len(seqs) > 1 else ""


class CheckFailed(Exception):
    """The independent checker found answers that break the model (a backend bug): exit 1."""


def cmd_eval(args: argparse.Namespace) -> int:
    from . import io
    from .evaluate import evaluate_many, format_table, refuse_misfit
    from .folder_eval import evaluate_folder, metrics_json, read_ground_truth
    from .outputs import check_outputs
    check_outputs({"--json": args.json}, {"results": args.results, "--gt": args.gt})
    if args.format == "kitti" and args.cls is None:
        raise UserError("--format kitti needs --class Car|Pedestrian")
    if Path(args.results).is_dir():
        run = evaluate_folder(args.results, args.gt, args.format, args.cls)
        per_seq, overall = run.per_sequence, run.overall
        if run.unscored:
            print(f"refimpl eval: note: {len(run.unscored)} ground-truth sequence(s) without a results file "
                  f"not scored: {', '.join(run.unscored)}", file=sys.stderr)
    else:
        if Path(args.gt).is_dir():
            raise UserError(f"{args.gt}: with one results file, --gt is that sequence's ground-truth file")
        gt = read_ground_truth(args.gt, args.format, args.cls)
        results = io.read_results(args.results, args.format, args.cls)
        refuse_misfit(gt, results, args.results)
        per_seq, overall = evaluate_many([(gt.name, gt, results)])
    print(format_table(per_seq, overall))
    if args.json:
        io.write_text_atomic(args.json, json.dumps(metrics_json(per_seq, overall), indent=2) + "\n")
    return EXIT_OK


def cmd_benchmark(args: argparse.Namespace) -> int:
    from .evaluate import format_table
    from .table6 import TITLES, dataset_kind, load_dataset
    from .tasks import RunRequest, run_requests
    from .outputs import check_outputs
    check_outputs({"--json": args.json, "--out": args.out})
    if args.peers is not None:
        return _benchmark_peers(args)
    if args.out:
        raise UserError("--out writes the peer comparison: give --peers too")
    if args.backend == "baseline" and args.const:
        raise UserError("--const needs an abduction backend (cpsat or clingo)")
    plan = _plan(args)
    requests = []
    for name in args.names:
        constants = () if args.backend == "baseline" else \
            tuple(_abduction_constants(*dataset_kind(name, args.data), args.const, args.no_preset).items())
        requests.append(RunRequest(name, load_dataset(name, args.data), args.backend, constants))
    runs = run_requests(requests, plan, label=f"benchmark/{args.backend}", quiet=args.quiet)
    report = {}
    for name, run in zip(args.names, runs):
        print(f"## {TITLES[name]} — {args.backend}\n")
        print(format_table(run.per_sequence, run.overall))
        print()
        report[name] = {"per_sequence": run.per_sequence, "overall": run.overall, "events": run.events}
    if args.json:
        from .io import write_text_atomic
        write_text_atomic(args.json, json.dumps({"backend": args.backend, "benchmarks": report}, indent=2,
                                                default=float))
    return EXIT_OK


def _benchmark_peers(args: argparse.Namespace) -> int:
    """benchmark --peers: baseline, abduction and the peers side by side on every dataset."""
    from .benchmarks import format_command, machine_note, write_section
    from .peers import PEERS, PEERS_BEGIN, PEERS_END, compare, comparison_report, comparison_table
    from .table6 import dataset_kind, load_dataset
    peers = [p.strip() for p in args.peers.split(",") if p.strip()]
    unknown = [p for p in peers if p not in PEERS]
    if unknown:
        raise UserError(f"--peers takes a comma-separated list out of {','.join(PEERS)}, got {args.peers!r}")
    backend = "cpsat" if args.backend == "baseline" else args.backend
    comparisons, report = [], {}
    for name in args.names:
        dataset = load_dataset(name, args.data)
        constants = _abduction_constants(*dataset_kind(name, args.data), args.const, args.no_preset)
        progress = Progress(len(dataset) * (2 + bool(constants) + len(peers)), f"{name}/peers",
                            enabled=not args.quiet)
        c = compare(name, args.data, peers, backend, constants, dataset=dataset, step=progress.step)
        comparisons.append(c)
        print(f"## {c.title}\n")
        print(comparison_table(c))
        report[name] = {s.label: {"overall": s.overall, "per_sequence": s.per_sequence, "frames": s.frames,
                                  "seconds": s.seconds, "parameters": s.parameters} for s in c.scores}
        report[name]["constants"] = c.constants
    if args.out:
        write_section(args.out, PEERS_BEGIN, PEERS_END,
                      comparison_report(comparisons, format_command(sys.argv[1:]), machine_note()))
        print(f"written: {args.out}")
    if args.json:
        from .io import write_text_atomic
        write_text_atomic(args.json, json.dumps({"backend": backend, "peers": peers, "benchmarks": report},
                                                indent=2, default=float))
    return EXIT_OK


def cmd_calibrate(args: argparse.Namespace) -> int:
    """Calibrate every named benchmark in turn (each is independent: its own preset and section)."""
    from .benchmarks import format_command, write_section
    from .calibrate import (CALIBRATE_BEGIN, CALIBRATE_END, calibrate, calibration_report, check_tunable,
                            chosen_preset, parse_grid)
    try:
        grid = parse_grid(args.grid)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    plan = _plan(args)
    for name in args.benchmark:
        check_tunable(name, args.data)  # refuse before hours of tracking, not after
    command = format_command(sys.argv[1:])
    for name in args.benchmark:
        cal = calibrate(name, args.data, grid, args.backend, plan, args.quiet,
                        loso=True if args.loso else None)
        text = calibration_report(cal, command, args.top)
        print(text)
        if args.out:
            write_section(args.out, CALIBRATE_BEGIN.format(name=name), CALIBRATE_END.format(name=name), text)
            print(f"written: {args.out}")
        if args.write_presets:
            from .presets import write_preset
            print(f"preset {cal.format}/{cal.object_class} written: {write_preset(chosen_preset(cal))}")
    return EXIT_OK


def cmd_table6(args: argparse.Namespace) -> int:
    from .table6 import DATASETS, TABLE6_DATASETS, BenchmarkRun, format_table6, load_dataset
    from .tasks import RunRequest, run_requests
    datasets = tuple(d.strip() for d in args.datasets.split(",")) if args.datasets else TABLE6_DATASETS
    from .outputs import check_outputs
    check_outputs({"--out": args.out})
    unknown = [d for d in datasets if d not in DATASETS]
    if unknown or not all(datasets):
        raise UserError(f"--datasets takes a comma-separated list out of {','.join(DATASETS)}, "
                        f"got {','.join(unknown)!r}")
    plan = _plan(args)
    requests = []
    for name in datasets:
        dataset = load_dataset(name, args.data)
        requests += [RunRequest(name, dataset, "baseline"), RunRequest(name, dataset, args.backend)]
    summaries = run_requests(requests, plan, label="table6", quiet=args.quiet)
    runs = [BenchmarkRun(r.dataset, r.tracker, s.per_sequence, s.overall, s.events, s.frames, s.seconds)
            for r, s in zip(requests, summaries)]
    text = format_table6([tuple(runs[i:i + 2]) for i in range(0, len(runs), 2)])
    print(text)
    if args.out:
        from .io import write_text_atomic
        write_text_atomic(args.out, text + "\n")
    return EXIT_OK


def cmd_diff(args: argparse.Namespace) -> int:
    from . import io
    from .diff import DiffReport
    from .scaleout import run_tasks
    from .tasks import DiffJob, diff_job
    backends = tuple(b.strip() for b in args.backends.split(","))
    if len(backends) != 2 or any(b not in ("cpsat", "clingo") for b in backends) or backends[0] == backends[1]:
        raise UserError(f"--backends takes two different backends out of cpsat,clingo, got {args.backends!r}")
    plan = _plan(args)
    if args.benchmark:
        seqs = [io.load_detections(s) for s in io.benchmark_sequences(args.benchmark, args.data)]
    elif args.dets:
        seqs = [_load_sequence(args, path) for path in args.dets]
    else:
        raise UserError("give --dets PATH (one or more sequences) or --benchmark NAME (every sequence of a benchmark)")
    total = DiffReport(backends)  # type: ignore[arg-type]
    reports = run_tasks(diff_job, [DiffJob(seq, backends) for seq in seqs], plan,  # type: ignore[arg-type]
                        label=f"diff {backends[0]},{backends[1]}", quiet=args.quiet, describe=lambda j: j.seq.name)
    for seq, report in zip(seqs, reports):
        total.add(report)
        print(f"{seq.name}: {report.summary()}")
        if report.first_divergence:
            print(report.first_divergence.describe())
    if len(seqs) > 1:
        print(f"TOTAL: {total.summary()}")
    return EXIT_OK if total.ok else EXIT_FAILURE


def cmd_sweep(args: argparse.Namespace) -> int:
    from .io import InputFormatError
    from .outputs import check_outputs
    from .sweep import format_sweep, plan_sweep, run_sweep, sweep_json
    check_outputs({"--json": args.json})
    plan = _plan(args)
    try:
        sweep = plan_sweep(args.benchmark, args.data, args.backend, args.grid, split=args.split)
    except InputFormatError:
        raise
    except ValueError as exc:
        raise UserError(str(exc)) from None
    result = run_sweep(sweep, plan, quiet=args.quiet)
    print(format_sweep(result), end="")
    if args.json:
        from .io import write_text_atomic
        write_text_atomic(args.json, json.dumps(sweep_json(result), indent=2, default=float) + "\n")
    return EXIT_OK


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
    if not all(backends) or any(b not in TRACKERS for b in backends):
        raise UserError(f"--backends takes a comma-separated list out of {','.join(TRACKERS)}, got {args.backends!r}")
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
    from .outputs import check_outputs
    out = None if args.out == "-" else args.out
    default_plot = str(Path(out).with_name("scalability.png")) if out and not args.throughput else None
    check_outputs({"--out": out, "--plot": args.plot or default_plot, "--json": args.json},
                  {"--from-json": args.from_json})
    progress = lambda total, label: Progress(total, label, enabled=not args.quiet)  # noqa: E731
    print(bm.run_bench_scale(
        sizes=sizes, overlaps=overlaps, seeds=args.seeds, backends=backends, time_limit=args.time_limit,
        out=None if args.out == "-" else args.out, plot=args.plot, json_path=args.json,
        from_json=args.from_json, throughput=args.throughput, trackers=trackers, data=args.data,
        command=bm.format_command(sys.argv[1:]), progress=progress))
    return EXIT_OK


def cmd_detectors(args: argparse.Namespace) -> int:
    from . import benchmarks as bm
    from . import detector_sweep as sw
    from . import detectors as dt
    from .solvers import BACKENDS
    if args.backend not in BACKENDS:
        raise UserError(f"--backend takes one of {', '.join(BACKENDS)}, got {args.backend!r}")
    try:
        p_max, fp, noise = (bm.parse_list(v, float) for v in (args.p_max, args.fp_per_frame, args.noise))
    except ValueError as exc:
        raise UserError(f"--p-max, --fp-per-frame and --noise take comma-separated numbers ({exc})") from None
    benches = bm.parse_list(args.benchmarks, str)
    datasets = bm.parse_list(args.sweep_datasets, str)
    sequences = bm.parse_list(args.sequences, str) if args.sequences else None
    for name, given, known in (("--benchmarks", benches, tuple(dt.REAL_DETECTORS)),
                               ("--sweep-datasets", datasets, sw.SWEEP_DATASETS)):
        unknown = [b for b in given if b not in known]
        if unknown or not given:
            raise UserError(f"{name} takes a comma-separated list out of {','.join(known)}, got {','.join(given)!r}")
    if sequences and len(datasets if args.sweep else benches) != 1:
        raise UserError("--sequences needs exactly one benchmark (or one --sweep-datasets entry)")
    if args.max_frames is not None and args.max_frames < 1:
        raise UserError("--max-frames must be >= 1")
    if args.sweep and not (p_max and fp and noise):
        raise UserError("--p-max, --fp-per-frame and --noise must not be empty")
    progress = None if args.quiet else (lambda total, label: Progress(total, label))
    try:
        print(dt.run_detectors(
            data=args.data, backend=args.backend, do_sweep=args.sweep, benchmarks=benches, sequences=sequences,
            max_frames=args.max_frames, sweep_datasets=datasets, p_max=p_max, fp_per_frame=fp, noise=noise,
            seed=args.seed, out=None if args.out == "-" else args.out, plot=args.plot, json_path=args.json,
            command=bm.format_command(sys.argv[1:]), with_ungated=args.ungated, progress=progress))
    except ValueError as exc:  # an unknown sequence name, a parameter out of range
        raise UserError(str(exc)) from None
    return EXIT_OK


def cmd_occlusion_suite(args: argparse.Namespace) -> int:
    from .occlusion import SCENARIOS, write_suite
    out = Path(args.out)
    taken = [s.name for s in SCENARIOS if (out / s.name).exists() and any((out / s.name).iterdir())]
    if taken and not args.force:
        raise UserError(f"{out / taken[0]} exists and is not empty (pass --force to overwrite the suite there)")
    for path in write_suite(out, args.seed):
        print(path)
    return EXIT_OK


def cmd_bench_occlusion(args: argparse.Namespace) -> int:
    from .benchmarks import write_section
    from .occlusion_bench import format_results, parse_variant, run_suite
    from .occlusion import SCENARIOS
    variants = [v.strip() for v in args.trackers.split(",") if v.strip()]
    for v in variants:
        try:
            parse_variant(v)
        except ValueError as exc:
            raise UserError(f"--trackers: {exc}") from None
    progress = Progress(len(SCENARIOS), "occlusion suite", enabled=not args.quiet)
    text = format_results(run_suite(variants, args.seed, progress.step))
    command = f"refimpl bench-occlusion --trackers {','.join(variants)} --seed {args.seed}"
    body = f"Command: `{command}`\n\n{text}"
    print(text)
    if args.out != "-":
        write_section(args.out, "<!-- bench-occlusion:begin -->", "<!-- bench-occlusion:end -->", body)
    return EXIT_OK


# ---------------------------------------------------------------------------------------
# Parser
# ---------------------------------------------------------------------------------------

def _class_name(text: str) -> str:
    key = text.lower()
    if key not in CLASSES:
        raise argparse.ArgumentTypeError(f"unknown class {text!r} (choose Car, Pedestrian or Cyclist)")
    return CLASSES[key]


def _add_scaleout(p: argparse.ArgumentParser) -> None:
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="run the sequences as tasks on a local Dask cluster of N processes (docs/scale-out.md)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run the tasks on an existing Dask cluster, e.g. tcp://10.0.0.5:8786")


def _parse_grid(text: str) -> tuple[str, tuple[int, ...]]:
    name, sep, values = text.partition("=")
    try:
        if not sep or not name.strip():
            raise ValueError
        parsed = tuple(int(v) for v in values.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected NAME=INTEGER,INTEGER,..., got {text!r}") from None
    if len(set(parsed)) != len(parsed):
        raise argparse.ArgumentTypeError(f"a value is given twice in {text!r}")
    return name.strip(), parsed


def build_parser() -> argparse.ArgumentParser:
    from .io import RESULT_FORMATS
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
    s.add_argument("--time-limit", type=_time_limit, default=None, metavar="SECONDS")
    s.add_argument("--const", type=_parse_const, action="append", metavar="NAME=VALUE",
                   help="override a model constant (repeatable)")
    s.add_argument("--check", action="store_true",
                   help="verify the answer with the independent checker; exit 1 on any violation")
    s.set_defaults(func=cmd_solve)

    t = sub.add_parser("track", help="track a detection file and write MOTChallenge results")
    t.add_argument("--dets", required=True, nargs="+", metavar="PATH",
                   help="detections: MOTChallenge det.txt or KITTI PointRCNN file (several with --out-dir)")
    t.add_argument("--format", choices=("mot", "kitti"), default="mot")
    t.add_argument("--class", dest="cls", type=_class_name, help="object class for KITTI: Car|Pedestrian|Cyclist")
    t.add_argument("--backend", choices=TRACKERS, default="baseline")
    t.add_argument("--out", help="results file of one --dets (MOTChallenge format unless --out-format kitti; "
                                 "- for standard output)")
    t.add_argument("--scores", choices=("auto", "probability", "raw"), default="auto",
                   help="MOTChallenge detection scores: probabilities in 0..1 or raw detector scores "
                        "(default auto: decided by the file, see refimpl/io.py)")
    t.add_argument("--out-dir", metavar="DIR", help="one results file per --dets, named after its MOTChallenge "
                   "sequence folder (.../TUD-Campus/det/det.txt -> TUD-Campus.txt) or its file stem (0011.txt)")
    t.add_argument("--out-format", choices=RESULT_FORMATS, default="mot",
                   help="results as MOTChallenge lines (default; KITTI frames stay 0-based) or in the KITTI "
                        "tracking format TrackEval's KITTI loader reads (needs --format kitti)")
    t.add_argument("--const", type=_parse_const, action="append", metavar="NAME=VALUE",
                   help="override a model constant (repeatable; as solve --const; abduction backends; on top "
                        "of the preset of --format/--class)")
    t.add_argument("--img-size", type=_parse_img_size, metavar="W,H",
                   help="image width and height in pixels (the field-of-view border; default: seqinfo.ini, "
                        "1242,375 for KITTI, unknown otherwise)")
    t.add_argument("--events", help="write the abduced event log in the paper's syntax")
    t.add_argument("--events-json", help="write the event log as JSON lines")
    t.add_argument("--time-limit", type=_time_limit, default=None, metavar="SECONDS",
                   help="per-frame solver limit; the best answer found in time is used and counted")
    t.add_argument("--check", action="store_true",
                   help="verify every frame's answer with the independent checker; exit 1 on any violation")
    t.add_argument("--scene", metavar="SCENE.json", help="write the scene (tracks, events, fluent timelines) "
                   "for query / explain / plot (cpsat or clingo backend)")
    t.add_argument("--no-preset", action="store_true",
                   help="run with model/constants.lp's defaults instead of the calibrated preset (model/presets.json)")
    _add_scaleout(t)
    t.add_argument("--quiet", action="store_true", help="no progress bar")
    t.set_defaults(func=cmd_track)

    e = sub.add_parser("eval", help="HOTA, CLEAR MOT and IDF1 of a results file, or of a folder of them "
                                     "(one <SEQ>.txt per sequence), against ground truth")
    e.add_argument("results", help="results file, or folder of <SEQ>.txt results files (MOTChallenge lines; "
                                   "for --format kitti also the KITTI tracking format)")
    e.add_argument("--gt", required=True, help="ground truth: MOTChallenge gt.txt or KITTI label_02 file; for a "
                   "results folder the root: ROOT/<SEQ>/gt/gt.txt (mot), ROOT/label_02/<SEQ>.txt or ROOT/<SEQ>.txt (kitti)")
    e.add_argument("--format", choices=("mot", "kitti"), default="mot")
    e.add_argument("--class", dest="cls", type=_class_name, help="object class for KITTI: Car|Pedestrian")
    e.add_argument("--json", help="also write {\"sequences\": {...}, \"overall\": {...}} (HOTA, DetA, AssA, MOTA, "
                                  "MOTP, IDF1 as fractions; IDs, Frag, FP, FN, MT, ML) to this file")
    e.set_defaults(func=cmd_eval)

    b = sub.add_parser("benchmark", help="track and evaluate every sequence of a benchmark")
    b.add_argument("names", nargs="+", choices=BENCHMARKS, metavar="NAME",
                   help=f"one or more of {', '.join(BENCHMARKS)}; *-sim use simulated detections (refimpl.simulate)")
    b.add_argument("--data", default="../shared/data", help="benchmark data root (default ../shared/data)")
    b.add_argument("--backend", choices=TRACKERS, default="baseline")
    b.add_argument("--json", help="also write the metrics as JSON")
    b.add_argument("--quiet", action="store_true", help="no progress bar")
    b.add_argument("--peers", metavar="LIST",
                   help="compare with peer trackers (sort,bytetrack,ocsort; the 'trackers' package, extra 'peers'): "
                        "baseline, abduction (--backend, cpsat if baseline) and every peer in one table per dataset")
    b.add_argument("--out", help="with --peers: write the tables into this markdown file (between marker comments)")
    b.add_argument("--const", type=_parse_const, action="append", metavar="NAME=VALUE",
                   help="override a model constant of the abduction tracker (repeatable; on top of the preset)")
    b.add_argument("--no-preset", action="store_true",
                   help="abduction with model/constants.lp's defaults instead of the calibrated preset")
    _add_scaleout(b)
    b.set_defaults(func=cmd_benchmark)

    cb = sub.add_parser("calibrate", help="grid-search the model's thresholds on a benchmark (its training split) "
                                          "and print the ranked table; the best point is the preset")
    cb.add_argument("--benchmark", required=True, nargs="+", choices=BENCHMARKS, metavar="NAME",
                    help="one or more benchmarks to tune on, each giving the preset of its format/class: "
                         "kitti-car-train, kitti-ped-train, mot15 (leave-one-sequence-out)")
    cb.add_argument("--grid", action="append", metavar="NAME=V1,V2,...",
                    help="replace (or add) one dimension of the search space (repeatable)")
    cb.add_argument("--backend", choices=[t for t in TRACKERS if t != "baseline"], default="cpsat")
    cb.add_argument("--loso", action="store_true", help="also leave-one-sequence-out (default for MOT benchmarks)")
    cb.add_argument("--top", type=int, default=None, help="print only the best N points")
    cb.add_argument("--write-presets", action="store_true", help="store the best point as the preset (model/presets.json)")
    cb.add_argument("--out", help="write the report into this markdown file (between marker comments)")
    cb.add_argument("--data", default="../shared/data", help="benchmark data root (default ../shared/data)")
    cb.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_scaleout(cb)
    cb.set_defaults(func=cmd_calibrate)

    t6 = sub.add_parser("table6", help="the paper's Table 6 on our data: baseline vs abduction on every dataset")
    t6.add_argument("--data", default="../shared/data", help="benchmark data root (default ../shared/data)")
    t6.add_argument("--backend", choices=("cpsat", "clingo"), default="cpsat")
    t6.add_argument("--datasets", help="comma-separated subset of mot15,kitti-car,kitti-ped,mot17-sim,mot20-01-sim")
    t6.add_argument("--out", help="also write the markdown table to this file")
    t6.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_scaleout(t6)
    t6.set_defaults(func=cmd_table6)

    x = sub.add_parser("diff", help="track with one backend and re-solve every frame with the other; "
                                     "exit 1 on any cost disagreement")
    x.add_argument("--dets", nargs="+", metavar="PATH", help="detections of one or more sequences")
    x.add_argument("--format", choices=("mot", "kitti"), default="mot")
    x.add_argument("--class", dest="cls", type=_class_name, help="object class for KITTI")
    x.add_argument("--benchmark", choices=BENCHMARKS, help="diff every sequence of a benchmark instead")
    x.add_argument("--data", default="../shared/data", help="benchmark data root (with --benchmark)")
    x.add_argument("--backends", default="cpsat,clingo", help="FIRST,SECOND (default cpsat,clingo)")
    x.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_scaleout(x)
    x.set_defaults(func=cmd_diff)

    sw = sub.add_parser("sweep", help="track and score a benchmark for every combination of model constants "
                                      "(one task per setting and sequence); one table")
    sw.add_argument("--benchmark", required=True, choices=BENCHMARKS, metavar="NAME",
                    help=f"one of {', '.join(BENCHMARKS)}")
    sw.add_argument("--grid", required=True, action="append", type=_parse_grid, metavar="NAME=V1,V2,...",
                    help="a model constant and its integer values (repeatable; the settings are all combinations)")
    sw.add_argument("--split", choices=("all", "tune", "val"), default="all",
                    help="KITTI: tune = the 10 training sequences outside evaluate_tracking.seqmap.val, "
                         "val = the 11 in it (default all)")
    sw.add_argument("--backend", choices=("cpsat", "clingo"), default="cpsat")
    sw.add_argument("--data", default="../shared/data", help="benchmark data root (default ../shared/data)")
    sw.add_argument("--json", help="also write every setting's overall scores as JSON")
    sw.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_scaleout(sw)
    sw.set_defaults(func=cmd_sweep)

    d = sub.add_parser("demo", help="track the bundled sample sequence and print its metrics")
    d.add_argument("--backends", default="baseline,cpsat",
                   help="comma-separated trackers to run: baseline, cpsat, clingo (default baseline,cpsat)")
    d.set_defaults(func=cmd_demo)

    sc = sub.add_parser("bench-scale", help="time the backends on synthetic frames (or, with --throughput, "
                                             "the tracking loop on MOT15 and KITTI Car); writes docs/benchmarks.md")
    sc.add_argument("--sizes", default="5,10,20,50,100,200", help="tracks per frame (default 5,10,20,50,100,200)")
    sc.add_argument("--overlaps", default="0.2,0.5,0.8", help="overlap shares (default 0.2,0.5,0.8)")
    sc.add_argument("--seeds", type=int, default=10, help="frames per size and overlap (default 10)")
    sc.add_argument("--backends", default="cpsat,cpsat-full,clingo",
                    help="solvers to time (default cpsat,cpsat-full,clingo; cpsat-full = CP-SAT without the fast path)")
    sc.add_argument("--time-limit", type=_time_limit, default=20.0, metavar="SECONDS",
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

    dt = sub.add_parser("detectors", help="which detector, and how much abduction helps it: real detectors side "
                                          "by side, or (--sweep) a simulated detector-quality grid")
    dt.add_argument("--data", default="../shared/data", help="benchmark data root (default ../shared/data)")
    dt.add_argument("--backend", default="cpsat", help="abduction backend (default cpsat)")
    dt.add_argument("--benchmarks", default="mot15,kitti-car", help="real-detector benchmarks (default mot15,kitti-car)")
    dt.add_argument("--sequences", help="comma-separated subset of sequences (one benchmark or sweep dataset)")
    dt.add_argument("--max-frames", type=int, help="only the first N frames of every sequence")
    dt.add_argument("--ungated", action="store_true",
                    help="also track every detector's boxes by abduction with every confidence set to 100")
    dt.add_argument("--sweep", action="store_true", help="instead: the simulated detector-quality sweep")
    dt.add_argument("--sweep-datasets", default="mot17,kitti-car", help="sweep ground truth (default mot17,kitti-car)")
    dt.add_argument("--p-max", default="0.5,0.7,0.9", help="sweep: detection probabilities (default 0.5,0.7,0.9)")
    dt.add_argument("--fp-per-frame", default="0.5,2,5", help="sweep: false positives per frame (default 0.5,2,5)")
    dt.add_argument("--noise", default="0.03,0.1", help="sweep: localisation noise (default 0.03,0.1)")
    dt.add_argument("--seed", type=int, default=0, help="sweep: simulated detector seed (default 0)")
    dt.add_argument("--out", default="-", help="markdown file whose generated section is replaced "
                    "(e.g. docs/detectors.md; default - for none)")
    dt.add_argument("--plot", help="sweep: PNG plot (default detectors-sweep.png beside --out)")
    dt.add_argument("--json", help="also write the raw numbers as JSON")
    dt.add_argument("--quiet", action="store_true", help="no progress bar")
    dt.set_defaults(func=cmd_detectors)

    oc = sub.add_parser("occlusion-suite", help="write the long-occlusion suite (docs/occlusion.md) as "
                                                "MOTChallenge sequences: DIR/<scenario>/{det,gt,seqinfo.ini}")
    oc.add_argument("--out", required=True, metavar="DIR", help="folder to write the scenarios into")
    oc.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    oc.add_argument("--force", action="store_true", help="overwrite scenario folders that exist")
    oc.set_defaults(func=cmd_occlusion_suite)

    bo = sub.add_parser("bench-occlusion", help="baseline vs abduction on the long-occlusion suite: identity kept, "
                                                "hide/unhide events on time (writes docs/occlusion.md)")
    bo.add_argument("--trackers", default="baseline,cpsat",
                    help="comma-separated variants: baseline, a backend, backend+hold, backend+oru, "
                         "backend+hold+oru (default baseline,cpsat)")
    bo.add_argument("--seed", type=int, default=0, help="suite seed (default 0)")
    bo.add_argument("--out", default="docs/occlusion.md",
                    help="markdown file whose generated section is replaced (default docs/occlusion.md; - for none)")
    bo.add_argument("--quiet", action="store_true", help="no progress bar")
    bo.set_defaults(func=cmd_bench_occlusion)

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
    """The command line; Ctrl-C (SIGINT) anywhere ends it with exit code 130 and one line, after the
    outputs' temporary files are removed (refimpl.outputs), so no partial output is left."""
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        _recheck_choices(parser, args)
        with warnings.catch_warnings():  # one-line warnings for this command only, restored after it
            warnings.showwarning = _one_line_warning
            return _run(args)
    except KeyboardInterrupt:
        print("refimpl: interrupted", file=sys.stderr)
        return 130


def _recheck_choices(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """argparse drops a value '--' (``--backend=--`` gives [], and neither the option's type nor its
    choices are applied to it): check every option again, so a command never sees such a value."""
    subparsers = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    sub = subparsers.choices[args.command]
    for action in sub._actions:
        if not hasattr(args, action.dest):
            continue
        value = getattr(args, action.dest)
        name = "/".join(action.option_strings) or action.dest
        if isinstance(action, argparse._AppendAction):
            if any(isinstance(v, list) for v in value or ()):
                sub.error(f"argument {name}: expected a value, got '--'")
            continue
        if action.nargs is None and isinstance(value, list):
            sub.error(f"argument {name}: expected one value, got '--'")
        if action.choices is None or value is action.default:
            continue
        values = value if isinstance(value, list) else [value]
        if not values or any(v not in action.choices for v in values):
            sub.error(f"argument {name}: invalid choice: {value!r} (choose from {', '.join(map(str, action.choices))})")


def run() -> None:
    """The process entry point (``refimpl`` and ``python -m refimpl``): main, then exit.  After an
    interrupt the process ends at once (os._exit, outputs already cleaned up, streams flushed)
    rather than spending half a second tearing down numpy, scipy and the solvers' modules."""
    code = main()
    if code == 130:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        os._exit(code)
    sys.exit(code)


def _run(args: argparse.Namespace) -> int:
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


if __name__ == "__main__":
    run()
