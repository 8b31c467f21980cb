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


@pytest.fixture
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
