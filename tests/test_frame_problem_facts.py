"""The frame problem (refimpl.core.spec) and the paper's fact format (refimpl.core.facts reads it, spec.write_facts writes it)."""

from __future__ import annotations

import pytest

from refimpl.core.spec import (Detection, FrameProblem, HistoryEvent, ProblemFormatError, Term, TrackPrediction,
                               natural_key, write_facts)
from refimpl.core.facts import parse_facts, parse_term, read_problem

PAPER_FRAMES = ["kitti_0020_t79.lp", "bus_t235.lp"]


@pytest.mark.parametrize("name", PAPER_FRAMES)
def test_paper_frame_round_trips_byte_exact(examples, name):
    text = (examples / name).read_text()
    problem = parse_facts(text, name)
    assert write_facts(problem) == text
    assert parse_facts(write_facts(problem)) == problem


def test_kitti_frame_reads_the_papers_numbers(examples):
    p = read_problem(str(examples / "kitti_0020_t79.lp"))
    # Appendix C: 15 detections (13 car, 2 truck), 10 tracks (trk_0 and trk_9 halted), 22 IoU facts
    assert p.time == 79
    assert len(p.detections) == 15 and len(p.tracks) == 10 and len(p.iou) == 22
    assert sum(d.type == "truck" for d in p.detections) == 2
    assert {t.id for t in p.tracks if t.state == "halted"} == {"trk_0", "trk_9"}
    assert p.track("trk_0").box == (-42, 227, 249, 159)  # negative x, as printed in the paper
    assert p.detection("det_0") == Detection("det_0", "car", 99, (0, 189, 208, 119))
    assert p.iou_map[("trk_0", "det_0")] == 34625
    assert HistoryEvent(Term("missing_detections", (Term("trk_0"),)), 70) in p.history


def test_several_facts_on_one_line_and_comments_are_read():
    # the paper prints several facts per line, e.g. in the bus frame of Section 4.1.1
    p = parse_facts(
        "#const curr_time=5. % a comment\n"
        "det(det_0, person, 99). det(det_1, bus, 86).\n"
        "box2d(det_0, 1, 2, 3, 4). box2d(det_1, -5, 6, 7, 8).\n"
    )
    assert [d.id for d in p.detections] == ["det_0", "det_1"]
    assert p.detection("det_1").box == (-5, 6, 7, 8)


def test_constants_and_history_round_trip():
    p = FrameProblem(
        time=10,
        detections=(Detection("det_0", "car", 50, (0, 0, 10, 10)),),
        tracks=(TrackPrediction("trk_1", "car", "halted", (1, 1, 10, 10)),),
        iou=(("trk_1", "det_0", 68067),),
        constants=(("iou_thresh", 20000),),
        history=(HistoryEvent(parse_term("hides_behind(trk_1,trk_2)"), 9),),
    )
    text = write_facts(p)
    assert "#const iou_thresh=20000." in text
    assert "occurs_at(hides_behind(trk_1,trk_2),9)." in text
    assert parse_facts(text) == p


@pytest.mark.parametrize(
    "text, message",
    [
        ("det(det_0, car, 99).", "missing '#const curr_time"),
        ("#const curr_time=1.\ndet(det_0, car).", "unknown fact det/2"),
        ("#const curr_time=1.\ndet(det_0, car, high).", "must be an integer"),
        ("#const curr_time=1.\ndet(det_0, car, 101).\nbox2d(det_0,0,0,1,1).", "confidence must be 0..100"),
        ("#const curr_time=1.\ndet(det_0, car, 9).\nbox2d(det_0, 0, 0, 0, 5).", "width and height must be > 0"),
        ("#const curr_time=1.\ndet(det_0, car, 9).\ndet(det_0, car, 9).", "duplicate det/trk id"),
        ("#const curr_time=1.\ndet(det_0, car, 9).\nbox2d(det_0,0,0,1,1).\niou(trk_9,det_0,5).", "unknown id trk_9"),
        ("#const curr_time=1.\ndet(det_0, car, 9)", "expected '.'"),
        ("#const curr_time=1.\ndet(det_0, car, 9).", "has no box2d"),
        ("#const curr_time=1.\ntrk(trk_0, car).\nbox2d(trk_0,0,0,1,1).", "has no trk_state"),
        ("#const curr_time=1.\noccurs_at(noise(trk_0),1).", "is not before curr_time=1"),
        ("#const curr_time=1.\n#const curr_time=2.", "curr_time defined twice"),
        ("#const curr_time=x.", "malformed #const"),
    ],
)
def test_malformed_facts_give_one_line_error_naming_file_and_line(text, message):
    with pytest.raises(ProblemFormatError) as err:
        parse_facts(text, "frame.lp")
    msg = str(err.value)
    assert message in msg
    assert msg.startswith("frame.lp")
    assert "\n" not in msg


def test_error_names_the_line_of_the_bad_fact():
    with pytest.raises(ProblemFormatError, match=r"^f.lp:3: "):
        parse_facts("#const curr_time=1.\n\nbox2d(det_0, 0, 0, -2, 5).\n", "f.lp")


def test_missing_file_is_a_format_error_not_a_traceback(tmp_path):
    with pytest.raises(ProblemFormatError, match="cannot read file"):
        read_problem(str(tmp_path / "nope.lp"))


def test_natural_key_orders_ids_by_number():
    assert sorted(["trk_12", "trk_2", "trk_10"], key=natural_key) == ["trk_2", "trk_10", "trk_12"]


