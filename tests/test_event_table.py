"""The event table (refimpl.knowledge.event_table.EVENT_TABLE) and the action/priority tables (refimpl.core.hypothesis)
are the one place for each event's and action's knowledge: these tests pin them to the ASP
encoding (model/*.lp) and prove that every consumer sees every event."""

from __future__ import annotations

import re

import pytest

from refimpl.core.constants import default_constants, model_dir, resolve_constants
from refimpl.knowledge.events import EventState, possible_events
from refimpl.knowledge.event_table import EVENT_TABLE, REEXPLAINED, explaining
from refimpl.core.hypothesis import ACTION_TABLE, PRIORITIES, action_cost
from refimpl.scene.plots import EVENT_STYLE
from refimpl.scene import Episode, SceneTrack, explain_episode, make_scene
from refimpl.solvers.cpsat import build_model
from refimpl.core.facts import parse_facts


def _lp(name: str) -> str:
    text = (model_dir() / name).read_text(encoding="utf-8")
    return "\n".join(line.split("%", 1)[0] for line in text.splitlines())  # drop comments


def test_every_event_of_the_asp_encoding_is_in_the_table_with_its_arity():
    # event(hides_behind(Trk1, Trk2)) :- ...   -> ('hides_behind', 2)
    heads = re.findall(r"^event\((\w+)\(([^)]*)\)\)", _lp("events.lp"), flags=re.M)
    asp = {name: len(args.split(",")) for name, args in heads}
    assert asp == {name: e.arity for name, e in EVENT_TABLE.items()}


def test_the_explain_rules_of_the_asp_encoding_match_the_table():
    # each choice rule "1 { occurs_at(E1..) ; occurs_at(E2..) } 1 :- action(X)." names the events
    # that explain that action; resumed(Trk) stands for resume(Trk, _)
    rules = re.findall(r"[01] \{(.*?)\} 1 :- (\w+)\(", _lp("events.lp"), flags=re.S)
    asp = {}
    for body, action in rules:
        action = "resume" if action == "resumed" else action
        asp[action] = tuple(re.findall(r"occurs_at\((\w+)\(", body))
    # ... and [explain_ignore] (0 { .. } 1) names the events that re-explain an ignored missing track
    assert asp == {a: tuple(e.name for e in explaining(a)) for a in ("halt", "resume", "start", "end")
                   + REEXPLAINED}


def test_every_event_has_its_cost_beside_it_in_events_lp():
    # '#const cost_lost=3.' and 'event_cost(lost(Trk), cost_lost) :- event(lost(Trk)).' in events.lp:
    # the one level-1 statement of optimisation.lp reads event_cost/2, so an event without it costs nothing
    text = _lp("events.lp")
    consts = set(re.findall(r"^#const (cost_\w+)=", text, flags=re.M))
    wired = {name: const for name, args, const, again in
             re.findall(r"^event_cost\((\w+)\(([^)]*)\), (\w+)\) :- event\((\w+)\(", text, flags=re.M)
             if name == again}
    assert consts == {e.cost_constant for e in EVENT_TABLE.values()}
    assert wired == {name: e.cost_constant for name, e in EVENT_TABLE.items()}
    assert all(e.cost_constant in default_constants() for e in EVENT_TABLE.values())
    assert "#minimize { C@1, E, event : occurs_at(E, curr_time), event_cost(E, C) }." in _lp("optimisation.lp")


def test_the_halting_and_starting_wiring_of_the_asp_encoding_matches_the_table():
    # 'halting_event_at(Trk, T) :- history_event(missing_detections(Trk), T).' per halting event
    # (halted_at, read by lost's precondition), starting_event_at per starting event (started_at,
    # read by noise's): an event of the table without its line would halt (start) a track in
    # Python and not in ASP
    text = _lp("events.lp")
    for head, action in (("halting_event_at", "halt"), ("starting_event_at", "start")):
        asp = re.findall(rf"^{head}\((\w+), T\) :- history_event\((\w+)\((\w+)", text, flags=re.M)
        assert all(first == arg for first, _, arg in asp), asp  # the event's first argument
        assert sorted(name for _, name, _ in asp) == sorted(e.name for e in explaining(action))
    # and no other file names an event: event_calculus.lp and optimisation.lp read the wiring
    for other in sorted(model_dir().glob("*.lp")):
        if other.name != "events.lp":
            named = set(re.findall(r"\b(\w+)\(", _lp(other.name))) & set(EVENT_TABLE)
            assert not named, (other.name, named)


