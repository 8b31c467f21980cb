"""Dask faults end in one line and exit code 2, never a traceback or a hang, and write nothing:
a malformed or unreachable --scheduler, an absurd --workers, a scheduler lost mid-run, every
worker lost, a task whose worker keeps dying; and a worker lost among several changes no byte.

The clusters are real: a scheduler and workers started as `python -m distributed.cli.dask_*`
processes on 127.0.0.1 (stopped by the fixture), or an in-process LocalCluster.  The CLI runs as
`python -m refimpl` subprocesses; their communicate() timeout is a hang guard, not a measurement."""

from __future__ import annotations

import contextlib
import io as stdio
import json
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

pytest.importorskip("distributed")

from refimpl import cli  # noqa: E402

from refimpl.runs import scaleout  # noqa: E402
from refimpl.runs.scaleout import ClusterError, Plan, check_address, run_tasks  # noqa: E402
from tools.signals import as_from_a_terminal  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
DEMO = REPO / "data" / "demo" / "TUD-Campus"
ENV = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
HANG_GUARD = 240  # seconds: a subprocess still running then is a hang


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> list[str]:
    """Three sequence folders CutN with TUD-Campus's first N = 71, 50 and 30 frames (det/det.txt
    and seqinfo.ini named CutN, so no warning line): three tasks of a few seconds each with CP-SAT."""
    root = tmp_path_factory.mktemp("seqs")
    lines = (DEMO / "det" / "det.txt").read_text().splitlines()
    paths = []
    for last in (71, 50, 30):
        det = root / f"Cut{last}" / "det" / "det.txt"
        det.parent.mkdir(parents=True)
        det.write_text("".join(line + "\n" for line in lines if int(line.split(",")[0]) <= last))
        info = (DEMO / "seqinfo.ini").read_text()
        assert "name=TUD-Campus\n" in info and "seqLength=71\n" in info
        info = info.replace("name=TUD-Campus\n", f"name=Cut{last}\n").replace("seqLength=71\n", f"seqLength={last}\n")
        (det.parent.parent / "seqinfo.ini").write_text(info)
        paths.append(str(det))
    return paths


@pytest.fixture(scope="module")
def serial(inputs, tmp_path_factory) -> dict[str, bytes]:
    """The files of a serial run (in this process)."""
    out_dir = tmp_path_factory.mktemp("serial")
    with contextlib.redirect_stdout(stdio.StringIO()), contextlib.redirect_stderr(stdio.StringIO()):
        assert cli.main(["track", "--backend", "cpsat", "--dets", *inputs, "--out-dir", str(out_dir), "--quiet"]) == 0
    files = {p.name: p.read_bytes() for p in sorted(out_dir.iterdir())}
    assert sorted(files) == ["Cut30.txt", "Cut50.txt", "Cut71.txt"]
    assert len(set(files.values())) == 3  # three different files: a mix-up would show
    return files


def _refimpl(*argv: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "refimpl", *argv], cwd=REPO, env=ENV, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def _finish(proc: subprocess.Popen) -> tuple[int, str, str]:
    try:
        out, err = proc.communicate(timeout=HANG_GUARD)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        pytest.fail(f"refimpl still running after {HANG_GUARD} s")
    return proc.returncode, out, err


def _one_error_line(code: int, err: str, command: str = "track") -> str:
    assert code == 2, err
    assert "Traceback" not in err, err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"refimpl {command}: error: "), err
    return lines[0]


def _track(inputs, out_dir, *extra) -> subprocess.Popen:
    return _refimpl("track", "--backend", "cpsat", "--dets", *inputs, "--out-dir", str(out_dir), "--quiet", *extra)


