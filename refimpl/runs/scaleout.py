"""Scale-out: run independent tasks (one sequence, one setting x sequence) serially or on Dask.

``run_tasks(fn, items, plan)`` is the one place that maps work to a cluster:

* ``Plan(workers=1)`` and no scheduler: a plain loop in this process;
* ``Plan(workers=N)``, N > 1: an embedded ``distributed.LocalCluster`` on 127.0.0.1 with N
  worker processes of one thread each (at most one per task), started for the call and closed
  after it, for work of at least N x LOCAL_MIN_FRAMES_PER_WORKER frames (smaller work: the
  plain loop, the scale-out rule);
* ``Plan(scheduler="tcp://host:port")``: an existing cluster (``dask scheduler`` plus
  ``dask worker`` processes, dask-jobqueue, dask-kubernetes; docs/scale-out.md).

Tasks are submitted in input order and their results returned in input order, whatever the
order in which they finish, so a caller that writes results in the order returned writes the
same bytes as a serial run.  Every task function must be a module-level function of refimpl
(workers import it by name) whose result depends on its arguments only.  The first task that
raises cancels the rest and its exception is raised here, as it would be in a serial run.

A cluster that fails is a :class:`ClusterError` (one line, exit 2 in the CLI) within a bounded
time, never a hang (docs/scale-out.md, "Faults"): a malformed address or an absurd number of
local workers at once (:class:`Plan`); an address that does not answer after the connect timeout;
a scheduler that goes away at once (its futures are cancelled) and one that stops answering after
the connect timeout; no worker connected for the worker timeout; a task whose workers kept dying
(Dask's ``KilledWorker``).  A worker lost while others remain costs only the time to re-run its
task elsewhere: the results, and so the bytes written, are the same.
"""

from __future__ import annotations

import logging
import os
import pickle
import sys
import time
from dataclasses import dataclass
from typing import Any, Callable, Sequence, TypeVar

from . import worker_start
from .progress import Progress

T = TypeVar("T")
R = TypeVar("R")


DEFAULT_CONNECT_TIMEOUT = 10.0
"""Seconds to wait for a --scheduler address to answer (at the start, and for every check of a
running cluster) before giving up."""

DEFAULT_WORKER_TIMEOUT = 60.0
"""Seconds a cluster may have no worker at all (none joined yet, or every one lost) before the
run gives up."""

WORKERS_PER_CPU = 4
"""A local cluster of more than this many worker processes per CPU is refused: the solvers are
single-threaded, so workers beyond one per CPU only share the CPUs (and each costs a process with
the solvers imported, about 150 MB); 4x leaves room to oversubscribe on purpose."""

LOCAL_MIN_FRAMES_PER_WORKER = 2000
"""The scale-out rule: a local cluster of N workers is started only for a run of at least N times
this many frames (tasks whose size is counted in frames: track, benchmark); a smaller run is
tracked serially in this process, which writes the same bytes.  A local cluster costs a fixed
~0.7-0.8 s of wall time on an idle 2-core machine (Dask's import in this process, 0.35 s; the
scheduler and the forked workers; OR-Tools imported by each), and the abduction loop now tracks
KITTI Car at ~2,000 frames per wall second end to end, so the cluster pays only for runs of more
than about 3,500 frames on 2 workers (docs/scale-out.md, measured with --serial-below 0: 1,589
frames 1.11x the serial wall time, 2,659 frames 0.92-1.21x, 4,519 frames 0.73-1.01x, median
0.84-0.88, 8,008 frames 0.78-0.79x; after the fifth pass, which took ~0.3 CPU-s off a cluster run,
1,589 frames 1.09-1.24x and 4,519 frames 0.74-0.79x, so the threshold stayed).  It was 1,000
while 1,000 frames were ~1.7-2 s of abduction.  An existing cluster (``scheduler``) is always
used: its start-up is paid already.
``Plan(serial_below=...)`` (``--serial-below``) sets the threshold, 0 always uses the cluster."""

