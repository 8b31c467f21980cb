"""What every command group of the `refimpl` command shares: exit codes, the name lists, the
one-line user error, and the argument types and helpers used by more than one command."""

from __future__ import annotations

import argparse
import gc
import math
from contextlib import contextmanager

from .. import io
from ..core.constants import default_constants
from ..core.errors import UserFacingError
from ..core.ranges import FPS_RANGE_TEXT, check_constant, fps_fits
from ..runs.scaleout import Plan
from ..io.datasets import DATASETS as BENCHMARKS  # noqa: F401  (the one dataset catalogue)
from ..solvers import BACKENDS, BASELINE, DEFAULT_BACKEND, ORACLE_PAIR, REFERENCE_BACKEND, TRACKERS  # noqa: F401  (the registry)
from ..tracking.options import TrackerOptions
from ..tracking.pipeline import AUTO, NONE, setup_for

EXIT_OK, EXIT_FAILURE, EXIT_USAGE = 0, 1, 2
CLASSES = {"car": "car", "pedestrian": "pedestrian", "cyclist": "cyclist"}


class UserError(UserFacingError):
    """A mistake in the command line or its inputs: reported in one line, exit code 2."""


def checked_constants(args: argparse.Namespace) -> dict[str, int]:
    """--const overrides (``track``, ``diff``), checked against the model's constants before any
    frame is tracked: one line for an unknown name or a value out of its range."""
    consts = dict(args.const or [])
    known = default_constants()
    unknown = sorted(set(consts) - set(known))
    if unknown:
        raise UserError(f"unknown constant(s) {', '.join(unknown)} (known: {', '.join(sorted(known))})")
    if getattr(args, "img_size", None) is not None and {"img_width", "img_height"} & set(consts):
        raise UserError("give the image size once: --img-size W,H or --const img_width=/img_height=")
    for name, value in consts.items():
        check_constant(name, value, f"--const {name}={value}")
    return consts


@contextmanager
def frozen_heap():
    """What exists before a command tracks (the interpreter's and refimpl's modules and tables, the
    detections read) kept out of the garbage collector's full collections while it tracks, handed
    back afterwards (gc.freeze / gc.unfreeze).  A full collection walks every object the
    collector tracks, ~0.5-1 us each here: with the ~25,000 of a `refimpl track` process one took
    15-20 ms in the middle of whichever frame triggered it, the slowest frame of a run
    (docs/benchmarks.md, "The slowest frames").  Objects made while tracking are collected as
    before; nothing changes what is computed."""
    gc.collect()
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def _parse_const(text: str) -> tuple[str, int]:
    name, sep, value = text.partition("=")
    try:
        if not sep or not name.strip():
            raise ValueError
        return name.strip(), int(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected NAME=INTEGER, got {text!r}") from None


def _positive_finite(text: str, unit: str) -> float:
    """A positive finite number of ``unit``; the argparse error names the unit otherwise."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of {unit}, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a positive finite number of {unit}, got {text!r}")
    return value


def _frame_budget(text: str | None) -> float | str | None:
    """--frame-budget: milliseconds >= 0, ``auto`` (the default budget of a real-time backend,
    refimpl.tracking.pipeline.DEFAULT_FRAME_BUDGET_MS) or ``none``; a command without the option
    (None): no budget.  A UserError (one line) otherwise."""
    if text is None:
        return None
    word = text.strip().lower()
    if word in (AUTO, NONE):
        return AUTO if word == AUTO else None
    try:
        value = float(word)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0):
        raise UserError(f"--frame-budget takes milliseconds >= 0, 'auto' or 'none', got {text!r}")
    return value


def _time_limit(text: str) -> float:
    """--time-limit: a positive finite number of seconds."""
    return _positive_finite(text, "seconds")


def _parse_fps(text: str) -> float:
    """A frame rate: a number of frames per second within FPS_MIN..FPS_MAX (refimpl.core.ranges)."""
    value = _positive_finite(text, "frames per second")
    if not fps_fits(value):
        raise argparse.ArgumentTypeError(f"must be {FPS_RANGE_TEXT}, got {text!r}")
    return value


def _parse_img_size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.split(","))
        if w <= 0 or h <= 0:
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected W,H (two positive integers, pixels), got {text!r}") from None
    return w, h


def _load_sequence(args: argparse.Namespace, path: str | None = None):
    path = args.dets if path is None else path
    fmt = io.get_format(args.format)
    if fmt.needs_class and args.cls is None:
        raise UserError(f"--format {fmt.name} needs --class Car|Pedestrian|Cyclist")
    try:
        return fmt.read_detections(path, object_class=args.cls if fmt.needs_class else None,
                                   scores_rule=getattr(args, "scores", "auto"))
    except io.InputFormatError:
        raise
    except ValueError as exc:  # an argument the reader refuses (a --scores rule the format has not)
        raise UserError(str(exc)) from None


def _setup(args: argparse.Namespace, fmt: str, cls: str | None, constants=None):
    """What to track with, by the one rule (refimpl.tracking.pipeline.setup_for): the preset of (format,
    class) unless --no-preset or another --preset, then --const and the tracker option flags."""
    asked = getattr(args, "preset", None)
    if getattr(args, "no_preset", False) and asked not in (None, AUTO, NONE):
        raise UserError(f"give --no-preset or --preset {asked}, not both")
    preset = NONE if getattr(args, "no_preset", False) else (asked or AUTO)
    try:
        return setup_for(io.get_format(fmt).preset_format, cls, args.backend, constants if constants is not None else dict(args.const or []),
                         _option_overrides(args), preset, getattr(args, "time_limit", None),
                         _frame_budget(getattr(args, "frame_budget", None)))
    except ValueError as exc:
        raise UserError(str(exc)) from None


def _option_overrides(args: argparse.Namespace) -> dict[str, object]:
    """{name: value} of the tracker option flags given on the command line."""
    return {name: getattr(args, name) for name in TrackerOptions.names() if getattr(args, name, None) is not None}


def _option_flags_given(args: argparse.Namespace) -> bool:
    """Whether any tracker option flag was given (they need an abduction backend)."""
    return bool(_option_overrides(args))


def _plan(args: argparse.Namespace):
    """Where the tasks of a many-sequence command run (refimpl.runs.scaleout)."""
    if args.workers is not None and args.workers < 1:
        raise UserError(f"--workers must be >= 1, got {args.workers}")
    if args.workers is not None and args.scheduler is not None:
        raise UserError("give --workers N (a local cluster) or --scheduler ADDRESS (an existing one), not both")
    if args.workers is None and args.scheduler is None and (args.connect_timeout or args.worker_timeout):
        raise UserError("--connect-timeout and --worker-timeout are for a Dask run: give --workers N or "
                        "--scheduler ADDRESS")
    serial_below = getattr(args, "serial_below", None)
    if serial_below is not None and args.workers is None:
        raise UserError("--serial-below is for a local cluster: give --workers N")
    if serial_below is not None and serial_below < 0:
        raise UserError(f"--serial-below must be >= 0 frames, got {serial_below}")
    return Plan(workers=args.workers or 1, scheduler=args.scheduler, connect_timeout=args.connect_timeout,
                worker_timeout=args.worker_timeout, serial_below=serial_below)


class CheckFailed(Exception):
    """The independent checker found answers that break the model (a backend bug): exit 1."""
