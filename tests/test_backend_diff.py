"""Frame-by-frame backend diff (refimpl.runs.diff) and its command."""

from __future__ import annotations

import contextlib
import dataclasses
import io as io_text
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from pathlib import Path

from refimpl.io.datasets import benchmark_sequences
from refimpl import io
from refimpl.cli import main
from refimpl.runs.diff import DiffJob, diff_job, diff_sequence
from refimpl.solvers import get_solver
from tools.signals import as_from_a_terminal

REPO = Path(__file__).resolve().parent.parent


def _campus(shared_data):
    return io.load_detections(next(s for s in benchmark_sequences("mot15", shared_data) if s.name == "TUD-Campus"))


def test_backends_agree_on_every_frame_of_a_real_sequence(shared_data):
    pytest.importorskip("clingo")
    report = diff_sequence(_campus(shared_data))
    assert report.frames == 71
    assert report.cost_equal == report.answer_equal == 71
    assert report.violations == 0 and report.checked == 142 and report.ok


class _DropsHideEvents:
    """A deliberately broken backend: it forgets every hides_behind explanation."""

    name = "broken"

    def __init__(self):
        self.inner = get_solver("cpsat")

    def solve(self, problem, time_limit=None):
        h = self.inner.solve(problem, time_limit)
        events = tuple(e for e in h.events if "hides_behind" not in e)
        return dataclasses.replace(h, events=events, backend="broken")


def test_a_broken_backend_is_caught_and_the_rule_named(shared_data):
    report = diff_sequence(_campus(shared_data), ("cpsat", "broken"),
                           solvers=(get_solver("cpsat"), _DropsHideEvents()))
    assert report.violations > 0 and not report.ok
    assert "broken breaks explain_halt" in report.first_divergence.explanation
    assert "occurs_at(hides_behind(" in report.first_divergence.describe()


def test_diff_command_exits_zero_when_backends_agree(capsys):
    pytest.importorskip("clingo")
    assert main(["diff", "--dets", str(REPO / "data/demo/TUD-Campus/det/det.txt"), "--quiet"]) == 0
    assert "71 equal answers" in capsys.readouterr().out


def test_diff_command_rejects_a_bad_backend_list(capsys):
    assert main(["diff", "--dets", "x", "--backends", "cpsat"]) == 2
    assert "two or three different backends" in capsys.readouterr().err


def test_a_frame_not_proven_in_time_is_reported_not_waited_for():
    pytest.importorskip("clingo")
    seq = io.load_detections(io.demo_sequence_paths())
    seq = dataclasses.replace(seq, frames=seq.frames[:8])
    # no time at all: every backend answers each frame with the obvious answer, flagged
    report = diff_sequence(seq, ("cpsat-full", "clingo", "cpsat"), time_limit=0)
    assert report.frames == 8 and report.not_proven == 8 and report.proven == 0
    assert report.unproven_frames[0][1] == ("cpsat-full", "clingo", "cpsat")
    assert report.violations == 0  # the obvious answers are admissible, their costs confirmed
    assert "8 not proven optimal within the time limit (frame " in report.summary()


def test_frames_beyond_clingos_sums_are_counted_not_fatal(shared_data):
    # cost_lost = 100,000,000: a sub-problem's level-1 bound (largest cost x (tracks^2 + 3 tracks
    # + detections)) leaves 2^31 - 1 from 22 events on (22 x 1e8 = 2.2e9), i.e. once a
    # sub-problem holds 4 tracks (16 + 12 = 28), or 3 tracks and 4 detections (9 + 9 + 4).  clingo
    # closes a group of components before it gets there (clingo_backend.clingo_parts), so only a
    # frame with one component (context tracks included) that large is refused; TUD-Campus has
    # frames on both sides.  The run goes on, the others are compared, cpsat-full's answers are all
    # checked.  (At 30,000,000, 72 events, every component of TUD-Campus fits: since issue 38
    # clingo solves all 71 frames, which the grouping by 16 own nodes refused in part.)
    pytest.importorskip("clingo")
    report = diff_sequence(_campus(shared_data), ("cpsat-full", "clingo"), constants={"cost_lost": 100_000_000})
    assert report.frames == 71
    assert 0 < report.out_of_range < 71 and report.proven > 0
    assert report.proven + report.out_of_range + report.not_proven == 71
    assert report.cost_equal == report.answer_equal == report.proven
    assert report.checked == 71 + (71 - report.out_of_range)  # clingo answers only what it can hold
    assert report.out_of_range_parts >= report.out_of_range
    assert report.ok and report.violations == 0
    assert f"{report.out_of_range} beyond clingo's 32-bit range, not compared" in report.summary()