SCHEMES = ("tcp", "tls", "ws", "wss")
"""Dask address schemes a separate process can connect to (``inproc://`` lives inside one process)."""

_POLL = 0.1  # seconds the wait for the next finished future lasts before the watchdog looks again
_CHECK_EVERY = 1.0  # seconds between asking the scheduler how many workers it has


class ClusterError(RuntimeError):
    """The Dask cluster could not be reached, started or kept (a user's address or setup, exit 2)."""


def cpu_count() -> int:
    """CPUs this process may run on (its affinity mask, where the system has one)."""
    try:
        return len(os.sched_getaffinity(0)) or 1
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def max_local_workers() -> int:
    return WORKERS_PER_CPU * cpu_count()


def check_address(address: str) -> str:
    """A Dask scheduler address as ``scheme://host:port`` (``host:port`` means tcp); ClusterError
    naming what is wrong with anything else."""
    text = address.strip()
    hint = "give the address the scheduler prints, e.g. tcp://10.0.0.5:8786"
    if not text:
        raise ClusterError(f"the scheduler address is empty: {hint}")
    if any(c.isspace() for c in text):
        raise ClusterError(f"scheduler {address!r}: not a Dask address (it has a space); {hint}")
    scheme, sep, rest = text.partition("://")
    if not sep:
        scheme, rest = "tcp", text
    if scheme == "inproc":
        raise ClusterError(f"scheduler {address!r}: an inproc:// address exists only inside the Python process "
                           f"that made it; {hint}")
    if scheme not in SCHEMES:
        raise ClusterError(f"scheduler {address!r}: not a Dask address (scheme {scheme!r}, known: "
                           f"{', '.join(SCHEMES)}); {hint}")
    host, colon, port = rest.rpartition(":")
    if not colon:
        raise ClusterError(f"scheduler {address!r}: no port; {hint}")
    bare = host[1:-1] if host.startswith("[") and host.endswith("]") else host
    if not bare or any(c in "/?#@" for c in bare) or "[" in bare or "]" in bare:
        raise ClusterError(f"scheduler {address!r}: not a host name or IP address before the port; {hint}")
    if not (port.isascii() and port.isdigit() and 0 < int(port) < 65536):
        raise ClusterError(f"scheduler {address!r}: the port must be a number 1..65535, got {port!r}; {hint}")
    return f"{scheme}://{host}:{int(port)}"


@dataclass(frozen=True)
class Plan:
    """Where tasks run: ``workers`` local processes, or the cluster at ``scheduler``.

    Checked when made: ``workers`` within 1 .. :func:`max_local_workers` (ValueError below 1,
    ClusterError above), ``scheduler`` a well-formed address (:func:`check_address`)."""

    workers: int = 1
    scheduler: str | None = None
    connect_timeout: float | None = None
    """Seconds; None for DEFAULT_CONNECT_TIMEOUT."""
    worker_timeout: float | None = None
    """Seconds; None for DEFAULT_WORKER_TIMEOUT."""
    serial_below: int | None = None
    """Frames: a local cluster runs only work of at least this many frames (None:
    LOCAL_MIN_FRAMES_PER_WORKER x workers; 0: always); see :meth:`serial_for`."""

    def __post_init__(self) -> None:
        if self.workers < 1:
            raise ValueError(f"workers must be >= 1, got {self.workers}")
        if self.serial_below is not None and self.serial_below < 0:
            raise ValueError(f"serial_below must be >= 0 frames, got {self.serial_below}")
        for name in ("connect_timeout", "worker_timeout"):
            value = getattr(self, name)
            if value is not None and not value > 0:
                raise ValueError(f"{name} must be a positive number of seconds, got {value}")
        if self.scheduler is not None:
            check_address(self.scheduler)
        elif self.workers > max_local_workers():
            raise ClusterError(f"{self.workers} local workers: more than {max_local_workers()} "
                               f"({WORKERS_PER_CPU} per CPU, {cpu_count()} CPUs here); for a bigger cluster start "
                               "one and give its scheduler's address (docs/scale-out.md)")

    @property
    def distributed(self) -> bool:
        return self.scheduler is not None or self.workers > 1

    @property
    def frames_threshold(self) -> int:
        """The fewest frames a local cluster is started for (LOCAL_MIN_FRAMES_PER_WORKER)."""
        return LOCAL_MIN_FRAMES_PER_WORKER * self.workers if self.serial_below is None else self.serial_below

    def serial_for(self, frames: int | None) -> bool:
        """Whether work of this many frames (None: not counted in frames) runs in this process: no
        cluster asked for, or a local one that would cost more than it saves (frames below
        :attr:`frames_threshold`).  An existing cluster (``scheduler``) is always used."""
        if not self.distributed:
            return True
        return self.scheduler is None and frames is not None and frames < self.frames_threshold

    @property
    def connect_seconds(self) -> float:
        return DEFAULT_CONNECT_TIMEOUT if self.connect_timeout is None else self.connect_timeout

    @property
    def worker_seconds(self) -> float:
        return DEFAULT_WORKER_TIMEOUT if self.worker_timeout is None else self.worker_timeout

    def where(self) -> str:
        return f"the Dask scheduler at {self.scheduler}" if self.scheduler is not None else "the local Dask cluster"


