"""SIGINT (issue 17, case 4): a real Ctrl-C ends a long command within a second or two, exit 130,
one line, and leaves neither an output file nor a temporary file behind.

Every tracker of the registry is interrupted inside its tracking loop (clingo then solves in this
process: it moves to its worker process after 500 solves, too late for a short test; an interrupt
there, and inside one long clingo or CP-SAT solve call: tests/test_tiebreak.py, test_sigint_*).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from refimpl.solvers import TRACKERS

from refimpl.experiments.walkers import write_sequence
from tools.signals import started_with

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def long_dets(tmp_path_factory) -> Path:
    # 4,000 frames x 20 walkers: the baseline needs ~10 s, cpsat ~30 s: long enough to interrupt
    return write_sequence(tmp_path_factory.mktemp("seq") / "LONG", 4000, 20, seed=0)


def _start(dets: Path, out_dir: Path, backend: str, sig: int, action=signal.SIG_DFL) -> subprocess.Popen:
    """`refimpl track` on ``dets``, started with ``action`` for ``sig`` (the default: as from a
    terminal, whatever this test's runner inherited: tools.signals), once it is inside its
    tracking loop."""
    out_dir.mkdir()
    argv = [sys.executable, "-m", "refimpl", "track", "--dets", str(dets), "--backend", backend,
            "--out", str(out_dir / "res.txt"), "--events", str(out_dir / "ev.lp"),
            "--events-json", str(out_dir / "ev.jsonl")]
    proc = subprocess.Popen(argv, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=started_with(action, sig))
    deadline = time.monotonic() + 60
    # the staged temporary files appear when tracking starts (after imports and reading)
    while len(list(out_dir.iterdir())) < 3:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline
        time.sleep(0.05)
    time.sleep(0.5)  # well inside the tracking loop
    assert proc.poll() is None
    return proc


def _interrupt(dets: Path, out_dir: Path, backend: str, sig: int = signal.SIGINT) -> tuple[int, float, str]:
    proc = _start(dets, out_dir, backend, sig)
    sent = time.monotonic()
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=30)
    return proc.returncode, time.monotonic() - sent, err


@pytest.mark.parametrize("backend", TRACKERS)
def test_sigint_ends_track_at_once_with_130_and_no_output(long_dets, tmp_path, backend):
    if backend == "clingo":
        pytest.importorskip("clingo")
    code, secs, err = _interrupt(long_dets, tmp_path / "out", backend)
    assert code == 130, err
    assert secs < 2.0, secs
    assert [line for line in err.splitlines() if not line.startswith(("refimpl: warning", "refimpl track: warning", "refimpl track: note:"))] == ["refimpl: interrupted"]
    assert os.listdir(tmp_path / "out") == []  # no results, no event log, no temporary file


def test_sigterm_ends_track_like_sigint_with_143(long_dets, tmp_path):
    # `kill PID` (SIGTERM) used to end the process at once by default, leaving the staged
    # temporary files (.res.txt.XXXX.tmp) behind in the output folder
    code, secs, err = _interrupt(long_dets, tmp_path / "out", "baseline", signal.SIGTERM)
    assert code == 143, err
    assert secs < 2.0, secs
    assert [line for line in err.splitlines() if not line.startswith(("refimpl: warning", "refimpl track: note:"))] == ["refimpl: terminated"]
    assert os.listdir(tmp_path / "out") == []


@pytest.mark.parametrize("sig, code", [(signal.SIGHUP, 129), (signal.SIGQUIT, 131)])
def test_sighup_and_sigquit_end_track_like_sigterm(long_dets, tmp_path, sig, code):
    # their default ended the process at once and left .res.txt.XXXX.tmp beside the output
    # (issue 37); handled as SIGTERM now, exit 128 + the signal's number
    got, _, err = _interrupt(long_dets, tmp_path / "out", "baseline", sig)
    assert got == code, err
    assert [line for line in err.splitlines() if not line.startswith(("refimpl: warning", "refimpl track: note:"))] == ["refimpl: terminated"]
    assert os.listdir(tmp_path / "out") == []


def test_a_run_under_nohup_keeps_running_on_sighup(long_dets, tmp_path):
    # nohup starts a command with SIGHUP ignored so that closing the terminal does not end it;
    # refimpl handles only signals at their default action, so the ignored SIGHUP stays ignored
    # and the run goes on; a later SIGTERM still ends it cleanly (143, no output left behind)
    proc = _start(long_dets, tmp_path / "out", "baseline", signal.SIGHUP, signal.SIG_IGN)
    proc.send_signal(signal.SIGHUP)
    time.sleep(1.0)  # the baseline needs ~10 s for the whole sequence: still tracking
    assert proc.poll() is None
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 143, err
    assert os.listdir(tmp_path / "out") == []


def test_an_interrupt_landing_in_a_finalizer_is_delivered_again_after_it():
    # clingo's Control.__del__ swallowed a KeyboardInterrupt raised inside it ("Exception ignored
    # in"), so 2 of ~40 Ctrl-Cs of a clingo `track` were lost and the run went on to its end.
    # Here a finalizer is interrupted: the handler must hand the signal on to the code after it.
    from refimpl.cli import _interrupt_handler

    class Finalized:
        def __del__(self):
            os.kill(os.getpid(), signal.SIGINT)
            for _ in range(1000):  # the handler runs inside this loop, i.e. inside __del__
                time.sleep(0.0001)

    old = signal.signal(signal.SIGINT, _interrupt_handler(KeyboardInterrupt))
    try:
        obj = Finalized()
        with pytest.raises(KeyboardInterrupt):
            del obj  # the finalizer runs and ends normally...
            time.sleep(2.0)  # ...and the interrupt arrives here, 10 ms later
    finally:
        signal.signal(signal.SIGINT, old)
