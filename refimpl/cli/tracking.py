"""The `track` command: detections in, results files (and event logs, a scene) out."""

from __future__ import annotations

import argparse
import io as stdio
import json
import sys
import warnings
from dataclasses import replace
from pathlib import Path

from .. import io
from ..core.confidence import EVIDENCE, one_score, same_score_message
from ..core.constants import default_constants
from ..core.display import visible
from ..core.loader import load
from ..runs.progress import Progress
from ..runs.scaleout import run_tasks
from ..runs.tasks import SCENE_FROM_RESULT, SCENE_TO_JSON, AnswerCheck, TrackJob, results_file_name, track_job
from ..io import ResultWriter, results_formatter
from ..io.outputs import OutputSet, STDOUT, check_outputs
from ..solvers import BACKENDS, BASELINE, get_solver
from ..tracking.options import option_flags
from ..tracking.pipeline import AUTO, run_sequence
from ..tracking.presets import preset_named, score_warning
from .common import (CheckFailed, EXIT_OK, UserError, _load_sequence, _option_flags_given, _plan, _setup,
                     checked_constants, frozen_heap)


def _track_outputs(args: argparse.Namespace) -> list[Path | str]:
    """Where each --dets goes: --out for one, or DIR/<sequence>.txt with --out-dir."""
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


def _track_inputs(args: argparse.Namespace) -> dict[str, str | None]:
    """The files `track` reads: the detections and the sequence files found beside them."""
    inputs: dict[str, str | None] = {}
    for k, path in enumerate(args.dets):
        dets = Path(path)
        label = "--dets" if len(args.dets) == 1 else f"--dets #{k + 1}"
        inputs[label] = path
        side, side_path = io.get_format(args.format).side_file(dets)
        inputs[f"{label} {side}"] = str(side_path)
    return inputs


def cmd_track(args: argparse.Namespace) -> int:
    out_fmt, in_fmt = io.get_format(args.out_format), io.get_format(args.format)
    if out_fmt.needs_class and out_fmt is not in_fmt:
        raise UserError(f"--out-format {out_fmt.name} writes {out_fmt.title} results ({out_fmt.first_frame}-based "
                        f"frames, a class): it needs --format {out_fmt.name}")
    if args.backend == BASELINE and (args.check or args.time_limit is not None or args.scene or args.const
                                       or args.img_size or args.fps or _option_flags_given(args)
                                       or args.frame_budget.strip().lower() != AUTO):
        raise UserError(f"{option_flags('--check', '--time-limit', '--frame-budget', '--scene', '--const', '--img-size', '--fps')} "
                        f"need an abduction backend ({', '.join(BACKENDS)}); the baseline abduces no events")
    if STDIN in args.dets:
        return _track_pipe(args)
    if args.seqinfo is not None:
        raise UserError("--seqinfo is for --dets - (standard input): a file finds its seqinfo.ini beside it")
    outs = _track_outputs(args)
    outputs = {("--out" if args.out is not None else f"--out-dir {Path(p).name}"): str(p) for p in outs}
    outputs.update({"--events": args.events, "--events-json": args.events_json, "--scene": args.scene})
    check_outputs(outputs, _track_inputs(args))  # before any work: never an input, never each other
    plan = _plan(args)
    setup = _setup(args, args.format, args.cls, checked_constants(args) if args.backend != BASELINE else None)
    seqs = [_load_sequence(args, path) for path in args.dets]  # every input read before any tracking
    if args.pool_scores == "yes":  # one detector's scores mean the same in every file (docs/model.md 3.19)
        seqs = io.calibrated_together(seqs, io.resolve_rule(args.scores, in_fmt.score_rule))
    if args.img_size is not None:
        seqs = [replace(seq, image_size=args.img_size) for seq in seqs]
    if args.fps is not None:
        seqs = [replace(seq, fps=args.fps) for seq in seqs]
    for seq, path in zip(seqs, args.dets):
        _warn_unknown_image_size(seq, setup, f"{path}: no seqinfo.ini beside it (../seqinfo.ini) and no --img-size")
    _say_setup(setup, seqs, args)
    summary = sys.stderr if STDOUT in outputs.values() else sys.stdout
    if len(seqs) == 1 and not plan.distributed:
        _track_streaming(seqs[0], args, outs[0], setup, summary)
        return EXIT_OK
    jobs = [TrackJob(seq, setup, args.check, out_format=args.out_format, object_class=args.cls) for seq in seqs]
    with frozen_heap():
        results = run_tasks(track_job, jobs, plan, label="track", quiet=args.quiet,
                            describe=lambda job: job.seq.name, steps=lambda job: len(job.seq.frames))
    failed = 0
    with OutputSet() as files:  # every results file lands together, after the last sequence
        for seq, out, path in zip(seqs, results, outs):  # input order: the same bytes however tasks ran
            for message in out.said:  # said where the task ran (a worker, or here), told here
                warnings.warn(f"{_prefix(seqs, seq)}{message}", UserWarning, stacklevel=2)
            for line in _limit_lines(out.frames, out.not_optimal_frames, out.budget_hits, out.over_budget, setup):
                print(f"refimpl track: {_prefix(seqs, seq)}{line}", file=sys.stderr)
            for line in out.violations:
                print(f"refimpl track: {_prefix(seqs, seq)}{line}", file=sys.stderr)
            if args.check:
                print(f"check: {_prefix(seqs, seq)}{out.checked} answers checked, {len(out.violations)} with "
                      "violations")
                if out.violations:
                    failed += len(out.violations)
                    continue  # a backend that broke the model writes no results
            files.write(path, out.text)  # formatted by the task (on a cluster: by its worker)
            tracks = len(set(out.rows[:, 1].tolist())) if len(out.rows) else 0
            print(visible(f"{seq.name}: {len(seq.frames)} frames, {tracks} tracks -> {path}"), file=summary)
            _warn_if_empty(seq, tracks, setup, args)
    if failed:
        raise CheckFailed(f"{failed} answers break a rule of the model")
    return EXIT_OK


