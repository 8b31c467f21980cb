"""clingo-specific tests of the ASP encoding (model/*.lp) and the clingo backend.

These ground the model for small frames and read the atoms the grounder derives as facts:
the event calculus (holds_at after a history), the spatial relations (against their Python
twins in refimpl/knowledge/relations.py), poss/1, and the backend's plumbing (options, constants, show).
The association behaviour shared with CP-SAT is in tests/test_association.py.
"""

from __future__ import annotations

import random
from dataclasses import replace
import re
import subprocess
import sys
from pathlib import Path

import pytest

clingo = pytest.importorskip("clingo")

from refimpl.core.constants import default_constants, model_dir  # noqa: E402
from refimpl.core.geometry import intersection_area  # noqa: E402
from refimpl.knowledge.relations import near_border, out_of_view, outside_fov, overlapping_top  # noqa: E402
from refimpl.solvers import NoAdmissibleHypothesis, SolverUnavailable  # noqa: E402
from refimpl.solvers.clingo_backend import (ClingoSolver, clingo_arguments,  # noqa: E402
                                            default_model_files, problem_facts)
from refimpl.core.spec import Detection, FrameProblem, HistoryEvent, TrackPrediction
from refimpl.core.facts import parse_term, read_problem

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "data" / "examples"


def trk(i, state="active", box=(300, 300, 50, 50), typ="car"):
    return TrackPrediction(f"trk_{i}", typ, state, box)


def det(i, box=(300, 300, 50, 50), typ="car", conf=90):
    return Detection(f"det_{i}", typ, conf, box)


def hist(event, t):
    return HistoryEvent(parse_term(event), t)


def frame(dets=(), trks=(), iou=(), history=(), constants=(), time=10):
    return FrameProblem(time=time, detections=tuple(dets), tracks=tuple(trks), iou=tuple(iou),
                        constants=tuple(constants), history=tuple(history))


def ground_facts(problem: FrameProblem, extra: str = "") -> set[str]:
    """Every atom the grounder derived as a fact (the stratified part of the program)."""
    ctl = ClingoSolver().control(problem, extra)
    ctl.ground([("base", [])])
    return {str(a.symbol) for a in ctl.symbolic_atoms if a.is_fact}


def values(facts: set[str], fluent: str, t: int) -> set[str]:
    prefix = f"holds_at({fluent},"
    suffix = f",{t})"
    return {f[len(prefix):-len(suffix)] for f in facts if f.startswith(prefix) and f.endswith(suffix)}


# =============================================================================================
# Event calculus
# =============================================================================================

THREE = [trk(1, "halted"), trk(2), trk(3, "halted")]
HISTORY = [
    hist("hides_behind(trk_1,trk_2)", 3),
    hist("missing_detections(trk_3)", 4),
    hist("unhides_from_behind(trk_1,trk_2)", 6),
    hist("leaves_fov(trk_2)", 7),
    hist("enters_fov(trk_2)", 8),
    hist("hides_behind(trk_3,trk_1)", 8),
]


def test_holds_at_after_a_history():
    facts = ground_facts(frame([], THREE, [], HISTORY))
    t = 10
    assert values(facts, "visibility(trk_1)", t) == {"fully_visible"}   # hidden at 3, unhidden at 6
    assert values(facts, "hidden_by(trk_1,trk_2)", t) == {"false"}
    # missing at 4; the hiding at 8 re-explains it but leaves it clipped (docs/model.md 3.18)
    assert values(facts, "clipped(trk_3)", t) == {"true"}
    assert values(facts, "visibility(trk_3)", t) == {"not_visible"}       # hid at 8
    assert values(facts, "hidden_by(trk_3,trk_1)", t) == {"true"}
    assert values(facts, "in_fov(trk_2)", t) == {"true"}                  # left at 7, entered at 8
    assert values(facts, "in_fov(trk_1)", t) == {"true"}                  # initial value
    assert values(facts, "clipped(trk_1)", t) == {"false"}


