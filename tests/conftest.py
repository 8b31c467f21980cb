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


@pytest.fixture(scope="session")
def data_root_with_val(shared_data, tmp_path_factory):
    """make(*sequences): a benchmark data root whose KITTI val split (kitti-*-val) is the given
    training sequences and its train split (kitti-*-train) the other ones: the shared MOT15 and
    KITTI files linked, only KITTI's val seqmap its own.  A test that needs the benchmark commands'
    code on a few KITTI sequences runs them on these instead of the 11 of the shared split."""
    shared = shared_data / "KITTI" / "tracking" / "training"

    def make(*sequences: str) -> Path:
        root = tmp_path_factory.mktemp("data_root")
        training = root / "KITTI" / "tracking" / "training"
        training.mkdir(parents=True)
        for sub in ("det_02_pointrcnn", "label_02"):
            (training / sub).symlink_to(shared / sub, target_is_directory=True)
        (root / "MOT15").symlink_to(shared_data / "MOT15", target_is_directory=True)
        # the seqmap's line: name, 'empty', first and one past the last frame (only the name is read)
        lines = []
        for s in sequences:
            last = max(int(line.split()[0]) for line in (shared / "label_02" / f"{s}.txt").read_text().splitlines())
            lines.append(f"{s} empty 000000 {last + 1:06d}\n")
        (training / "evaluate_tracking.seqmap.val").write_text("".join(lines))
        return root

    return make