def _limit_lines(frames: int, not_optimal: int, budget_hits: int, over_budget: int, setup) -> list[str]:
    """What the time limit and the frame budget did to a run, one line each (none when nothing)."""
    lines = []
    if not_optimal - budget_hits:
        lines.append(f"{not_optimal - budget_hits} of {frames} frames not proven optimal within the time limit "
                     "(best answer found used)")
    if budget_hits:
        lines.append(f"{budget_hits} of {frames} frames hit the frame budget of {setup.frame_budget:g} ms (best "
                     "answer found so far used, not proven optimal)")
    if over_budget > budget_hits:
        lines.append(f"{over_budget - budget_hits} of {frames} frames took longer than the frame budget of "
                     f"{setup.frame_budget:g} ms with a proven answer (the fast path is not interrupted)")
    return lines


def _warn_unknown_image_size(seq, setup, why: str) -> None:
    if seq.image_size is None and "img_width" not in dict(setup.constants):
        warnings.warn(f"{why}: the image size is unknown, so the right and bottom field-of-view borders are "
                      "not tested (enters_fov, leaves_fov, clipped)")


def _say_setup(setup, seqs, args: argparse.Namespace) -> None:
    """One line on stderr: which tracker and preset run (unless --quiet), and a warning when the
    file's scores lie far from what the preset was fitted on (refimpl.tracking.presets.score_warning)."""
    if setup.baseline:
        return  # SORT: no preset, nothing to say
    if not args.quiet:
        print(f"refimpl track: note: {setup.describe()}", file=sys.stderr)
    if setup.preset == "none":
        return
    together = getattr(args, "pool_scores", "no") == "yes" and len(seqs) > 1  # one share for the run
    evidence = io.resolve_rule(args.scores, io.get_format(args.format).score_rule) == EVIDENCE
    for seq in seqs[:1] if together else seqs:
        if not isinstance(seq.frames, tuple):
            continue  # a pipe (refimpl.io.stream): its frames are read once, by the tracker
        same = one_score(f for s in (seqs if together else [seq]) for f in s.frames) if evidence else None
        if same is not None:
            print(f"refimpl track: warning: {same_score_message(seq.name, same, together)}", file=sys.stderr)
            continue
        line = score_warning(preset_named(setup.preset), seq, dict(setup.constants), seqs if together else ())
        if line:
            print(f"refimpl track: warning: {line}", file=sys.stderr)


def _warn_if_empty(seq, tracks: int, setup, args: argparse.Namespace) -> None:
    """A run that wrote no track says so, with the likely cause."""
    if tracks:
        return
    n = seq.num_detections
    if n == 0:
        cls = f" of class {args.cls}" if args.cls else ""
        why = f"the file has no detection{cls} (is --class right?)"
    else:
        low, high = seq.confidence_range
        need = dict(setup.constants).get("conf_thresh_new_track")
        if need is None and not setup.baseline:
            need = default_constants()["conf_thresh_new_track"]
        why = (f"{n} detections, confidences {low}..{high}" +
               (f" (a new track needs > {need}: conf_thresh_new_track; see --scores)" if need is not None else ""))
        if getattr(args, "pool_scores", "no") == "yes" and len(args.dets) > 1 and not setup.baseline:
            why += ("; its scores were calibrated beside the run's other files, read as one detector's "
                    "(--pool-scores no reads each file alone)")
    print(f"refimpl track: warning: {seq.name}: no track written: {why}", file=sys.stderr)


