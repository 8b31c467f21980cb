"""A detector pipe (issue 29 item 3): ``refimpl track --dets -`` reads detections from standard
input frame by frame as they arrive and writes each frame's rows as soon as they are final; the
rows equal the file run's byte for byte, and a malformed or out-of-order row ends in one line
naming its line number."""

from __future__ import annotations

import io as stdio
import select
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from refimpl import io
from refimpl.cli import main

REPO = Path(__file__).resolve().parent.parent
DATA = REPO.parent / "shared" / "data"
KITTI_DETS = DATA / "KITTI" / "tracking" / "training" / "det_02_pointrcnn"
TUD = DATA / "MOT15" / "train" / "TUD-Campus"
DEMO = REPO / "data" / "demo" / "TUD-Campus" / "det" / "det.txt"

needs_data = pytest.mark.skipif(not (DATA / "MOT15").is_dir(), reason=f"benchmark data not found at {DATA}")


def _pipe(argv: list[str]) -> list[str]:
    return [sys.executable, "-m", "refimpl", "track", "--dets", "-", "--quiet", *argv]


def _same_frames(streamed, read) -> None:
    assert [f.frame for f in streamed] == [f.frame for f in read.frames[:len(streamed)]]
    for a, b in zip(streamed, read.frames):
        assert a.types == b.types
        for x, y in ((a.boxes, b.boxes), (a.scores, b.scores), (a.confidences, b.confidences)):
            assert x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y)


# -- the stream reader gives the file readers' frames ------------------------------------------

@needs_data
@pytest.mark.parametrize("name, rule", [("det_sort_frcnn.txt", "auto"), ("det.txt", "auto"),
                                        ("det_sort_frcnn.txt", "rank")])
def test_the_stream_reader_gives_the_mot_file_readers_frames(name, rule):
    # det_sort_frcnn.txt holds probabilities (0.5..1.0: auto reads them as such); the official
    # ACF det.txt holds raw scores, mostly above 1 (auto ranks them, from its first frame as from
    # the whole file: TUD-Campus' frame 1 already has most of its scores outside 0..1)
    path = TUD / "det" / name
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", io.InputFormatWarning)
        read = io.read_mot_detections(path, scores_rule=rule)
        with open(path, encoding="utf-8") as fh:
            stream = io.stream_mot_detections(fh, seqinfo=TUD / "seqinfo.ini", scores_rule=rule)
            frames = list(stream.frames)
    assert len(frames) == len(read.frames) == 71  # seqLength of TUD-Campus/seqinfo.ini
    _same_frames(frames, read)
    assert (stream.name, stream.image_size, stream.fps) == ("TUD-Campus", (640, 480), 25.0)
    assert stream.num_detections == read.num_detections and stream.confidence_range == read.confidence_range


@needs_data
def test_the_stream_reader_gives_the_kitti_file_readers_frames_and_drops_the_same_box():
    # Car/0000 has one zero-area box: line 614, x1 = x2 = 1241 (the right border), y1 185.4478,
    # y2 374 -> h = 188.5522; dropped and warned about once, at the end of the stream, as the file
    # reader does at once
    path = KITTI_DETS / "Car" / "0000.txt"
    with pytest.warns(io.InputFormatWarning, match="dropped 1 zero-area") as read_warnings:
        read = io.read_kitti_detections(path, "car")
    with open(path, encoding="utf-8") as fh, pytest.warns(io.InputFormatWarning) as stream_warnings:
        stream = io.stream_kitti_detections(fh, "car")
        frames = list(stream.frames)
    assert len(frames) == len(read.frames) == 154
    _same_frames(frames, read)
    assert tuple(stream.dropped) == read.dropped == ((614, "zero-area box w=0 h=188.552"),)
    assert [str(w.message).split(": ", 1)[1] for w in stream_warnings] == \
        [str(w.message).split(": ", 1)[1] for w in read_warnings]


