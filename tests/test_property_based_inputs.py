"""Property-based tests (hypothesis) of the readers, the pipe and the library API (issue 37): any
input is tracked or refused in one line, never a traceback (tests/properties.py says what is
generated and checked).  Bounded here (REFIMPL_PROPERTY_EXAMPLES examples each, default 40, a
deadline per input); tests/tools/properties.py runs them longer and counts (docs/robustness.md).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest

pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402

import properties as prop  # noqa: E402

EXAMPLES = int(os.environ.get("REFIMPL_PROPERTY_EXAMPLES", "40"))
BOUNDED = settings(max_examples=EXAMPLES, deadline=5000, derandomize=True,
                   suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


@BOUNDED
@given(prop.MOT_TEXT)
def test_any_motchallenge_file_is_read_or_refused_in_one_line(text):
    with tempfile.TemporaryDirectory() as folder:
        assert prop.check_file(text, Path(folder), "mot") in ("tracked", "refused")


@BOUNDED
@given(prop.KITTI_TEXT)
def test_any_kitti_file_is_read_or_refused_in_one_line(text):
    with tempfile.TemporaryDirectory() as folder:
        assert prop.check_file(text, Path(folder), "kitti") in ("tracked", "refused")


@BOUNDED
@given(prop.MOT_TEXT)
def test_any_pipe_is_read_or_refused_in_one_line(text):
    assert prop.check_pipe(text) in ("tracked", "refused")


@BOUNDED
@given(prop.FRAMES)
def test_any_frames_given_to_update_are_tracked_or_refused_in_one_line(frames):
    assert prop.check_api(frames) in ("tracked", "refused")


def test_the_checks_tell_a_refusal_from_a_tracked_input(tmp_path):
    # a well-formed row is read; a row with a negative width is refused (one line); on the API
    # a (2, 4) array (no score) is refused and a (1, 5) frame is tracked: the checks can say both
    good = "1,-1,10,20,30,40,0.9,-1,-1,-1\n"
    assert prop.check_file(good, tmp_path, "mot") == "tracked" == prop.check_pipe(good)
    bad = "1,-1,10,20,-30,40,0.9,-1,-1,-1\n"
    assert prop.check_file(bad, tmp_path, "mot") == "refused" == prop.check_pipe(bad)
    import numpy as np
    assert prop.check_api([np.zeros((2, 4))]) == "refused"
    assert prop.check_api([np.array([[10.0, 10.0, 50.0, 90.0, 0.9]])]) == "tracked"
