"""The `refimpl` command: argument parsing, exit codes and one-line errors; no logic of its own.

This package holds the entry points (``main``, ``run``) and the error handling; ``parser`` builds
the argument parser and holds ``COMMANDS``, the function of each command (loaded when it runs, so
a command imports only its own group's module); ``common`` holds what the commands share (exit
codes, ``UserError``), and one module per command group holds the commands: ``solving`` (solve, diff),
``tracking`` (track), ``evaluation`` (eval), ``benchmarks`` (benchmark, calibrate, table6, sweep,
bench-scale, detectors, occlusion-suite, bench-occlusion), ``scenes`` (query, explain, plot, report)
and ``demo``.  A command's function is imported from its module (``refimpl.cli.tracking.cmd_track``)."""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
import warnings
from typing import Sequence

from ..core.display import visible
from ..core.errors import UserFacingError
from ..core.loader import load
from ..runs.progress import Progress  # noqa: F401  (re-exported, as refimpl/cli.py had it)
from ..runs.scaleout import ClusterError
from ..solvers import BACKENDS  # noqa: F401
from .common import (  # noqa: F401  (the public names of refimpl.cli)
    BENCHMARKS,
    CLASSES,
    EXIT_FAILURE,
    EXIT_OK,
    EXIT_USAGE,
    TRACKERS,
    CheckFailed,
    UserError,
)
from .parser import COMMANDS, build_parser

USER_ERRORS: tuple[type[BaseException], ...] = (UserFacingError, ClusterError)
"""What a command may raise that ends it with one line and exit code 2: every refimpl error deriving
from refimpl.core.errors.UserFacingError (a mistake in an argument or a file, a problem without an
answer), and a Dask cluster that cannot be reached or used (refimpl.runs.scaleout)."""


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"refimpl: warning: {visible(str(message))}", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """The command line; Ctrl-C (SIGINT) anywhere ends it with exit code 130 and one line, after the
    outputs' temporary files are removed (refimpl.io.outputs), so no partial output is left (SIGTERM
    likewise, exit 143, and SIGHUP, SIGQUIT: 129, 131, when the process was started by run())."""
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        _recheck_choices(parser, args)
        with warnings.catch_warnings():  # one-line warnings for this command only, restored after it
            warnings.showwarning = _one_line_warning
            return _run(args)
    except Terminated as exc:
        print("refimpl: terminated", file=sys.stderr)
        return 128 + exc.signum
    except KeyboardInterrupt:
        print("refimpl: interrupted", file=sys.stderr)
        return 130


TERMINATING = (signal.SIGTERM, signal.SIGHUP, signal.SIGQUIT)
"""The signals whose default would end the process at once, leaving the outputs' temporary files
(``.FILE.XXXX.tmp``) beside them: each is handled as Ctrl-C is (Terminated)."""


class Terminated(KeyboardInterrupt):
    """SIGTERM (or SIGHUP, SIGQUIT), once run() has asked for it: handled as Ctrl-C is (outputs
    removed, one line), exit 128 + the signal's number (143, 129, 131)."""

    def __init__(self, signum: int = signal.SIGTERM) -> None:
        super().__init__(signum)
        self.signum = int(signum)


def _in_finalizer(frame) -> bool:
    """Whether a signal landed inside a ``__del__`` (clingo's ``Control.__del__`` frees the
    solver's memory): an exception raised there is printed as "Exception ignored in" and the
    program goes on, so a Ctrl-C would be lost and the run would carry on to its end."""
    while frame is not None:
        if frame.f_code.co_name == "__del__":
            return True
        frame = frame.f_back
    return False


def _interrupt_handler(exception: type[BaseException]):
    """A SIGINT / SIGTERM handler raising ``exception``, or, inside a finalizer, sending the signal
    again 10 ms later, when the finalizer is done (measured before: 2 of ~40 Ctrl-Cs of a clingo
    ``track`` were swallowed by ``Control.__del__`` and the run went on)."""
    def handler(signum, frame) -> None:
        if _in_finalizer(frame):
            threading.Timer(0.01, os.kill, (os.getpid(), signum)).start()
            return
        raise exception(signum) if issubclass(exception, Terminated) else exception()
    return handler


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
        if action.nargs == "+" and value == []:
            sub.error(f"argument {name}: expected at least one value, got '--'")
        if action.choices is None or value is action.default:
            continue
        values = value if isinstance(value, list) else [value]
        if not values or any(v not in action.choices for v in values):
            sub.error(f"argument {name}: invalid choice: {value!r} (choose from {', '.join(map(str, action.choices))})")


def run() -> None:
    """The process entry point (``refimpl`` and ``python -m refimpl``): main, then exit.  After an
    interrupt the process ends at once (os._exit, outputs already cleaned up, streams flushed)
    rather than spending half a second tearing down numpy, scipy and the solvers' modules."""
    for signum in TERMINATING:  # `kill`, a job scheduler, a closed terminal: no partial output either
        if signal.getsignal(signum) == signal.SIG_DFL:
            signal.signal(signum, _interrupt_handler(Terminated))
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:  # Ctrl-C, never lost in a finalizer
        signal.signal(signal.SIGINT, _interrupt_handler(KeyboardInterrupt))
    code = main()
    if code > 128:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        os._exit(code)
    sys.exit(code)


def _run(args: argparse.Namespace) -> int:
    try:
        return load(COMMANDS[args.command])(args)
    except USER_ERRORS as exc:
        print(f"refimpl {args.command}: error: {visible(str(exc))}", file=sys.stderr)
        return EXIT_USAGE
    except BrokenPipeError:
        sys.stderr.close()  # the reader went away (e.g. `| head`): not an error of ours
        return EXIT_OK
    except OSError as exc:
        where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        print(visible(f"refimpl {args.command}: error: {where}{exc.strerror or exc}"), file=sys.stderr)
        return EXIT_USAGE
    except CheckFailed as exc:
        print(f"refimpl {args.command}: check failed: {visible(str(exc))}", file=sys.stderr)
        return EXIT_FAILURE
