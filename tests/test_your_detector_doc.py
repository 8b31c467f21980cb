"""docs/your-detector.md runs as it stands: its ```python blocks in one namespace and its ```sh
lines (``refimpl`` being this checkout's ``python -m refimpl``), in document order, in one empty
folder; then what the page says of them holds on the files they wrote."""

from __future__ import annotations

import contextlib
import io as stdio
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
DOC = REPO / "docs" / "your-detector.md"
BLOCK = re.compile(r"^```(python|sh)\n(.*?)^```$", re.S | re.M)


def _sh(line: str, cwd: Path) -> None:
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST")}
    env["PYTHONPATH"] = str(REPO) + os.pathsep + env.get("PYTHONPATH", "")
    shell = f'set -o pipefail\nrefimpl() {{ "{sys.executable}" -m refimpl "$@"; }}\n{line}'
    done = subprocess.run(["bash", "-c", shell], cwd=cwd, env=env, capture_output=True, text=True, timeout=300,
                          stdin=subprocess.DEVNULL)
    assert done.returncode == 0, f"{line}\n{done.stderr}"


def test_every_block_runs_and_the_four_ways_agree(tmp_path, monkeypatch):
    pytest.importorskip("supervision")
    blocks = BLOCK.findall(DOC.read_text(encoding="utf-8"))
    assert [lang for lang, _ in blocks].count("python") >= 4 and [lang for lang, _ in blocks].count("sh") >= 3
    monkeypatch.chdir(tmp_path)
    scope: dict = {}
    printed = stdio.StringIO()
    for lang, code in blocks:
        if lang == "python":
            with contextlib.redirect_stdout(printed):
                exec(compile(code, str(DOC), "exec"), scope)
        else:
            for line in code.splitlines():
                if line.strip():
                    _sh(line, tmp_path)
    out = printed.getvalue()
    # the array way ran the preset `track` runs on a det.txt, with the image's size
    assert "cpsat, preset mot/pedestrian, frame budget 25 ms (640, 480)" in out
    # the Detections way: every detection of the last frame has an id or -1, its class as it came (0)
    assert set(scope["tracked"].class_id) == {0} and len(scope["tracked"].tracker_id) == len(scope["tracked"])
    # the file the page writes holds the detector's floats bit for bit, so `track` on it writes the
    # rows the library wrote (same preset, image size and frame rate); the pipe writes them too
    tracks = (tmp_path / "tracks.txt").read_bytes()
    assert len(tracks.splitlines()) > 200
    assert (tmp_path / "file-tracks.txt").read_bytes() == tracks
    assert (tmp_path / "piped-tracks.txt").read_bytes() == tracks
    assert (tmp_path / "events.lp").read_text().count("occurs_at(") == len(scope["tracker"].events)
    for page in ("report.html", "file-report.html"):
        assert (tmp_path / page).read_text().lstrip().lower().startswith("<!doctype html")
