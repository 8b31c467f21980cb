"""Hostile and endless input (issue 37): a record without end is refused after its cap in bounded
memory, a read serves Ctrl-C, and each case ends in one line with its exit code."""

from __future__ import annotations

import html
import io as stdio
import json
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from refimpl import Tracker
from refimpl.cli import main
from refimpl.scene.plots import MIN_OBSERVED
from refimpl.core import confidence, geometry
from refimpl.core.confidence import SortedWindow
from refimpl.core.records import MAX_LINE_CHARS, MAX_TEXT_CHARS, RecordTooLong, bounded_lines, read_text
from refimpl.io import MAX_DETECTIONS_PER_FRAME, InputFormatError, read_mot_detections, stream_mot_detections
from tools.signals import as_from_a_terminal

REPO = Path(__file__).resolve().parent.parent
DEMO = REPO / "data" / "demo" / "TUD-Campus" / "det" / "det.txt"
ROW = "1,-1,100,100,20,40,0.9,-1,-1,-1\n"
"""One MOTChallenge detection row of frame 1."""


def _errors(err: str) -> list[str]:
    return [line for line in err.splitlines() if line and not line.startswith(("refimpl: warning", "refimpl track: note"))]


# -- bounded records -------------------------------------------------------------------------

def test_a_line_of_the_cap_is_read_and_one_character_more_is_refused():
    # MAX_LINE_CHARS characters and a newline are one line; MAX_LINE_CHARS + 1 are refused on
    # line 2 (the first line is a short one), without reading what follows it
    ok = "x" * MAX_LINE_CHARS
    assert list(bounded_lines(stdio.StringIO(ok + "\n" + ok))) == [ok + "\n", ok]
    stream = stdio.StringIO("a\n" + "y" * (MAX_LINE_CHARS + 1) + "z" * 50)
    with pytest.raises(RecordTooLong) as info:
        list(bounded_lines(stream))
    assert info.value.line == 2
    assert stream.tell() == 2 + MAX_LINE_CHARS + 1  # read up to the cap and one character, no further