def test_every_role_of_the_table_is_consistent_with_the_effects_and_actions():
    for e in EVENT_TABLE.values():
        # a halt kind exactly for the halting events; the kinds tell the halts apart
        assert bool(e.halt_kind) == (e.explains == "halt"), e.name
        # an occluder is a second track: only a pair event names one
        assert e.occluder is None or (e.arity == 2 and e.occluder == 1), e.name
    assert len({e.halt_kind for e in explaining("halt")}) == len(explaining("halt"))
    # hides_behind ends its track's visibility, unhides_from_behind comes out from behind
    assert [e.name for e in EVENT_TABLE.values() if e.hides] == ["hides_behind"]
    assert [e.name for e in EVENT_TABLE.values() if e.unhides] == ["unhides_from_behind"]


def test_a_pair_events_prefilter_is_implied_by_its_precondition():
    # the CP-SAT model tests poss only for the pairs its prefilter leaves: on random frames, every
    # pair whose precondition holds passes the prefilter (else the model would miss an event)
    import random

    from framegen import random_frame
    from refimpl.knowledge.relations import overlapping_top

    rng = random.Random(11)
    seen = {e.name: 0 for e in EVENT_TABLE.values() if e.prefilter}
    for _ in range(300):
        problem = random_frame(rng, with_history=True)
        state, c = EventState.from_problem(problem), resolve_constants(problem)
        by_id = {t.id: t for t in problem.tracks}
        for atom, ok in possible_events(problem, state, c).items():
            name, args = atom.split("(")[0], atom[atom.index("(") + 1:-1].split(",")
            spec = EVENT_TABLE[name]
            if not ok or not spec.prefilter:
                continue
            seen[name] += 1
            t1, t2 = by_id[args[0]], by_id[args[1]]
            if spec.prefilter == "overlapping_top":
                assert overlapping_top(t1.box, t2.box, c["hide_overlap"]), atom
            else:
                assert state.holds_at(("visibility", t1.id), "not_visible"), atom
                partners = state.hidden_by_holding(t1.id, "true")
                assert partners is None or t2.id in partners, atom
    assert all(seen.values()), seen  # each prefiltered event was possible somewhere


def test_hidden_by_holding_is_the_set_of_tracks_holding_the_value():
    # the 'hidden_by' prefilter tests only these partners: on random histories (hides_behind,
    # recover's hidden_by(T, X) := false for every X, events at one time point, some inconsistent),
    # for both states the CP-SAT backend queries, each value: the set is exactly the tracks X != T
    # with holds_at(hidden_by(T, X), value), or None where the default value (that of a track no
    # event named) is it
    import random

    from framegen import random_frame
    from refimpl.solvers.trackwise_state import TrackwiseState

    rng = random.Random(5)
    counts = {"set": 0, "nonempty": 0, "none": 0}
    for _ in range(300):
        problem = random_frame(rng, with_history=True)
        ids = [t.id for t in problem.tracks]
        for state in (EventState.from_problem(problem), TrackwiseState(problem.history, ids)):
            for t1 in ids:
                for value in ("true", "false"):
                    got = state.hidden_by_holding(t1, value)
                    holding = {x for x in ids if x != t1 and state.holds_at(("hidden_by", t1, x), value)}
                    if got is None:  # a track no event named holds it: the default does
                        counts["none"] += 1
                        assert state.holds_at(("hidden_by", t1, "trk_never_named"), value), (t1, value)
                    else:
                        counts["set"] += 1
                        counts["nonempty"] += bool(got)
                        assert set(got) & set(ids) == holding, (t1, value)
    assert all(counts.values()), counts


MAXIMISED = ("assign", "resume")
"""The actions optimisation.lp maximises (weight -1 in ACTION_TABLE, written as 1 in #maximize)."""


def test_the_action_costs_and_priorities_are_those_of_optimisation_lp():
    text = _lp("optimisation.lp")
    # every level is reported: '#minimize { 0@P }.' once per priority, highest first
    assert tuple(int(p) for p in re.findall(r"#minimize \{ 0@(\d+) \}", text)) == PRIORITIES
    # 'W@P, ..., tag : action(...)' for the counted actions
    found = {name: (int(p), int(w)) for w, p, name in
             re.findall(r"(\d+)@(\d+), [\w, ]+ : (\w+)\(", text) if name in ACTION_TABLE and name not in MAXIMISED}
    expected = {a.name: (a.level, a.weight) for a in ACTION_TABLE.values()
                if a.level is not None and a.name not in MAXIMISED}
    assert found == expected
    # assign and resume are maximised at @10 (resume: docs/model.md 3.15): ML + 1 per pair, i.e. a
    # cost of -(ML + 1), and nothing at @2 for a resume; ML is the pair's matching_likelihood (3.30)
    assert re.search(r"#maximize \{ ML@10, Trk, Det : assign\(Trk, Det\), matching_likelihood\(Trk, Det, ML\);\s+"
                     r"ML@10, Trk, Det : resume\(Trk, Det\), matching_likelihood\(Trk, Det, ML\) \}", text)
    assert re.search(r"#maximize \{ 1@10, Trk, Det, count : assign\(Trk, Det\);\s+"
                     r"1@10, Trk, Det, count : resume\(Trk, Det\) \}", text)
    assert action_cost("assign", 500) == (-501, 0, 0, 0, 0, 0)
    assert action_cost("resume", 500) == (-501, 0, 0, 0, 0, 0)
    assert action_cost("halt") == (0, 0, 0, 0, 0, 0)


