"""The commands on one frame problem and on backends: `solve` and `diff`."""

from __future__ import annotations

import argparse
import sys
import time

from .. import io
from ..core.constants import resolve_constants
from ..core.ranges import check_constant, check_ranges
from ..core.spec import ProblemFormatError, with_constants
from ..core.facts import read_problem
from ..core.hypothesis import cost_list_text, cost_text
from ..runs.diff import DiffJob, DiffReport, diff_job
from ..runs.scaleout import run_tasks
from ..io.datasets import load_dataset
from ..solvers import BACKENDS, CLINGO, get_solver
from ..solvers.asp_model import AspModelError, load_asp_model
from ..solvers.check import check_answer
from ..solvers.check_optimum import FrameOptimum
from .common import EXIT_FAILURE, EXIT_OK, UserError, _load_sequence, _plan, checked_constants


def cmd_solve(args: argparse.Namespace) -> int:
    started = time.perf_counter()  # --time-limit bounds the command: reading a large file counts
    if (args.file is None) == (args.example is None):
        raise UserError(f"give either a fact FILE or --example NAME ({', '.join(sorted(io.shipped_examples()))})")
    if args.example is not None:
        args.file = str(io.shipped_examples()[args.example])
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
    left = None if args.time_limit is None else max(0.0, args.time_limit - (time.perf_counter() - started))
    hyp = get_solver(args.backend).solve(problem, time_limit=left)
    violations = ()
    if args.check:
        report = check_answer(problem, hyp)
        violations = report.messages
        if report.cost != hyp.cost:
            violations += (f"[cost_vector] the answer's cost is {cost_list_text(report.cost)}, "
                           f"not {cost_list_text(hyp.cost)}",)
        optimum = ""
        if not violations and hyp.optimal:  # the checker's own enumeration where components are small
            verdict = FrameOptimum.of(problem).verdict(hyp)
            if verdict.better is not None:
                violations += (f"[optimum] flagged optimal, but {verdict.detail}",)
            optimum = f"; {verdict.detail}"
    if args.json:
        print(hyp.to_json())
    else:
        print(f"time {hyp.time}  backend {hyp.backend}  {'optimal' if hyp.optimal else 'NOT proven optimal'}"
              f"  {hyp.solve_ms:.1f} ms")
        print("actions: " + " ".join(hyp.actions))
        print("events:  " + (" ".join(hyp.events) or "-"))
        print("cost:    " + cost_text(hyp.cost))
    if args.check:
        print("check:   " + ("; ".join(violations) if violations else
                             "every rule holds, cost vector confirmed" + optimum),
              file=sys.stderr if args.json else sys.stdout)
    return EXIT_FAILURE if violations else EXIT_OK


def cmd_diff(args: argparse.Namespace) -> int:
    backends = tuple(b.strip() for b in args.backends.split(","))
    if len(backends) not in (2, 3) or any(b not in BACKENDS for b in backends) or len(set(backends)) != len(backends):
        raise UserError(f"--backends takes two or three different backends out of {','.join(BACKENDS)}, "
                        f"got {args.backends!r}")
    asp_model = None
    if args.asp_model is not None:
        if CLINGO not in backends:
            raise UserError(f"--asp-model runs your encoding on the {CLINGO} backend: add it to --backends "
                            f"(got {args.backends!r})")
        try:
            asp_model = load_asp_model(args.asp_model, args.time_limit)  # grounding bounded too
        except AspModelError as exc:
            raise UserError(str(exc)) from None
        differences = asp_model.differences()  # printed once the inputs are known to be good
    constants = tuple(checked_constants(args).items())  # one line for an unknown name or a value out of range
    plan = _plan(args)
    if args.benchmark:
        seqs = [seq for _, seq, _ in load_dataset(args.benchmark, args.data)]
    elif args.dets:
        seqs = [_load_sequence(args, path) for path in args.dets]
        rule = io.resolve_rule(io.DEFAULT_SCORE_RULE, io.get_format(args.format).score_rule)
        seqs = io.calibrated_together(seqs, rule)  # the files read as one run of track reads them
    else:
        raise UserError("give --dets PATH (one or more sequences) or --benchmark NAME (every sequence of a benchmark)")
    if asp_model is not None:
        print(differences, flush=True)
    reports = run_tasks(diff_job, [DiffJob(seq, backends, args.time_limit, asp_model, constants) for seq in seqs], plan,
                        label=f"diff {','.join(backends)}", quiet=args.quiet, describe=lambda j: j.seq.name,
                        steps=lambda j: len(j.seq.frames), frames_rule=False)  # a bar frame by frame, as track's
    total = DiffReport(reports[0].backends, levels=reports[0].levels) if reports else DiffReport(backends)
    for seq, report in zip(seqs, reports):
        total.add(report)
        print(f"{seq.name}: {report.summary()}")
        if report.first_divergence:
            print(report.first_divergence.describe())
    if len(seqs) > 1:
        print(f"TOTAL: {total.summary()}")
    return EXIT_OK if total.ok else EXIT_FAILURE
