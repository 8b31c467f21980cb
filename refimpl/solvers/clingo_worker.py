"""clingo in a child process, recycled every so many solves: bounded memory, hard time limits.

Why: clingo interns every symbol it ever sees (function terms with their numbers: box2d/5,
iou/3, holds_at/3 at each new time point ...) in a process-wide table that is never freed, so a
process that solves frame after frame grows without bound (~0.2-0.3 MB per MOT15 frame) even
with a fresh Control per solve.  A child process that is replaced after ``recycle`` solves gives
the memory back.  It also makes the time limit hard: grounding cannot be stopped inside a
process, but a child that overruns its limit by GRACE seconds is killed (the parent then uses the
obvious answer, as for any search without a model).

The child is a fresh interpreter (``python -m refimpl.solvers.clingo_worker FD``, in a session of
its own) that talks over a multiprocessing Connection: unlike multiprocessing's spawn it never
re-imports the caller's ``__main__``, so scripts without an ``if __name__ == "__main__"`` guard work,
and a terminal's Ctrl-C does not reach it.  The parent polls the pipe every POLL seconds, so a
Ctrl-C raises KeyboardInterrupt in the parent within that time, and the child is killed.

This module is the child's side (its loop, ``_serve``); the parent's side, which starts, recycles
and kills the child, is refimpl.solvers.clingo_process (imported by the backend, so the backend
never imports this module and this module may import the backend).
"""

from __future__ import annotations

import multiprocessing.connection
import resource
import signal
import sys
import time

from .clingo_backend import ClingoSolver


def _serve(conn) -> None:
    """The child's loop: its options first, then (problem, time limit, time.monotonic() of the
    send) in, ("grounded",) once the problem is grounded, then ("ok", result, cpu seconds) or
    ("error", type, message) out; None or a closed pipe ends it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides about interrupts
    options = conn.recv()
    cap = options.pop("memory_cap", None)
    if cap:  # a user's encoding: its grounding may not take the machine (ClingoSolver)
        resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
    solver = ClingoSolver(**options, isolate=False)
    while True:
        try:
            job = conn.recv()
        except EOFError:
            return
        if job is None:
            return
        problem, time_limit, sent = job
        if time_limit is not None:  # the limit counts from the parent's send: a child that was
            # just started (imports, ~1 s) or a large problem's transfer must not push the search
            # past the parent's kill (time.monotonic is the system's clock, the parent's too)
            time_limit = max(0.0, time_limit - (time.monotonic() - sent))
        cpu = time.process_time()
        try:
            result = solver._solve_one(problem, time_limit, grounded=lambda: conn.send(("grounded",)))
            conn.send(("ok", result, time.process_time() - cpu))
        except MemoryError:
            conn.send(("error", "MemoryError", f"frame {problem.time}: the encoding went beyond its memory cap of "
                                               f"{cap / 2 ** 30:g} GiB (does a rule ground a product of every "
                                               "detection or every time point?)"))
        except Exception as exc:  # sent back and raised again in the parent
            conn.send(("error", type(exc).__name__, str(exc)))


if __name__ == "__main__":
    _serve(multiprocessing.connection.Connection(int(sys.argv[1])))