def test_a_re_explained_track_stays_clipped_and_keeps_the_missing_bound():
    # docs/model.md 3.18.  THREE/HISTORY at 10: trk_3 missing at 4, re-explained as hidden at 8:
    # not_visible and still clipped, so its bound is lost_after_missing (3) only; trk_1 hid at 3
    # and came back at 6 (visible, unclipped): lost_after_missing as any visible track
    facts = ground_facts(frame([], THREE, [], HISTORY))
    assert {f for f in facts if f.startswith("lost_after(")} == {
        "lost_after(trk_1,3)", "lost_after(trk_2,3)", "lost_after(trk_3,3)"}
    # missing at 1, re-explained at 2, unhidden at 3 (which resets clipped), hidden directly at 5:
    # not_visible and unclipped, so lost_after_hidden (30)
    facts = ground_facts(frame([], [trk(1, "halted"), trk(2)], [],
                               [hist("missing_detections(trk_1)", 1), hist("hides_behind(trk_1,trk_2)", 2),
                                hist("unhides_from_behind(trk_1,trk_2)", 3), hist("hides_behind(trk_1,trk_2)", 5)]))
    assert values(facts, "clipped(trk_1)", 10) == {"false"}
    assert {f for f in facts if f.startswith("lost_after(trk_1,")} == {"lost_after(trk_1,30)"}


def test_an_event_takes_effect_from_the_next_time_point():
    facts = ground_facts(frame([], THREE, [], HISTORY))
    # time is compressed to mintime, the history's time points and curr_time...
    assert {f for f in facts if f.startswith("time(")} == {f"time({t})" for t in (-1, 3, 4, 6, 7, 8, 10)}
    assert "first_time(-1)" in facts
    # ...and per fluent to the first point, the points where an event sets it, and curr_time
    assert {f for f in facts if f.startswith("next_time(visibility(trk_1),")} == {
        "next_time(visibility(trk_1),-1,3)", "next_time(visibility(trk_1),3,6)",
        "next_time(visibility(trk_1),6,10)"}
    assert values(facts, "visibility(trk_1)", -1) == {"fully_visible"}
    assert values(facts, "visibility(trk_1)", 3) == {"fully_visible"}     # the event is at 3
    assert values(facts, "visibility(trk_1)", 6) == {"not_visible"}       # from 3 on, until 6
    assert values(facts, "visibility(trk_1)", 10) == {"fully_visible"}    # unhidden at 6
    assert values(facts, "in_fov(trk_2)", 8) == {"false"}                  # left at 7
    assert values(facts, "in_fov(trk_2)", 10) == {"true"}                  # entered at 8
    # each fluent has exactly one value at each of its time points in this history (it sets no
    # fluent to two values at once)
    fluents = {f[len("fluent("):-1] for f in facts if f.startswith("fluent(")}
    for fl in fluents:
        points = {f.rsplit(",", 1)[1][:-1] for f in facts if f.startswith(f"holds_at({fl},")}
        assert "-1" in points and "10" in points
        for t in points:
            assert len(values(facts, fl, int(t))) == 1, (fl, t)


def test_holds_at_is_a_relation_when_one_time_point_sets_two_values():
    # hides_behind and recover at the same time point: both values hold afterwards
    facts = ground_facts(frame([], [trk(1, "halted"), trk(2)], [],
                               [hist("hides_behind(trk_1,trk_2)", 5), hist("recover(trk_1)", 5)]))
    assert values(facts, "visibility(trk_1)", 10) == {"not_visible", "fully_visible"}
    assert values(facts, "hidden_by(trk_1,trk_2)", 10) == {"true", "false"}
    # "visibility != not_visible" is read as: not holds_at(visibility, not_visible)
    assert "poss(missing_detections(trk_1))" not in facts
    assert "poss(recover(trk_1))" in facts
    assert "poss(unhides_from_behind(trk_1,trk_2))" in facts


def test_history_naming_departed_tracks_affects_current_tracks_only():
    facts = ground_facts(frame([], [trk(1, "halted"), trk(2)], [],
                               [hist("hides_behind(trk_1,trk_9)", 5), hist("noise(trk_10)", 6),
                                hist("hides_behind(trk_9,trk_2)", 6)]))
    assert values(facts, "visibility(trk_1)", 10) == {"not_visible"}
    assert values(facts, "hidden_by(trk_1,trk_2)", 10) == {"false"}
    assert not any("trk_9" in f or "trk_10" in f for f in facts if f.startswith(("holds_at", "fluent")))
    # hidden behind a track that is gone: no unhides, but recover can explain a resume
    assert not any(f.startswith("poss(unhides_from_behind(trk_1,") for f in facts)
    assert "poss(recover(trk_1))" in facts


def test_recover_resets_every_hidden_by_of_the_track():
    facts = ground_facts(frame([], [trk(1, "halted"), trk(2), trk(3)], [],
                               [hist("hides_behind(trk_1,trk_2)", 2), hist("hides_behind(trk_1,trk_3)", 3),
                                hist("missing_detections(trk_1)", 3), hist("recover(trk_1)", 5)]))
    assert values(facts, "hidden_by(trk_1,trk_2)", 10) == {"false"}
    assert values(facts, "hidden_by(trk_1,trk_3)", 10) == {"false"}
    assert values(facts, "clipped(trk_1)", 10) == {"false"}
    assert values(facts, "visibility(trk_1)", 10) == {"fully_visible"}