# ---------------------------------------------------------------------------------------------
# diff --asp-model: clingo on a user's own encoding against the oracle
# ---------------------------------------------------------------------------------------------

HALT_CHOICE = """1 { occurs_at(hides_behind(Trk, Trk2), curr_time) : can_occur(hides_behind(Trk, Trk2));
    occurs_at(missing_detections(Trk), curr_time) } 1 :- halt(Trk)."""


def _copy_model(folder: Path, edit=None) -> Path:
    """model/*.lp copied into folder, with ``edit(name, text) -> text`` applied to each file."""
    folder.mkdir()
    for lp in sorted((REPO / "model").glob("*.lp")):
        text = lp.read_text()
        (folder / lp.name).write_text(edit(lp.name, text) if edit else text)
    return folder


def _demo40():
    # TUD-Campus's first 40 frames with its scores read as probabilities (the frames these tests
    # were written on: several have more than one answer optimal on levels 10..1)
    paths = io.demo_sequence_paths()
    seq = io.read_mot_detections(paths.dets_path, seqinfo=paths.seqinfo_path, scores_rule="probability")
    return dataclasses.replace(seq, frames=seq.frames[:40])


def _glimpse_sequence():
    # one pedestrian seen at frame 1, missed at 2, seen again at 3 and 4, at the same box (conf 90)
    def frame(t, boxes):
        b = np.array(boxes, dtype=float).reshape(-1, 4)
        return io.DetectionFrame(t, b, np.full(len(b), 0.9), np.full(len(b), 90, dtype=np.int64),
                                 ("pedestrian",) * len(b))
    box = (400, 200, 50, 100)
    return io.DetectionSequence("glimpse", (frame(1, [box]), frame(2, []), frame(3, [box]), frame(4, [box])),
                                1, (1000, 600), 10.0)


def test_diff_const_reaches_every_backend_and_a_rule_missing_from_one_is_found(tmp_path, capsys):
    # With --const glimpse_frames=1 the track started at 1 and missed at 2 (2 - 1 <= 1) is a glimpse
    # (docs/model.md 3.32): at 3 the model starts det_0 anew where it would have resumed the track.
    # An encoding without [glimpse] still resumes it: one disagreement, at frame 3, and only with
    # the constant given (without it the rule is off in both).  The model's own backends agree on
    # every frame either way.
    pytest.importorskip("clingo")
    from refimpl.solvers.asp_model import load_asp_model
    folder = _copy_model(tmp_path / "noglimpse", lambda name, text: text.replace(
        "glimpse(Trk) :- trk(Trk, _),", "glimpse(Trk) :- trk(Trk, _), Trk != Trk,"))
    model = load_asp_model(folder)
    seq = _glimpse_sequence()
    assert diff_sequence(seq, asp_model=model).disagreements == 0
    report = diff_job(DiffJob(seq, ("cpsat-full", "clingo"), asp_model=model, constants=(("glimpse_frames", 1),)))
    assert report.disagreement_frames == [3] and not report.ok
    assert diff_sequence(seq, ("cpsat", "cpsat-full", "clingo"), constants={"glimpse_frames": 1}).ok
    # the command line: a value out of range is one line and exit 2, before any frame is tracked
    assert main(["diff", "--dets", "x", "--const", "glimpse_frames=-1"]) == 2
    assert "glimpse_frames=-1 must be >= 0" in capsys.readouterr().err


def test_an_unchanged_copy_of_the_model_gives_no_disagreement(tmp_path):
    pytest.importorskip("clingo")
    from refimpl.solvers.asp_model import load_asp_model
    model = load_asp_model(_copy_model(tmp_path / "mine"))
    assert model.tiebreak  # optimisation.lp's [level0_tiebreak] reads tiebreak_pair / tiebreak_event
    report = diff_sequence(_demo40(), asp_model=model)
    assert report.backends == ("cpsat-full", "clingo[mine]")
    assert report.frames == report.proven == report.answer_equal == 40
    assert report.disagreements == report.ties == report.violations == 0 and report.ok


