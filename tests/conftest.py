"""Shared fixtures: paths to the repository's examples and the shared benchmark data."""

from __future__ import annotations

from pathlib import Path

import pytest

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