def test_initial_values_at_mintime_and_a_history_before_it():
    facts = ground_facts(frame([], [trk(1)], [], []))
    assert values(facts, "visibility(trk_1)", -1) == {"fully_visible"}
    assert values(facts, "in_fov(trk_1)", 10) == {"true"}
    assert values(facts, "clipped(trk_1)", 10) == {"false"}
    # -c mintime overrides the default; an event at mintime or before still applies
    facts = ground_facts(frame([], [trk(1, "halted")], [], [hist("missing_detections(trk_1)", 0)],
                               constants=[("mintime", 5)]))
    assert "first_time(0)" in facts
    assert values(facts, "clipped(trk_1)", 10) == {"true"}


def test_started_at_and_halted_at_take_the_latest_time():
    facts = ground_facts(frame([], [trk(1, "halted"), trk(2)], [],
                               [hist("enters_fov(trk_1)", 1), hist("missing_detections(trk_1)", 2),
                                hist("recover(trk_1)", 3), hist("enters_fov(trk_1)", 4),
                                hist("hides_behind(trk_1,trk_2)", 6)]))
    assert {f for f in facts if f.startswith(("started_at", "halted_at"))} == {
        "started_at(trk_1,4)", "halted_at(trk_1,6)"}


# =============================================================================================
# Spatial relations: the ASP encoding agrees with refimpl/knowledge/relations.py
# =============================================================================================

def test_spatial_relations_match_python():
    rng = random.Random(3)
    consts = {"hide_overlap": 10, "img_width": 640, "img_height": 480, "border_margin": 10}
    for _ in range(4):
        tracks = []
        for i in range(12):
            w, h = rng.randrange(1, 200), rng.randrange(1, 200)
            tracks.append(trk(i, box=(rng.randrange(-50, 600), rng.randrange(-50, 450), w, h)))
        facts = ground_facts(frame([], tracks, constants=list(consts.items())))
        for a in tracks:
            assert (f"near_border({a.id})" in facts) == near_border(a.box, 640, 480, 10)
            assert (f"out_of_view({a.id})" in facts) == out_of_view(a.box, 640, 480, 75)
            assert f"area({a.id},{a.box[2] * a.box[3]})" in facts
            for b in tracks:
                if a.id == b.id:
                    continue
                inter = intersection_area(a.box, b.box)
                assert f"inter({a.id},{b.id},{inter})" in facts
                assert (f"overlap({a.id},{b.id})" in facts) == (inter > 0)
                assert (f"position(overlapping_top,{a.id},{b.id})" in facts) == overlapping_top(a.box, b.box, 10)


@pytest.mark.parametrize("width,height,leave_visible", [(640, 480, 0), (640, 480, 50), (640, 0, 75), (0, 0, 100)])
def test_out_of_view_matches_python(width, height, leave_visible):
    # boxes straddling every border, inside, outside and beyond; an image size of 0 does not clip
    rng = random.Random(leave_visible + width)
    tracks = [trk(i, box=(rng.randrange(-150, 700), rng.randrange(-150, 550), rng.randrange(1, 200),
                          rng.randrange(1, 200))) for i in range(30)]
    consts = {"img_width": width, "img_height": height, "leave_visible": leave_visible}
    facts = ground_facts(frame([], tracks, constants=list(consts.items())))
    got = {a.id for a in tracks if f"out_of_view({a.id})" in facts}
    assert got == {a.id for a in tracks if out_of_view(a.box, width, height, leave_visible)}
    if leave_visible == 0:   # only a box with no pixel inside: outside_fov (spatial.lp) exactly
        assert got == {a.id for a in tracks if outside_fov(a.box, width, height)}


def test_near_border_ignores_unknown_image_size():
    facts = ground_facts(frame([], [trk(1, box=(2000, 2000, 50, 50)), trk(2, box=(11, 11, 5, 5))]))
    assert not any(f.startswith("near_border") for f in facts)


def test_size_bigger_is_box_area():
    facts = ground_facts(frame([det(1, box=(0, 0, 10, 10)), det(2, box=(0, 0, 101, 1))]))
    assert "size(bigger,det_2,100)" in facts and "size(bigger,det_1,100)" not in facts


# =============================================================================================
# Preconditions on the paper's frames
# =============================================================================================

