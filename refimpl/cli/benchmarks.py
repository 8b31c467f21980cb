"""The measuring commands: `benchmark`, `calibrate`, `table6`, `sweep`, `bench-scale`, `bench-latency`,
`bench-peers`, `detectors`, `occlusion-suite` and `bench-occlusion`."""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

from .. import io
from ..evaluation.evaluate import format_table
from ..experiments import benchmarks as bm, crowds as cr, detector_sweep as sw, detectors as dt, latency as lt
from ..experiments.benchmarks import format_command, machine_note, write_section
from ..experiments.calibrate import (CALIBRATE_BEGIN, CALIBRATE_END, calibrate, calibration_report, check_tunable,
                                     chosen_preset, default_preset, parse_grid, refuse_held_out, robust_default,
                                     robust_report, write_preset)
from ..experiments.occlusion import SCENARIOS, write_suite
from ..experiments.occlusion_bench import format_results, parse_variant, run_suite
from ..experiments.shift_table import SHIFTS_BEGIN, SHIFTS_END, shift_table
from ..experiments.peers import (PEERS_BEGIN, PEERS_END, compare, comparison_report, comparison_table,
                                 parse_peers, peer_class, per_sequence_table)
from ..experiments.peers_report import TUNED_BEGIN, TUNED_END, installed_peers, not_run_note, tuned_on_report
from ..runs.progress import Progress
from ..experiments.sweep import format_sweep, plan_sweep, run_sweep, sweep_json
from ..experiments.table6 import BenchmarkRun, format_table6
from ..experiments.benchmark_tasks import RunRequest, run_requests
from ..io import InputFormatError, write_text_atomic
from ..io.datasets import (DATASETS, PEER_TABLE_DATASETS, SHIFT_TABLE_DATASETS, TABLE6_DATASETS, TITLES,
                            dataset_kind, load_dataset)
from ..io.outputs import OutputSet, check_outputs
from ..io.shifts import parse_shifts, shifted_dataset
from ..solvers import BACKENDS, BASELINE, DEFAULT_BACKEND, TRACKERS
from ..tracking.options import option_flags
from ..tracking.presets import load_presets, startable_share
from .common import EXIT_OK, UserError, _option_flags_given, _plan, _setup, frozen_heap


def cmd_benchmark(args: argparse.Namespace) -> int:
    check_outputs({"--json": args.json, "--out": args.out})
    if args.shift is not None:
        return _benchmark_shifts(args)
    if args.results_dir and args.peers is not None:
        raise UserError("--results-dir writes the results files of refimpl's tracker: give it without --peers")
    if args.peers is not None:
        return _benchmark_peers(args)
    if args.out:
        raise UserError("--out writes the peer comparison: give --peers too")
    if args.per_sequence:
        raise UserError("--per-sequence is for the peer comparison (without --peers every sequence is "
                        "printed already): give --peers too")
    if args.repeat != 1:
        raise UserError("--repeat times the peer comparison's trackers: give --peers too")
    if args.backend == BASELINE and (args.const or _option_flags_given(args)):
        raise UserError(f"{option_flags('--const')} need an abduction backend ({', '.join(BACKENDS)})")
    plan = _plan(args)
    requests = []
    for name in args.names:
        setup = _setup(args, *dataset_kind(name, args.data))
        if not args.quiet:
            print(f"refimpl benchmark: {name}: {setup.describe()}", file=sys.stderr)
        requests.append(RunRequest(name, load_dataset(name, args.data), setup.backend, setup.constants,
                                   setup.options, setup.preset, setup.tuned_fps, setup.in_frames,
                                   keep_rows=bool(args.results_dir)))
    with frozen_heap():  # as `refimpl track` runs: the loaded sets out of the full collections
        runs = run_requests(requests, plan, label=f"benchmark/{args.backend}", quiet=args.quiet)
    if args.results_dir:
        _write_results(args, runs)
    report = {}
    for name, run in zip(args.names, runs):
        print(f"## {TITLES[name]} — {args.backend}\n")
        print(format_table(run.per_sequence, run.overall))
        print()
        report[name] = {"per_sequence": run.per_sequence, "overall": run.overall, "events": run.events}
    if args.json:
        write_text_atomic(args.json, json.dumps({"backend": args.backend, "benchmarks": report}, indent=2,
                                                default=float))
    return EXIT_OK