def _track_streaming(seq, args: argparse.Namespace, out_path, setup, summary, live: bool = False) -> None:
    """One sequence in this process: results and event logs streamed to staged files as frames are
    decided (bounded memory, docs/robustness.md), committed together at the end.  ``live`` (a
    detector pipe): ``seq`` is a refimpl.io.DetectionStream, and an output to standard output is
    written and flushed as each frame's rows are final instead of staged."""
    solver = None if setup.baseline else get_solver(setup.backend)  # its libraries loaded before any output is staged
    with OutputSet() as outs:
        def open_out(path):
            return _Flushed(sys.stdout) if live and path == STDOUT else outs.open(path)
        sink = ResultWriter(open_out(out_path), open_out(args.events) if args.events else None,
                            open_out(args.events_json) if args.events_json else None, seq.first_frame,
                            results_formatter(args.out_format, seq.first_frame, args.cls))
        check = AnswerCheck(lambda line: print(f"refimpl track: {line}", file=sys.stderr)) \
            if args.check and not setup.baseline else None
        # a pipe's rows on standard output would mix with a progress bar on the same terminal
        bar_ok = not args.quiet and not (live and STDOUT in (out_path, args.events, args.events_json))
        with Progress(None if live else len(seq.frames), seq.name, enabled=bar_ok, unit="frame") as bar, \
                frozen_heap():
            result = run_sequence(seq, setup, observer=check, sink=sink, keep_records=bool(args.scene),
                                  on_frame=bar.step, solver=solver)
        for line in _limit_lines(result.frames, result.not_optimal_frames, result.budget_hits, result.over_budget,
                                 setup):
            print(f"refimpl track: {line}", file=sys.stderr)
        if check is not None:
            print(f"check: {check.checked} answers checked, {len(check.violations)} with violations", file=summary)
            if check.violations:
                raise CheckFailed(f"{len(check.violations)} answers break a rule of the model")
        if args.scene:
            scene = load(SCENE_FROM_RESULT)(seq, result)
            outs.write(args.scene, json.dumps(load(SCENE_TO_JSON)(scene), separators=(",", ":")) + "\n")
    print(visible(f"{seq.name}: {result.frames} frames, {len(sink.track_ids)} tracks -> {out_path}"), file=summary)
    _warn_if_empty(seq, len(sink.track_ids), setup, args)


STDIN = "-"
"""``--dets -``: the detections come from standard input."""


class _Flushed:
    """A text stream every write of which is flushed at once (a pipe's reader sees each frame's rows)."""

    def __init__(self, stream) -> None:
        self.stream = stream

    def write(self, text: str) -> None:
        self.stream.write(text)
        self.stream.flush()


def _on_first(frames, call):
    """The frames, with ``call()`` made just before the first one is handed on."""
    for k, frame in enumerate(frames):
        if k == 0:
            call()
        yield frame


def _track_pipe(args: argparse.Namespace) -> int:
    """``track --dets -``: detections read from standard input frame by frame as a detector writes
    them, each frame's rows written as soon as they are final (to standard output, flushed, with
    ``--out -``; else streamed into the staged outputs), in the tracker's bounded streaming mode.
    The rows equal those of the file run on the same lines (docs/robustness.md, "A detector pipe")."""
    if len(args.dets) > 1:
        raise UserError("--dets - reads one sequence from standard input: give it alone")
    if args.out is None or args.out_dir is not None:
        raise UserError("--dets - writes one results file: give --out FILE, or --out - for standard output")
    if args.scene:
        raise UserError("--scene keeps every box of every track to the end, so its memory grows with a pipe: "
                        "write the detections to a file and track that")
    if args.workers is not None or args.scheduler is not None:
        raise UserError("--workers and --scheduler spread many sequences over processes; --dets - is one sequence")
    fmt = io.get_format(args.format)
    if fmt.needs_class and args.cls is None:
        raise UserError(f"--format {fmt.name} needs --class Car|Pedestrian|Cyclist")
    outputs = {"--out": args.out, "--events": args.events, "--events-json": args.events_json}
    check_outputs(outputs, {"--seqinfo": args.seqinfo})
    setup = _setup(args, args.format, args.cls, checked_constants(args) if args.backend != BASELINE else None)
    if sys.stdin is None:
        raise UserError("--dets -: standard input is closed")
    text = stdio.TextIOWrapper(sys.stdin.buffer, encoding="utf-8-sig", newline=None)  # lines as they arrive
    try:
        try:
            stream = fmt.stream_detections(text, object_class=args.cls if fmt.needs_class else None,
                                           seqinfo=args.seqinfo, scores_rule=args.scores, image_size=args.img_size)
        except ValueError as exc:
            raise UserError(str(exc)) from None
        if args.fps is not None:
            stream.fps = args.fps
        def starting() -> None:  # once the first frame has arrived (an empty input is one error line)
            _warn_unknown_image_size(stream, setup, f"{stream.path}: no --seqinfo and no --img-size")
            _say_setup(setup, [stream], args)
        stream.frames = _on_first(stream.frames, starting)
        _track_streaming(stream, args, args.out, setup, sys.stderr if STDOUT in outputs.values() else sys.stdout,
                         live=True)
    finally:
        text.detach()  # standard input stays open (and sys.stdin usable)
    return EXIT_OK


def _prefix(seqs, seq) -> str:
    return f"{seq.name}: " if len(seqs) > 1 else ""