def no_tick() -> None:
    """The tick a task gets where nobody listens (on a Dask worker): a module-level no-op, so it pickles."""


def call_pickled(fn: Callable[..., R], item: bytes, *args: Any) -> R:
    """``fn(pickle.loads(item), *args)``: how a task runs on a cluster.  Its item travels as the
    bytes the client pickled: Dask's scheduler unpickles and pickles again every argument of a task
    it does not see as bytes (a KITTI sequence's 800 frames: 7 ms each way, in the command's
    process on a local cluster, beside the workers), and bytes it hands on as they are."""
    return fn(pickle.loads(item), *args)


def _pickled(item: Any) -> bytes:
    """The item as pickle bytes; as Dask does, cloudpickle for what pickle cannot take by reference
    (a function defined in a test, a lambda), which ``pickle.loads`` reads back all the same."""
    try:
        return pickle.dumps(item, protocol=pickle.HIGHEST_PROTOCOL)
    except (pickle.PicklingError, AttributeError, TypeError):
        import cloudpickle  # a dependency of Dask's, there whenever a cluster is
        return cloudpickle.dumps(item, protocol=pickle.HIGHEST_PROTOCOL)


def run_tasks(fn: Callable[..., R], items: Sequence[T], plan: Plan = Plan(), label: str = "tasks",
              quiet: bool = False, describe: Callable[[T], str] | None = None,
              steps: Callable[[T], int] | None = None, frames_rule: bool = True) -> list[R]:
    """``[fn(item) for item in items]``, in input order, on the plan's workers; a progress bar on
    stderr unless quiet.

    Without ``steps`` the bar counts tasks.  With ``steps`` (e.g. ``lambda job: len(job.seq.frames)``)
    it counts steps (frames), ``fn`` is called as ``fn(item, tick)`` and should call ``tick()``
    once per step: in a serial run every tick advances the bar (a long single sequence moves frame
    by frame); on a cluster ``tick`` is :func:`no_tick` and the bar advances by ``steps(item)``
    when the task finishes.  With ``steps`` a local cluster runs only work of at least
    ``plan.frames_threshold`` steps, smaller work runs serially (:meth:`Plan.serial_for`), unless
    ``frames_rule`` is false: that rule was measured on tracking frames, and a frame of ``diff``
    (every backend solves it, clingo among them) is hundreds of times that work, so diff counts
    its frames for the bar only."""
    items = list(items)
    sizes = [int(steps(item)) for item in items] if steps is not None else [1] * len(items)
    progress = Progress(sum(sizes), label, enabled=not quiet, unit="task" if steps is None else "frame")
    try:
        if not items or plan.serial_for(sum(sizes) if steps is not None and frames_rule else None):  # the rule
            out = []
            for item, size in zip(items, sizes):
                if steps is None:
                    out.append(fn(item))
                    progress.step(describe(item) if describe else "")
                    continue
                progress.describe(describe(item) if describe else "")
                ticked = _Ticks(progress, size)
                out.append(fn(item, ticked.tick))
                ticked.finish()  # a task that ticked fewer times than its steps still fills its share
            return out
        return _run_on_cluster(fn, items, plan, progress, describe, sizes, steps is not None)
    finally:
        progress.close()


