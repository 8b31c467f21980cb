"""What a user setting refimpl up meets on the command line (issue 36): `refimpl --version`;
`track --fps`, the frame rate of a video whose file does not say it, for every format and for a
pipe (a rate that is no frame rate ends in one error line, exit 2); `solve --example NAME`, a
frame the package ships, from any folder."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

import refimpl
from refimpl.cli import main

REPO = Path(__file__).resolve().parent.parent
DEMO = REPO / "data" / "demo" / "TUD-Campus"


def test_version_names_the_package_version(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out == f"refimpl {refimpl.__version__}\n"
    # the one place the version is spelled: pyproject reads it from refimpl/__init__.py
    assert re.search(r'^dynamic = \["version"\]', (REPO / "pyproject.toml").read_text(), re.M)


@pytest.mark.parametrize("value", ["-1", "0", "inf", "nan", "fast", "0.01", "1e300"])
def test_a_rate_that_is_no_frame_rate_is_one_error_line(value, capsys, tmp_path):
    with pytest.raises(SystemExit) as exit_:
        main(["track", "--dets", str(DEMO / "det" / "det.txt"), "--out", str(tmp_path / "o.txt"), "--fps", value])
    assert exit_.value.code == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if "error" in line]
    assert len(errors) == 1 and "--fps" in errors[0] and value in errors[0]
    assert not (tmp_path / "o.txt").exists()


def _track(tmp_path, name, argv) -> bytes:
    out = tmp_path / name
    assert main(["track", *argv, "--out", str(out), "--quiet"]) == 0
    return out.read_bytes()


def test_fps_on_a_kitti_file(shared_data, tmp_path):
    # KITTI files are 10 fps: --fps 10 is what track assumes.  At --fps 1 a halt may last
    # round(10 s * 1) = 10 frames instead of 100 (lost_after_hidden_max), so tracks hidden longer
    # on Car 0001 are lost and restart: other rows.
    dets = ["--dets", str(shared_data / "KITTI/tracking/training/det_02_pointrcnn/Car/0001.txt"), "--format",
            "kitti", "--class", "Car"]
    default = _track(tmp_path, "default.txt", dets)
    assert _track(tmp_path, "ten.txt", [*dets, "--fps", "10"]) == default
    assert _track(tmp_path, "one.txt", [*dets, "--fps", "1"]) != default


def test_fps_on_a_mot_file_without_seqinfo_is_the_seqinfo_rate(tmp_path, capsys):
    # the demo's det.txt alone, told what its seqinfo.ini says (640 x 480, 25 fps), writes the
    # bytes of the run beside seqinfo.ini
    alone = tmp_path / "det.txt"
    alone.write_bytes((DEMO / "det" / "det.txt").read_bytes())
    with_seqinfo = _track(tmp_path, "seqinfo.txt", ["--dets", str(DEMO / "det" / "det.txt")])
    told = _track(tmp_path, "told.txt", ["--dets", str(alone), "--img-size", "640,480", "--fps", "25"])
    assert told == with_seqinfo


def test_fps_on_a_pipe_is_the_file_runs_fps(shared_data, tmp_path):
    path = shared_data / "KITTI/tracking/training/det_02_pointrcnn/Car/0001.txt"
    kitti = ["--format", "kitti", "--class", "Car", "--fps", "1"]
    filed = _track(tmp_path, "file.txt", ["--dets", str(path), *kitti])
    piped = subprocess.run([sys.executable, "-m", "refimpl", "track", "--dets", "-", *kitti, "--out", "-", "--quiet"],
                           input=path.read_bytes(), capture_output=True, cwd=REPO, check=True).stdout
    # a pipe ends at its last detection's frame; the file runs to label_02's frame count: the pipe's
    # rows are the file's rows
    assert len(piped) > 1000 and filed.startswith(piped)


def test_baseline_refuses_fps(capsys):
    assert main(["track", "--dets", str(DEMO / "det" / "det.txt"), "--backend", "baseline", "--fps", "25",
                 "--out", "unused.txt"]) == 2
    assert "--fps" in capsys.readouterr().err


def test_solve_example_names_a_shipped_frame_from_any_folder(tmp_path, monkeypatch, capsys):
    assert main(["solve", str(REPO / "data" / "examples" / "bus_t235.lp"), "--json"]) == 0
    by_path = json.loads(capsys.readouterr().out)
    monkeypatch.chdir(tmp_path)  # an empty folder: data/examples/ is not here
    assert main(["solve", "--example", "bus_t235", "--json"]) == 0
    by_name = json.loads(capsys.readouterr().out)
    by_path.pop("solve_ms"), by_name.pop("solve_ms")
    assert by_name == by_path and "halt(trk_13)" in by_name["actions"]


@pytest.mark.parametrize("argv", [[], ["x.lp", "--example", "bus_t235"]])
def test_solve_takes_a_file_or_an_example(argv, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["solve", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err == ("refimpl solve: error: give either a fact FILE or --example NAME "
                   "(bus_t235, bus_t268, kitti_0020_t79, resume_t20)")