def test_a_changed_rule_is_reported_on_exactly_the_frames_where_it_matters(tmp_path):
    # The copy's explain_halt offers only missing_detections: a halt can no longer be explained by
    # hides_behind.  Its answers are a subset of the model's, so on a frame whose (unique) optimum
    # has no halt explained by hides_behind that optimum is the copy's too: the same answer.  On a
    # frame whose optimum has one, the copy cannot return it: a disagreement.  The frames where it
    # matters are read off the oracle's own answers, tracked here without the diff.
    pytest.importorskip("clingo")
    from refimpl.tracking.pipeline import Setup, run_sequence
    from refimpl.solvers.asp_model import load_asp_model
    assert HALT_CHOICE in (REPO / "model/events.lp").read_text()
    folder = _copy_model(tmp_path / "nohide", lambda name, text: text.replace(
        HALT_CHOICE, "1 { occurs_at(missing_detections(Trk), curr_time) } 1 :- halt(Trk)."))
    seq = _demo40()
    matters = []

    def observe(problem, hyp):
        halted = set(hyp.halts)
        if any(name == "hides_behind" and args[0] in halted for name, args in hyp.event_terms):
            matters.append(problem.time)

    run_sequence(seq, Setup("cpsat-full", ()), observer=observe)
    assert len(matters) >= 5
    report = diff_sequence(seq, asp_model=load_asp_model(folder))
    assert report.disagreement_frames == matters and report.disagreements == len(matters)
    # missing_detections is an admissible explanation there, one cost unit dearer at level 1; the
    # checker's enumeration (refimpl.solvers.check_optimum) finds the cheaper hides_behind on its own
    assert report.violations == 0 and not report.ok
    assert 0 < report.false_optima <= len(matters)
    assert ("clingo[nohide] claims optimal, but a cheaper answer exists at priority 1"
            in report.first_divergence.explanation)
    assert f"{len(matters)} disagreements (frame {matters[0]}, " in report.summary()


