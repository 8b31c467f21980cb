"""A Dask preload for the embedded cluster's worker processes: the command's process alone answers
Ctrl-C and SIGTERM.

A Ctrl-C reaches every process of the terminal's process group, the workers of ``--workers N``
included; each one raised KeyboardInterrupt in its own event loop and printed a traceback beside
the command's one line (``refimpl: interrupted``).  The command closes its cluster on the way out
(refimpl.experiments.scaleout), which stops the workers, so a worker ignores SIGINT, and takes
SIGTERM (how its nanny stops a worker that does not close in time) as a plain exit, as a spawned
process would, not as the handler a forked one inherits from the command line.
"""

from __future__ import annotations

import signal


def dask_setup(worker) -> None:
    """Run by Dask in each worker process when it starts (``LocalCluster(preload=[__name__])``)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