@needs_data
def test_a_kitti_stream_ends_at_its_last_rows_frame():
    # Pedestrian/0010: the last detection is in frame 292, its label_02 file runs to frame 293;
    # the file reader has that frame (empty), a stream cannot know of it
    path = KITTI_DETS / "Pedestrian" / "0010.txt"
    read = io.read_kitti_detections(path, "pedestrian", scores_rule="rank")
    with open(path, encoding="utf-8") as fh:
        frames = list(io.stream_kitti_detections(fh, "pedestrian", scores_rule="rank").frames)
    assert (len(frames), len(read.frames)) == (293, 294) and len(read.frames[-1]) == 0
    _same_frames(frames, read)


# -- the pipe's rows equal the file run's -------------------------------------------------------

@needs_data
def test_a_kitti_pipe_writes_the_file_runs_results(tmp_path, capsys):
    path = KITTI_DETS / "Car" / "0000.txt"
    assert main(["track", "--dets", str(path), "--format", "kitti", "--class", "Car", "--quiet",
                 "--out", str(tmp_path / "file.txt")]) == 0
    capsys.readouterr()
    with open(path, "rb") as fh:
        done = subprocess.run(_pipe(["--format", "kitti", "--class", "Car", "--out", str(tmp_path / "pipe.txt")]),
                              cwd=REPO, stdin=fh, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    expected = (tmp_path / "file.txt").read_bytes()
    # a real run's rows (0000 has 154 frames with several cars in most), not a nearly empty file
    assert (tmp_path / "pipe.txt").read_bytes() == expected and expected.count(b"\n") > 300
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file.txt", "pipe.txt"]  # no staged file left
    assert done.stderr.splitlines() == ["refimpl: warning: <stdin>: dropped 1 zero-area (or thinner than 0.01 px) "
                                        "detection box(es) on line(s) 614"]
    tracks = len({line.split(b",")[1] for line in expected.splitlines()})
    assert done.stdout == f"<stdin>: 154 frames, {tracks} tracks -> {tmp_path / 'pipe.txt'}\n"


@needs_data
def test_rows_come_out_of_a_slow_pipe_before_its_end_and_equal_the_file_runs(tmp_path, capsys):
    path = TUD / "det" / "det_sort_frcnn.txt"
    assert main(["track", "--dets", str(path), "--quiet", "--out", str(tmp_path / "file.txt"),
                 "--events", str(tmp_path / "file.lp")]) == 0
    capsys.readouterr()
    lines = path.read_text(encoding="utf-8").splitlines(keepends=True)
    frames: dict[int, list[str]] = {}
    for line in lines:
        frames.setdefault(int(line.split(",")[0]), []).append(line)
    proc = subprocess.Popen(_pipe(["--seqinfo", str(TUD / "seqinfo.ini"), "--out", "-",
                                   "--events", str(tmp_path / "pipe.lp")]),
                            cwd=REPO, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, bufsize=1)
    try:
        fed = 45  # a detector writing one frame at a time, slower than the tracker
        for number in range(1, fed + 1):
            proc.stdin.write("".join(frames.get(number, [])))
            proc.stdin.flush()
            time.sleep(0.01)
        # standard input is still open: whatever comes out now was written before its end
        ready, _, _ = select.select([proc.stdout], [], [], 240)  # a hang guard, not a timing
        assert ready, "no row within 240 s of the first 45 frames"
        first = proc.stdout.readline()
        assert first, proc.stderr.read()
        assert proc.poll() is None  # still waiting for more detections
        assert 1 <= int(first.split(",")[0]) < fed  # a row of a frame already fed
        for number in range(fed + 1, 72):
            proc.stdin.write("".join(frames.get(number, [])))
        proc.stdin.close()
        rest = proc.stdout.read()
        err = proc.stderr.read()
        assert proc.wait(timeout=240) == 0, err
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    expected = (tmp_path / "file.txt").read_text(encoding="utf-8")
    assert first + rest == expected and expected.count("\n") > 200
    assert (tmp_path / "pipe.lp").read_bytes() == (tmp_path / "file.lp").read_bytes()
    assert err.splitlines()[-1].startswith("TUD-Campus: 71 frames, ")  # the summary goes to stderr


def _run_pipe(monkeypatch, capsys, data: str | bytes, argv: list[str]) -> tuple[int, str, str]:
    """``track --dets - ARGV`` in this process with ``data`` on standard input."""
    raw = data.encode("utf-8") if isinstance(data, str) else data
    monkeypatch.setattr(sys, "stdin", stdio.TextIOWrapper(stdio.BytesIO(raw), encoding="utf-8"))
    code = main(["track", "--dets", "-", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_the_baseline_pipe_writes_the_file_runs_results(tmp_path, monkeypatch, capsys):
    assert main(["track", "--dets", str(DEMO), "--backend", "baseline", "--quiet",
                 "--out", str(tmp_path / "file.txt")]) == 0
    capsys.readouterr()
    code, out, err = _run_pipe(monkeypatch, capsys, DEMO.read_text(encoding="utf-8"),
                               ["--backend", "baseline", "--seqinfo", str(DEMO.parent.parent / "seqinfo.ini"),
                                "--out", "-"])
    expected = (tmp_path / "file.txt").read_text(encoding="utf-8")
    assert code == 0 and out == expected and expected.count("\n") > 200
    assert "TUD-Campus: 71 frames, " in err


# -- mistakes: one line naming the line, exit 2, nothing silently skipped ----------------------

ROW = "{frame},-1,100,100,20,40,{score}\n"


def _rows(*frames, score=0.9) -> str:
    return "".join(ROW.format(frame=f, score=score) for f in frames)


@pytest.mark.parametrize("data, argv, line", [
    (_rows(1, 2, 2, 1), [], "<stdin>:4: frame 1 after frame 2 (line 3): a stream is read frame by frame, "
                            "so its frame numbers must not decrease"),
    (_rows(1) + "\n" + "2,-1,100,x,20,40,0.9\n", [], "<stdin>:3: field 4 (y) is not a number: 'x'"),
    (_rows(1, 1) + "2,-1,100,100\n", [], "<stdin>:3: expected 7 to 10 comma-separated fields "
                                        "(frame,id,x,y,w,h,score,...), found 4"),
    (_rows(1) + _rows(2.5), [], "<stdin>:2: frame is not an integer: 2.5"),
    (_rows(1) + "2,-1,100,100,0.001,40,0.9\n", [], "<stdin>:2: box width and height must be >= 0.01 pixels, "
                                                   "got w=0.001 h=40"),
    # a frame's rows are checked when it is complete, before the next frame's first row: frame 2's
    # bad line 3 is found before frame 3's bad line 4
    (_rows(1, 2) + "2,-1,2000000,100,20,40,0.9\n3,-1,100,100,-20,40,0.9\n", [],
     "<stdin>:3: x 2e+06 is implausibly large (box coordinates are pixels, at most 1e+06 in magnitude)"),
    # a pipe has no last frame (issue 37: it took no frame past 100,000), but a gap of more than
    # MAX_FRAME frames without a row is a typo, as a file's frame beyond it is
    (_rows(1) + _rows(100_002), [], "<stdin>:2: frame 100002 after frame 1: more than 100000 frames without a "
                                    "row (a typo?)"),
    (_rows(1) + _rows(72), ["--seqinfo", str(DEMO.parent.parent / "seqinfo.ini")],
     "<stdin>:2: frame 72 is after the last frame 71 (seqLength in seqinfo.ini)"),
    # --scores probability refuses a score outside 0..1 (auto reads any scale)
    (_rows(1, 2) + _rows(3, score=7.5), ["--scores", "probability"],
     "<stdin>:3: score 7.5 is not a probability in 0..1 (--scores auto reads any scale)"),
    ("0,2,10,10,30,40,1.2,1,1,1,1,1,1,1,1\n0,4,10,10,30,40,1.2,1,1,1,1,1,1,1,1\n", ["--format", "kitti", "--class",
     "Car"], "<stdin>:2: unknown class type 4 (1 pedestrian, 2 car, 3 cyclist)"),
    ("", [], "<stdin>: empty input (no data lines)"),
    ("\n  \n\r\n", [], "<stdin>: empty input (no data lines)"),
])
def test_a_bad_row_ends_the_pipe_in_one_line_naming_it(data, argv, line, tmp_path, monkeypatch, capsys):
    out = tmp_path / "out.txt"
    code, _, err = _run_pipe(monkeypatch, capsys, data, ["--backend", "baseline", "--quiet", "--out", str(out), *argv])
    assert code == 2
    *before, last = err.splitlines()
    assert last == f"refimpl track: error: {line}"
    # before it at most the warning that the image size is unknown (once a first frame was read)
    assert all(w.startswith("refimpl: warning: <stdin>: no --seqinfo and no --img-size") for w in before)
    assert len(before) <= 1 and (before == [] if "empty" in line or "--seqinfo" in argv else True)
    assert list(tmp_path.iterdir()) == []  # the staged results file is removed


def test_rows_written_before_a_bad_row_stay_written_on_standard_output(monkeypatch, capsys):
    # 8 frames of one box, then a frame number that goes back: the baseline (SORT: min_hits 3,
    # every frame final at once) wrote the rows of frames 1..7 before it read line 9; frame 8 was
    # not complete (a later line of frame 8 could still come), so it is not tracked
    code, out, err = _run_pipe(monkeypatch, capsys, _rows(*range(1, 9), 3),
                               ["--backend", "baseline", "--out", "-"])
    assert code == 2 and err.splitlines()[-1].startswith("refimpl track: error: <stdin>:9: frame 3 after frame 8")
    assert [int(r.split(",")[0]) for r in out.splitlines()] == list(range(1, 8))


def test_the_end_of_the_input_needs_no_final_newline(tmp_path, monkeypatch, capsys):
    text = DEMO.read_text(encoding="utf-8")
    _, whole, _ = _run_pipe(monkeypatch, capsys, text, ["--backend", "baseline", "--out", "-"])
    code, cut, _ = _run_pipe(monkeypatch, capsys, text.rstrip("\n"), ["--backend", "baseline", "--out", "-"])
    assert code == 0 and cut == whole and whole.count("\n") > 200


def test_with_the_rank_rule_later_scores_need_no_scale(monkeypatch, capsys):
    # what auto refuses above is read under --scores rank: each confidence is from the rank of its score
    # among all seen so far, this frame's included, k / n, mapped onto 20..100 (RANK_LOW):
    # floor(20 + 80 * k / n + 1/2): frame 1 {0.9}: 0.9 -> 1/1 -> 100; frame 2 {0.5, 0.9}: 0.5 ->
    # 1/2 -> 60; frame 3 {0.5, 0.7, 0.9, 7.5}: 0.7 -> 2/4 -> 60, 7.5 -> 4/4 -> 100
    data = _rows(1) + _rows(2, score=0.5) + _rows(3, score=0.7) + _rows(3, score=7.5)
    frames = list(io.stream_mot_detections(stdio.StringIO(data), scores_rule="rank").frames)
    assert [f.confidences.tolist() for f in frames] == [[100], [60], [60, 100]]
    code, _, err = _run_pipe(monkeypatch, capsys, data, ["--scores", "rank", "--backend", "baseline", "--out", "-",
                                                         "--quiet"])
    assert code == 0 and "<stdin>: 3 frames, " in err


@pytest.mark.parametrize("argv, fragment", [
    ([str(DEMO), "--out", "o.txt"], "--dets - reads one sequence from standard input"),
    (["--out-dir", "x"], "--dets - writes one results file"),
    (["--out", "o.txt", "--scene", "s.json"], "--scene keeps every box"),
    (["--out", "o.txt", "--workers", "2"], "--dets - is one sequence"),
    (["--out", "o.txt", "--format", "kitti"], "--format kitti needs --class"),
    (["--out", "o.txt", "--format", "kitti", "--class", "Car", "--seqinfo", str(DEMO.parent.parent / "seqinfo.ini")],
     "KITTI detections have no seqinfo.ini"),
])
def test_pipe_options_that_do_not_fit_end_in_one_line(argv, fragment, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    code, _, err = _run_pipe(monkeypatch, capsys, _rows(1), argv)
    assert code == 2 and fragment in err and len(err.strip().splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


def test_seqinfo_is_for_the_pipe_only(tmp_path, capsys):
    assert main(["track", "--dets", str(DEMO), "--seqinfo", str(DEMO.parent.parent / "seqinfo.ini"),
                 "--out", str(tmp_path / "o.txt")]) == 2
    assert "--seqinfo is for --dets -" in capsys.readouterr().err


def test_on_the_fuzzers_inputs_the_stream_reader_agrees_with_the_file_readers(tmp_path):
    # the detection inputs among the first 600 of tests/tools/fuzz.py (seed 0; seed files with 1 to 4 mutations):
    # where both readers accept, the same frames (a KITTI stream may end before the file's empty
    # last frames); where only the stream refuses, it is for what a stream cannot do (rows going
    # back, or scores outside 0..1 after a first frame of probabilities); every refusal is one
    # line naming <stdin> and, where it names a line, a non-blank line of the input
    from tools.fuzzing.cases import generate
    from tools.fuzzing.seeds import load_seeds
    seeds = load_seeds()
    seen = {"both accept": 0, "stream only refuses": 0}
    for index in range(600):
        case = generate(seeds, 0, index, 0)
        if case.target not in ("mot_det", "kitti_det"):
            continue
        kitti = case.target == "kitti_det"
        cls = "pedestrian" if "Pedestrian" in case.seed_name else "car"
        path = tmp_path / f"{index}.txt"
        path.write_bytes(case.data)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                read = io.read_kitti_detections(path, cls) if kitti else io.read_mot_detections(path)
            except io.InputFormatError:
                read = None
            text = stdio.TextIOWrapper(stdio.BytesIO(case.data), encoding="utf-8-sig", newline=None)
            try:
                stream = io.stream_kitti_detections(text, cls) if kitti else io.stream_mot_detections(text)
                frames, error = list(stream.frames), None
            except io.InputFormatError as exc:
                frames, error = None, str(exc)
        if error is not None:
            assert error.startswith("<stdin>") and "\n" not in error, (index, error)
            named = error.split(":")[1]
            if named.isdigit():
                physical = case.data.decode("utf-8-sig", "replace").replace("\r\n", "\n").replace("\r", "\n")
                assert physical.split("\n")[int(named) - 1].strip(), (index, error)
        if read is not None and frames is not None:
            seen["both accept"] += 1
            _same_frames(frames, read)
            assert all(len(f) == 0 for f in read.frames[len(frames):])
        elif read is not None:
            seen["stream only refuses"] += 1
            assert "must not decrease" in error or "from its first frame" in error, (index, error)
        elif frames is not None:
            pytest.fail(f"input {index}: the file reader refuses what the stream reader accepts")
    assert seen["both accept"] > 30 and seen["stream only refuses"] > 10, seen  # both paths ran


def test_a_score_the_rule_cannot_read_is_one_line_for_a_file_too(tmp_path, capsys):
    # every rule reads every format; a KITTI logit of 1.2 is not a probability in 0..1
    (tmp_path / "0000.txt").write_text("0,2,10,10,30,40,1.2,1,1,1,1,1,1,1,1\n", encoding="utf-8")
    assert main(["track", "--dets", str(tmp_path / "0000.txt"), "--format", "kitti", "--class", "Car",
                 "--scores", "probability", "--out", str(tmp_path / "o.txt")]) == 2
    err = capsys.readouterr().err
    assert err == (f"refimpl track: error: {tmp_path / '0000.txt'}:1: score 1.2 is not a probability in 0..1 "
                   "(--scores auto reads any scale)\n")
    assert not (tmp_path / "o.txt").exists()
    assert main(["track", "--dets", str(tmp_path / "0000.txt"), "--format", "kitti", "--class", "Car",
                 "--scores", "raw", "--out", str(tmp_path / "o.txt")]) == 0