def _write_results(args: argparse.Namespace, runs) -> None:
    """benchmark --results-dir DIR: every scored sequence's rows as DIR/<dataset>/<sequence>.txt, in
    the MOTChallenge lines ``refimpl track`` writes (KITTI frames kept 0-based), all files together."""
    with OutputSet() as files:
        for name, run in zip(args.names, runs):
            fmt, cls = dataset_kind(name, args.data)
            first = io.get_format(fmt).first_frame
            (Path(args.results_dir) / name).mkdir(parents=True, exist_ok=True)
            for seq, rows in run.rows.items():
                files.write(Path(args.results_dir) / name / f"{seq}.txt", io.results_formatter(io.MOT, first, cls)(rows))
    print(f"results: {args.results_dir}/<dataset>/<sequence>.txt", file=sys.stderr)


def runnable_peers(text: str, command: str) -> tuple[list[str], dict[str, str]]:
    """``--peers``: (the peers to run, {peer not run: its package}; not_run_note words it).  Peers named one by one must
    run: a missing package is one line, exit 2, before any data is read.  ``all`` is every
    registered peer whose package is installed; the others are named on stderr and in the note
    (BoxMOT needs torch, which not every machine has); none installed is the first one's line."""
    try:
        asked = parse_peers(text)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    if text.strip() != "all":
        for p in asked:
            peer_class(p)
        return list(asked), {}
    run, missing = installed_peers(asked)
    if not run:
        peer_class(asked[0])
    if missing:
        print(f"refimpl {command}: {not_run_note(missing)}", file=sys.stderr)
    return list(run), missing


def _benchmark_shifts(args: argparse.Namespace) -> int:
    """benchmark --shift: baseline, abduction (and --peers) on every shift of every dataset
    (refimpl.io.shifts): HOTA / IDF1 per shift, the worst case and the largest drop."""
    try:
        shifts = parse_shifts(args.shift)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    if args.results_dir or args.per_sequence or args.repeat != 1:
        raise UserError("--shift prints one table of shifts per dataset: give it without --results-dir, "
                        "--per-sequence and --repeat")
    peers, _ = runnable_peers(args.peers, "benchmark") if args.peers is not None else ([], {})
    backend = DEFAULT_BACKEND if args.backend == BASELINE else args.backend
    tables, report = _shift_tables(args, args.names, shifts, peers, backend)
    if args.out:
        write_section(args.out, SHIFTS_BEGIN, SHIFTS_END, _shifts_section(tables))
        print(f"written: {args.out}")
    if args.json:
        write_text_atomic(args.json, json.dumps({"backend": backend, "peers": peers, "shifts": report}, indent=2,
                                                default=float))
    return EXIT_OK


def _shift_tables(args: argparse.Namespace, names, shifts, peers, backend: str) -> tuple[list[str], dict]:
    """Every dataset under every shift, each table printed: (the tables, {dataset: {shift: {tracker:
    (HOTA, IDF1)}}})."""
    tables, report = [], {}
    for name in names:
        dataset = load_dataset(name, args.data)
        setup = _setup(argparse.Namespace(**{**vars(args), "backend": backend}), *dataset_kind(name, args.data))
        progress = Progress(len(shifts) * len(dataset) * (2 + len(peers)), f"{name}/shifts", enabled=not args.quiet)
        results: dict[str, dict[str, tuple[float, float]]] = {}
        for shift in shifts:
            shifted = shifted_dataset(dataset, shift)
            with frozen_heap():
                c = compare(name, args.data, peers, backend, dict(setup.constants), dataset=shifted,
                            step=progress.step, options=setup.options, without_preset=False, setup=setup)
            results[shift] = {s.label: (s.overall["hota"], s.overall["idf1"]) for s in c.scores}
        table = f"## {TITLES[name]}: shifts (HOTA / IDF1)\n\n{shift_table(results)}\n"
        print(table)
        tables.append(table)
        report[name] = results
    return tables, report


