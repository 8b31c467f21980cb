"""The package as a user installs it (issue 36): a wheel that carries the model (model/*.lp,
presets.json) and the bundled data, and, installed, solves a shipped example and runs the demo
from an empty folder.  The wheel is built from a copy of the checkout (the build writes build/
and *.egg-info beside its sources) without build isolation (no download), and installed without
its dependencies into a folder put first on PYTHONPATH, so the installed copy is the one run.
A fresh venv with the dependencies is measured by hand (README, "Set up")."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent

pytest.importorskip("build")


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    src = tmp_path_factory.mktemp("src")
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(REPO / name, src / name)
    for name in ("refimpl", "model", "data"):
        shutil.copytree(REPO / name, src / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    dist = tmp_path_factory.mktemp("dist")
    subprocess.run([sys.executable, "-m", "build", "--wheel", "--no-isolation", "--outdir", str(dist), str(src)],
                   check=True, capture_output=True)
    (found,) = dist.glob("refimpl-*.whl")
    return found


def test_the_wheel_carries_the_model_and_the_bundled_data(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    for lp in (REPO / "model").glob("*.lp"):
        assert f"refimpl/model/{lp.name}" in names
    assert "refimpl/model/presets.json" in names and "refimpl/py.typed" in names
    for example in (REPO / "data" / "examples").glob("*.lp"):
        assert f"refimpl/data/examples/{example.name}" in names
    for part in ("det/det.txt", "gt/gt.txt", "seqinfo.ini"):
        assert f"refimpl/data/demo/TUD-Campus/{part}" in names


def test_installed_it_solves_a_shipped_example_and_runs_the_demo_from_an_empty_folder(wheel, tmp_path):
    site, empty = tmp_path / "site", tmp_path / "empty"
    empty.mkdir()
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target", str(site), str(wheel)],
                   check=True, capture_output=True)
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST")}
    env["PYTHONPATH"] = str(site)

    def run(*argv: str) -> str:
        return subprocess.run([sys.executable, *argv], cwd=empty, env=env, check=True, capture_output=True,
                              text=True).stdout

    assert run("-c", "import refimpl; print(refimpl.__file__)").startswith(str(site))
    answer = json.loads(run("-m", "refimpl", "solve", "--example", "bus_t235", "--json"))
    # the paper's bus frame (Section 4.1.1): the car trk_13 hides behind the bus trk_12 (docs/model.md)
    assert "halt(trk_13)" in answer["actions"] and "occurs_at(hides_behind(trk_13,trk_12),235)" in answer["events"]
    demo = run("-m", "refimpl", "demo", "--backends", "cpsat")
    assert demo.startswith("refimpl demo: TUD-Campus (71 frames") and "| TUD-Campus |" in demo
    assert list(empty.iterdir()) == []  # nothing written where it ran
