"""Shared fixtures: paths to the repository's examples and the shared benchmark data."""

from __future__ import annotations

from pathlib import Path

import pytest

from refimpl.solvers import BACKENDS, LIBRARIES

REPO = Path(__file__).resolve().parent.parent
EXAMPLES = REPO / "data" / "examples"
SHARED_DATA = REPO.parent / "shared" / "data"


@pytest.fixture
def examples() -> Path:
    return EXAMPLES


@pytest.fixture(scope="session")
def shared_data() -> Path:
    if not (SHARED_DATA / "MOT15").is_dir():
        pytest.skip(f"benchmark data not found at {SHARED_DATA} (clone with ../shared beside it)")
    return SHARED_DATA


@pytest.fixture(params=BACKENDS)
def backend(request) -> str:
    """Every abduction backend of the registry (refimpl.solvers.BACKENDS): a test that takes this
    fixture runs once per backend, so a new backend is tested by registering it; skipped where the
    backend's library is not installed."""
    pytest.importorskip(LIBRARIES[request.param])
    return request.param


@pytest.fixture(scope="session")
def kitti_car_0011(tmp_path_factory) -> dict[str, Path]:
    """KITTI Car 0011 tracked once per session with the abduction tracker, as the issue's command
    does (cpsat, the KITTI Car preset): {"results": KITTI tracking-format results, "scene": the
    scene file, "label": the ground truth}; skipped without the shared data."""
    training = SHARED_DATA / "KITTI" / "tracking" / "training"
    dets = training / "det_02_pointrcnn" / "Car" / "0011.txt"
    if not dets.is_file():
        pytest.skip(f"benchmark data not found at {SHARED_DATA} (clone with ../shared beside it)")
    from refimpl.cli import main
    out = tmp_path_factory.mktemp("kitti_car_0011")
    files = {"results": out / "trackers" / "refimpl" / "data" / "0011.txt", "scene": out / "0011.scene.json",
             "label": training / "label_02" / "0011.txt"}
    assert main(["track", "--dets", str(dets), "--format", "kitti", "--class", "Car", "--backend", "cpsat",
                 "--out", str(files["results"]), "--out-format", "kitti", "--scene", str(files["scene"]),
                 "--quiet"]) == 0
    return files
