"""Many sequences at once: serial, on an embedded 2-worker cluster and on a cluster started with
the `dask scheduler` / `dask worker` commands write the same bytes."""

from __future__ import annotations

import contextlib
import gc
import io as stdio
import json
import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest

from refimpl import cli
from refimpl.runs.tasks import results_file_name

REPO = Path(__file__).resolve().parent.parent
DEMO = REPO / "data" / "demo" / "TUD-Campus"


def run_cli(argv):
    out, err = stdio.StringIO(), stdio.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(argv)
    return code, out.getvalue(), err.getvalue()


def _track(inputs, out_dir, *extra):
    code, out, err = run_cli(["track", "--backend", "cpsat", "--dets", *inputs, "--out-dir", str(out_dir),
                              "--quiet", *extra])
    assert code == 0, err
    return out


def _files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def _cut(path: Path, last: int) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("".join(line + "\n" for line in (DEMO / "det" / "det.txt").read_text().splitlines()
                            if int(line.split(",")[0]) <= last))


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """Three small sequences, the longest first so that with two workers a later task finishes
    first: TUD-Campus (71 frames), its first 40 frames in a sequence folder Cut40/det/det.txt and
    its first 20 as a KITTI-style stem 0007.txt."""
    root = tmp_path_factory.mktemp("inputs")
    _cut(root / "Cut40" / "det" / "det.txt", 40)
    _cut(root / "Car" / "0007.txt", 20)
    return [str(DEMO / "det" / "det.txt"), str(root / "Cut40" / "det" / "det.txt"), str(root / "Car" / "0007.txt")]


@pytest.fixture(scope="module")
def serial(inputs, tmp_path_factory):
    """The serial run: its stdout and its files."""
    out_dir = tmp_path_factory.mktemp("serial")
    return _track(inputs, out_dir), _files(out_dir), out_dir


def test_results_file_names():
    assert results_file_name("/d/MOT15/train/TUD-Campus/det/det.txt") == "TUD-Campus.txt"
    assert results_file_name("/d/MOT15/train/TUD-Campus/det/det_sort_frcnn.txt") == "TUD-Campus.txt"
    assert results_file_name("/d/det_02_pointrcnn/Car/0011.txt") == "0011.txt"
    assert results_file_name("somewhere/run.txt") == "run.txt"


def test_the_serial_files(inputs, serial, tmp_path):
    _, files, _ = serial
    assert sorted(files) == ["0007.txt", "Cut40.txt", "TUD-Campus.txt"]
    # the one-file run writes the same bytes as the many-file run reading each file alone (the
    # default run calibrates each file's scores on the others too, docs/model.md 3.19: its
    # TUD-Campus rows are the run's own)
    assert run_cli(["track", "--backend", "cpsat", "--dets", inputs[0], "--out", str(tmp_path / "one.txt"),
                    "--quiet"])[0] == 0
    _track(inputs, tmp_path / "apart", "--pool-scores", "no")
    apart = _files(tmp_path / "apart")
    assert (tmp_path / "one.txt").read_bytes() == apart["TUD-Campus.txt"]
    files = apart
    # tracking is online up to a fixed delay (AbductionTracker.delay): the MOT preset fills an
    # occlusion episode of up to fill_hidden = 30 frames once the track is confirmed again,
    # min_hits = 3 updates later, so a frame's rows are final 33 frames later (the backfilled
    # confirmation reaches back 3, bridged gaps 2); a sequence cut after frame 40 has the full run's
    # rows of frames 1..7 (the one cut after frame 20 has no frame final yet)
    for name, last in (("Cut40.txt", 40),):
        def upto(text, f=last - 33):
            return [r for r in text.decode().splitlines() if int(r.split(",")[0]) <= f]
        assert upto(files[name]) == upto(files["TUD-Campus.txt"]) != []


def test_two_local_workers_write_the_same_bytes(inputs, serial, tmp_path):
    stdout, files, out_dir = serial
    # --serial-below 0: a real cluster for these few frames (the rule would track them serially)
    parallel = _track(inputs, tmp_path / "par", "--workers", "2", "--serial-below", "0")
    assert _files(tmp_path / "par") == files
    assert parallel.replace(str(tmp_path / "par"), str(out_dir)) == stdout


def test_a_warning_said_in_a_worker_reaches_the_user_in_input_order(inputs, tmp_path):
    # --img-size 10,10: frame 1 of each input (TUD-Campus, and Cut40 and 0007, its first 40 and 20
    # frames) has 6 detections, every one centred outside a 10 x 10 image. Serially and on two local
    # workers (whose stderr is not the user's) alike: one line per sequence, named, in input order.
    for extra in ([], ["--workers", "2", "--serial-below", "0"]):
        code, _, err = run_cli(["track", "--backend", "cpsat", "--dets", *inputs, "--out-dir",
                                str(tmp_path / str(len(extra))), "--quiet", "--img-size", "10,10", *extra])
        assert code == 0, err
        said = [line for line in err.splitlines() if "centred outside" in line]
        assert [line.split(": frame 1: ")[0] for line in said] == [
            "refimpl: warning: TUD-Campus", "refimpl: warning: Cut40", "refimpl: warning: 0007"], said
        assert all("frame 1: 6 detection(s) centred outside the 10 x 10 image" in line for line in said)


