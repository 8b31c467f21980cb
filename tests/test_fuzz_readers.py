"""Robustness of the fact-format parser and the MOTChallenge / KITTI readers (tests/tools/fuzz.py, tools.fuzzing).

A small seeded fuzz run must end with zero tracebacks; then one hand-made case per category of
the robustness issue (truncated lines, wrong arity, non-numbers, NaN/inf, non-positive sizes,
duplicate ids, iou facts naming unknown ids, frames out of order, empty files, huge numbers),
each asserting the one-line error text and its ``file:line``, plus the regressions the fuzzer
found (see docs/robustness.md).
"""

from __future__ import annotations

import contextlib
import io as stdio
import os
import re
import time
from pathlib import Path

import pytest

from refimpl import cli, io
from refimpl.io import InputFormatError
from refimpl.core.spec import ProblemFormatError, write_facts
from refimpl.core.facts import parse_facts, read_problem
from tools import fuzzing as fuzz

REPO = Path(__file__).resolve().parent.parent


DET = "1,-1,10,20,30,40,0.9\n2,-1,11,21,30,40,0.8\n"
GT = "1,1,10,20,30,40,1,-1,-1,-1\n2,1,11,21,30,40,1,-1,-1,-1\n"
KDET = ("0,2,10,20,40,60,1.5,1,1,1,1,1,1,0,0\n"
        "1,2,11,21,41,61,1.5,1,1,1,1,1,1,0,0\n")
KGT = ("0 1 Car 0 0 0 10 20 40 60 1 1 1 1 1 1 0\n"
       "1 1 Car 0 0 0 11 21 41 61 1 1 1 1 1 1 0\n")
FACTS = """\
#const curr_time=7.
det(det_0, car, 90).
box2d(det_0, 10, 20, 30, 40).
trk(trk_1, car).
trk_state(trk_1, active).
box2d(trk_1, 11, 21, 30, 40).
iou(trk_1,det_0,81000).
"""


def write(path: Path, data: str | bytes) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(data, bytes):
        path.write_bytes(data)
    else:
        path.write_text(data, encoding="utf-8")
    return path


def fails(exc_type, path: Path, line: int | None, fragment: str):
    """The error is one line, starts with '<path>:<line>: ' (or '<path>: ') and contains fragment."""
    where = f"{path}:{line}: " if line is not None else f"{path}: "
    return pytest.raises(exc_type, match="^" + re.escape(where) + r"[^\n]*" + re.escape(fragment) + r"[^\n]*$")


def io_fails(path, line, fragment):
    return fails(InputFormatError, path, line, fragment)


def facts_fail(path, line, fragment):
    return fails(ProblemFormatError, path, line, fragment)


# ---------------------------------------------------------------------------------------
# the fuzz run


def test_seeded_fuzz_run_ends_without_tracebacks():
    t0 = time.perf_counter()
    summary = fuzz.run(300, seed=0, cli_every=20, timeout=30)
    # inputs come in groups of one per target (6); every 20th group also runs the CLI: groups 0, 20 and 40
    # of the 50, so 3 x 6 CLI runs, every target through the command line
    assert summary.inputs == 300 and summary.cli_runs == 18
    details = "\n".join(f"{r.outcome}: {fuzz.describe(r.case)}\n{r.detail}" for r in summary.failures[:3])
    assert summary.failures == [], details
    accepted = sum(v for (_, o), v in summary.counts.items() if o == "accepted")
    errors = sum(v for (_, o), v in summary.counts.items() if o == "error")
    assert accepted > 25 and errors > 150  # both paths are exercised (84 and 234 at seed 0)
    assert time.perf_counter() - t0 < 60


def test_fuzz_inputs_are_reproducible_from_seed_and_index():
    seeds = fuzz.load_seeds()
    a = fuzz.generate(seeds, 0, 123, 20)
    b = fuzz.generate(seeds, 0, 123, 20)
    c = fuzz.generate(seeds, 1, 123, 20)
    assert (a.data, a.mutations, a.target) == (b.data, b.mutations, b.target)
    assert a.data != c.data or a.mutations != c.mutations