def test_poss_on_bus_frames():
    facts = ground_facts(read_problem(str(EXAMPLES / "bus_t235.lp")))
    assert {f for f in facts if f.startswith("poss(hides_behind")} == {"poss(hides_behind(trk_13,trk_12))"}
    assert not any(f.startswith(("poss(unhides", "poss(recover", "poss(lost", "poss(noise")) for f in facts)
    # trk_12's box starts at x = 48 > 10: no track is near the (left/top) border
    assert not any(f.startswith("poss(leaves_fov") for f in facts)

    facts = ground_facts(read_problem(str(EXAMPLES / "bus_t268.lp")))
    assert values(facts, "visibility(trk_13)", 268) == {"not_visible"}
    assert values(facts, "hidden_by(trk_13,trk_12)", 268) == {"true"}
    assert "halted_at(trk_13,235)" in facts
    # 268 - 235 = 33 >= lost_after_hidden = 30, but the bus trk_12 still overlaps trk_13's predicted
    # box inside the image: trk_13 is kept in mind and cannot be lost (docs/model.md, kept_in_mind)
    assert "kept_in_mind(trk_13)" in facts
    assert {f for f in facts if f.startswith(("poss(unhides", "poss(recover", "poss(lost"))} == {
        "poss(unhides_from_behind(trk_13,trk_12))", "poss(recover(trk_13))"}
    assert "poss(missing_detections(trk_13))" not in facts


def test_kitti_history():
    facts = ground_facts(read_problem(str(EXAMPLES / "kitti_0020_t79.lp")))
    assert values(facts, "clipped(trk_0)", 79) == {"true"}
    assert values(facts, "clipped(trk_9)", 79) == {"true"}
    assert values(facts, "clipped(trk_7)", 79) == {"false"}   # missing at 72, recovered at 73
    assert {"halted_at(trk_0,70)", "halted_at(trk_7,72)", "halted_at(trk_9,69)"} <= facts
    # Both tracks are near the left border (x = -42 and -26 <= border_margin), but the image size is
    # unknown in this file, so only the left border clips: trk_0 (-42, 227, 249, 159) has
    # 207 / 249 = 83.1 % of its box inside, trk_11 (-26, 188, 235, 113) 209 / 235 = 88.9 %.
    # leaves_fov needs at most leave_visible = 75 % inside (docs/model.md 3.25): neither has left.
    assert {f for f in facts if f.startswith("poss(leaves_fov")} == set()


@pytest.mark.parametrize("leave_visible,expected", [
    (100, {"poss(leaves_fov(trk_0))", "poss(leaves_fov(trk_11))"}),   # the border alone (before 3.25)
    (85, {"poss(leaves_fov(trk_0))"}),                                 # 83.1 % <= 85 < 88.9 %
    (83, set()),                                                       # 100 * 207 * 159 > 83 * 249 * 159
])
def test_leaves_fov_needs_the_box_mostly_out_of_view(leave_visible, expected):
    problem = read_problem(str(EXAMPLES / "kitti_0020_t79.lp"))
    problem = replace(problem, constants=problem.constants + (("leave_visible", leave_visible),))
    facts = ground_facts(problem)
    assert {f for f in facts if f.startswith("poss(leaves_fov")} == expected
    # relations.out_of_view (the precondition the CP-SAT model and the checker read) says the same
    for t in problem.tracks:
        if t.id in ("trk_0", "trk_11"):
            assert out_of_view(t.box, 0, 0, leave_visible) == (f"poss(leaves_fov({t.id}))" in expected)


# =============================================================================================
# Rules checked by forcing atoms (clingo only: extra ASP text)
# =============================================================================================

def _solve_with(problem: FrameProblem, extra: str):
    ctl = ClingoSolver().control(problem, extra)
    ctl.ground([("base", [])])
    models = []
    result = ctl.solve(on_model=lambda m: models.append((sorted(str(s) for s in m.symbols(shown=True)),
                                                         dict(zip(m.priority, m.cost)))))
    return result, models


@pytest.mark.parametrize("forced,sat", [
    (":- not occurs_at(missing_detections(trk_13), 235).", True),
    (":- not occurs_at(hides_behind(trk_13, trk_15), 235).", False),   # no overlap
    (":- not end(trk_13).", False),                                      # end_constraints
    (":- not ignore_trk(trk_13).", False),                               # ignore_trk_constraints
    (":- not resume(trk_13, det_1).", False),                            # resume_constraints
    (":- not assign(trk_13, det_1).", False),                            # IoU 0.03
    (":- not halt(trk_12).", True),
    (":- not start(det_5). :- occurs_at(enters_fov(det_5), 235).", False),  # explain_start
    (":- not occurs_at(recover(trk_13), 235).", False),                  # no event without its action
])
def test_forced_atoms_on_bus_t235(forced, sat):
    result, models = _solve_with(read_problem(str(EXAMPLES / "bus_t235.lp")), forced)
    assert bool(result.satisfiable) == sat
    if sat:
        assert result.exhausted