def test_parse_atom_reads_a_solvers_atoms_as_terms():
    from refimpl.core.spec import Term, event_of, parse_atom, track_number
    # a flat action, a nested event atom, a constant: name and arguments as a Term, printed back as given
    for atom in ("assign(trk_1,det_2)", "occurs_at(hides_behind(trk_13,trk_12),235)", "halt(trk_3)", "a"):
        assert str(parse_atom(atom)) == atom
    assert parse_atom("assign(trk_1,det_2)") == Term("assign", (Term("trk_1"), Term("det_2")))
    assert parse_atom("assign(trk_1,det_2)").arg_names == ("trk_1", "det_2")
    e = parse_atom("occurs_at(hides_behind(trk_13,trk_12),235)")
    assert e.name == "occurs_at" and e.args[1].as_int() == 235 and e.args[0].arg_names == ("trk_13", "trk_12")
    # event_of: the event of an occurs_at atom, a bare event as it is
    assert event_of("occurs_at(recover(trk_1),7)") == Term("recover", (Term("trk_1"),))
    assert event_of("recover(trk_1)") == Term("recover", (Term("trk_1"),))
    # the tracker's ids trk_<n>
    assert track_number("trk_12") == 12 and track_number("trk_0") == 0
    # blanks between the parts are allowed, as the old slicing allowed them
    assert parse_atom("assign(trk_1, det_2)") == parse_atom("assign(trk_1,det_2)")
    for bad in ("", "a(", "a(b", "a)b", "(a)", "a(b,)", "a()", "a b", "a(b c)", "a(b))", "a(b(c)"):
        with pytest.raises(ValueError, match="not an atom"):
            parse_atom(bad)


def test_parse_atom_keeps_no_event_atom_of_a_frame():
    # issue 38: every 'occurs_at(E,T)' names its frame and is asked for once, so the memo kept
    # 6,924 Terms on MOT15 that no later frame asked for, and every full garbage collection walked
    # them; actions (which frames ask for again) are kept, at most 4,096
    from refimpl.core import spec
    spec._parse_atom_memo.cache_clear()
    for t in range(300):
        assert spec.parse_atom(f"occurs_at(missing_detections(trk_{t}),{t})").args[1].as_int() == t
    assert spec._parse_atom_memo.cache_info().currsize == 0
    for _ in range(2):
        for t in range(300):
            spec.parse_atom(f"assign(trk_{t},det_0)")
    info = spec._parse_atom_memo.cache_info()
    assert (info.currsize, info.misses, info.hits) == (300, 300, 300)
    assert info.maxsize == 4096
    # memo=False parses afresh and keeps nothing
    assert spec.parse_atom("halt(trk_9)", memo=False) == spec.parse_atom("halt(trk_9)")
    assert spec._parse_atom_memo.cache_info().currsize == 301


def test_resolved_constants_are_a_fresh_dict_and_an_unknown_name_fails_every_time():
    # resolve_constants memoises the merge of a problem's #const values: a caller changing the
    # dict it got must not change the next one, and an unknown name is an error on every call
    from refimpl.core.constants import default_constants, resolve_constants
    p = FrameProblem(7, constants=(("iou_thresh", 20000),))
    first = resolve_constants(p)
    assert (first["iou_thresh"], first["curr_time"]) == (20000, 7)
    first["iou_thresh"] = 1
    again = resolve_constants(FrameProblem(8, constants=(("iou_thresh", 20000),)))
    assert (again["iou_thresh"], again["curr_time"]) == (20000, 8)
    assert resolve_constants(FrameProblem(8))["iou_thresh"] == default_constants()["iou_thresh"] == 30000
    bad = FrameProblem(1, constants=(("nosuch", 3),))
    for _ in range(2):
        with pytest.raises(ProblemFormatError, match="unknown constant 'nosuch'"):
            resolve_constants(bad)


_FRAME = ("#const curr_time=5.\ntrk(trk_1,car). trk_state(trk_1,active). box2d(trk_1,0,0,10,20).\n"
          "det(det_1,car,90). box2d(det_1,1,1,10,20).\n")


@pytest.mark.parametrize("line", [
    "iou(trk_1,det_1,500).",
    "iou(trk_1,det_1,0500).",  # the integer as written is normalised: 500
    "iou(trk_1,det_1,-0).",
    "iou(trk_1,det_1,500). match_type(car,car).",  # two facts on a line
    "iou(trk_1,det_1,500).% a comment",
    "iou( trk_1,det_1,500).",  # spaces: the general reader
    "occurs_at(hides_behind(trk_1,trk_1),3).",  # a nested term: the general reader
    "iou(trk_1,det_1,99999999999).",  # out of range: the general reader words the error
    "iou(trk_1,det_1,5x).",
    "iou(not,det_1,5).",
    "not(trk_1,det_1,5).",
    "iou(_t,det_1,5).",
    "iou(trk_1,det_1,5)",
    "iou(trk_1,det_1,500)..",
    "iou(trk_1,det_1,500,1).",
    "iou().",
])
def test_the_flat_fact_reader_reads_what_the_general_reader_reads(monkeypatch, line):
    # facts.py reads a flat fact (names and integers, no spaces) with one regular expression and
    # everything else term by term: the same FrameProblem, or the same error, either way
    from refimpl.core import facts

    def read():
        try:
            return parse_facts(_FRAME + line + "\n", "f.lp")
        except ProblemFormatError as exc:
            return str(exc)

    fast = read()
    monkeypatch.setattr(facts, "_flat_fact", lambda text: None)
    assert fast == read()