def test_the_scale_out_rule_runs_small_work_serially():
    from refimpl.runs.scaleout import LOCAL_MIN_FRAMES_PER_WORKER, Plan, run_tasks
    two = Plan(workers=2)
    assert two.frames_threshold == 2 * LOCAL_MIN_FRAMES_PER_WORKER
    assert two.serial_for(2 * LOCAL_MIN_FRAMES_PER_WORKER - 1) and not two.serial_for(2 * LOCAL_MIN_FRAMES_PER_WORKER)
    assert not two.serial_for(None)  # tasks not counted in frames (diff, calibrate): the cluster
    assert not Plan(workers=2, serial_below=0).serial_for(1)
    assert not Plan(scheduler="tcp://127.0.0.1:1").serial_for(1)  # an existing cluster is always used
    assert Plan().serial_for(10 ** 9)  # no cluster asked for
    with pytest.raises(ValueError, match="serial_below"):
        Plan(workers=2, serial_below=-1)
    # three tasks of 1,200 frames each with two workers: 3,600 < 2 x 2,000 frames, so they run in
    # this process (a cluster could not even pickle the lambda), one tick per frame reaching the bar
    ticks = []

    def task(item, tick):
        for _ in range(item):
            tick()
        ticks.append(item)
        return os.getpid()

    assert LOCAL_MIN_FRAMES_PER_WORKER == 2000  # the numbers of this test
    pids = run_tasks(task, [1200, 1200, 1200], two, quiet=True, steps=lambda item: item)
    assert pids == [os.getpid()] * 3 and ticks == [1200, 1200, 1200]


def _worker_state(item):
    return item, os.getpid(), gc.get_freeze_count() > 0, signal.getsignal(signal.SIGINT) == signal.SIG_IGN


def test_embedded_workers_freeze_what_they_inherit_and_leave_ctrl_c_to_the_command():
    # refimpl.runs.worker_start runs in each forked worker: gc.freeze() (the inherited heap
    # is not visited, so not copied, by the worker's collections) and SIGINT ignored; the command's
    # own process is left as it was (nothing frozen, its Ctrl-C handler kept).  Each item travels
    # pickled (scaleout.call_pickled) and comes back as it went.
    from refimpl.runs.scaleout import Plan, run_tasks
    before = gc.get_freeze_count(), signal.getsignal(signal.SIGINT)
    out = run_tasks(_worker_state, [("a", 1), ("b", 2)], Plan(workers=2), quiet=True)
    assert [item for item, *_ in out] == [("a", 1), ("b", 2)]
    assert all(pid != os.getpid() and frozen and ignored for _, pid, frozen, ignored in out)
    assert (gc.get_freeze_count(), signal.getsignal(signal.SIGINT)) == before