class _Ticks:
    """One task's ticks, at most ``size`` of them reach the bar."""

    def __init__(self, progress: Progress, size: int):
        self.progress, self.left = progress, size

    def tick(self) -> None:
        if self.left > 0:
            self.left -= 1
            self.progress.step()

    def finish(self) -> None:
        if self.left > 0:
            self.progress.step(n=self.left)
            self.left = 0


def _run_on_cluster(fn, items, plan: Plan, progress: Progress, describe, sizes, with_tick: bool) -> list:
    with _client(plan, len(items)) as client:
        # submitted longest first where sizes are known (ties, and tasks not counted in frames, in
        # input order), with their size as Dask's priority (a higher one starts first), so the last
        # task to finish is a short one; results are still returned in input order.  pure=False:
        # two equal items are still two tasks.  No cancel on the way out: closing the client
        # (bounded by the connect timeout; a cancel call to a hung scheduler is not) releases every
        # task it submitted.
        order = sorted(range(len(items)), key=lambda i: -sizes[i]) if with_tick else range(len(items))
        futures: list = [None] * len(items)
        for i in order:
            futures[i] = client.submit(call_pickled, fn, _pickled(items[i]),
                                       *((no_tick,) if with_tick else ()), pure=False,
                                       priority=sizes[i] if with_tick else 0)
        watchdog = _Watchdog(client, plan)
        results: list = [None] * len(items)
        pending = dict(enumerate(futures))
        while pending:
            finished = [i for i, fut in pending.items() if fut.done()]
            for i in finished:  # in input order, whichever finished first
                what = describe(items[i]) if describe else f"task {i + 1}"
                fetched, results[i] = _fetch(pending[i], what, plan)
                if fetched:
                    del pending[i]
                    progress.step(what if describe else "", n=sizes[i])
            if pending and not finished:
                watchdog.check()
                _wait_any(list(pending.values()), _POLL)
        return results


def _wait_any(futures: list, seconds: float) -> None:
    """Return as soon as one of the futures is done, or after ``seconds`` (then the caller's
    watchdog looks at the cluster again): the last result is taken when it arrives, not up to a
    poll interval later."""
    from distributed import wait
    from distributed.client import FutureCancelledError, FuturesCancelledError
    try:
        wait(futures, timeout=seconds, return_when="FIRST_COMPLETED")
    except TimeoutError:
        pass
    except (FutureCancelledError, FuturesCancelledError):
        pass  # those futures are done (cancelled): the caller's _fetch names what was lost


def _fetch(fut, what: str, plan: Plan) -> tuple[bool, Any]:
    """(True, result) of a finished future; (False, None) when it could not be fetched in time (its
    worker lost since? the scheduler re-runs it: look again).  A task's own exception is raised as
    it is (as a serial run would); a cancelled future or KilledWorker is a ClusterError."""
    from distributed.client import FutureCancelledError
    from distributed.scheduler import KilledWorker
    if fut.status == "error":
        exc = fut.exception()
        if isinstance(exc, KilledWorker):
            tries = exc.allowed_failures + 1
            raise ClusterError(f"{what}: every worker that ran it died ({tries} {'try' if tries == 1 else 'tries'} "
                               f"on {plan.where()}): crashed or killed, e.g. out of memory") from None
        fut.result()
    try:
        return True, fut.result(timeout=plan.connect_seconds)
    except FutureCancelledError:
        raise ClusterError(f"lost {plan.where()} while running {what}: its tasks were cancelled") from None
    except TimeoutError:
        return False, None


