"""`refimpl track` imports only what tracking needs (issue 27, item 1: start-up).

A fresh interpreter runs the command line's ``main`` (what ``python -m refimpl`` runs) on a small
sequence and reports ``sys.modules``.  None of the heavy libraries that only other commands, other
backends or the scorers need may be in it: scipy.stats (2 s, via filterpy), pandas (via OR-Tools'
cp_model), matplotlib, Dask, clingo, motmetrics, TrackEval.  A set-membership test, not a timing
test: the time these imports cost is measured in docs/benchmarks.md ("Start-up").
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from refimpl import io
from refimpl.solvers.cpsat import CpSatSolver
from refimpl.tracking.pipeline import Setup, run_sequence

REPO = Path(__file__).resolve().parent.parent

NEVER = ("scipy.stats", "pandas", "matplotlib", "dask", "distributed", "clingo", "motmetrics", "trackeval",
         "filterpy")
"""Not on any tracking path (filterpy: refimpl.tracking.kalman replaced it; it is the tests' reference)."""

_SCRIPT = """
import json, sys
from refimpl.cli import main
code = main(sys.argv[1:])
print(json.dumps({"code": code, "modules": sorted(sys.modules)}))
"""


def _modules(args: list[str]) -> set[str]:
    """sys.modules after `refimpl ARGS` in a fresh interpreter started in this checkout."""
    out = subprocess.run([sys.executable, "-c", _SCRIPT, *args], cwd=REPO, capture_output=True, text=True,
                         check=True)
    report = json.loads(out.stdout.strip().splitlines()[-1])
    assert report["code"] == 0, out.stderr
    return set(report["modules"])


def _loaded(modules: set[str], package: str) -> list[str]:
    return sorted(m for m in modules if m == package or m.startswith(package + "."))


def _kitti_file(tmp_path: Path) -> Path:
    """Three frames of PointRCNN Car detections (frame,type,x1,y1,x2,y2,score,h,w,l,x,y,z,rot_y,alpha):
    two cars moving right by 4 px per frame."""
    lines = []
    for f in range(3):
        lines.append(f"{f},2,{100 + 4 * f}.0,170.0,{180 + 4 * f}.0,240.0,12.5,1.5,1.6,3.7,-5.0,1.6,20.0,-1.5,-1.3")
        lines.append(f"{f},2,{600 + 4 * f}.0,175.0,{700 + 4 * f}.0,260.0,11.0,1.5,1.6,3.9,2.0,1.6,15.0,-1.6,-1.4")
    path = tmp_path / "0000.txt"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_track_with_cpsat_imports_neither_scipy_stats_nor_pandas_nor_ortools(tmp_path):
    demo = io.demo_sequence_paths()
    # the precondition of "no OR-Tools": the fast path answers every frame of the demo, so CP-SAT
    # is never needed (a frame it declined would import ortools.sat.python.cp_model, legitimately);
    # --no-preset: the model's default constants and the default options, as here
    solver = CpSatSolver()
    seq = io.read_mot_detections(demo.dets_path)
    run_sequence(seq, Setup(), solver=solver)
    assert dict(solver.stats) == {"fast": len(seq.frames)}

    out = tmp_path / "a.txt"
    modules = _modules(["track", "--dets", str(demo.dets_path), "--backend", "cpsat", "--no-preset", "--out", str(out),
                        "--quiet"])
    assert out.read_text().count("\n") > 100  # it did track: TUD-Campus has 71 frames of 1 to 8 people
    assert "refimpl.tracking.tracker" in modules and "refimpl.solvers.fast_path" in modules  # the path ran here
    for package in NEVER + ("ortools", "scipy"):
        assert _loaded(modules, package) == [], f"`refimpl track --backend cpsat` imported {package}"


def test_track_kitti_imports_no_heavy_library(tmp_path):
    out = tmp_path / "a.txt"
    modules = _modules(["track", "--dets", str(_kitti_file(tmp_path)), "--format", "kitti", "--class", "Car",
                        "--backend", "cpsat", "--out", str(out), "--quiet"])
    assert out.read_text() != ""  # the first min_hits frames are written (SORT's start-up rule)
    for package in NEVER:
        assert _loaded(modules, package) == [], f"`refimpl track --format kitti` imported {package}"


@pytest.mark.parametrize("backend", ["baseline", "cpsat-full"])
def test_other_trackers_import_only_their_own_solver(tmp_path, backend):
    demo = io.demo_sequence_paths()
    out = tmp_path / "a.txt"
    modules = _modules(["track", "--dets", str(demo.dets_path), "--backend", backend, "--out", str(out), "--quiet"])
    assert out.read_text() != ""
    if backend == "baseline":  # SORT's Hungarian assignment is scipy.optimize.linear_sum_assignment
        assert "scipy.optimize" in modules
    else:  # the full model on every frame: OR-Tools is imported, and brings pandas with it
        assert "ortools.sat.python.cp_model" in modules
    allowed = {"pandas"} if backend == "cpsat-full" else set()
    for package in set(NEVER) - allowed:
        assert _loaded(modules, package) == [], f"`refimpl track --backend {backend}` imported {package}"