def _shifts_section(tables: list[str], note: str = "") -> str:
    """The shift section of a markdown file: the command and the machine, any note, the tables."""
    return (f"Made by `{format_command(sys.argv[1:])}`; {machine_note()}\n\n" + (f"Peers {note}.\n\n" if note else "")
            + "\n".join(tables))


def _benchmark_peers(args: argparse.Namespace) -> int:
    """benchmark --peers: baseline, abduction and the peers side by side on every dataset."""
    peers, missing = runnable_peers(args.peers, "benchmark")  # before any data is read
    if args.repeat < 1:
        raise UserError(f"--repeat must be >= 1, got {args.repeat}")
    backend = DEFAULT_BACKEND if args.backend == BASELINE else args.backend
    comparisons, report = _peer_tables(args, args.names, peers, backend)
    if args.out:
        write_section(args.out, PEERS_BEGIN, PEERS_END,
                      comparison_report(comparisons, format_command(sys.argv[1:]), machine_note(),
                                        args.per_sequence, not_run_note(missing)))
        print(f"written: {args.out}")
    if args.json:
        write_text_atomic(args.json, json.dumps({"backend": backend, "peers": peers, "benchmarks": report},
                                                indent=2, default=float))
    return EXIT_OK


def _peer_tables(args: argparse.Namespace, names, peers, backend: str) -> tuple[list, dict]:
    """Baseline, abduction and the peers on every dataset, each table printed: (the Comparisons,
    the JSON report {dataset: {tracker: scores}})."""
    comparisons, report = [], {}
    for name in names:
        dataset = load_dataset(name, args.data)
        setup = _setup(argparse.Namespace(**{**vars(args), "backend": backend}), *dataset_kind(name, args.data))
        constants, options = dict(setup.constants), setup.options
        progress = Progress(len(dataset) * (2 + bool(constants or options.changed()) + len(peers)),
                            f"{name}/peers", enabled=not args.quiet)
        with frozen_heap():  # what was loaded and scored before kept out of the full collections, for every tracker
            c = compare(name, args.data, peers, backend, constants, dataset=dataset, step=progress.step,
                        options=options, repeat=args.repeat, setup=setup)
        comparisons.append(c)
        print(f"## {c.title}\n")
        print(comparison_table(c))
        if args.per_sequence:
            print(f"Per sequence (HOTA / IDF1 / IDs):\n\n{per_sequence_table(c)}")
        report[name] = {s.label: {"overall": s.overall, "per_sequence": s.per_sequence, "frames": s.frames,
                                  "seconds": s.seconds, "parameters": s.parameters} for s in c.scores}
        report[name]["constants"] = c.constants
        report[name]["tracker_options"] = dict(c.options)
    return comparisons, report


def cmd_bench_peers(args: argparse.Namespace) -> int:
    """bench-peers: every generated section of docs/peers.md in one run (a command of its own rather
    than a mode of ``benchmark``: it takes no dataset names, it runs the ones the dataset registry
    puts in the report, like bench-scale and bench-latency regenerate docs/benchmarks.md)."""
    out = None if args.out == "-" else args.out
    check_outputs({"--out": out, "--json": args.json})
    peers, missing = runnable_peers("all" if args.peers is None else args.peers, "bench-peers")
    note = not_run_note(missing)
    for name in dict.fromkeys((*PEER_TABLE_DATASETS, *SHIFT_TABLE_DATASETS)):
        dataset_kind(name, args.data)  # every set's files are there before the first of a long run is tracked
    command = format_command(sys.argv[1:])
    tuned = tuned_on_report(load_presets(), command)
    print(tuned)
    run = argparse.Namespace(**{**vars(args), "backend": DEFAULT_BACKEND, "const": None, "repeat": 1,
                                "per_sequence": True})  # the defaults a user gets
    comparisons, peer_report = _peer_tables(run, PEER_TABLE_DATASETS, list(peers), DEFAULT_BACKEND)
    tables, shift_report = _shift_tables(run, SHIFT_TABLE_DATASETS, parse_shifts("all"), list(peers), DEFAULT_BACKEND)
    if out:  # every section is made before the first is written; the prose around them stays
        write_section(out, TUNED_BEGIN, TUNED_END, tuned)
        write_section(out, PEERS_BEGIN, PEERS_END, comparison_report(comparisons, command, machine_note(), True, note))
        write_section(out, SHIFTS_BEGIN, SHIFTS_END, _shifts_section(tables, note))
        print(f"written: {out}")
    if args.json:
        write_text_atomic(args.json, json.dumps({"backend": DEFAULT_BACKEND, "peers": list(peers), "not_run": missing,
                                                 "benchmarks": peer_report, "shifts": shift_report},
                                                indent=2, default=float))
    return EXIT_OK