def test_fuzz_classifies_a_traceback_and_a_multi_line_error_as_failures(tmp_path):
    p = write(tmp_path / "x.txt", "x")
    outcome, _ = fuzz.classify_error(InputFormatError("two\nlines", p, 1), p, b"x", {str(p): b"x"})
    assert outcome == "traceback"
    outcome, _ = fuzz.classify_error(InputFormatError("no line named", p), p, b"x", {str(p): b"x"})
    assert outcome == "bad-error"
    outcome, _ = fuzz.classify_error(InputFormatError("blank line", p, 2), p, b"x\n\n", {str(p): b"x\n\n"})
    assert outcome == "bad-error"
    outcome, _ = fuzz.classify_error(InputFormatError("fine", p, 1), p, b"x", {str(p): b"x"})
    assert outcome == "error"


# ---------------------------------------------------------------------------------------
# one hand-made case per category


def test_truncated_lines(tmp_path):
    p = write(tmp_path / "det.txt", DET + "3,-1,12,2")
    with io_fails(p, 3, "expected 7 to 10 comma-separated fields (frame,id,x,y,w,h,score,...), found 4"):
        io.read_mot_detections(p)
    k = write(tmp_path / "label.txt", KGT + "2 1 Car 0 0 0 11 21\n")
    with io_fails(k, 3, "expected 17 space-separated fields"):
        io.read_kitti_ground_truth(k, "car")
    f = write(tmp_path / "t.lp", FACTS + "box2d(det_1, 1, 2\n")
    with facts_fail(f, 8, "unexpected end of line inside a fact (facts stay on one line)"):
        read_problem(str(f))
    g = write(tmp_path / "u.lp", FACTS.replace("iou(trk_1,det_0,81000).", "iou(trk_1,det_0,81000)"))
    with facts_fail(g, 7, "expected '.' at the end of the line"):
        read_problem(str(g))


def test_wrong_arity(tmp_path):
    f = write(tmp_path / "a.lp", FACTS.replace("det(det_0, car, 90).", "det(det_0, car)."))
    with facts_fail(f, 2, "unknown fact det/2 (expected one of det/3, box2d/5"):
        read_problem(str(f))
    k = write(tmp_path / "k.txt", KDET.replace("0,0\n1,2", "0\n1,2", 1))
    with io_fails(k, 1, "expected 15 comma-separated fields (frame,type,x1,y1,x2,y2,score,"):
        io.read_kitti_detections(k, "car")
    g = write(tmp_path / "gt.txt", GT + "3,1,12,22,30,40,1,1\n")
    with io_fails(g, 3, "expected 9 to 10 comma-separated fields"):
        io.read_mot_ground_truth(g)


def test_non_numbers(tmp_path):
    p = write(tmp_path / "det.txt", DET.replace("11,21", "eleven,21"))
    with io_fails(p, 2, "field 3 (x) is not a number: 'eleven'"):
        io.read_mot_detections(p)
    r = write(tmp_path / "res.txt", "1,7,0x1F,0,10,10,1,-1,-1,-1\n")
    with io_fails(r, 1, "field 3 (x) is not a number: '0x1F'"):
        io.read_mot_results(r)
    f = write(tmp_path / "n.lp", FACTS.replace("box2d(det_0, 10,", "box2d(det_0, ten,"))
    with facts_fail(f, 3, "box2d(det_0,ten,20,30,40): ten must be an integer"):
        read_problem(str(f))
    h = write(tmp_path / "h.lp", FACTS.replace("90).", "9.5)."))
    with facts_fail(h, 2, "expected ',' or ')', got '.'"):
        read_problem(str(h))


@pytest.mark.parametrize("value", ["nan", "NaN", "inf", "-inf", "1e309"])
def test_nan_and_inf(tmp_path, value):
    p = write(tmp_path / "det.txt", DET.replace("0.8", value))
    with io_fails(p, 2, f"field 7 (score) is not finite: '{value}'"):
        io.read_mot_detections(p)
    k = write(tmp_path / "k.txt", KGT.replace("11 21 41 61", f"11 {value} 41 61"))
    with io_fails(k, 2, f"field 8 (y1) is not finite: '{value}'"):
        io.read_kitti_ground_truth(k, "car")