def test_a_file_without_newline_is_refused_naming_its_first_line(tmp_path, capsys):
    path = tmp_path / "det.txt"
    path.write_text(ROW + "9" * (MAX_LINE_CHARS + 1))
    with pytest.raises(InputFormatError, match=rf":2: longer than {MAX_LINE_CHARS} characters"):
        read_mot_detections(path)
    assert main(["track", "--dets", str(path), "--out", str(tmp_path / "r.txt")]) == 2
    assert _errors(capsys.readouterr().err) == [
        f"refimpl track: error: {path}:2: longer than {MAX_LINE_CHARS} characters (a data line is a few dozen): "
        "not a data file?"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["det.txt"]


def test_dev_zero_is_refused_after_the_cap_as_a_file_and_as_a_pipe(tmp_path, capsys):
    # /dev/zero is one line of NUL characters without end: it was read whole (~60 MB/s until the
    # memory ran out); now its first MAX_LINE_CHARS + 1 characters are read, then one line
    assert main(["track", "--dets", "/dev/zero", "--out", str(tmp_path / "r.txt")]) == 2
    assert _errors(capsys.readouterr().err) == [
        f"refimpl track: error: /dev/zero:1: longer than {MAX_LINE_CHARS} characters (a data line is a few dozen): "
        "not a data file?"]
    with open("/dev/zero", "rb") as zero:  # a pipe: a detector that never writes a newline
        proc = subprocess.run([sys.executable, "-m", "refimpl", "track", "--dets", "-", "--out",
                               str(tmp_path / "r.txt")], stdin=zero, capture_output=True, text=True, cwd=REPO,
                              timeout=120)
    assert proc.returncode == 2
    assert _errors(proc.stderr) == [f"refimpl track: error: <stdin>:1: longer than {MAX_LINE_CHARS} characters "
                                    "(a data line is a few dozen): not a data file?"]
    assert list(tmp_path.iterdir()) == []


def test_files_read_at_once_are_capped_too(tmp_path, capsys):
    # a fact file (solve), a scene file (explain) and an ASP encoding are read at once: /dev/zero
    # as any of them is refused after MAX_TEXT_CHARS + 1 characters, in one line
    big = tmp_path / "big.txt"
    big.write_text("a" * 11)
    assert read_text(big, limit=11) == "a" * 11
    with pytest.raises(RecordTooLong, match="longer than 10 characters"):
        read_text(big, limit=10)
    assert main(["solve", "/dev/zero"]) == 2
    assert _errors(capsys.readouterr().err) == [
        f"refimpl solve: error: /dev/zero: longer than {MAX_TEXT_CHARS} characters: too large for a file read "
        "at once (not the file meant?)"]
    assert main(["explain", "/dev/zero"]) == 2
    assert _errors(capsys.readouterr().err)[0].startswith(
        f"refimpl explain: error: /dev/zero: longer than {MAX_TEXT_CHARS} characters")


def test_ctrl_c_ends_a_pipe_waiting_for_its_next_line(tmp_path):
    # two frames written, then nothing: the reader blocks in read(); SIGINT ends it with 130 and
    # one line, and the staged results file is removed
    proc = subprocess.Popen([sys.executable, "-m", "refimpl", "track", "--dets", "-", "--backend", "baseline",
                             "--out", str(tmp_path / "r.txt")], stdin=subprocess.PIPE, stderr=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True, cwd=REPO, preexec_fn=as_from_a_terminal(signal.SIGINT))
    proc.stdin.write(ROW + ROW.replace("1,", "2,", 1))
    proc.stdin.flush()
    # frame 1 is complete once frame 2's line is read: the warning that no image size is known
    # comes then, so the next read is the blocking one
    assert proc.stderr.readline().startswith("refimpl: warning: <stdin>: no --seqinfo")
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130
    assert _errors(err) == ["refimpl: interrupted"]
    assert list(tmp_path.iterdir()) == []


# -- huge frames -----------------------------------------------------------------------------

def _frame_rows(frame: int, n: int) -> str:
    """n detections of one frame, side by side (distinct boxes: a real crowd, not one repeated)."""
    return "".join(f"{frame},-1,{10 + 3 * (k % 1000)},{10 + 50 * (k // 1000)},20,40,0.9,-1,-1,-1\n" for k in range(n))


def test_a_frame_beyond_the_cap_is_one_line_in_a_file_a_pipe_and_the_api(tmp_path, capsys):
    # two frames of 100,000 boxes allocated a 20 GiB IoU matrix; a frame may now hold at most
    # MAX_DETECTIONS_PER_FRAME detections.  Frame 1 holds the cap (accepted), frame 2 one more:
    # the row one beyond the cap is line 5,000 + 5,001 = 10,001
    cap = MAX_DETECTIONS_PER_FRAME
    text = _frame_rows(1, cap) + _frame_rows(2, cap + 1)
    path = tmp_path / "det.txt"
    path.write_text(text)
    message = (f"frame 2 has more than {cap} detections (refimpl's cap per frame, docs/robustness.md: the track x "
               "detection IoU would not fit in memory)")
    with pytest.raises(InputFormatError) as info:
        read_mot_detections(path)
    assert str(info.value) == f"{path}:{2 * cap + 1}: {message}"
    path.write_text(_frame_rows(1, cap))
    assert [len(f) for f in read_mot_detections(path).frames] == [cap]  # the cap itself is read
    stream = stream_mot_detections(stdio.StringIO(text))
    with pytest.raises(InputFormatError) as info:
        list(stream.frames)
    assert str(info.value) == f"<stdin>:{2 * cap + 1}: {message}"
    tracker = Tracker("cpsat")
    assert tracker.update(np.zeros((0, 5))).shape == (0, 5)
    with pytest.raises(ValueError) as info:
        tracker.update(np.tile([1.0, 1.0, 5.0, 5.0, 0.9], (cap + 1, 1)))
    assert str(info.value) == message


def test_empty_arrays_are_empty_frames_but_rows_without_columns_are_refused():
    # (0, 4) and (0,) hold no row: an empty frame; (5, 0) holds five rows without their columns and
    # is refused as (2, 4) is (it was taken as an empty frame)
    tracker = Tracker("cpsat")
    for empty in (np.zeros((0, 4)), np.zeros(0), []):
        assert tracker.update(empty).shape == (0, 5)
    for shape in ((5, 0), (2, 4)):
        with pytest.raises(ValueError, match=rf"^dets must be an \(N, 5\) array .*; got shape \({shape[0]}, {shape[1]}\)$"):
            tracker.update(np.zeros(shape))
    assert tracker.frame == 4  # the three empty frames were tracked, the refused ones not


def test_the_iou_matrix_in_blocks_is_the_whole_matrix_bit_for_bit(monkeypatch):
    # iou_matrix computes a large matrix in row blocks of _IOU_BLOCK pairs (bounded temporaries);
    # each value is computed elementwise, so a block size of 1,000 pairs (a block of 1 row of
    # 700 boxes, then rows of 1) and one block of everything give the same bits
    rng = np.random.default_rng(0)
    a, b = rng.uniform(0, 500, (300, 4)), rng.uniform(0, 500, (700, 4))
    monkeypatch.setattr(geometry, "_IOU_BLOCK", 1 << 40)
    whole = geometry.iou_matrix(a, b)
    monkeypatch.setattr(geometry, "_IOU_BLOCK", 1000)
    blocks = geometry.iou_matrix(a, b)
    assert np.array_equal(whole, blocks) and (whole > 0).sum() > 1000  # real overlaps, not all zeros


# -- long streams ----------------------------------------------------------------------------

def test_a_sorted_window_keeps_the_last_values_with_their_flags():
    # a window of 5; a frame's values come sorted: [1, 3, 3] (flags 1, 0, 2), then [2, 3] (4, 3):
    # equal values stay in arrival order (3: flags 0, 2, 3).  A sixth value, 0 (5), pushes out the
    # oldest, the 1 (flag 1): left are 0 (5), 2 (4), 3 (0), 3 (2), 3 (3).  One more 3 (6) pushes
    # out the oldest 3, the one of flag 0, not another 3
    window = SortedWindow(5)
    window.add(np.array([1.0, 3.0, 3.0]), np.array([1.0, 0.0, 2.0]))
    window.add(np.array([2.0, 3.0]), np.array([4.0, 3.0]))
    assert window.values.tolist() == [1.0, 2.0, 3.0, 3.0, 3.0] and window.flags.tolist() == [1, 4, 0, 2, 3]
    window.add(np.array([0.0]), np.array([5.0]))
    assert window.values.tolist() == [0.0, 2.0, 3.0, 3.0, 3.0] and window.flags.tolist() == [5, 4, 0, 2, 3]
    window.add(np.array([3.0]), np.array([6.0]))
    assert window.values.tolist() == [0.0, 2.0, 3.0, 3.0, 3.0] and window.flags.tolist() == [5, 4, 2, 3, 6]


def test_the_rank_rule_over_a_window_is_the_rule_over_the_last_scores(monkeypatch):
    # with a window of 4 scores, frame 3's confidences are ranks among its own 2 and frame 2's
    # 2 (frame 1's scores have gone): 0.5 -> 2 of 4 at most it (0.3, 0.5) -> 50; 0.9 -> 3 of 4 -> 75
    monkeypatch.setattr(confidence, "SCORE_WINDOW", 4)
    rank = confidence.OnlineRank()
    rank.confidences([0.1, 0.2])
    rank.confidences([0.3, 0.95])
    assert rank.confidences([0.5, 0.9]).tolist() == [50, 75]  # window 0.3, 0.5, 0.9, 0.95
    rank.confidences([0.99])
    assert rank._seen.values.tolist() == [0.5, 0.9, 0.95, 0.99]


def test_without_history_update_gives_the_same_rows_and_keeps_nothing_behind():
    # the demo sequence through Tracker(history=True) and Tracker() (the default, history=False):
    # the rows of every update are equal; the second keeps no finished track and refuses what needs
    # the history, saying how to have it
    seq = read_mot_detections(DEMO)
    full, bounded = Tracker("cpsat", img_size=(640, 480), history=True), Tracker("cpsat", img_size=(640, 480))
    assert (full.history, bounded.history) == (True, False)
    for frame in seq.frames:
        dets = np.column_stack([frame.boxes[:, :2], frame.boxes[:, :2] + frame.boxes[:, 2:], frame.scores])
        a, b = full.update(dets), bounded.update(dets)
        assert np.array_equal(a, b)
    assert len(full.result().rows) > 200 and full._tracker.finished  # tracks ended along the way
    assert bounded._tracker.finished == [] and bounded._frames == [] and bounded.frame == full.frame
    for name in ("result", "scene", "sequence", "interpolated_rows", "events"):
        with pytest.raises(ValueError) as info:
            getattr(bounded, name)() if name != "events" else bounded.events
        what = name if name == "events" else f"{name}()"
        assert str(info.value) == (f"{what}: this Tracker keeps no history (the default, for bounded memory on "
                                   "an endless stream); make it with Tracker(..., history=True) to have it")


def test_a_pipe_takes_frame_one_million():
    # a detector pipe refused frame 100,001 ("after the last frame 100000": 55 minutes of a 30 fps
    # camera); it has no last frame now, only a bound on the gap between two rows.  Rows of
    # frames 1, 100,001, ..., 900,001 (gaps of 100,000, the bound) and 1,000,000: the reader
    # yields every frame 1..1,000,000 (the empty ones between the rows too), the last with its row
    rows = "".join(ROW.replace("1,", f"{f},", 1) for f in range(1, 1_000_001, 100_000)) + ROW.replace("1,", "1000000,", 1)
    stream = stream_mot_detections(stdio.StringIO(rows))
    last = None
    for count, frame in enumerate(stream.frames, start=1):
        last = frame
    assert last.frame == 1_000_000 and len(last) == 1 and count == 1_000_000  # every frame 1..1,000,000


def test_a_noise_factor_beyond_the_bound_is_one_line(tmp_path, capsys):
    # --velocity-noise 1e308 made the Kalman covariance inf and the state NaN: an InvalidPrediction
    # traceback.  The factor is bounded by NOISE_FACTOR_MAX (1e6, which tracks)
    out = tmp_path / "r.txt"
    assert main(["track", "--dets", str(DEMO), "--out", str(out), "--velocity-noise", "1e6", "--quiet"]) == 0
    capsys.readouterr()
    with pytest.raises(SystemExit) as info:
        main(["track", "--dets", str(DEMO), "--out", str(out), "--velocity-noise", "1e308"])
    assert info.value.code == 2
    assert capsys.readouterr().err.splitlines()[-1].endswith(
        "argument --velocity-noise: velocity_noise must be a positive number up to 1e+06, got '1e308'")
    with pytest.raises(ValueError, match=r"area_noise must be a positive number up to 1e\+06, got 1e\+308"):
        Tracker("cpsat", area_noise=1e308)


# -- control characters in what a command prints ----------------------------------------------

HOSTILE = "\x1b[2J\x1b]0;owned\x07\r\x9b\u202e\x7f"
"""Clear the screen, set the window title, return to the line's start, a C1 CSI, right-to-left, DEL."""
SHOWN = r"\x1b[2J\x1b]0;owned\x07\r\x9b\u202e\x7f"
"""The same as refimpl prints it: each control character as a Python string literal writes it."""


def _controls(text: str) -> set[str]:
    """The control characters (C0 but the newline, DEL, C1, the bidirectional ones) in text."""
    return {c for c in text if (ord(c) < 32 and c != "\n") or 0x7F <= ord(c) < 0xA0 or 0x202A <= ord(c) <= 0x202E}


@pytest.fixture(scope="module")
def hostile_scene(tmp_path_factory):
    """The demo's scene with the control characters in its name, in track 2's id (and the timeline
    keys naming it) and in track 1's type."""
    folder = tmp_path_factory.mktemp("hostile-scene")
    scene = folder / "scene.json"
    assert main(["track", "--dets", str(DEMO), "--out", str(folder / "r.txt"), "--scene", str(scene), "--quiet"]) == 0
    data = json.loads(scene.read_text())
    assert [t["id"] for t in data["tracks"][:2]] == ["trk_1", "trk_2"] and data["tracks"][1]["observed"]
    data["name"] = "TUD" + HOSTILE
    data["tracks"][0]["type"] = "pedestrian" + HOSTILE
    data["tracks"][1]["id"] = "trk_2" + HOSTILE
    data["timelines"] = {k.replace("(trk_2)", f"(trk_2{HOSTILE})"): v for k, v in data["timelines"].items()}
    hostile = folder / "hostile.json"
    hostile.write_text(json.dumps(data))
    return hostile


def test_control_characters_of_a_scene_are_escaped_on_the_terminal(hostile_scene, tmp_path, capsys):
    # they reached the terminal raw through explain, query and report (the screen cleared, the
    # title set); each is printed as its escape now, and the lines stay the lines they were
    assert main(["explain", str(hostile_scene)]) == 0
    out = capsys.readouterr().out
    assert f"Track 1 (pedestrian{SHOWN}) entered the field of view at frame 1." in out.splitlines()
    assert not _controls(out)
    assert main(["query", str(hostile_scene), "tracks"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith(f"trk_1 (pedestrian{SHOWN}): frames 1-")
    assert lines[1].startswith(f"trk_2{SHOWN} (pedestrian): frames 1-") and not _controls("\n".join(lines))
    # --json stays exact: JSON escapes them itself (\u001b), and the answer reads back as the file's id
    assert main(["query", str(hostile_scene), "tracks", "--json"]) == 0
    text = capsys.readouterr().out
    answer = json.loads(text)["answer"]
    assert not _controls(text) and answer[0]["type"] == f"pedestrian{HOSTILE}" and answer[1]["track"] == f"trk_2{HOSTILE}"
    assert main(["report", str(hostile_scene), "--out", str(tmp_path / "r.html")]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"TUD{SHOWN}: ") and not _controls(out)
    # a user's mistake naming the scene: its one error line too
    assert main(["explain", str(hostile_scene), "--track", "trk_99"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"refimpl explain: error: no track trk_99 in scene TUD{SHOWN} (") and err.count("\n") == 1
    assert not _controls(err)


def test_the_html_report_holds_no_control_character_and_its_filter_still_matches(hostile_scene, tmp_path):
    # html.escape left them in the page (raw on a terminal with --out -); the page shows them as
    # their escapes, in its text, its attributes and the script's data alike, so the script's track
    # ids are still the data-track attributes its filter compares them with
    page = tmp_path / "r.html"
    assert main(["report", str(hostile_scene), "--out", str(page)]) == 0
    text = page.read_text(encoding="utf-8")
    assert not _controls(text)
    assert f"<h1>TUD{html.escape(SHOWN)} <small>" in text
    data = json.loads(re.search(r'<script type="application/json" id="report-data">(.*?)</script>', text).group(1))
    ids = {t[0] for t in data["tracks"]}
    assert f"trk_2{SHOWN}" in ids and ["trk_1", 1, f"pedestrian{SHOWN}"] in data["tracks"]
    attributes = {html.unescape(v) for v in re.findall(r'data-track="([^"]*)"', text) if "esc(" not in v}
    assert f"trk_2{SHOWN}" in attributes and attributes <= ids


def test_a_dollar_sign_in_a_scene_is_not_mathtext(hostile_scene, tmp_path, capsys):
    # matplotlib read "a$\x$" (a type, a track id) as mathtext: a ParseFatalException traceback
    pytest.importorskip("matplotlib")
    data = json.loads(hostile_scene.read_text())
    data["tracks"][0]["type"], data["name"] = "ped$\\frac$", "a$\\x$"
    data["tracks"][1]["id"] = "trk_2$\\sqrt{$"
    scene = tmp_path / "dollars.json"
    scene.write_text(json.dumps(data))
    assert main(["plot", str(scene), "--out", str(tmp_path / "a.png")]) == 0
    assert main(["plot", str(scene), "--out", str(tmp_path / "b.png"), "--frame", "5"]) == 0
    # the plot names how many of the scene's tracks it draws: those observed in at least MIN_OBSERVED
    # frames (refimpl.scene.plots; the file says how often each was)
    drawn = sum(1 for t in data["tracks"] if len(t["observed"]) >= MIN_OBSERVED)
    assert capsys.readouterr().out.splitlines() == [f"a$\\x$ frames 1-71: {drawn} tracks -> {tmp_path / 'a.png'}",
                                                    f"a$\\x$ frame 5: 3 boxes -> {tmp_path / 'b.png'}"]


def test_a_detection_file_named_with_control_characters_is_named_escaped(tmp_path, capsys):
    # the summary line names the sequence (the file's folder) and the results path: a name made of
    # control characters reaches the terminal as SHOWN, and the results file is still written
    folder = tmp_path / ("seq" + HOSTILE.replace("\r", ""))
    folder.mkdir()
    det = folder / "det.txt"
    det.write_text(DEMO.read_text())
    out = folder / "out.txt"
    assert main(["track", "--dets", str(det), "--out", str(out)]) == 0
    printed = capsys.readouterr()
    assert not _controls(printed.out) and not _controls(printed.err)
    assert SHOWN.replace(r"\r", "") in printed.out and out.stat().st_size > 0


def test_a_frame_of_a_users_encoding_beyond_its_memory_cap_is_refused_in_one_line(tmp_path):
    # a rule that grounds 10^8 atoms for every detection: nothing without a frame (the check passes),
    # gigabytes on the first frame with a detection; under a cap of 512 MiB the child's clingo runs
    # out and the frame is refused in one line (EncodingMemoryError, a UserFacingError)
    pytest.importorskip("clingo")
    from refimpl.core.errors import UserFacingError
    from refimpl.core.facts import parse_facts
    from refimpl.solvers.clingo_backend import ClingoSolver, default_model_files
    folder = tmp_path / "huge"
    folder.mkdir()
    for lp in default_model_files():
        extra = "huge(D, X) :- det(D, _, _), X = 1..100000000.\n" if lp.name == "association.lp" else ""
        (folder / lp.name).write_text(lp.read_text() + extra)
    solver = ClingoSolver(model_files=sorted(folder.glob("*.lp")), memory_cap=512 * 2 ** 20, inline_solves=0)
    problem = parse_facts("#const curr_time=1.\ndet(det_0, car, 90).\nbox2d(det_0, 10, 10, 40, 40).\n")
    with pytest.raises(UserFacingError) as err:
        solver.solve(problem, time_limit=120)
    assert "frame 1: the encoding went beyond its memory cap of 0.5 GiB" in str(err.value)
    assert "\n" not in str(err.value)