def cmd_calibrate(args: argparse.Namespace) -> int:
    """Calibrate every named benchmark in turn (each is independent: its own preset and section)."""
    if args.default:
        return _calibrate_default(args)
    try:
        grid = parse_grid(args.grid)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    plan = _plan(args)
    for name in args.benchmark:
        refuse_held_out(name)  # whatever the data root holds
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
            preset = chosen_preset(cal)
            share = startable_share([d for _, d, _ in load_dataset(name, args.data)], preset.constants)
            print(f"preset {cal.format}/{cal.object_class} written: "
                  f"{write_preset(replace(preset, startable=share))}")
    return EXIT_OK


def _calibrate_default(args: argparse.Namespace) -> int:
    """calibrate --default: the robust default preset over every named tuning benchmark at once."""
    if args.grid:
        raise UserError("--default chooses among the stored presets: give no --grid")
    for name in args.benchmark:
        check_tunable(name, args.data)
    choice = robust_default(args.benchmark, args.data, args.backend, _plan(args), args.quiet)
    text = robust_report(choice, format_command(sys.argv[1:]))
    print(text)
    if args.out:
        write_section(args.out, "<!-- calibrate:default:begin -->", "<!-- calibrate:default:end -->", text)
        print(f"written: {args.out}")
    if args.write_presets:
        print(f"preset default written: {write_preset(default_preset(choice))}")
    return EXIT_OK


def cmd_table6(args: argparse.Namespace) -> int:
    datasets = tuple(d.strip() for d in args.datasets.split(",")) if args.datasets else TABLE6_DATASETS
    check_outputs({"--out": args.out})
    unknown = [d for d in datasets if d not in DATASETS]
    if unknown or not all(datasets):
        raise UserError(f"--datasets takes a comma-separated list out of {','.join(DATASETS)}, "
                        f"got {','.join(unknown)!r}")
    plan = _plan(args)
    requests = []
    for name in datasets:
        dataset = load_dataset(name, args.data)
        requests += [RunRequest(name, dataset, BASELINE), RunRequest(name, dataset, args.backend)]
    summaries = run_requests(requests, plan, label="table6", quiet=args.quiet)
    runs = [BenchmarkRun(r.dataset, r.tracker, s.per_sequence, s.overall, s.events, s.frames, s.seconds)
            for r, s in zip(requests, summaries)]
    text = format_table6([tuple(runs[i:i + 2]) for i in range(0, len(runs), 2)])
    print(text)
    if args.out:
        write_text_atomic(args.out, text + "\n")
    return EXIT_OK


def cmd_sweep(args: argparse.Namespace) -> int:
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
        write_text_atomic(args.json, json.dumps(sweep_json(result), indent=2, default=float) + "\n")
    return EXIT_OK


def cmd_bench_scale(args: argparse.Namespace) -> int:
    try:
        sizes = bm.parse_list(args.sizes, int) if args.sizes is not None else list(
            bm.DENSE_SIZES if args.dense else bm.DEFAULT_SIZES)
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
    if args.dense and min(sizes) < 1:
        raise UserError(f"--dense needs --sizes of at least 1 track, got {min(sizes)}")
    out = None if args.out == "-" else args.out
    default_plot = (str(Path(out).with_name("scalability.png"))
                    if out and not args.throughput and not args.dense else None)
    check_outputs({"--out": out, "--plot": args.plot or default_plot, "--json": args.json},
                  {"--from-json": args.from_json})
    progress = lambda total, label: Progress(total, label, enabled=not args.quiet)  # noqa: E731
    print(bm.run_bench_scale(
        sizes=sizes, overlaps=overlaps, seeds=args.seeds, backends=backends, time_limit=args.time_limit,
        out=None if args.out == "-" else args.out, plot=args.plot, json_path=args.json,
        from_json=args.from_json, throughput=args.throughput, trackers=trackers, data=args.data,
        command=bm.format_command(sys.argv[1:]), progress=progress, dense=args.dense))
    return EXIT_OK