class _Watchdog:
    """Bounds the wait for a cluster that cannot finish: no worker for the worker timeout, or a
    scheduler that does not answer for the connect timeout, is a ClusterError."""

    def __init__(self, client: Any, plan: Plan):
        self.client, self.plan = client, plan
        now = time.monotonic()
        self.last_worker = self.last_answer = now
        self.next_check = now

    def check(self) -> None:
        now = time.monotonic()
        if now < self.next_check:
            return
        self.next_check = now + _CHECK_EVERY
        if self.client.status == "closed":
            raise ClusterError(f"lost {self.plan.where()}: the connection is closed")
        try:
            workers = len(self.client.nthreads(callback_timeout=self.plan.connect_seconds))
        except (OSError, TimeoutError):
            if time.monotonic() - self.last_answer >= self.plan.connect_seconds:
                raise ClusterError(f"lost {self.plan.where()}: no answer for {self.plan.connect_seconds:g} s") \
                    from None
            return
        now = self.last_answer = time.monotonic()
        if workers:
            self.last_worker = now
        elif now - self.last_worker >= self.plan.worker_seconds:
            raise ClusterError(f"{self.plan.where()} has had no worker for {self.plan.worker_seconds:g} s "
                               "(none joined, or every one was lost); the tasks cannot run")


START_METHOD = "fork" if sys.platform.startswith("linux") else "spawn"
"""How the embedded cluster's nannies start their worker processes.  ``fork`` on Linux: the worker
is a copy of this process, with Dask, distributed and the task's refimpl modules imported already,
where a ``spawn`` worker starts a fresh interpreter and imports them again (measured here: a
spawned worker had used 0.7-1.1 CPU-s before its first task, importing Dask and distributed, and
then imported refimpl and the solvers while unpickling it; a forked one 0.09 CPU-s).  Forking is
safe here: the nannies fork from Dask's event-loop thread while this process's main thread waits
(for the cluster to start, or for results when a nanny replaces a killed worker) holding no lock,
and no solver leaves a thread behind (a CP-SAT run of KITTI Car 0011 in this process: 2 threads
before and after).  Elsewhere (macOS: fork is unsafe with its system libraries) Dask's default,
spawn."""

LOCAL_CLUSTER_CONFIG = {
    # Measured here (2 cores): a 2-worker LocalCluster left idle for 30 s burns about 0.09
    # CPU-seconds per second with Dask's defaults and 0.02 with these, which matters when the
    # machine is shared and the command gets a fraction of a core (docs/scale-out.md).
    # The statistical profiler samples every running task's stack every 10 ms; the tick monitor
    # wakes every event loop every 20 ms; the system monitor polls psutil twice a second.
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.worker.multiprocessing-method": START_METHOD,
    # one task per worker at a time (Dask's default, 1.1, hands a one-thread worker two): the
    # scheduler keeps the rest queued and gives each worker the next, longest, task only when it
    # is free, so one worker never holds a long task the other could have started
    "distributed.scheduler.worker-saturation": 1.0,
}
"""Dask settings of the embedded cluster only (an existing cluster keeps its own)."""


def _quietly(call: Callable, *args, **kwargs) -> None:
    """Tear-down of a cluster that may be gone already: its errors add nothing to the one reported."""
    try:
        call(*args, **kwargs)
    except Exception:  # noqa: BLE001 - cancelling or closing a lost cluster; the run's own error is raised
        pass


SECURE_SCHEMES = ("tls", "wss")
"""Schemes whose connection needs Dask's TLS settings (certificates: ``distributed.comm.tls.*``)."""


