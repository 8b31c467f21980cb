"""The start-up benchmark's input: the first frame of a detections file (benchmarks/bench_startup.py)."""

from __future__ import annotations

import time

import pytest

from benchmarks.bench_startup import first_frame, run_to_first_solve


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


def _kitti(tmp_path):
    """Two frames of one PointRCNN Car detection (frame,type,x1,y1,x2,y2,score,h,w,l,x,y,z,rot_y,alpha)."""
    path = tmp_path / "0000.txt"
    path.write_text("0,2,100.0,170.0,180.0,240.0,12.5,1.5,1.6,3.7,-5.0,1.6,20.0,-1.5,-1.3\n"
                    "1,2,104.0,170.0,184.0,240.0,12.5,1.5,1.6,3.7,-5.0,1.6,20.0,-1.5,-1.3\n")
    return path


@pytest.mark.parametrize("backend", ["cpsat", "baseline"])
def test_first_solve_is_stamped_inside_the_run_and_the_command_still_writes(tmp_path, backend):
    # the stamp is written when the first frame returns, so it lies between the process start
    # and the end of the whole run; the command itself runs unchanged and writes its output
    out = tmp_path / "out.txt"
    args = ["track", "--dets", str(_kitti(tmp_path)), "--format", "kitti", "--class", "Car", "--backend", backend,
            "--out", str(out), "--quiet"]
    started = time.time()
    first = run_to_first_solve(args, tmp_path / "stamp")
    whole = time.time() - started
    assert 0 < first < whole
    assert out.read_text().count("\n") >= 1  # the car tracked in at least one frame


def test_a_failing_command_is_one_error_not_a_time(tmp_path):
    with pytest.raises(SystemExit, match="the command failed"):
        run_to_first_solve(["track", "--dets", str(tmp_path / "missing.txt"), "--format", "kitti", "--out",
                            str(tmp_path / "o.txt")], tmp_path / "stamp")