def test_negative_or_zero_sizes(tmp_path):
    p = write(tmp_path / "det.txt", DET.replace("11,21,30,40", "11,21,0,40"))
    with io_fails(p, 2, "box width and height must be > 0, got w=0 h=40"):
        io.read_mot_detections(p)
    g = write(tmp_path / "gt.txt", GT.replace("10,20,30,40", "10,20,30,-4"))
    with io_fails(g, 1, "box width and height must be > 0, got w=30 h=-4"):
        io.read_mot_ground_truth(g)
    k = write(tmp_path / "k.txt", KDET.replace("11,21,41,61", "41,21,11,61"))
    with io_fails(k, 2, "box has negative size: x2-x1=-30, y2-y1=40"):
        io.read_kitti_detections(k, "car")
    f = write(tmp_path / "z.lp", FACTS.replace("box2d(trk_1, 11, 21, 30, 40)", "box2d(trk_1, 11, 21, 0, 40)"))
    with facts_fail(f, 6, "box2d(trk_1,11,21,0,40): width and height must be > 0"):
        read_problem(str(f))


def test_duplicate_ids(tmp_path):
    g = write(tmp_path / "gt.txt", GT + GT.splitlines()[0] + "\n")
    with io_fails(g, 3, "duplicate (frame 1, id 1); first seen on line 1"):
        io.read_mot_ground_truth(g)
    k = write(tmp_path / "k.txt", KGT + KGT.splitlines()[1] + "\n")
    with io_fails(k, 3, "duplicate (frame 1, id 1); first seen on line 2"):
        io.read_kitti_ground_truth(k, "car")
    f = write(tmp_path / "d.lp", FACTS + "det(det_0, car, 50).\n")
    with facts_fail(f, 8, "duplicate det/trk id for det_0"):
        read_problem(str(f))
    t = write(tmp_path / "t.lp", FACTS + "trk(det_0, car).\n")
    with facts_fail(t, 8, "duplicate det/trk id for det_0"):
        read_problem(str(t))


def test_iou_facts_naming_unknown_ids(tmp_path):
    f = write(tmp_path / "i.lp", FACTS.replace("iou(trk_1,det_0,81000)", "iou(trk_1,det_9,81000)"))
    with facts_fail(f, 7, "iou(trk_1,det_9,81000) names unknown id det_9"):
        read_problem(str(f))
    g = write(tmp_path / "j.lp", FACTS + "iou(trk_ghost,det_0,5).\n")
    with facts_fail(g, 8, "iou(trk_ghost,det_0,5) names unknown id trk_ghost"):
        read_problem(str(g))


def test_frames_out_of_order_are_accepted_and_sorted(tmp_path):
    lines = DET.splitlines() + ["1,-1,50,50,5,5,0.7"]
    a = io.read_mot_detections(write(tmp_path / "a" / "det.txt", "\n".join(lines) + "\n"))
    b = io.read_mot_detections(write(tmp_path / "b" / "det.txt", "\n".join(lines[::-1]) + "\n"))
    assert [f.frame for f in b.frames] == [1, 2]
    for fa, fb in zip(a.frames, b.frames):  # the same boxes per frame (order within a frame kept from the file)
        assert sorted(map(tuple, fa.boxes.tolist())) == sorted(map(tuple, fb.boxes.tolist()))
    g = io.read_mot_ground_truth(write(tmp_path / "gt.txt", "".join(GT.splitlines(keepends=True)[::-1])))
    assert g.frames.tolist() == [1, 2]
    r = write(tmp_path / "res.txt", "3,1,0,0,10,10,1,-1,-1,-1\n1,2,0,0,10,10,1,-1,-1,-1\n")
    out = tmp_path / "sorted.txt"
    io.write_mot_results(out, io.read_mot_results(r))
    assert out.read_text().splitlines()[0].startswith("1,2,")
    f = write(tmp_path / "f.lp", "".join(FACTS.splitlines(keepends=True)[::-1]))
    p = read_problem(str(f))
    assert p.time == 7 and parse_facts(write_facts(p)) == p


def test_empty_files(tmp_path):
    for name, text in (("empty.txt", ""), ("blank.txt", "\n  \n\t\n")):
        p = write(tmp_path / name, text)
        with io_fails(p, None, "empty file (no data lines)"):
            io.read_mot_detections(p)
        with io_fails(p, None, "empty file (no data lines)"):
            io.read_kitti_ground_truth(p, "car")
        assert io.read_mot_results(p, allow_empty=True).shape == (0, 6)
    f = write(tmp_path / "e.lp", "% nothing here\n")
    with facts_fail(f, None, "missing '#const curr_time=<int>.'"):
        read_problem(str(f))