def cmd_bench_latency(args: argparse.Namespace) -> int:
    out = None if args.out == "-" else args.out
    check_outputs({"--out": out}, {})
    command = bm.format_command(sys.argv[1:])
    if args.crowds:
        return _bench_crowds(args, out, command)
    datasets = bm.parse_list(args.datasets, str)
    unknown = [d for d in datasets if d not in DATASETS]
    if unknown or not datasets:
        raise UserError(f"--datasets takes a comma-separated list out of {', '.join(DATASETS)}, got {args.datasets!r}")
    if args.backend not in BACKENDS:
        raise UserError(f"--backend takes one of {', '.join(BACKENDS)}, got {args.backend!r}")
    progress = Progress(None, "latency", enabled=not args.quiet)
    runs = lt.measure_latency(datasets, args.data, args.backend, step=progress.step)
    progress.close()
    report = lt.latency_report(runs, command, machine_note(), args.backend)
    print(report)
    if out:
        write_section(out, lt.LATENCY_BEGIN, lt.LATENCY_END, report)
        print(f"written: {out}")
    return EXIT_OK


def _bench_crowds(args: argparse.Namespace, out: str | None, command: str) -> int:
    try:
        sizes = bm.parse_list(args.sizes, int)
    except ValueError:
        raise UserError(f"--sizes takes comma-separated integers, got {args.sizes!r}") from None
    trackers = bm.parse_list(args.trackers, str)
    peers = [] if args.peers.strip().lower() == "none" else bm.parse_list(args.peers, str)
    unknown = [t for t in trackers if t not in TRACKERS]
    if unknown or not trackers:
        raise UserError(f"--trackers takes a comma-separated list out of {', '.join(TRACKERS)}, got {args.trackers!r}")
    if not sizes or min(sizes) < 1 or args.frames < 1:
        raise UserError("--sizes must be objects per frame >= 1, --frames >= 1")
    peers, _ = runnable_peers(",".join(peers), "bench-latency") if peers else ([], {})
    progress = Progress(len(sizes) * (len(trackers) + len(peers)), "crowds", enabled=not args.quiet)
    result = cr.bench_crowds(sizes, args.frames, trackers, peers, args.time_limit, args.seed, step=progress.step)
    progress.close()
    report = cr.crowd_report(result, command, machine_note())
    print(report)
    if out:
        write_section(out, cr.CROWDS_BEGIN, cr.CROWDS_END, report)
        print(f"written: {out}")
    return EXIT_OK


def cmd_detectors(args: argparse.Namespace) -> int:
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
        print(sw.run_detectors(
            data=args.data, backend=args.backend, do_sweep=args.sweep, benchmarks=benches, sequences=sequences,
            max_frames=args.max_frames, sweep_datasets=datasets, p_max=p_max, fp_per_frame=fp, noise=noise,
            seed=args.seed, out=None if args.out == "-" else args.out, plot=args.plot, json_path=args.json,
            command=bm.format_command(sys.argv[1:]), with_ungated=args.ungated, progress=progress))
    except ValueError as exc:  # an unknown sequence name, a parameter out of range
        raise UserError(str(exc)) from None
    return EXIT_OK


def cmd_occlusion_suite(args: argparse.Namespace) -> int:
    out = Path(args.out)
    taken = [s.name for s in SCENARIOS if (out / s.name).exists() and any((out / s.name).iterdir())]
    if taken and not args.force:
        raise UserError(f"{out / taken[0]} exists and is not empty (pass --force to overwrite the suite there)")
    for path in write_suite(out, args.seed):
        print(path)
    return EXIT_OK


def cmd_bench_occlusion(args: argparse.Namespace) -> int:
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