class Cluster:
    """A scheduler and ``workers`` worker processes (no nanny: a killed worker stays dead) on 127.0.0.1."""

    def __init__(self, root: Path, workers: int):
        self.root, self.procs = root, []
        sched_file = root / "scheduler.json"
        self.scheduler = self._start(["distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0",
                                      "--no-dashboard", "--scheduler-file", str(sched_file)])
        deadline = time.monotonic() + 60
        while not sched_file.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        time.sleep(0.2)  # the file is written at once; let it be complete
        self.address = json.loads(sched_file.read_text())["address"]
        self.workers = [self._start(["distributed.cli.dask_worker", self.address, "--no-nanny", "--nthreads", "1",
                                     "--no-dashboard", "--name", f"w{k}", "--local-directory", str(root / f"w{k}")])
                        for k in range(workers)]
        if workers:
            with self.client() as client:
                client.wait_for_workers(workers, timeout=60)

    def _start(self, argv: list[str]) -> subprocess.Popen:
        proc = subprocess.Popen([sys.executable, "-m", *argv], cwd=REPO, env=ENV,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        self.procs.append(proc)
        return proc

    def client(self):
        from distributed import Client
        return Client(self.address, timeout=30, set_as_default=False)

    def busy_worker(self, run: subprocess.Popen) -> int:
        """Wait until some worker is running a task of ``run``; its index in self.workers."""
        with self.client() as client:
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline and run.poll() is None:
                names = {addr: w["name"] for addr, w in client.scheduler_info()["workers"].items()}
                busy = [names[addr] for addr, keys in client.processing().items() if keys and addr in names]
                if busy:
                    return int(str(sorted(busy)[0])[1:])
                time.sleep(0.1)
        pytest.fail("no worker ever ran a task (or the run ended first)")

    def stop(self) -> None:
        for proc in reversed(self.procs):
            if proc.poll() is None:
                proc.kill()
        for proc in self.procs:
            proc.wait(timeout=30)


@pytest.fixture
def cluster(tmp_path):
    made = []

    def start(workers: int) -> Cluster:
        made.append(Cluster(tmp_path, workers))
        return made[-1]
    yield start
    for c in made:
        c.stop()


# -- addresses and worker counts: refused before any work --------------------------------------

@pytest.mark.parametrize("address, reason", [
    ("127.0.0.1", "no port"),
    ("not a url", "not a Dask address (it has a space)"),
    ("inproc://x", "an inproc:// address exists only inside the Python process"),
    ("http://127.0.0.1:8786", "not a Dask address (scheme 'http'"),
])
def test_a_malformed_scheduler_address_is_one_line(address, reason, tmp_path):
    code, out, err = _finish(_refimpl("track", "--dets", str(DEMO / "det" / "det.txt"), "--out",
                                      str(tmp_path / "x.txt"), "--scheduler", address, "--quiet"))
    line = _one_error_line(code, err)
    assert f"scheduler {address!r}: {reason}" in line and "tcp://10.0.0.5:8786" in line
    assert out == "" and list(tmp_path.iterdir()) == []


def test_check_address_accepts_what_dask_prints_and_names_what_is_wrong():
    assert check_address("tcp://10.0.0.5:8786") == "tcp://10.0.0.5:8786"
    assert check_address(" 10.0.0.5:8786 ") == "tcp://10.0.0.5:8786"  # host:port means tcp, as in Dask
    assert check_address("tls://[::1]:8786") == "tls://[::1]:8786"
    assert check_address("tcp://sched.example.org:08786") == "tcp://sched.example.org:8786"
    for bad, reason in [("tcp://h:0", "1..65535"), ("tcp://h:65536", "1..65535"), ("tcp://h:x", "1..65535"),
                        ("tcp://:8786", "not a host name"), ("tcp://a/b:8786", "not a host name"),
                        ("ucx://h:1", "scheme 'ucx'"), ("", "empty"), ("tcp://h", "no port")]:
        with pytest.raises(ClusterError, match=f".*{reason}"):
            check_address(bad)


def test_an_unreachable_scheduler_is_one_line_after_the_connect_timeout(tmp_path):
    with socket.socket() as s:  # a port nothing listens on: bound, its number read, closed
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    code, out, err = _finish(_refimpl("track", "--dets", str(DEMO / "det" / "det.txt"), "--out",
                                      str(tmp_path / "x.txt"), "--scheduler", f"tcp://127.0.0.1:{port}",
                                      "--connect-timeout", "1", "--quiet"))
    assert f"cannot reach tcp://127.0.0.1:{port}" in _one_error_line(code, err)
    assert list(tmp_path.iterdir()) == []


@pytest.fixture
def silent_server():
    """A TCP server on 127.0.0.1 that accepts every connection and never writes a byte: its
    address.  Dask's connect waited for its handshake without a time limit (issue 37)."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(16)
    server.settimeout(0.1)  # accept() wakes up to see the stop flag (close() does not wake it)
    accepted: list[socket.socket] = []
    stop = threading.Event()

    def serve() -> None:
        while not stop.is_set():
            try:
                accepted.append(server.accept()[0])
            except socket.timeout:
                continue
            except OSError:  # closed
                return
    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    yield f"127.0.0.1:{server.getsockname()[1]}"
    stop.set()
    thread.join(timeout=10)
    server.close()
    for conn in accepted:
        conn.close()


@pytest.mark.parametrize("scheme", ["tcp", "ws"])
def test_a_scheduler_that_accepts_and_never_answers_is_one_line(scheme, silent_server, tmp_path):
    # it hung for ever (still waiting at 120 s with --connect-timeout 2): the TCP connection was
    # bounded by the timeout, Dask's handshake read after it was not; the server saw the connection
    address = f"{scheme}://{silent_server}"
    code, out, err = _finish(_refimpl("track", "--dets", str(DEMO / "det" / "det.txt"), "--out",
                                      str(tmp_path / "x.txt"), "--scheduler", address, "--connect-timeout", "2",
                                      "--quiet"))
    assert _one_error_line(code, err) == (f"refimpl track: error: cannot reach {address}: no Dask handshake within "
                                          "2 s (--connect-timeout; is it a Dask scheduler?)")
    assert out == "" and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("scheme", ["tls", "wss"])
def test_a_tls_address_without_tls_settings_is_one_line(scheme, silent_server, tmp_path):
    # it was a TypeError traceback from Dask ("TLS expects a `ssl_context` argument")
    address = f"{scheme}://{silent_server}"
    code, out, err = _finish(_refimpl("track", "--dets", str(DEMO / "det" / "det.txt"), "--out",
                                      str(tmp_path / "x.txt"), "--scheduler", address, "--quiet"))
    assert _one_error_line(code, err) == (
        f"refimpl track: error: scheduler {address}: a {scheme}:// address needs Dask's TLS settings (the "
        "certificates, distributed.comm.tls.* in Dask's configuration; docs/scale-out.md)")
    assert out == "" and list(tmp_path.iterdir()) == []


def test_an_absurd_number_of_local_workers_is_refused_before_any_work(tmp_path):
    bound = 4 * len(os.sched_getaffinity(0))  # 4 local workers per CPU this process may use
    code, out, err = _finish(_refimpl("track", "--dets", str(DEMO / "det" / "det.txt"), "--out",
                                      str(tmp_path / "x.txt"), "--workers", "1000000"))
    assert f"1000000 local workers: more than {bound} (4 per CPU" in _one_error_line(code, err)
    assert list(tmp_path.iterdir()) == []
    assert Plan(workers=bound).workers == bound  # the bound itself is allowed
    with pytest.raises(ClusterError, match=f"{bound + 1} local workers"):
        Plan(workers=bound + 1)
    assert Plan(workers=bound + 1, scheduler="tcp://h:1").distributed  # no local bound on a cluster's size


def test_a_local_cluster_starts_at_most_one_worker_per_task(monkeypatch):
    # a fake LocalCluster records what it is asked for and then fails as a cluster that cannot start
    import distributed
    asked = []

    def fake(**kwargs):
        asked.append(kwargs["n_workers"])
        raise OSError("no cluster in this test")
    monkeypatch.setattr(distributed, "LocalCluster", fake)
    with pytest.raises(ClusterError, match="cannot reach a local cluster of 4 workers: no cluster in this test"):
        run_tasks(len, [[1], [2]], Plan(workers=4), quiet=True)
    assert asked == [2]  # 2 tasks: 2 workers, not 4


def test_timeouts_without_a_cluster_are_one_line(tmp_path):
    code, out, err = _finish(_refimpl("track", "--dets", str(DEMO / "det" / "det.txt"), "--out",
                                      str(tmp_path / "x.txt"), "--worker-timeout", "5"))
    assert "--connect-timeout and --worker-timeout are for a Dask run" in _one_error_line(code, err)


# -- faults during a run -------------------------------------------------------------------------

def test_a_scheduler_lost_mid_run_is_one_line_and_writes_nothing(inputs, cluster, tmp_path):
    c = cluster(1)
    run = _track(inputs, tmp_path / "out", "--scheduler", c.address)
    c.busy_worker(run)  # a task is running
    c.scheduler.kill()
    code, out, err = _finish(run)
    line = _one_error_line(code, err)
    assert f"lost the Dask scheduler at {c.address} while running Cut" in line
    assert out == "" and not (tmp_path / "out").exists()


def test_every_worker_lost_mid_run_is_one_line_after_the_worker_timeout(inputs, cluster, tmp_path):
    c = cluster(2)
    run = _track(inputs, tmp_path / "out", "--scheduler", c.address, "--worker-timeout", "2")
    c.busy_worker(run)
    for worker in c.workers:
        worker.kill()
    code, out, err = _finish(run)
    line = _one_error_line(code, err)
    assert f"the Dask scheduler at {c.address} has had no worker for 2 s (none joined, or every one was lost)" in line
    assert out == "" and not (tmp_path / "out").exists()


def test_a_cluster_without_workers_is_one_line_after_the_worker_timeout(inputs, cluster, tmp_path):
    c = cluster(0)
    code, out, err = _finish(_track(inputs[-1:], tmp_path / "out", "--scheduler", c.address, "--worker-timeout", "1"))
    assert "has had no worker for 1 s" in _one_error_line(code, err)
    assert not (tmp_path / "out").exists()


def test_a_worker_killed_among_two_changes_no_byte(inputs, serial, cluster, tmp_path):
    c = cluster(2)
    run = _track(inputs, tmp_path / "out", "--scheduler", c.address)
    busy = c.busy_worker(run)
    c.workers[busy].kill()  # its task is lost and re-run on the other worker
    assert run.poll() is None  # killed mid-run
    code, out, err = _finish(run)
    assert code == 0, err
    assert {p.name: p.read_bytes() for p in sorted((tmp_path / "out").iterdir())} == serial
    assert out.count(" -> ") == 3


def test_a_task_whose_worker_dies_is_one_line(monkeypatch):
    # os._exit kills the worker running it; with no retry allowed (Dask's allowed-failures, 3 by
    # default, 0 here: the embedded scheduler reads it from this process's config) the task is
    # Dask's KilledWorker at its first death (one task: one worker is started)
    import dask
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        with pytest.raises(ClusterError, match=r"^seq-A: every worker that ran it died \(1 try on the local Dask "
                                               r"cluster\): crashed or killed"):
            run_tasks(os._exit, [3], Plan(workers=2), quiet=True, describe=lambda n: {3: "seq-A"}[n])


# -- progress ------------------------------------------------------------------------------------

class _Bar:
    """Records what run_tasks tells its progress bar."""

    made: list["_Bar"] = []

    def __init__(self, total, label, enabled=True, unit="it"):
        self.total, self.unit, self.events = total, unit, []
        _Bar.made.append(self)

    def step(self, what="", n=1):
        self.events.append(("step", what, n))

    def describe(self, what):
        self.events.append(("describe", what))

    def close(self):
        self.events.append(("close",))


def _frames(item, tick):
    """A task of ``item[1]`` frames that ticks ``item[2]`` times (module level: workers import it)."""
    for _ in range(item[2]):
        tick()
    return item[0]


def test_a_serial_run_advances_its_bar_per_frame(monkeypatch):
    monkeypatch.setattr(scaleout, "Progress", _Bar)
    _Bar.made.clear()
    items = [("a", 3, 3), ("b", 2, 1), ("c", 1, 5)]  # b ticks once of 2 frames, c five times of 1
    assert run_tasks(_frames, items, quiet=False, describe=lambda it: it[0], steps=lambda it: it[1]) == ["a", "b", "c"]
    (bar,) = _Bar.made
    assert (bar.total, bar.unit) == (6, "frame")  # 3 + 2 + 1 frames
    # a: three ticks; b: one tick, then its second frame when it returns; c: one tick counted of five
    assert bar.events == [("describe", "a"), ("step", "", 1), ("step", "", 1), ("step", "", 1),
                          ("describe", "b"), ("step", "", 1), ("step", "", 1),
                          ("describe", "c"), ("step", "", 1), ("close",)]


def test_a_cluster_run_advances_its_bar_by_each_tasks_frames(monkeypatch):
    monkeypatch.setattr(scaleout, "Progress", _Bar)
    _Bar.made.clear()
    items = [("a", 3, 3), ("b", 2, 2)]
    # serial_below=0: a cluster for these 5 frames (the scale-out rule would run them serially)
    assert run_tasks(_frames, items, Plan(workers=2, serial_below=0), describe=lambda it: it[0],
                     steps=lambda it: it[1]) == ["a", "b"]
    (bar,) = _Bar.made
    assert bar.total == 5
    steps = sorted(e for e in bar.events if e[0] == "step")  # tasks finish in any order
    assert steps == [("step", "a", 3), ("step", "b", 2)] and bar.events[-1] == ("close",)


# -- Ctrl-C ----------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def long_inputs(tmp_path_factory) -> list[str]:
    """Two sequence folders LongK with TUD-Campus's 71 frames repeated 60 times (4,260 frames, frame
    f of copy k numbered f + 71 k): two tasks of 2-4 s each with CP-SAT (at ~1,500-2,000 frames per
    second), long enough to be interrupted while the workers run them (15 copies were 0.5-0.7 s,
    which the interrupt, half a second after the workers appear, sometimes missed)."""
    root = tmp_path_factory.mktemp("long")
    lines = (DEMO / "det" / "det.txt").read_text().splitlines()
    paths = []
    for k in (1, 2):
        det = root / f"Long{k}" / "det" / "det.txt"
        det.parent.mkdir(parents=True)
        rows = []
        for copy in range(60):
            for line in lines:
                frame, rest = line.split(",", 1)
                rows.append(f"{int(frame) + 71 * copy},{rest}\n")
        det.write_text("".join(rows))
        info = (DEMO / "seqinfo.ini").read_text()
        info = info.replace("name=TUD-Campus\n", f"name=Long{k}\n").replace("seqLength=71\n", "seqLength=4260\n")
        (det.parent.parent / "seqinfo.ini").write_text(info)
        paths.append(str(det))
    return paths


def _children(pid: int) -> list[str]:
    return subprocess.run(["pgrep", "-P", str(pid)], capture_output=True, text=True).stdout.split()


def test_ctrl_c_on_a_local_cluster_is_the_commands_one_line(long_inputs, tmp_path):
    # a Ctrl-C reaches the whole process group, the forked workers included: they ignore it
    # (refimpl.runs.worker_start) and the command closes its cluster, says one line and
    # exits 130, writing nothing (before, every worker printed its KeyboardInterrupt traceback)
    import signal
    run = subprocess.Popen([sys.executable, "-m", "refimpl", "track", "--backend", "cpsat", "--dets", *long_inputs,
                            "--out-dir", str(tmp_path / "out"), "--quiet", "--workers", "2", "--serial-below", "0"],
                           cwd=REPO, env=ENV, text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           start_new_session=True, preexec_fn=as_from_a_terminal(signal.SIGINT))
    deadline = time.monotonic() + 120
    while run.poll() is None and time.monotonic() < deadline and len(_children(run.pid)) < 2:
        time.sleep(0.1)  # until both workers exist
    time.sleep(0.5)  # their first task begun (not a measurement: any moment while they run must do)
    workers = _children(run.pid)
    assert run.poll() is None and len(workers) >= 2, "the run ended (or lost its workers) before the interrupt"
    os.killpg(run.pid, signal.SIGINT)
    code, out, err = _finish(run)
    assert (code, err.splitlines()) == (130, ["refimpl: interrupted"]), (code, err)
    assert out == "" and not (tmp_path / "out").exists()
    assert not [w for w in workers if Path(f"/proc/{w}").exists()]  # the workers are gone too
