"""The start-up benchmark's input: the first frame of a detections file (refimpl.experiments.bench_startup)."""

from __future__ import annotations

from refimpl.experiments.bench_startup import first_frame


def test_first_frame_keeps_exactly_the_lines_of_the_files_first_frame(tmp_path):
    # KITTI-style lines (frame first): frame 0 has two detections, frame 1 one; a blank line is skipped
    src = tmp_path / "0000.txt"
    src.write_text("0,2,1,2,3,4,9.5\n0,2,5,6,7,8,8.0\n\n1,2,1,2,3,4,9.1\n")
    out = tmp_path / "one.txt"
    assert first_frame(str(src), out) == 2
    assert out.read_text() == "0,2,1,2,3,4,9.5\n0,2,5,6,7,8,8.0\n"


def test_the_first_frame_is_the_first_lines_frame_even_when_it_is_not_zero(tmp_path):
    src = tmp_path / "seq.txt"
    src.write_text("7,2,1,2,3,4,9.5\n8,2,1,2,3,4,9.1\n7,2,9,9,3,4,9.0\n")
    out = tmp_path / "one.txt"
    # frame 7 is the first line's; its two lines are kept in file order, frame 8 is dropped
    assert first_frame(str(src), out) == 2
    assert out.read_text() == "7,2,1,2,3,4,9.5\n7,2,9,9,3,4,9.0\n"
