"""Scale-out: run independent tasks (one sequence, one setting x sequence) serially or on Dask.

``run_tasks(fn, items, plan)`` is the one place that maps work to a cluster:

* ``Plan(workers=1)`` and no scheduler: a plain loop in this process;
* ``Plan(workers=N)``, N > 1: an embedded ``distributed.LocalCluster`` on 127.0.0.1 with N
  worker processes of one thread each, started for the call and closed after it;
* ``Plan(scheduler="tcp://host:port")``: an existing cluster (``dask scheduler`` plus
  ``dask worker`` processes, dask-jobqueue, dask-kubernetes; docs/scale-out.md).

Tasks are submitted in input order and their results returned in input order, whatever the
order in which they finish, so a caller that writes results in the order returned writes the
same bytes as a serial run.  Every task function must be a module-level function of refimpl
(workers import it by name) whose result depends on its arguments only.  The first task that
raises cancels the rest and its exception is raised here, as it would be in a serial run.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Sequence, TypeVar

from .progress import Progress

T = TypeVar("T")
R = TypeVar("R")


DEFAULT_CONNECT_TIMEOUT = 10.0
"""Seconds to wait for a --scheduler address to answer before giving up."""


class ClusterError(RuntimeError):
    """The Dask cluster could not be reached or started (a user's address or setup, exit 2)."""


@dataclass(frozen=True)
class Plan:
    """Where tasks run: ``workers`` local processes, or the cluster at ``scheduler``."""

    workers: int = 1
    scheduler: str | None = None
    connect_timeout: float | None = None
    """Seconds; None for DEFAULT_CONNECT_TIMEOUT."""

    def __post_init__(self) -> None:
        if self.workers < 1:
            raise ValueError(f"workers must be >= 1, got {self.workers}")
        if self.scheduler is not None and not self.scheduler.strip():
            raise ValueError("the scheduler address is empty")

    @property
    def distributed(self) -> bool:
        return self.scheduler is not None or self.workers > 1


def run_tasks(fn: Callable[[T], R], items: Sequence[T], plan: Plan = Plan(), label: str = "tasks",
              quiet: bool = False, describe: Callable[[T], str] | None = None) -> list[R]:
    """``[fn(item) for item in items]``, in input order, on the plan's workers; a progress bar
    on stderr (one step per finished task) unless quiet."""
    items = list(items)
    progress = Progress(len(items), label, enabled=not quiet, unit="task")
    try:
        if not plan.distributed or not items:
            out = []
            for item in items:
                out.append(fn(item))
                progress.step(describe(item) if describe else "")
            return out
        return _run_on_cluster(fn, items, plan, progress, describe)
    finally:
        progress.close()


def _run_on_cluster(fn, items, plan: Plan, progress: Progress, describe) -> list:
    from distributed import as_completed
    with _client(plan) as client:
        index = {}
        futures = []
        for i, item in enumerate(items):  # submitted in input order
            fut = client.submit(fn, item, pure=False)
            index[fut.key] = i
            futures.append(fut)
        try:
            for fut in as_completed(futures):
                if fut.status == "error":
                    fut.result()  # raises the task's own exception
                progress.step(describe(items[index[fut.key]]) if describe else "")
            return client.gather(futures)  # a list in submission (= input) order
        finally:
            client.cancel(futures)


LOCAL_CLUSTER_CONFIG = {
    # Measured here (2 cores): a 2-worker LocalCluster left idle for 30 s burns about 0.09
    # CPU-seconds per second with Dask's defaults and 0.02 with these, which matters when the
    # machine is shared and the command gets a fraction of a core (docs/scale-out.md).
    # The statistical profiler samples every running task's stack every 10 ms; the tick monitor
    # wakes every event loop every 20 ms; the system monitor polls psutil twice a second.
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
}
"""Dask settings of the embedded cluster only (an existing cluster keeps its own)."""


class _client:
    """A distributed.Client for the plan, with its embedded LocalCluster when there is one."""

    def __init__(self, plan: Plan):
        self.plan = plan
        self.cluster: Any = None
        self.client: Any = None
        self.config: Any = None

    def __enter__(self):
        import logging  # here, with Dask: the serial path (every one-sequence `track`) needs neither

        import dask
        from distributed import Client, LocalCluster
        if self.plan.scheduler is None:
            self.config = dask.config.set(LOCAL_CLUSTER_CONFIG)  # for this cluster's lifetime, then undone
        try:
            if self.plan.scheduler is not None:
                timeout = self.plan.connect_timeout
                if timeout is None:
                    timeout = DEFAULT_CONNECT_TIMEOUT
                self.client = Client(self.plan.scheduler, timeout=timeout)
            else:
                # silence_logs: workers log connection errors while the cluster shuts down (a task's
                # own error reaches us as its exception); no dashboard, and the scheduler's HTTP
                # endpoint on a free port rather than a warning when 8787 is taken
                self.cluster = LocalCluster(n_workers=self.plan.workers, threads_per_worker=1, processes=True,
                                            host="127.0.0.1", dashboard_address=None,
                                            scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                                            silence_logs=logging.CRITICAL)
                self.client = Client(self.cluster)
        except (OSError, TimeoutError) as exc:
            self.__exit__(None, None, None)
            where = self.plan.scheduler or f"a local cluster of {self.plan.workers} workers"
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise ClusterError(f"cannot reach {where}: {reason}") from None
        return self.client

    def __exit__(self, *exc) -> None:
        try:
            if self.client is not None:
                self.client.close()
            if self.cluster is not None:
                self.cluster.close()
        finally:
            if self.config is not None:
                self.config.__exit__(None, None, None)
                self.config = None
