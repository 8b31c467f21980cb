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
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.connection
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from ..core.spec import FrameProblem

POLL = 0.1
"""Seconds between two checks of the pipe (time limit, SIGINT)."""
GRACE = 1.0
"""Seconds a child may overrun its time limit (finishing its search, reporting) before it is killed."""
DEFAULT_RECYCLE = 1000
"""Solves per child process before it is replaced."""


def _serve(conn) -> None:
    """The child's loop: its options first, then (problem, time limit) in, ("ok", result, cpu
    seconds) or ("error", type, message) out; None or a closed pipe ends it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides about interrupts
    from .clingo_backend import ClingoSolver

    solver = ClingoSolver(**conn.recv(), isolate=False)
    while True:
        try:
            job = conn.recv()
        except EOFError:
            return
        if job is None:
            return
        problem, time_limit = job
        cpu = time.process_time()
        try:
            result = solver._solve_one(problem, time_limit)
            conn.send(("ok", result, time.process_time() - cpu))
        except Exception as exc:  # sent back and raised again in the parent
            conn.send(("error", type(exc).__name__, str(exc)))


class ClingoWorker:
    """One child process at a time, started on demand and replaced after ``recycle`` solves."""

    def __init__(self, options: dict, recycle: int = DEFAULT_RECYCLE):
        self.options = dict(options)
        self.recycle = int(recycle)
        self._proc = None
        self._conn = None
        self._served = 0
        self.started = 0
        """Child processes started so far (tests and benchmarks read it)."""
        self.cpu_seconds = 0.0
        """CPU time the children spent in the solves they answered."""

    def _start(self) -> None:
        parent, child = multiprocessing.Pipe()
        env = dict(os.environ)
        root = str(Path(__file__).resolve().parents[2])  # this refimpl, also when not installed
        env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
        self._proc = subprocess.Popen([sys.executable, "-m", "refimpl.solvers.clingo_worker", str(child.fileno())],
                                      pass_fds=(child.fileno(),), env=env, start_new_session=True,
                                      stdin=subprocess.DEVNULL)
        child.close()
        parent.send(self.options)
        self._conn = parent
        self._served = 0
        self.started += 1

    def close(self) -> None:
        """End the child (politely if it is idle, else killed)."""
        proc, conn = self._proc, self._conn
        self._proc = self._conn = None
        if proc is None:
            return
        try:
            conn.send(None)
        except (OSError, ValueError):
            pass
        try:
            proc.wait(timeout=0.5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        conn.close()

    def _kill(self) -> None:
        proc, conn = self._proc, self._conn
        self._proc = self._conn = None
        if proc is not None:
            proc.kill()
            proc.wait()
            conn.close()

    def solve_one(self, problem: FrameProblem, time_limit: float | None) -> Any:
        """ClingoSolver._solve_one(problem, time_limit) in the child: its result, or None when the
        child overran the limit by GRACE (killed); its exceptions are raised here again."""
        from . import NoAdmissibleHypothesis

        if self._proc is not None and (self._served >= self.recycle or self._proc.poll() is not None):
            self.close()
        if self._proc is None:
            self._start()
        self._served += 1
        deadline = None if time_limit is None else time.perf_counter() + time_limit + GRACE
        try:
            self._conn.send((problem, time_limit))
            while not self._conn.poll(POLL):
                if deadline is not None and time.perf_counter() > deadline:
                    self._kill()
                    return None
                if self._proc.poll() is not None:
                    raise RuntimeError(f"the clingo worker process ended (exit code {self._proc.returncode})")
            reply = self._conn.recv()
        except BaseException:  # KeyboardInterrupt included: the child's state is unknown
            self._kill()
            raise
        if reply[0] == "ok":
            self.cpu_seconds += reply[2]
            return reply[1]
        _, name, message = reply
        if name == "NoAdmissibleHypothesis":
            raise NoAdmissibleHypothesis(message)
        raise RuntimeError(message)

    def __del__(self) -> None:
        try:
            self._kill()
        except Exception:
            pass


if __name__ == "__main__":
    _serve(multiprocessing.connection.Connection(int(sys.argv[1])))