def test_huge_numbers(tmp_path):
    p = write(tmp_path / "det.txt", DET.replace("2,-1", "123456789,-1"))
    with io_fails(p, 2, "frame 123456789 is after the last frame 100000 (implausibly large frame number)"):
        io.read_mot_detections(p)
    q = write(tmp_path / "q.txt", DET.replace("11,21", "1e12,21"))
    with io_fails(q, 2, "x 1e+12 is implausibly large (box coordinates are pixels, at most 1e+06 in magnitude)"):
        io.read_mot_detections(q)
    k = write(tmp_path / "k.txt", KDET.replace("41,61", "18446744073709551616,61"))
    with io_fails(k, 2, "x2 1.84467e+19 is implausibly large"):
        io.read_kitti_detections(k, "car")
    f = write(tmp_path / "h.lp", FACTS.replace("box2d(det_0, 10,", f"box2d(det_0, {10 ** 30},"))
    with facts_fail(f, 3, f"integer {10 ** 30} is outside the 32-bit range -2147483648..2147483647"):
        read_problem(str(f))
    g = write(tmp_path / "g.lp", FACTS.replace("#const curr_time=7.", "#const curr_time=" + "7" * 100_000 + "."))
    with facts_fail(g, 1, "#const curr_time: integer 777777777777...(100000 digits) is outside the 32-bit range"):
        read_problem(str(g))
    assert parse_facts(FACTS.replace("10, 20, 30, 40", "2147483647, -2147483648, 1, 1")).detections[0].box == \
        (2147483647, -2147483648, 1, 1)
    # a huge score is accepted: raw scores are clipped to 0..100 (it used to overflow to confidence 0)
    s = io.read_mot_detections(write(tmp_path / "s.txt", DET.replace("0.8", "1e300")))
    assert s.frames[1].confidences.tolist() == [100]
    write(tmp_path / "S" / "seqinfo.ini", "[Sequence]\nname=S\nframeRate=25\nseqLength=" + "9" * 30
          + "\nimWidth=640\nimHeight=480\n")
    d = write(tmp_path / "S" / "det" / "det.txt", DET)
    with io_fails(tmp_path / "S" / "seqinfo.ini", 4, "seqLength 999999999999999999999999999999 is implausibly large"):
        io.read_mot_detections(d)


# ---------------------------------------------------------------------------------------
# further findings of the fuzzer (regressions)


def test_deeply_nested_term_is_an_error_not_a_recursion_error(tmp_path):
    f = write(tmp_path / "n.lp", FACTS + "occurs_at(" + "f(" * 5000 + "a" + ")" * 5000 + ",1).\n")
    with facts_fail(f, 8, "term nested deeper than 100 levels"):
        read_problem(str(f))
    ok = parse_facts(FACTS + "occurs_at(" + "f(" * 50 + "a" + ")" * 50 + ",1).\n")
    assert parse_facts(write_facts(ok)) == ok


def test_trk_state_for_an_unknown_track_names_its_line(tmp_path):
    f = write(tmp_path / "s.lp", FACTS + "trk_state(trk_77, active).\n")
    with facts_fail(f, 8, "trk_state for unknown track trk_77"):
        read_problem(str(f))


def test_fact_file_with_a_byte_order_mark_is_read(tmp_path):
    f = write(tmp_path / "bom.lp", b"\xef\xbb\xbf" + FACTS.replace("\n", "\r\n").encode())
    assert read_problem(str(f)) == parse_facts(FACTS)


@pytest.mark.parametrize("char", ["\x0b", "\x0c", "\x1c", "\x85", "\u2028"])
def test_line_numbers_count_only_real_line_ends(tmp_path, char):
    # str.splitlines() also splits at these characters, which shifted every later line number
    p = write(tmp_path / "det.txt", f"1,-1,10,20,30,40,0.9{char}\n2,-1,11,21,30,40,0.8\n3,-1,x,1,1,1,1\n")
    with io_fails(p, 3, "field 3 (x) is not a number: 'x'"):
        io.read_mot_detections(p)
    f = write(tmp_path / "f.lp", FACTS.replace("car, 90).", f"car,{char}90).") + "det(det_0, car, 5).\n")
    with facts_fail(f, 8, "duplicate det/trk id for det_0"):
        read_problem(str(f))


