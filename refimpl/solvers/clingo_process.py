"""clingo's worker process, seen from the parent: started on demand, replaced every so many
solves, killed when it overruns its time limit (the why and the protocol: refimpl.solvers.clingo_worker,
the child's side).

The child runs ``python -m refimpl.solvers.clingo_worker FD``; this module names that program
but never imports it (the child imports the ASP backend, which imports this module).
"""

from __future__ import annotations

import multiprocessing
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from ..core.errors import UserFacingError
from ..core.spec import FrameProblem
from . import NoAdmissibleHypothesis

CHILD_MODULE = "refimpl.solvers.clingo_worker"
"""The program the child runs (``python -m CHILD_MODULE FD``)."""

POLL = 0.1
"""Seconds between two checks of the pipe (time limit, SIGINT)."""
GRACE = 1.0
"""Seconds a child that has grounded its problem may overrun its time limit (finishing its search,
reporting) before it is killed (one still grounding at its limit is killed then: it could only
answer None);
under a short limit less, 0.5 s + 5 % of it (``grace``): the child stops its own search at the limit
(its POLL is 0.1 s) and what is left is sending the answer."""


class EncodingMemoryError(MemoryError, UserFacingError):
    """A user's encoding went beyond the worker's memory cap on a frame (one line)."""


def grace(time_limit: float) -> float:
    """How long after its limit a child is killed: GRACE, or 0.5 s + 5 % of a limit under 10 s, so
    that a solve ends within 10 % of its limit + 1 s, the child's own start included."""
    return min(GRACE, 0.5 + 0.05 * time_limit)
DEFAULT_RECYCLE = 1000
"""Solves per child process before it is replaced."""


def start_child(module: str) -> tuple[subprocess.Popen, Any]:
    """``python -m module FD`` in a session of its own (a terminal's Ctrl-C reaches the parent
    only), this refimpl on its path, and the parent's end of the Connection it talks over."""
    parent, child = multiprocessing.Pipe()
    env = dict(os.environ)
    root = str(Path(__file__).resolve().parents[2])  # this refimpl, also when not installed
    env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    proc = subprocess.Popen([sys.executable, "-m", module, str(child.fileno())], pass_fds=(child.fileno(),),
                            env=env, start_new_session=True, stdin=subprocess.DEVNULL)
    child.close()
    return proc, parent


def wait_reply(proc: subprocess.Popen, conn, seconds: float | None) -> Any:
    """The child's next message, or None when none came within ``seconds`` (None: no limit);
    polled every POLL seconds, so a Ctrl-C or SIGTERM of the parent is served meanwhile (the
    caller kills the child then).  A child that ended without a message is a RuntimeError."""
    deadline = None if seconds is None else time.perf_counter() + seconds
    while not conn.poll(POLL):
        if deadline is not None and time.perf_counter() > deadline:
            return None
        if proc.poll() is not None:
            raise RuntimeError(f"the clingo worker process ended (exit code {proc.returncode})")
    return conn.recv()


def kill_child(proc: subprocess.Popen, conn) -> None:
    proc.kill()
    proc.wait()
    conn.close()


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

    def __getstate__(self) -> dict:
        """Pickled without its child process (a process and a pipe cannot be pickled): the copy
        starts a child of its own at its first solve, and the original's child stays the original's."""
        state = dict(self.__dict__)
        state.update(_proc=None, _conn=None, _served=0)
        return state

    def _start(self) -> None:
        self._proc, self._conn = start_child(CHILD_MODULE)
        self._conn.send(self.options)
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
        child was killed: still grounding at the limit, or past it by ``grace`` after grounding;
        its exceptions are raised here again."""
        if self._proc is not None and (self._served >= self.recycle or self._proc.poll() is not None):
            self.close()
        if self._proc is None:
            self._start()
        self._served += 1
        limit = None if time_limit is None else time.perf_counter() + time_limit
        deadline = None if limit is None else limit + grace(time_limit)
        grounded = False  # a child still grounding at its limit can only answer None: killed then
        try:
            self._conn.send((problem, time_limit, time.monotonic()))
            while True:
                while not self._conn.poll(POLL if grounded or limit is None else
                                          max(0.0, min(POLL, limit - time.perf_counter()))):
                    now = time.perf_counter()
                    if limit is not None and (now > deadline or (not grounded and now >= limit)):
                        self._kill()
                        return None
                    if self._proc.poll() is not None:
                        raise RuntimeError(f"the clingo worker process ended (exit code {self._proc.returncode})")
                reply = self._conn.recv()
                if reply[0] != "grounded":
                    break
                grounded = True
        except BaseException:  # KeyboardInterrupt included: the child's state is unknown
            self._kill()
            raise
        if reply[0] == "ok":
            self.cpu_seconds += reply[2]
            return reply[1]
        _, name, message = reply
        if name == "NoAdmissibleHypothesis":
            raise NoAdmissibleHypothesis(message)
        if name == "MemoryError":
            raise EncodingMemoryError(message)
        raise RuntimeError(message)

    def __del__(self) -> None:
        try:
            self._kill()
        except Exception:
            pass