def _handshake(address: str, seconds: float) -> None:
    """Connect to the scheduler at ``address`` and exchange Dask's handshake, all of it within
    ``seconds``, then close; ClusterError when that fails.  Dask's own ``connect`` bounds the TCP
    connection by its timeout but then waits for the handshake without one (distributed 2024.x,
    ``comm/core.py``), so ``Client()`` hung for ever on a server that accepts and never answers;
    and a ``tls://`` or ``wss://`` address without TLS settings was a TypeError there."""
    import asyncio
    from distributed.comm import connect
    from distributed.security import Security
    scheme = address.partition("://")[0]
    args = Security().get_connection_args("client")  # what Client() uses: Dask's configuration
    if scheme in SECURE_SCHEMES and args.get("ssl_context") is None:
        raise ClusterError(f"scheduler {address}: a {scheme}:// address needs Dask's TLS settings (the "
                           "certificates, distributed.comm.tls.* in Dask's configuration; docs/scale-out.md)")

    async def attempt() -> None:
        comm = await connect(address, timeout=seconds, **args)
        await comm.close()

    try:
        asyncio.run(asyncio.wait_for(attempt(), seconds))
    except (asyncio.TimeoutError, TimeoutError):
        raise ClusterError(f"cannot reach {address}: no Dask handshake within {seconds:g} s (--connect-timeout; "
                           "is it a Dask scheduler?)") from None
    except (OSError, ValueError, TypeError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ClusterError(f"cannot reach {address}: {reason}") from None


class _client:
    """A distributed.Client for the plan, with its embedded LocalCluster when there is one; Dask's
    own log lines are silenced while it lives (a fault is reported once, as a ClusterError)."""

    def __init__(self, plan: Plan, tasks: int):
        self.plan, self.tasks = plan, tasks
        self.cluster: Any = None
        self.client: Any = None
        self.config: Any = None
        self.quiet: Any = None

    def __enter__(self):
        import dask  # here: an optional dependency, and the serial path (every one-sequence `track`) needs none
        from distributed import Client, LocalCluster
        from distributed.utils import silence_logging_cmgr
        self.quiet = silence_logging_cmgr(logging.CRITICAL)  # Dask's stderr handlers, restored on exit
        self.quiet.__enter__()
        if self.plan.scheduler is None:
            self.config = dask.config.set(LOCAL_CLUSTER_CONFIG)  # for this cluster's lifetime, then undone
        try:
            if self.plan.scheduler is not None:
                address = check_address(self.plan.scheduler)
                _handshake(address, self.plan.connect_seconds)  # Client() itself may wait for ever
                self.client = Client(address, timeout=self.plan.connect_seconds)
            else:
                # silence_logs: workers log connection errors while the cluster shuts down (a task's
                # own error reaches us as its exception); no dashboard, and the scheduler's HTTP
                # endpoint on a free port rather than a warning when 8787 is taken; memory_limit=0:
                # no memory monitor in the nannies (this process) and workers, which polled every
                # process's memory 10 times a second (idle: 0.019 CPU-s/s in this process, 0.011
                # without); a worker out of memory is killed by the system instead, and its task
                # re-run elsewhere or reported (docs/scale-out.md, "Faults")
                self.cluster = LocalCluster(n_workers=min(self.plan.workers, self.tasks), threads_per_worker=1,
                                            processes=True, host="127.0.0.1", dashboard_address=None,
                                            scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                                            memory_limit=0, silence_logs=logging.CRITICAL,
                                            preload=[worker_start.__name__])  # signals, gc.freeze
                self.client = Client(self.cluster)
        except (OSError, TimeoutError, ValueError) as exc:
            self.__exit__(None, None, None)
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            where = self.plan.scheduler or f"a local cluster of {self.plan.workers} workers"
            raise ClusterError(f"cannot reach {where}: {reason}") from None
        return self.client

    def __exit__(self, *exc) -> None:
        try:
            if self.client is not None:
                _quietly(self.client.close, timeout=self.plan.connect_seconds)
            if self.cluster is not None:
                _quietly(self.cluster.close, timeout=self.plan.connect_seconds)
        finally:
            if self.config is not None:
                self.config.__exit__(None, None, None)
                self.config = None
            if self.quiet is not None:
                self.quiet.__exit__(None, None, None)
                self.quiet = None