def test_seqinfo_with_a_huge_integer_is_an_error_not_a_type_error(tmp_path):
    s = write(tmp_path / "seqinfo.ini", "[Sequence]\nname=S\nframeRate=25\nseqLength=7\nimWidth=" + "9" * 25
              + "\nimHeight=480\n")
    info = io.read_seqinfo(s)  # a huge (but positive) image width used to raise TypeError in np.isfinite
    assert info["imWidth"] == int("9" * 25)
    t = write(tmp_path / "t" / "seqinfo.ini", "[Sequence]\nname=S\nframeRate=25\nseqLength=-" + "9" * 25
              + "\nimWidth=1\nimHeight=1\n")
    with io_fails(t, 4, "seqLength must be > 0"):
        io.read_seqinfo(t)


# ---------------------------------------------------------------------------------------
# the command line: one stderr line, exit 2, no results file left behind


def run_cli(argv):
    out, err = stdio.StringIO(), stdio.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(argv)
    return code, out.getvalue(), err.getvalue()


def test_cli_track_failure_is_one_line_and_leaves_no_results_file(tmp_path):
    d = write(tmp_path / "det.txt", DET + "3,-1,1,1,nan,1,0.5\n")
    out = tmp_path / "out" / "res.txt"
    code, _, err = run_cli(["track", "--dets", str(d), "--backend", "baseline", "--out", str(out)])
    assert code == 2
    assert err == f"refimpl track: error: {d}:3: field 5 (w) is not finite: 'nan'\n"
    assert not out.exists() and not (out.parent.exists() and any(out.parent.iterdir()))


def test_cli_track_write_failure_leaves_no_partial_file(tmp_path, monkeypatch):
    d = write(tmp_path / "det.txt", DET)
    out = tmp_path / "res.txt"

    def broken_fsync(fd):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "fsync", broken_fsync)
    code, _, err = run_cli(["track", "--dets", str(d), "--backend", "baseline", "--out", str(out)])
    errors = [line for line in err.splitlines() if not line.startswith("refimpl: warning:")]
    # the message names the output (it used to say only "No space left on device"); + the no-seqinfo warning
    assert code == 2 and errors == [f"refimpl track: error: cannot write {out}: No space left on device"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["det.txt"]


def test_cli_solve_and_eval_report_bad_inputs_in_one_line(tmp_path):
    f = write(tmp_path / "p.lp", FACTS.replace("det_0,81000", "det_9,81000"))
    code, _, err = run_cli(["solve", str(f), "--backend", "cpsat"])
    assert code == 2 and err == f"refimpl solve: error: {f}:7: iou(trk_1,det_9,81000) names unknown id det_9\n"
    r = write(tmp_path / "r.txt", "1,1,10,20,30,40,1,-1,-1,-1\n1,1,10,20,30,40,1,-1,-1,-1\n")
    g = write(tmp_path / "gt.txt", GT)
    code, _, err = run_cli(["eval", str(r), "--gt", str(g)])
    assert code == 2 and err == f"refimpl eval: error: {r}:2: duplicate (frame 1, id 1); first seen on line 1\n"


def test_sub_hundredth_pixel_detection_boxes_are_errors_or_dropped(tmp_path):
    # 1e-300 wide boxes made the abduction tracker's Kalman state underflow (InvalidPrediction) and
    # 0.001 wide ones made the baseline write results write_mot_results refuses (ValueError)
    p = write(tmp_path / "det.txt", DET.replace("11,21,30,40", "11,21,1e-300,40"))
    with io_fails(p, 2, "box width and height must be >= 0.01 pixels, got w=1e-300 h=40"):
        io.read_mot_detections(p)
    k = write(tmp_path / "k.txt", KDET.replace("11,21,41,61", "11,21,11.001,61"))
    with pytest.warns(io.InputFormatWarning, match=r"line\(s\) 2"):
        seq = io.read_kitti_detections(k, "car")
    assert seq.num_detections == 1 and seq.dropped == ((2, "below 0.01 px box w=0.001 h=40"),)
    with io_fails(k, 2, "box width and height must be >= 0.01 pixels, got w=0.001 h=40"):
        io.read_kitti_detections(k, "car", on_degenerate="error")
    thin = write(tmp_path / "thin.txt", "".join(f"{f},-1,100,100,0.001,100,0.99,-1,-1,-1\n" for f in range(1, 7)))
    out = tmp_path / "out.txt"
    code, _, err = run_cli(["track", "--dets", str(thin), "--backend", "baseline", "--out", str(out)])
    assert code == 2 and err.startswith(f"refimpl track: error: {thin}:1: box width and height must be >= 0.01")
    assert not out.exists()