def test_an_encoding_without_the_tiebreak_counts_ties_not_disagreements(tmp_path, capsys):
    # optimisation.lp without its level-0 statements ([level0_tiebreak] and the 0@0 line): clingo
    # picks any answer optimal on levels 10..1.  Where the frame has several, it may pick another
    # than the oracle's: a tie, counted, not a disagreement.
    pytest.importorskip("clingo")
    from refimpl.solvers.asp_model import load_asp_model

    def drop_tiebreak(name, text):
        if name != "optimisation.lp":
            return text
        return text[:text.index("% [level0_tiebreak]")].replace("#minimize { 0@0 }.\n", "")

    folder = _copy_model(tmp_path / "notb", drop_tiebreak)
    model = load_asp_model(folder)
    assert not model.tiebreak
    seq = _demo40()
    report = diff_sequence(seq, asp_model=model)
    assert report.levels == (10, 5, 3, 2, 1)
    assert report.proven == report.cost_equal == 40  # equal on levels 10..1 on every frame
    assert report.ties > 0 and report.ties == len(report.tie_frames)
    assert report.answer_equal + report.ties == 40
    assert report.disagreements == 0 and report.violations == 0 and report.ok
    # on those frames the full model's tie-break picks the oracle's answer (the test above: 0 ties)
    full = diff_sequence(dataclasses.replace(seq, frames=seq.frames[:max(report.tie_frames) + 1]))
    assert full.ties == 0 and full.answer_equal == full.proven
    # the command says the same, exit 0
    assert main(["diff", "--dets", str(REPO / "data/demo/TUD-Campus/det/det.txt"), "--asp-model", str(folder),
                 "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "equal cost vectors on levels 10..1" in out and "; 0 disagreements;" in out
    # only optimisation.lp changed: no constant, event, action or fluent differs (issue 41)
    assert out.splitlines()[0] == "clingo[notb] against model/: the same constants, events, actions and fluents"


@pytest.mark.parametrize("make, message", [
    (lambda d: d, "no such folder"),
    (lambda d: (d.mkdir(), d)[1], "no .lp files in it"),
    (lambda d: (d.mkdir(), (d / "a.lp").write_text("foo(X :- bar.\n"), d)[2], "a.lp:1:7-9: error: syntax error"),
    (lambda d: (d.mkdir(), (d / "a.lp").write_text("foo(X) :- not bar(X).\n"), d)[2], "unsafe variables"),
])
def test_a_bad_asp_model_folder_is_one_line_and_exit_2(tmp_path, capsys, make, message):
    pytest.importorskip("clingo")
    folder = make(tmp_path / "mine")
    assert main(["diff", "--dets", str(REPO / "data/demo/TUD-Campus/det/det.txt"), "--asp-model", str(folder),
                 "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0] and str(folder) in err[0]


def _endless(tmp_path) -> Path:
    folder = tmp_path / "endless"
    folder.mkdir()
    (folder / "a.lp").write_text("p(0). p(X+1) :- p(X).\n")  # grounds without end
    return folder


def test_an_encoding_that_grounds_without_end_is_one_line_at_the_time_limit(tmp_path, capsys):
    # it ignored --time-limit, Ctrl-C and SIGTERM and ended in a MemoryError traceback (issue 37):
    # the check now grounds in a child process, killed at the time limit
    pytest.importorskip("clingo")
    folder = _endless(tmp_path)
    assert main(["diff", "--dets", str(REPO / "data/demo/TUD-Campus/det/det.txt"), "--asp-model", str(folder),
                 "--time-limit", "1", "--quiet"]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"refimpl diff: error: --asp-model {folder}: grounding it without a frame took longer than the time limit "
        "(1 s, --time-limit): does a rule derive atoms without end, such as p(X+1) :- p(X)?"]


@pytest.mark.parametrize("sig, code, line", [(signal.SIGINT, 130, "refimpl: interrupted"),
                                             (signal.SIGTERM, 143, "refimpl: terminated")])
def test_ctrl_c_and_sigterm_end_the_grounding_of_an_encoding(tmp_path, sig, code, line):
    pytest.importorskip("clingo")
    folder = _endless(tmp_path)
    proc = subprocess.Popen([sys.executable, "-m", "refimpl", "diff", "--dets",
                             str(REPO / "data/demo/TUD-Campus/det/det.txt"), "--asp-model", str(folder),
                             "--time-limit", "600", "--quiet"], cwd=REPO, stderr=subprocess.PIPE, text=True,
                            preexec_fn=as_from_a_terminal(sig))
    deadline = time.monotonic() + 120
    while not (child := _child_running(proc.pid, "refimpl.solvers.asp_model_worker")):  # grounding has begun
        assert proc.poll() is None and time.monotonic() < deadline
        time.sleep(0.1)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    assert (proc.returncode, err.splitlines()) == (code, [line])  # on failure, what the command said
    assert not (Path("/proc") / str(child)).exists()  # the child was killed and reaped


def _child_running(pid: int, module: str) -> int | None:
    """The id of a process started by ``pid`` that runs ``python -m module``, if one runs."""
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
            cmd = (entry / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        ppid = int(stat.rpartition(")")[2].split()[1])
        if ppid == pid and module.encode() in cmd:
            return int(entry.name)
    return None


def test_asp_model_needs_clingo_among_the_backends(tmp_path, capsys):
    folder = _copy_model(tmp_path / "mine")
    assert main(["diff", "--dets", "x", "--backends", "cpsat,cpsat-full", "--asp-model", str(folder)]) == 2
    assert "add it to --backends" in capsys.readouterr().err


def test_an_encoding_without_any_answer_is_a_disagreement_not_a_crash(tmp_path):
    # ':- det(D, _, _).' forbids every frame with a detection; each of the first 5 demo frames has
    # some, and the oracle answers each: 5 disagreements, none compared, the run goes on
    pytest.importorskip("clingo")
    from refimpl.solvers.asp_model import load_asp_model
    folder = _copy_model(tmp_path / "none", lambda name, text: text + (
        "\n:- det(D, _, _).\n" if name == "association.lp" else ""))
    seq = io.load_detections(io.demo_sequence_paths())
    seq = dataclasses.replace(seq, frames=seq.frames[:5])
    assert all(len(f.boxes) for f in seq.frames)
    report = diff_sequence(seq, asp_model=load_asp_model(folder))
    assert report.frames == 5 and report.disagreements == 5 and report.proven == 0 and not report.ok
    assert report.disagreement_frames == [f.frame for f in seq.frames]
    assert report.first_divergence.explanation == "clingo[none] finds no admissible answer, cpsat-full does"


class _Terminal(io_text.StringIO):
    def isatty(self) -> bool:
        return True


def test_diff_shows_its_progress_frame_by_frame_on_a_terminal_only(tmp_path):
    # TUD-Campus (seqinfo.ini: 71 frames): the bar counts frames as both backends answer them, as
    # track's does (it used to count the one sequence: 0/1 until the end)
    argv = ["diff", "--dets", str(REPO / "data/demo/TUD-Campus/det/det.txt"), "--backends", "cpsat,cpsat-full"]

    def run(extra, stderr):
        out = io_text.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(stderr):
            assert main(argv + extra) == 0
        return out.getvalue(), stderr.getvalue()

    out, err = run([], _Terminal())
    assert out.startswith("TUD-Campus: cpsat vs cpsat-full: 71 frames") and "71/71" in err and "frame" in err
    counts = {int(k) for k in re.findall(r"\b(\d+)/71\b", err)}
    assert counts - {0, 71}, f"no count between 0 and 71 frames: {sorted(counts)}"  # it moved during the run
    assert run(["--quiet"], _Terminal())[1] == ""           # --quiet: no bar
    assert run([], io_text.StringIO())[1] == ""              # not a terminal: no bar


# --asp-model runs the encoding with its own #const values (issue 41, item 1)
# ---------------------------------------------------------------------------------------------

def _set_const(file: str, name: str, value: int):
    """An edit for _copy_model: ``#const name=...`` set to value in ``file``."""
    def edit(fname, text):
        if fname != file:
            return text
        lines = [f"#const {name}={value}." if ln.startswith(f"#const {name}=") else ln for ln in text.splitlines()]
        assert lines != text.splitlines(), f"no #const {name} in {file}"
        return "\n".join(lines) + "\n"
    return edit


def test_the_users_iou_threshold_runs_and_the_changed_constant_is_named_first(tmp_path, capsys):
    # iou_thresh=5000: the copy may assign a pair of IoU 0.05..0.3, which the reference (0.3) and
    # the checker (refimpl's constants) refuse.  Before, refimpl's -c iou_thresh=30000 overrode the
    # copy's value and diff reported 0 disagreements, exit 0.
    pytest.importorskip("clingo")
    from refimpl.tracking.pipeline import Setup, run_sequence
    from refimpl.solvers.asp_model import load_asp_model
    folder = _copy_model(tmp_path / "loose", _set_const("constants.lp", "iou_thresh", 5000))
    assert main(["diff", "--dets", str(REPO / "data/demo/TUD-Campus/det/det.txt"), "--asp-model", str(folder),
                 "--quiet"]) == 1
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "clingo[loose] against model/: 1 constant differs: iou_thresh=5000 (model/: 30000)"
    assert "breaks assignment_constraints" in "\n".join(out)
    # it can only matter on a frame with a same-type pair of IoU in (5000, 30000]: read off the
    # oracle's own problems, tracked without the diff
    seq = _demo40()
    loose = []
    run_sequence(seq, Setup("cpsat-full", ()), observer=lambda p, h: loose.append(p.time) if any(
        5000 < ml <= 30000 for _, _, ml in p.iou) else None)
    report = diff_sequence(seq, asp_model=load_asp_model(folder))
    assert report.disagreements > 0 and set(report.disagreement_frames) <= set(loose)


def test_the_users_event_cost_runs(tmp_path):
    # cost_unhides_from_behind=3 makes recover (2) the copy's cheaper explanation of a resume; the
    # checker prices it with refimpl's costs, so wherever the oracle resumes by unhides_from_behind
    # the copy's answer is worse at level 1: a disagreement on exactly those frames
    pytest.importorskip("clingo")
    from refimpl.tracking.pipeline import Setup, run_sequence
    from refimpl.solvers.asp_model import load_asp_model
    model = load_asp_model(_copy_model(tmp_path / "dear", _set_const("events.lp", "cost_unhides_from_behind", 3)))
    assert model.differences() == ("clingo[dear] against model/: 1 constant differs: "
                                   "cost_unhides_from_behind=3 (model/: 1)")
    seq = _demo40()
    unhides = []
    run_sequence(seq, Setup("cpsat-full", ()), observer=lambda p, h: unhides.append(p.time) if any(
        name == "unhides_from_behind" for name, _ in h.event_terms) else None)
    assert unhides
    report = diff_sequence(seq, asp_model=model)
    assert report.disagreement_frames == unhides and report.violations == 0


def test_the_first_line_names_constants_events_and_fluents_in_one_encoding_only(tmp_path):
    pytest.importorskip("clingo")
    from refimpl.solvers.asp_model import load_asp_model
    same = load_asp_model(_copy_model(tmp_path / "same"))
    assert same.differences() == "clingo[same] against model/: the same constants, events, actions and fluents"
    # no noise among the explanations of an end, and a fluent of its own: both named
    noise = "    occurs_at(noise(Trk), curr_time) } 1 :- end(Trk)."
    assert noise in (REPO / "model/events.lp").read_text()
    folder = _copy_model(tmp_path / "quiet", lambda name, text: text.replace(
        ";\n" + noise, " } 1 :- end(Trk).") + ("fluent(tired(T)) :- trk(T, _).\n" if name == "fluents.lp" else ""))
    assert load_asp_model(folder).differences() == (
        "clingo[quiet] against model/: events only in model/: noise; fluents only in clingo[quiet]: tired")
    # a constant the files do not define is refimpl's (-c), as before: no difference
    undefined = load_asp_model(_copy_model(tmp_path / "lean", lambda name, text: "\n".join(
        ln for ln in text.splitlines() if not ln.startswith("#const size_threshold="))))
    assert "size_threshold" not in undefined.vocabulary.defined
    assert undefined.differences().endswith("the same constants, events, actions and fluents")
