"""Scenes: JSON round trip, fluent timelines, queries, explanations, anticipation, situations, CLI errors.

Most tests use one hand-made scene, BUS, whose numbers are derived by hand in the comments:

* image 600 x 240, frames 200..280;
* trk_12 (bus): static box (100, 100, 200, 100) = x 100..300, y 100..200, observed 200..280;
* trk_13 (car): 40 x 60 box at y = 120 (y 120..180, inside the bus vertically), moving right at
  5 px/frame, x(f) = 30 + 5 (f - 220); observed 220..234 (x 30..100), hidden behind the bus by
  hides_behind at 235, halted 235..267 with predicted x(f) = 100 + 5 (f - 234) (the same line),
  resumed by unhides_from_behind at 268 (x 270), observed 268..280 (x 270..330);
* trk_5 (pedestrian): static (500, 20, 20, 50), observed 200..250 except 210, 211 (missing at
  210, recovered at 212), leaves the field of view at 250;
* trk_7 (pedestrian): (550, 30, 20, 40) at 205, 206; discarded as noise at 207.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys

import pytest

from refimpl.io.datasets import benchmark_sequences
from refimpl import cli
from refimpl.scene import (EgoRegion, ReasoningConfig, SceneError, SceneTrack, anticipate, episodes, explain,
                           fluent_timelines, hidden_behind_at, hiding_episodes, load_scene, make_scene, query,
                           save_scene, scene_from_json, scene_to_json, score_scene, situations,
                           summarise_outcomes)
from refimpl.core.spec import HistoryEvent
from refimpl.core.facts import parse_term
from refimpl.solvers import BACKENDS


def ev(atom: str, t: int) -> HistoryEvent:
    return HistoryEvent(parse_term(atom), t)


def car_x(f: int) -> float:
    return 30.0 + 5 * (f - 220)


def bus_scene():
    bus = SceneTrack("trk_12", "bus", tuple((f, (100.0, 100.0, 200.0, 100.0)) for f in range(200, 281)), (), None)
    car = SceneTrack(
        "trk_13", "car",
        tuple((f, (car_x(f), 120.0, 40.0, 60.0)) for f in [*range(220, 235), *range(268, 281)]),
        tuple((f, (car_x(f), 120.0, 40.0, 60.0)) for f in range(235, 268)), None)
    ped = SceneTrack("trk_5", "pedestrian",
                     tuple((f, (500.0, 20.0, 20.0, 50.0)) for f in range(200, 251) if f not in (210, 211)),
                     tuple((f, (500.0, 20.0, 20.0, 50.0)) for f in (210, 211)), 250)
    noise = SceneTrack("trk_7", "pedestrian", tuple((f, (550.0, 30.0, 20.0, 40.0)) for f in (205, 206)), (), 207)
    events = [ev("enters_fov(trk_5)", 200), ev("enters_fov(trk_12)", 200), ev("enters_fov(trk_7)", 205),
              ev("noise(trk_7)", 207), ev("missing_detections(trk_5)", 210), ev("recover(trk_5)", 212),
              ev("enters_fov(trk_13)", 220), ev("hides_behind(trk_13,trk_12)", 235), ev("leaves_fov(trk_5)", 250),
              ev("unhides_from_behind(trk_13,trk_12)", 268)]
    return make_scene("BUS", [bus, car, ped, noise], events, 200, 280, (600, 240), 25.0)


@pytest.fixture
def scene():
    return bus_scene()


# ---------------------------------------------------------------------------------------
# the scene and its file
# ---------------------------------------------------------------------------------------

def test_saved_scene_loads_equal(scene, tmp_path):
    path = tmp_path / "bus.scene.json"
    save_scene(path, scene)
    assert load_scene(path) == scene
    assert scene_from_json(json.loads(json.dumps(scene_to_json(scene)))) == scene


def test_fluent_timelines_replay_the_events_with_effects_from_the_next_frame():
    # hides_behind at 235 makes trk_13 not_visible and hidden_by true from 236 on; unhides at 268
    # resets both from 269; missing_detections at 10 clips trk_5 at 11..12, recover at 12 unclips
    # it from 13.  Lives: trk_13 230..280, trk_5 5..20, trk_12 230..280.
    events = [ev("hides_behind(trk_13,trk_12)", 235), ev("unhides_from_behind(trk_13,trk_12)", 268),
              ev("missing_detections(trk_5)", 10), ev("recover(trk_5)", 12), ev("leaves_fov(trk_5)", 18)]
    lines = fluent_timelines(events, {"trk_13": (230, 280), "trk_5": (5, 20), "trk_12": (230, 280)})
    assert lines["visibility(trk_13)"] == ((230, 235, "fully_visible"), (236, 268, "not_visible"),
                                           (269, 280, "fully_visible"))
    assert lines["hidden_by(trk_13,trk_12)"] == ((230, 235, "false"), (236, 268, "true"), (269, 280, "false"))
    assert lines["clipped(trk_5)"] == ((5, 10, "false"), (11, 12, "true"), (13, 20, "false"))
    assert lines["in_fov(trk_5)"] == ((5, 18, "true"), (19, 20, "false"))
    assert lines["visibility(trk_12)"] == ((230, 280, "fully_visible"),)
    assert "hidden_by(trk_12,trk_13)" not in lines  # no event names that pair


def test_set_valued_fluent_gives_overlapping_intervals():
    # two events at 3 set visibility(trk_1) to two values at once: both hold from 4 on
    events = [ev("hides_behind(trk_1,trk_2)", 3), ev("recover(trk_1)", 3)]
    lines = fluent_timelines(events, {"trk_1": (1, 6)})
    assert lines["visibility(trk_1)"] == ((1, 3, "fully_visible"), (4, 6, "fully_visible"), (4, 6, "not_visible"))


def test_scene_timelines_follow_the_track_lives(scene):
    assert scene.timeline("hidden_by(trk_13,trk_12)") == ((220, 235, "false"), (236, 268, "true"),
                                                          (269, 280, "false"))
    assert scene.timeline("clipped(trk_5)") == ((200, 210, "false"), (211, 212, "true"), (213, 250, "false"))
    assert scene.timeline("visibility(trk_7)") == ((205, 207, "fully_visible"),)


# ---------------------------------------------------------------------------------------
# queries
# ---------------------------------------------------------------------------------------

def test_query_hidden_by_lists_the_hidden_tracks_with_their_frames(scene):
    a = query(scene, "hidden_by trk_12")
    assert a.lines == ("trk_13 hidden by trk_12: frames 236-268",)
    assert a.data == [{"track": "trk_13", "frames": [[236, 268]]}]
    assert query(scene, "hidden_by 13").lines == ("no track was hidden by trk_13",)


def test_query_holds_at_gives_every_fluent_of_a_track(scene):
    assert query(scene, "holds_at trk_13 240").lines == (
        "visibility(trk_13) = not_visible", "clipped(trk_13) = false", "in_fov(trk_13) = true",
        "hidden_by(trk_13,trk_12) = true", "trk_13 at 240: halted box (130, 120, 40, 60)")
    # at 235 the hides_behind of 235 has not taken effect yet
    assert query(scene, "holds_at trk_13 235").lines[0] == "visibility(trk_13) = fully_visible"
    assert query(scene, "holds_at trk_13 235").lines[3] == "hidden_by(trk_13,X) = false for every other track X"


def test_query_events_between_two_frames(scene):
    assert query(scene, "events 230 270").lines == (
        "occurs_at(hides_behind(trk_13,trk_12),235)", "occurs_at(leaves_fov(trk_5),250)",
        "occurs_at(unhides_from_behind(trk_13,trk_12),268)")
    assert query(scene, "events 200 212 trk_5").lines == (
        "occurs_at(enters_fov(trk_5),200)", "occurs_at(missing_detections(trk_5),210)",
        "occurs_at(recover(trk_5),212)")


def test_query_relation_overlapping_and_near(scene):
    # overlapping (interiors share area) needs x + 40 > 100 and x < 300 with both observed:
    # x(f) = 30 + 5 (f - 220) > 60 from f = 227; at 268..273 x = 270..295 < 300 (274: x = 300 touches)
    assert query(scene, "relation trk_12 overlapping").lines == ("trk_13 overlapping trk_12: frames 227-234, 268-273",)
    # near: centre distance |x + 20 - 200| < mean diagonal (sqrt(200^2+100^2) + sqrt(40^2+60^2)) / 2 = 147.9
    # -> 32.1 < x < 327.9: f = 221..234 and 268..279 (x(280) = 330); trk_5 is 327 px away: not near
    assert query(scene, "relation trk_12 near").lines == ("trk_13 near trk_12: frames 221-234, 268-279",)
    # movement over 5 frames (both observed at f - 5 and f): the car's centre x + 20 gains 25 px on
    # the bus centre 200 while left of it (225..234), loses 25 px right of it (273..280)
    assert query(scene, "relation trk_12 approaching").lines == ("trk_13 approaching trk_12: frames 225-234",)
    assert query(scene, "relation trk_12 moving_away").lines == ("trk_13 moving_away trk_12: frames 273-280",)
    # lifetimes: trk_13 (220..280) finishes trk_12 (200..280)
    assert query(scene, "relation trk_12 finishes").data == [{"track": "trk_13", "frames": [[220, 280]]}]


def test_query_track_tells_its_life(scene):
    assert query(scene, "track trk_13").lines == (
        "trk_13 (car): frames 220-280, observed in 28, halted in 33",
        "  hidden behind trk_12: frames 235-267 (unhides_from_behind at 268)",
        "  alive at the end of the sequence (frame 280)")
    assert query(scene, "track 5").lines == (
        "trk_5 (pedestrian): frames 200-250, observed in 49, halted in 2",
        "  missing: frames 210-211 (recover at 212)",
        "  ended at frame 250 (leaves_fov)")


def test_query_answers_as_json(scene):
    data = json.loads(query(scene, "events 268 268").to_json())
    assert data == {"query": "events 268 268",
                    "answer": [{"time": 268, "event": "unhides_from_behind(trk_13,trk_12)"}]}


@pytest.mark.parametrize("text, message", [
    ("", "empty query"),
    ("who_hid trk_12", "unknown query 'who_hid'"),
    ("hidden_by", "query 'hidden_by' takes the form 'hidden_by T'"),
    ("holds_at trk_13 soon", "FRAME must be a frame number, got 'soon'"),
    ("hidden_by trk_99", "no track trk_99 in scene BUS (4 tracks, trk_5 .. trk_13)"),
    ("relation trk_12 nearby", "unknown relation 'nearby'"),
])
def test_bad_query_is_a_one_line_error_listing_the_forms(scene, text, message):
    with pytest.raises(SceneError) as info:
        query(scene, text)
    assert message in str(info.value)
    assert "\n" not in str(info.value)
    if "relation" not in message and "no track" not in message:
        assert "query forms: tracks | track T | hidden_by T | holds_at T FRAME" in str(info.value)


# ---------------------------------------------------------------------------------------
# explanations
# ---------------------------------------------------------------------------------------

def test_explanation_sentences_one_per_episode_in_time_order(scene):
    assert explain(scene) == [
        "Track 5 (pedestrian) entered the field of view at frame 200.",
        "Track 12 (bus) entered the field of view at frame 200.",
        "Track 7 (pedestrian) entered the field of view at frame 205.",
        "Track 7 (pedestrian), seen since frame 205, was discarded as noise at frame 207.",
        "Track 5 (pedestrian) was missed by the detector at frame 210 and was detected again at frame 212,"
        " 2 frames later.",
        "Track 13 (car) entered the field of view at frame 220.",
        "Track 13 (car) went out of sight behind track 12 (bus) at frame 235 and reappeared at frame 268,"
        " 33 frames later.",
        "Track 5 (pedestrian) left the field of view at frame 250.",
    ]


def test_explanation_of_one_track_includes_what_it_hid(scene):
    assert explain(scene, "12") == [
        "Track 12 (bus) entered the field of view at frame 200.",
        "Track 13 (car) went out of sight behind track 12 (bus) at frame 235 and reappeared at frame 268,"
        " 33 frames later."]


def test_explanation_of_halts_that_end_the_track():
    # hidden then lost 30 frames later; missing then noise; hidden and still hidden at the end
    t = SceneTrack("trk_1", "car", ((1, (0.0, 0.0, 10.0, 10.0)),), (), 31)
    u = SceneTrack("trk_2", "car", ((1, (0.0, 0.0, 20.0, 20.0)),), (), None)
    v = SceneTrack("trk_3", "cyclist", ((2, (0.0, 0.0, 20.0, 20.0)),), (), 4)
    s = make_scene("S", [t, u, v], [ev("hides_behind(trk_1,trk_2)", 1), ev("lost(trk_1)", 31),
                                    ev("missing_detections(trk_3)", 3), ev("noise(trk_3)", 4),
                                    ev("hides_behind(trk_2,trk_3)", 2)], 1, 40)
    assert explain(s) == [
        "Track 1 (car) went out of sight behind track 2 (car) at frame 1 and was given up as lost at frame 31,"
        " 30 frames later.",
        "Track 2 (car) went out of sight behind track 3 (cyclist) at frame 2 and was still hidden at the end"
        " of the sequence (frame 40).",
        "Track 3 (cyclist) was missed by the detector at frame 3 and was discarded as noise at frame 4,"
        " 1 frame later."]


# ---------------------------------------------------------------------------------------
# anticipation (paper 4.1.2) and the ego region
# ---------------------------------------------------------------------------------------

def test_anticipated_reappearance_of_a_box_moving_behind_a_wider_static_box(scene):
    # At now = 235 the car's last 6 observations 229..234 (x 75..100) give 5 px/frame; predicted
    # x(f) = 100 + 5 (f - 234).  At 235 it is x 105..145 inside the bus (coverage 1 >= 0.5).  It
    # moves out when the bus covers less than half its width: 300 - x < 20, x > 280, so
    # f - 234 > 36: f = 271 (x = 285; at 270 x = 280 covers exactly 20/40 = 0.5, still behind).
    a = anticipate(scene, "trk_13", 235)
    assert (a.hider, a.at, a.box, a.position) == ("trk_12", 271, (285.0, 120.0, 40.0, 60.0), (305.0, 150.0))
    # bottom-centre (305, 180) lies in the ego region x 200..400, y 120..240 of the 600 x 240 image,
    # but 271 - 235 = 36 is not below the threshold 30: no warning yet
    assert a.in_front and not a.warning
    assert a.atoms() == ["anticipate(unhides_from_behind(trk_13,trk_12),271)",
                         "point2d(interpolated_position(trk_13,271),305,150)"]
    # at 245 the same line gives 271 again: 26 < 30 frames ahead -> warning; with threshold 20 none
    b = anticipate(scene, "trk_13", 245)
    assert b.at == 271 and b.warning
    assert b.atoms()[-1] == "warning(hidden_entity_in_front(trk_13,271))"
    assert not anticipate(scene, "trk_13", 245, ReasoningConfig(anticipation_threshold=20)).warning
    # the Kalman reading (last observed x 100 at 234, first predicted x 105 at 235) is the same
    # line; with covered_share 0.6 both move out when 300 - x < 24: x(270) = 280 (0.5 < 0.6),
    # x(269) = 275 (25/40 = 0.625, still behind)
    for motion in ("velocity", "kalman"):
        k = anticipate(scene, "trk_13", 235, ReasoningConfig(motion=motion, covered_share=0.6))
        assert (k.at, k.box) == (270, (280.0, 120.0, 40.0, 60.0))


def test_no_anticipation_for_a_visible_track_or_one_not_behind(scene):
    assert hidden_behind_at(scene, "trk_13", 234) is None
    assert hidden_behind_at(scene, "trk_13", 267) == "trk_12"
    assert hidden_behind_at(scene, "trk_13", 268) is None  # unhidden at 268
    assert anticipate(scene, "trk_13", 230) is None
    # proper part read strictly (covered_share 1.0): inside at 235; out when x(f) + 40 > 300,
    # 100 + 5 (f - 234) > 260, f > 266: 267 (at 266 the right edges meet: still a part)
    assert anticipate(scene, "trk_13", 235, ReasoningConfig(covered_share=1.0)).at == 267


def test_ego_region_tests_the_bottom_centre_of_a_box():
    r = EgoRegion()  # x in [1/3, 2/3] of the width, y in [1/2, 1] of the height
    size = (600, 300)  # region x 200..400, y 150..300
    assert r.contains((180, 100, 40, 60), size)          # bottom-centre (200, 160): on the edge, inside
    assert not r.contains((170, 100, 40, 60), size)      # (190, 160): left of it
    assert not r.contains((250, 20, 40, 60), size)       # (270, 80): above it
    assert not r.contains((250, 100, 40, 60), None)      # unknown image size: never in front
    assert EgoRegion.parse("0,1,0.8,1").contains((0, 200, 10, 50), size)  # (5, 250): in the bottom band
    with pytest.raises(SceneError, match="ego region must be X0,X1,Y0,Y1"):
        EgoRegion.parse("0.3,0.7")
    with pytest.raises(SceneError, match="0 <= x0 < x1 <= 1"):
        EgoRegion(0.7, 0.3, 0.5, 1)


def test_query_anticipate(scene):
    assert query(scene, "anticipate trk_13 245").lines[:3] == (
        "anticipate(unhides_from_behind(trk_13,trk_12),271)",
        "point2d(interpolated_position(trk_13,271),305,150)",
        "warning(hidden_entity_in_front(trk_13,271))")
    assert query(scene, "anticipate trk_13 230").lines == ("trk_13 is not hidden at frame 230",)
    # read strictly (covered_share 1.0), at 267 the predicted x 265..305 sticks out 5 px: 35/40 covered
    assert query(scene, "anticipate trk_13 267", ReasoningConfig(covered_share=1.0)).lines == (
        "no anticipation: trk_13 is hidden behind trk_12 at frame 267, but trk_12 covers only 88% of its "
        "predicted box (the rule needs 100%)",)


def test_score_scene_compares_the_anticipation_with_the_actual_reappearance(scene):
    # one hides -> unhides episode: hidden at 235, reappeared at 268 at x 270 (centre (290, 150));
    # anticipated at 235 for 271 at centre (305, 150): frame error +3, position error 15 px
    (o,) = score_scene(scene)
    assert (o.hidden_at, o.reappeared_at, o.anticipation.at) == (235, 268, 271)
    s = summarise_outcomes([o])
    assert s["at_hiding"]["frame_error"]["median"] == 3
    assert s["at_hiding"]["lead"]["median"] == 33
    assert math.isclose(s["at_hiding"]["position_error"]["median"], 15.0)
    # baseline "next frame, where last seen": 236 vs 268 is 32 frames off, and the last seen
    # centre (120, 150) at 234 is 170 px from (290, 150)
    assert s["baseline"]["abs_frame_error"]["median"] == 32
    assert math.isclose(s["baseline"]["position_error"]["median"], 170.0)


# ---------------------------------------------------------------------------------------
# situations
# ---------------------------------------------------------------------------------------

def test_hidden_entity_while_the_hidden_box_is_in_front(scene):
    # halted 235..267 at x(f) = 100 + 5 (f - 234); bottom-centre (x + 20, 180) is in the region
    # x 200..400, y 120..240 from x + 20 >= 200: f >= 250
    found = [s for s in situations(scene) if s.kind == "HIDDEN_ENTITY"]
    assert [(s.objects, s.start, s.end) for s in found] == [(("trk_13", "trk_12"), 250, 267)]
    assert query(scene, "situations").lines == ("HIDDEN_ENTITY trk_13 hidden behind trk_12 in front: frames 250-267",)


def stopping_scene(x: float):
    # y(f) = 100 + 8 f for f = 0..10, then 180 (the 40 x 40 box stops); image 600 x 400,
    # ego region x 200..400, y 200..400.  Bottom-centre speeds over 3 frames: 8 px/frame up to
    # f = 10, v(11) = 16/3, v(12) = 8/3, v(13) = v(14) = ... = 0.
    # Stop at f when v(f-3) >= 4 and v(f) <= 0.25 v(f-3): f = 13 (8 -> 0), f = 14 (5.33 -> 0);
    # not 12 (8 -> 2.67 > 2), not 15 (v(12) = 2.67 < 4).  Spans 10..13 and 11..14 merge: 10-14.
    boxes = tuple((f, (x, 100.0 + 8 * min(f, 10), 40.0, 40.0)) for f in range(0, 21))
    return make_scene("STOP", [SceneTrack("trk_1", "car", boxes, (), None)], [], 0, 20, (600, 400))


def test_sudden_stop_of_a_track_in_front():
    assert [(s.kind, s.objects, s.start, s.end) for s in situations(stopping_scene(280.0))] == [
        ("SUDDEN_STOP", ("trk_1",), 10, 14)]
    # the same stop at the left border (bottom-centre x = 40) is not in front
    assert situations(stopping_scene(20.0)) == []
    # a stricter ratio: 0 <= 0.1 * 8 still holds at 13 and 14
    assert len(situations(stopping_scene(280.0), ReasoningConfig(stop_ratio=0.1))) == 1
    # a higher minimum speed than 8 px/frame: no stop
    assert situations(stopping_scene(280.0), ReasoningConfig(stop_min_speed=9)) == []


def test_gradual_slowdown_is_not_a_sudden_stop():
    # the step shrinks by 0.5 px/frame per frame from 8: over 3 frames the speed falls by 1.5, so
    # while v(f-3) >= 4, v(f) >= 2.5 > 0.25 * 8 >= 0.25 v(f-3)
    ys, y = [], 100.0
    for f in range(0, 21):
        ys.append((f, (280.0, y, 40.0, 40.0)))
        y += max(8 - 0.5 * f, 0)
    s = make_scene("SLOW", [SceneTrack("trk_1", "car", tuple(ys), (), None)], [], 0, 20, (600, 400))
    assert situations(s) == []


# ---------------------------------------------------------------------------------------
# episodes
# ---------------------------------------------------------------------------------------

def test_episodes_pair_each_halt_with_what_ended_it(scene):
    kinds = [(e.kind, e.track, e.start, e.end, e.end_event) for e in episodes(scene)
             if e.kind in ("hidden", "missing")]
    assert kinds == [("missing", "trk_5", 210, 212, "recover"),
                     ("hidden", "trk_13", 235, 268, "unhides_from_behind")]
    (h,) = hiding_episodes(scene)
    assert (h.track, h.hider, h.hidden_at, h.resumed_at, h.how) == ("trk_13", "trk_12", 235, 268,
                                                                    "unhides_from_behind")


# ---------------------------------------------------------------------------------------
# command line: one-line errors, exit 2
# ---------------------------------------------------------------------------------------

def run_cli(capsys, *argv):
    code = cli.main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_query_explain_on_a_saved_scene(scene, tmp_path, capsys):
    path = str(tmp_path / "bus.json")
    save_scene(path, scene)
    code, out, _ = run_cli(capsys, "query", path, "hidden_by", "trk_12")
    assert code == 0 and out == "trk_13 hidden by trk_12: frames 236-268\n"
    code, out, _ = run_cli(capsys, "query", path, "events", "268", "268", "--json")
    assert code == 0 and json.loads(out)["answer"] == [{"time": 268, "event": "unhides_from_behind(trk_13,trk_12)"}]
    code, out, _ = run_cli(capsys, "query", path, "anticipate", "13", "245", "--anticipation-threshold", "20")
    assert code == 0 and "warning" not in out
    code, out, _ = run_cli(capsys, "explain", path, "--track", "13")
    assert code == 0 and out.splitlines()[-1].endswith("reappeared at frame 268, 33 frames later.")


@pytest.mark.parametrize("content, message", [
    ("{not json", "not a refimpl scene file (invalid JSON at line 1 column 2"),
    ('{"format": "something-else"}', "not a refimpl scene"),
    ('[1, 2]', "the top level must be a JSON object"),
])
def test_cli_bad_scene_file_is_a_one_line_error_naming_the_file(tmp_path, capsys, content, message):
    path = tmp_path / "bad.json"
    path.write_text(content)
    code, out, err = run_cli(capsys, "query", str(path), "tracks")
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and str(path) in err and message in err
    assert "Traceback" not in err


def test_cli_truncated_scene_fields_and_missing_file(scene, tmp_path, capsys):
    data = scene_to_json(scene)
    data["tracks"][0]["observed"][0] = [200, 1, 2]  # a box row with too few numbers
    path = tmp_path / "broken.json"
    path.write_text(json.dumps(data))
    code, _, err = run_cli(capsys, "explain", str(path))
    assert code == 2 and "tracks[0].observed: each entry must be [frame, x, y, w, h]" in err
    code, _, err = run_cli(capsys, "query", str(tmp_path / "nope.json"), "tracks")
    assert code == 2 and "nope.json: no such scene file" in err


def test_cli_bad_query_exits_2_with_the_forms(scene, tmp_path, capsys):
    path = str(tmp_path / "bus.json")
    save_scene(path, scene)
    code, out, err = run_cli(capsys, "query", path, "who", "hid", "trk_13")
    assert code == 2 and out == "" and err.count("\n") == 1
    assert err.startswith("refimpl query: error: unknown query 'who'; query forms: tracks | track T")


def test_cli_track_with_scene_needs_an_abduction_backend(tmp_path, capsys):
    from refimpl import io
    dets = io.demo_sequence_paths().dets_path
    code, _, err = run_cli(capsys, "track", "--dets", str(dets), "--backend", "baseline", "--out",
                           str(tmp_path / "r.txt"), "--scene", str(tmp_path / "s.json"))
    assert code == 2 and "--scene" in err and f"need an abduction backend ({', '.join(BACKENDS)})" in err


def test_cli_track_writes_a_scene(tmp_path, capsys):
    # the bundled 71-frame TUD-Campus sample, cut to its first 20 frames to stay fast
    from refimpl import io
    src = io.demo_sequence_paths()
    dets = tmp_path / "TUD-Campus" / "det" / "det.txt"
    dets.parent.mkdir(parents=True)
    lines = [l for l in src.dets_path.read_text().splitlines() if l and int(float(l.split(",")[0])) <= 20]
    dets.write_text("\n".join(lines) + "\n")
    out = tmp_path / "scene.json"
    code, stdout, err = run_cli(capsys, "track", "--dets", str(dets), "--backend", "cpsat",
                                "--out", str(tmp_path / "r.txt"), "--scene", str(out))
    assert code == 0, err
    s = load_scene(out)
    assert s.first_frame == 1 and s.last_frame == 20 and s.tracks and s.events
    assert all(t.observed for t in s.tracks)


def test_python_m_refimpl_scene_help_runs():
    r = subprocess.run([sys.executable, "-m", "refimpl.scene", "--help"], capture_output=True, text=True)
    assert r.returncode == 0 and "anticipation-eval" in r.stdout


# ---------------------------------------------------------------------------------------
# a real sequence
# ---------------------------------------------------------------------------------------

def test_real_sequence_hides_and_unhides_pair_up_on_the_same_track_pair(shared_data):
    # MOT15 TUD-Campus (71 frames) tracked with cpsat: people walking past each other
    from refimpl import io
    from refimpl.scene import scene_from_result
    from refimpl.tracking.pipeline import Setup, run_sequence
    seq = next(s for s in benchmark_sequences("mot15", shared_data) if s.name == "TUD-Campus")
    dets = io.load_detections(seq)
    s = scene_from_result(dets, run_sequence(dets, Setup("cpsat")))
    pairs = [h for h in hiding_episodes(s) if h.how == "unhides_from_behind"]
    assert pairs, "no hides_behind -> unhides_from_behind pair in TUD-Campus"
    for h in pairs:
        unhide = [e.time for e in s.events if e.event.name == "unhides_from_behind"
                  and [str(a) for a in e.event.args] == [h.track, h.hider] and e.time == h.resumed_at]
        assert unhide == [h.resumed_at]
        assert h.resumed_at > h.hidden_at
        # hidden while halted; observed again at the reappearance
        t = s.track(h.track)
        assert all(t.box_at(f)[0] == "halted" for f in range(h.hidden_at, h.resumed_at))
        assert t.observed_box(h.resumed_at) is not None
        # the fluent agrees: hidden_by(T1,T2) true from the frame after hiding to the reappearance
        assert (h.hidden_at + 1, h.resumed_at, "true") in s.timeline(f"hidden_by({h.track},{h.hider})")