# A frame in which every event of the table is possible (derivations in the comments):
#   trk_1 (100,100,100,100) active, trk_2 (120,110,120,100) active: trk_2 covers 80*90 = 7200 px
#     of trk_1's 10000 (> hide_overlap 10 %) and its bottom 210 >= 200, so overlapping_top:
#     hides_behind(trk_1,trk_2) and missing_detections(trk_1) are possible;
#   trk_3 halted, hidden behind trk_2 since 95 (not_visible, hidden_by): unhides_from_behind
#     (trk_3,trk_2) and recover(trk_3) are possible, and det_0 (iou 90000, conf 90) can resume it;
#   trk_4 halted, started and missing at 97, at the right border and mostly beyond it (x+w =
#     1010 > 1000-10; 10 of its 20 columns inside: 50 % <= leave_visible 75 %, out_of_view): at
#     curr_time 100, noise (100-97 <= noise_max_age 3), lost (100-97 >= lost_after_missing 3)
#     and leaves_fov are possible;
#   det_0 cannot start a track (trk_3 is where it is: IoU 0.9 > iou_thresh_occupied 0.5,
#     [start_occupied]); det_1 (area 2500 > 100, conf 90 > 40, no track overlaps it) can:
#     enters_fov(det_1).
FRAME = """
#const curr_time=100.
#const img_width=1000.
#const img_height=500.
det(det_0, car, 90).
box2d(det_0, 132, 121, 50, 50).
det(det_1, car, 90).
box2d(det_1, 600, 300, 50, 50).
trk(trk_1, car). trk_state(trk_1, active). box2d(trk_1, 100, 100, 100, 100).
trk(trk_2, car). trk_state(trk_2, active). box2d(trk_2, 120, 110, 120, 100).
trk(trk_3, car). trk_state(trk_3, halted). box2d(trk_3, 130, 120, 50, 50).
trk(trk_4, car). trk_state(trk_4, halted). box2d(trk_4, 990, 100, 20, 20).
iou(trk_3, det_0, 90000).
occurs_at(enters_fov(trk_1), 10).
occurs_at(enters_fov(trk_2), 10).
occurs_at(enters_fov(trk_3), 10).
occurs_at(hides_behind(trk_3, trk_2), 95).
occurs_at(enters_fov(trk_4), 97).
occurs_at(missing_detections(trk_4), 97).
"""


@pytest.fixture(scope="module")
def every_event_frame():
    problem = parse_facts(FRAME)
    return problem, EventState.from_problem(problem), resolve_constants(problem)


def test_the_frame_makes_every_event_possible(every_event_frame):
    problem, state, c = every_event_frame
    possible = {atom.split("(")[0] for atom, ok in possible_events(problem, state, c).items() if ok}
    assert possible == set(EVENT_TABLE)


def test_the_cpsat_model_has_a_variable_for_every_event(every_event_frame):
    problem, state, c = every_event_frame
    am = build_model(problem, state, c)
    assert {atom.split("(")[0] for atom in am.events} == set(EVENT_TABLE)


def test_the_scene_has_a_sentence_and_the_plots_a_style_for_every_event():
    scene = make_scene("t", [SceneTrack("trk_1", "car", ((1, (0.0, 0.0, 10.0, 10.0)),), (), None),
                             SceneTrack("trk_2", "car", ((1, (0.0, 0.0, 10.0, 10.0)),), (), None)], [], 1, 20)
    for name, e in EVENT_TABLE.items():
        sentence = explain_episode(scene, Episode(name, "trk_1", 5, "trk_2" if e.arity == 2 else None))
        assert e.phrase in sentence and not sentence.startswith("Event "), sentence
        assert EVENT_STYLE[name][:2] == (e.marker, e.colour)
    for halt in explaining("halt"):
        ep = Episode(halt.closing, "trk_1", 5, "trk_2" if halt.arity == 2 else None, 9, "recover")
        assert halt.phrase in explain_episode(scene, ep)


