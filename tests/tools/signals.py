"""What a test's child process starts with for a signal, whatever the test runner inherited.

A command started in the background by a non-interactive shell (``cmd &``) inherits SIGINT
ignored, and one started by ``nohup`` SIGHUP ignored; Python then installs no Ctrl-C handler, and
refimpl keeps an ignored signal ignored (refimpl.cli.run: nohup asks for that).  A test that sends
a child a signal gives the child the disposition it tests, so it passes however pytest was
started."""

from __future__ import annotations

import signal
from collections.abc import Callable


def started_with(action, *signals: int) -> Callable[[], None]:
    """A ``preexec_fn`` for subprocess: the child starts with ``action`` (signal.SIG_DFL,
    signal.SIG_IGN) for each of ``signals``."""
    def preexec() -> None:
        for sig in signals:
            signal.signal(sig, action)
    return preexec


def as_from_a_terminal(*signals: int) -> Callable[[], None]:
    """A ``preexec_fn``: each of ``signals`` at its default action, as a command typed at a
    terminal starts."""
    return started_with(signal.SIG_DFL, *signals)
