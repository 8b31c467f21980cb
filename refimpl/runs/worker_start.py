"""A Dask preload for the embedded cluster's worker processes, run when each one starts: the
command's process alone answers Ctrl-C and SIGTERM, and the heap a forked worker inherits stays
shared.

Signals.  A Ctrl-C reaches every process of the terminal's process group, the workers of
``--workers N`` included; each one raised KeyboardInterrupt in its own event loop and printed a
traceback beside the command's one line (``refimpl: interrupted``).  The command closes its
cluster on the way out (refimpl.runs.scaleout), which stops the workers, so a worker
ignores SIGINT, and takes SIGTERM (how its nanny stops a worker that does not close in time) as a
plain exit, as a spawned process would, not as the handler a forked one inherits from the command
line.

The heap.  A forked worker shares the command's memory pages until it writes to them, and a full
garbage collection writes to every object it visits (its reference bookkeeping), so the worker's
first collections copied the whole inherited heap (Dask, the solvers, numpy: ~150 MB) page by page
while it tracked: 12 KITTI Car sequences on 2 workers took 2.07 CPU-s of tracking against 1.86 s
in one process, the first task of each worker 14-42 % more than serially.  ``gc.freeze()`` at the
worker's start moves every inherited object out of the collector's reach (Python's documented
use for it, before or after a fork): 1.82-1.94 CPU-s, each first task within a few percent of its
serial time.  Objects made by the tasks are collected as before; what is frozen is what the
command's process had made before the fork, which it keeps alive anyway.
"""
from __future__ import annotations

import gc
import signal


def dask_setup(worker) -> None:
    """Run by Dask in each worker process when it starts (``LocalCluster(preload=[__name__])``)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    gc.freeze()  # what this process inherited from the command's is not collected (nor copied) here