def test_a_cluster_started_with_the_dask_commands_writes_the_same_bytes(inputs, serial, tmp_path):
    if shutil.which("dask") is None:
        pytest.skip("the dask command is not installed")
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    sched_file = tmp_path / "scheduler.json"
    procs = []
    try:
        procs.append(subprocess.Popen(
            ["dask", "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
             "--scheduler-file", str(sched_file)], cwd=REPO, env=env,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        deadline = time.monotonic() + 20
        while not sched_file.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        address = json.loads(sched_file.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        for k in range(2):  # two worker processes of one thread (no nanny: fewer processes to start)
            procs.append(subprocess.Popen(
                ["dask", "worker", address, "--no-nanny", "--nthreads", "1", "--no-dashboard",
                 "--local-directory", str(tmp_path / f"worker{k}")], cwd=REPO, env=env,
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        from distributed import Client
        with Client(address, timeout=20) as client:
            client.wait_for_workers(2, timeout=30)
        _track(inputs, tmp_path / "remote", "--scheduler", address)
        assert _files(tmp_path / "remote") == serial[1]

        # results come back in input order although the first task finishes last: two workers,
        # task 0 sleeps 1.5 s while tasks 1 and 2 (no sleep) finish on the other worker
        from refimpl.runs.scaleout import Plan, run_tasks
        items = [["sleep", "1.5"], ["true"], ["echo"]]
        finished = []
        done = run_tasks(subprocess.run, items, Plan(scheduler=address), quiet=True,
                         describe=lambda item: finished.append(item[0]) or "")
        assert [r.args for r in done] == items
        assert finished[-1] == "sleep"
    finally:
        # one at a time, each worker before the scheduler: a worker sent SIGTERM while the scheduler
        # closes at the same moment could hang in its own close (distributed's CancelledError after
        # "scheduler connection broken") until it was killed, 10 s per worker in one run of two
        for p in reversed(procs):
            p.terminate()
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


def test_two_inputs_with_one_name_are_a_one_line_error(tmp_path):
    other = tmp_path / "elsewhere" / "TUD-Campus" / "det"
    other.mkdir(parents=True)
    shutil.copy(DEMO / "det" / "det.txt", other / "det.txt")
    code, out, err = run_cli(["track", "--dets", str(DEMO / "det" / "det.txt"), str(other / "det.txt"),
                              "--out-dir", str(tmp_path / "o")])
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "would both write" in err and "TUD-Campus.txt" in err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("argv, message", [
    (["--out", "x.txt", "--out-dir", "d"], "give --out FILE (one --dets) or --out-dir DIR"),
    (["--out", "x.txt", "--workers", "0"], "--workers must be >= 1"),
    (["--out", "x.txt", "--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "not both"),
    (["--out-dir", "d", "--serial-below", "100"], "--serial-below is for a local cluster: give --workers N"),
    (["--out-dir", "d", "--workers", "2", "--serial-below", "-1"], "--serial-below must be >= 0 frames"),
    (["--out-dir", "d", "--events", "e.lp"], "use them with --out"),
])
def test_track_option_mistakes(argv, message, tmp_path):
    code, _, err = run_cli(["track", "--dets", str(DEMO / "det" / "det.txt"), *argv])
    assert code == 2 and message in err and err.count("\n") == 1


def test_several_dets_need_out_dir():
    det = str(DEMO / "det" / "det.txt")
    code, _, err = run_cli(["track", "--dets", det, det, "--out", "x.txt"])
    assert code == 2 and "2 --dets need --out-dir" in err


def test_an_unreachable_scheduler_is_a_one_line_error(tmp_path, monkeypatch):
    from refimpl.runs import scaleout
    monkeypatch.setattr(scaleout, "DEFAULT_CONNECT_TIMEOUT", 1.0)  # nothing listens on port 9
    code, _, err = run_cli(["track", "--dets", str(DEMO / "det" / "det.txt"), "--out", str(tmp_path / "x.txt"),
                            "--scheduler", "tcp://127.0.0.1:9", "--quiet"])
    assert code == 2 and "cannot reach tcp://127.0.0.1:9" in err and err.count("\n") == 1
    assert not (tmp_path / "x.txt").exists()


def test_run_requests_regroups_tasks_per_request():
    # three requests on the bundled sequence, flattened into tasks and regrouped in order: the
    # first and third (both SORT) agree, and each equals scoring that tracker's rows directly
    import math

    from refimpl import io
    from refimpl.tracking.baseline import track_sequence as sort_track
    from refimpl.evaluation.evaluate import evaluate_many
    from refimpl.runs.scaleout import Plan
    from refimpl.experiments.benchmark_tasks import RunRequest, run_requests
    from refimpl.tracking.pipeline import Setup, run_sequence

    seq = io.demo_sequence_paths()
    dets, gt = io.load_detections(seq), io.load_ground_truth(seq)
    data = [(seq.name, dets, gt)]
    runs = run_requests([RunRequest("demo", data, "baseline"), RunRequest("demo", data, "cpsat"),
                         RunRequest("demo", data, "baseline")], Plan(), quiet=True)
    direct = [evaluate_many([(seq.name, gt, rows)])[1]
              for rows in (sort_track(dets), run_sequence(dets, Setup()).rows)]
    for run, expected in zip(runs, direct + direct[:1]):
        for key in ("mota", "idf1", "fp", "fn", "idsw", "num_gt"):
            a, b = run.overall[key], expected[key]
            assert a == b or (isinstance(a, float) and math.isnan(a) and math.isnan(b)), key
    assert runs[0].events == {} and sum(runs[1].events.values()) > 0
    assert [r.frames for r in runs] == [71, 71, 71]


def test_const_and_img_size_reach_every_sequence(inputs, serial, tmp_path):
    # conf_thresh_new_track=101 is above every confidence (0..100): no track starts in any sequence,
    # so every results file is empty; and --img-size changes nothing the default run wrote when it
    # equals TUD-Campus's seqinfo.ini (640x480) for the sequence that has one
    code, out, err = run_cli(["track", "--backend", "cpsat", "--dets", *inputs[:2], "--out-dir", str(tmp_path / "c"),
                              "--const", "conf_thresh_new_track=101", "--quiet"])
    assert code == 0, err
    assert [p.read_text() for p in sorted((tmp_path / "c").iterdir())] == ["", ""]
    assert out.count(" 0 tracks -> ") == 2
    code, _, err = run_cli(["track", "--backend", "cpsat", "--dets", *inputs, "--out-dir", str(tmp_path / "s"),
                            "--img-size", "640,480", "--quiet"])
    assert code == 0, err
    assert (tmp_path / "s" / "TUD-Campus.txt").read_bytes() == serial[1]["TUD-Campus.txt"]