def test_missing_detections_costs_one_more_than_hiding():
    result, models = _solve_with(read_problem(str(EXAMPLES / "bus_t235.lp")),
                                 ":- not occurs_at(missing_detections(trk_13), 235).")
    assert models[-1][1][1] == 3  # 2 (missing_detections) + 1 (enters_fov(det_5))


# =============================================================================================
# The backend
# =============================================================================================

def test_answer_shows_only_actions_and_current_events():
    h = ClingoSolver().solve(read_problem(str(EXAMPLES / "bus_t268.lp")))
    assert all(re.fullmatch(r"(assign|resume)\(trk_\d+,det_\d+\)|(start|ignore_det)\(det_\d+\)|"
                            r"(end|halt|ignore_trk)\(trk_\d+\)", a) for a in h.actions)
    assert h.events == ("occurs_at(unhides_from_behind(trk_13,trk_12),268)",)  # no history


def test_arguments_and_facts():
    p = read_problem(str(EXAMPLES / "kitti_0020_t79.lp"))
    args = clingo_arguments(p)
    assert "--opt-mode=opt" in args and "--parallel-mode=1" in args
    consts = {args[i + 1].split("=")[0]: int(args[i + 1].split("=")[1]) for i, a in enumerate(args) if a == "-c"}
    assert consts == {**default_constants(), "curr_time": 79}
    facts = problem_facts(p)
    assert "#const" not in facts
    # the first pair of its component weighs 2^0, in the one chunk at priority 0: (trk_1,det_1), the
    # first pair of the frame since (trk_0,det_0) is no candidate ([resume_claimed], docs/model.md
    # 3.29: trk_0 missing since 70, 79 - 70 >= claim_after 3, and det_0 is trk_11's only detection,
    # IoU 0.834 > 0.5)
    assert "tiebreak_pair(trk_1,det_1,0,1)." in facts
    assert "tiebreak_pair(trk_0,det_0," not in facts
    assert [f.name for f in default_model_files()] == sorted(f.name for f in model_dir().glob("*.lp"))
    assert "constants.lp" in [f.name for f in default_model_files()]


def test_solve_is_deterministic_and_threads_agree():
    p = read_problem(str(EXAMPLES / "kitti_0020_t79.lp"))
    a, b = ClingoSolver().solve(p), ClingoSolver().solve(p)
    assert (a.answer, a.cost, a.optimal) == (b.answer, b.cost, b.optimal)
    c = ClingoSolver(threads=2).solve(p)
    assert c.optimal and c.cost == a.cost
    assert a.backend == "clingo" and a.time == 79 and a.solve_ms > 0


def test_no_admissible_hypothesis_message_is_one_line():
    p = frame([], [trk(1)], [], [hist("missing_detections(trk_1)", 5)])
    with pytest.raises(NoAdmissibleHypothesis, match="no admissible hypothesis at t=10"):
        ClingoSolver().solve(p)


def test_importing_refimpl_does_not_import_clingo():
    code = ("import sys; import refimpl, refimpl.solvers, refimpl.solvers.clingo_backend; "
            "print('clingo' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_missing_clingo_raises_solver_unavailable(monkeypatch):
    monkeypatch.setitem(sys.modules, "clingo", None)  # makes 'import clingo' fail
    with pytest.raises(SolverUnavailable, match=r"pip install 'refimpl\[asp\]'"):
        ClingoSolver()


# =============================================================================================
# The encoding's documentation: every rule carries a spec label
# =============================================================================================

def test_every_rule_is_labelled():
    """Each paragraph (block between blank lines) holding a rule has a '% [label]' comment."""
    for path in default_model_files():
        if path.name == "constants.lp":
            continue
        for block in re.split(r"\n\s*\n", path.read_text(encoding="utf-8")):
            code = [ln for ln in block.splitlines() if ln.strip() and not ln.lstrip().startswith("%")]
            code = [ln for ln in code if not ln.lstrip().startswith("#defined")]
            if not code:
                continue
            assert re.search(r"^% \[[a-z0-9_]+\]", block, re.M), f"{path.name}: unlabelled rule:\n{block}"
            # a label precedes every statement that starts a line at column 0
            lines = block.splitlines()
            for i, ln in enumerate(lines):
                if ln and not ln[0].isspace() and not ln.startswith(("%", "#defined")):
                    above = [x for x in lines[:i] if x.startswith("% [")]
                    assert above, f"{path.name}: no label above {ln!r}"