def test_every_event_has_its_precondition_and_integrity_constraint_in_events_lp():
    # 'poss(NAME(..)) :- event(NAME(..)), ...' and ':- occurs_at(NAME(..), curr_time), not poss(NAME(..)).'
    # per event: without the constraint ASP could abduce the event where it is impossible
    text = _lp("events.lp")
    poss_heads = set(re.findall(r"^poss\((\w+)\(", text, flags=re.M))
    guarded = {a for a, b in re.findall(r"^:- occurs_at\((\w+)\([^)]*\), curr_time\), not poss\((\w+)\(",
                                        text, flags=re.M) if a == b}
    assert poss_heads == set(EVENT_TABLE) and guarded == set(EVENT_TABLE)


def test_clingo_derives_the_same_possible_events_as_python():
    # poss/1 is in the stratified part of the encoding, so grounding decides it: on the
    # every-event frame and on random frames with random histories (tests/framegen.py, which
    # draws every event of the table), clingo's poss/1 facts are Python's possible events
    pytest.importorskip("clingo")
    import random

    from framegen import random_frame
    from refimpl.solvers.clingo_backend import ClingoSolver

    rng = random.Random(5)
    problems = [parse_facts(FRAME)] + [random_frame(rng, with_history=True) for _ in range(40)]
    for problem in problems:
        ctl = ClingoSolver().control(problem, "")
        ctl.ground([("base", [])])
        asp = {str(a.symbol)[len("poss("):-1] for a in ctl.symbolic_atoms
               if a.is_fact and a.symbol.name == "poss"}
        state, c = EventState.from_problem(problem), resolve_constants(problem)
        python = {atom for atom, ok in possible_events(problem, state, c).items() if ok}
        assert asp == python, (problem.to_facts(), asp ^ python)


# string constants of refimpl's code (not docstrings) that may name an event: the paper's query
# syntax shown in a usage line
_NAMED_ON_PURPOSE = {("scene/queries.py", "anticipate(unhides_from_behind(T,T2),T') for T hidden at FRAME, "
                      "with the warning")}


def test_no_module_but_the_event_table_chooses_an_event_by_name():
    # every consumer reads the table's roles (explains, halt_kind, occluder, prefilter, hides,
    # unhides, ...): a string constant in code that is an event's name ('hides_behind') or the
    # start of its term ('recover(') would be an event chosen by name.  Names that are plain English
    # words too (lost, noise) count only as terms.  Docstrings are prose and not looked at.
    import ast
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent / "refimpl"
    term = re.compile(r"\b(%s)\(" % "|".join(EVENT_TABLE))
    found = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root).as_posix()
        if rel == "knowledge/event_table.py":
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        prose = {id(n.value) for n in ast.walk(tree)
                 if isinstance(n, ast.Expr) and isinstance(n.value, ast.Constant)}
        for n in ast.walk(tree):
            if isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in prose:
                named = (n.value in EVENT_TABLE and "_" in n.value) or term.search(n.value)
                if named and (rel, n.value) not in _NAMED_ON_PURPOSE:
                    found.append(f"{rel}:{n.lineno}: {n.value[:60]!r}")
    assert not found, found


def test_every_halt_kind_reaches_the_track_summary_and_the_report():
    # one scene per halting event: trk_1 observed in frames 1-4, halted by the event at 5, halted
    # (predicted) in 5-7, resumed at 8 by a one-track resume: track_summary lists one halt of the
    # event's kind from 5 to 7 ('to' is the frame before the resume), and the report's box states
    # in frames 5-7 are that kind
    from refimpl.scene.report import frame_states
    from refimpl.scene.queries import track_summary
    from refimpl.core.spec import HistoryEvent, Term

    resume = next(e for e in explaining("resume") if e.arity == 1)
    box = (0.0, 0.0, 10.0, 10.0)
    for halt in explaining("halt"):
        args = (Term("trk_1"), Term("trk_2")) if halt.arity == 2 else (Term("trk_1"),)
        events = [HistoryEvent(Term(explaining("start")[0].name, (Term("trk_1"),)), 1),
                  HistoryEvent(Term(halt.name, args), 5), HistoryEvent(Term(resume.name, (Term("trk_1"),)), 8)]
        tracks = [SceneTrack("trk_1", "car", tuple((f, box) for f in (1, 2, 3, 4, 8, 9)),
                             tuple((f, box) for f in (5, 6, 7)), None),
                  SceneTrack("trk_2", "car", tuple((f, box) for f in range(1, 10)), (), None)]
        scene = make_scene("t", tracks, events, 1, 9)
        halts = track_summary(scene, "trk_1")["halts"]
        assert [(h["kind"], h["from"], h["to"], h["ended_by"]) for h in halts] == [(halt.halt_kind, 5, 7, resume.name)]
        states = frame_states(scene)
        assert [b.state for f in (5, 6, 7) for b in states[f] if b.track == "trk_1"] == [halt.halt_kind] * 3
