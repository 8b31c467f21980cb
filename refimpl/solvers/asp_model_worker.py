"""The check of a user's ASP encoding (refimpl.solvers.asp_model) in a child process: its side.

clingo cannot stop grounding inside a process (``Control.interrupt`` stops a search only), and a
signal handler of Python runs only when clingo returns, so an encoding that grounds without end
(``p(0). p(X+1) :- p(X).``) ignored Ctrl-C, SIGTERM and ``--time-limit`` and ended in a
``MemoryError``.  The check runs here instead, in a process the parent kills at its time limit or
at its own interrupt (refimpl.solvers.clingo_process.wait_reply), under a cap on its address space.

Protocol: (files, where, memory cap in bytes) in; ("ready",) once clingo is imported, then
("ok", (tiebreak, vocabulary)), ("error", message) or ("memory",) out.
"""

from __future__ import annotations

import multiprocessing.connection
import resource
import signal
import sys

from .asp_model import AspModelError, clingo_module, read_encoding


def _serve(conn) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides about interrupts
    files, where, memory = conn.recv()
    resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
    try:
        clingo_module(where)
        conn.send(("ready",))
        conn.send(("ok", read_encoding(files, where)))
    except AspModelError as exc:
        conn.send(("error", str(exc)))
    except MemoryError:
        conn.send(("memory",))


if __name__ == "__main__":
    _serve(multiprocessing.connection.Connection(int(sys.argv[1])))
