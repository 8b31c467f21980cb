"""The start-up benchmark's input: the first frame of a detections file (refimpl.experiments.bench_startup)."""

from __future__ import annotations

import pytest

from refimpl.experiments.bench_startup import first_frame


@pytest.mark.parametrize("lines, kept", [
    # KITTI-style lines (frame first): frame 0 has two detections, frame 1 one; a blank line is skipped
    ("0,2,1,2,3,4,9.5\n0,2,5,6,7,8,8.0\n\n1,2,1,2,3,4,9.1\n", "0,2,1,2,3,4,9.5\n0,2,5,6,7,8,8.0\n"),
    # frame 7 is the first line's, although frame 8 comes between them: its two lines
    # are kept in file order, frame 8 is dropped
    ("7,2,1,2,3,4,9.5\n8,2,1,2,3,4,9.1\n7,2,9,9,3,4,9.0\n", "7,2,1,2,3,4,9.5\n7,2,9,9,3,4,9.0\n"),
])
def test_first_frame_keeps_exactly_the_lines_of_the_first_lines_frame(tmp_path, lines, kept):
    src, out = tmp_path / "seq.txt", tmp_path / "one.txt"
    src.write_text(lines)
    assert first_frame(str(src), out) == kept.count("\n")
    assert out.read_text() == kept
