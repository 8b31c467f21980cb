"""The long-occlusion suite (refimpl.experiments.occlusion) and its benchmark (refimpl.experiments.occlusion_bench)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from refimpl import io
from refimpl.cli import main
from refimpl.core.geometry import iou_matrix
from refimpl.experiments.occlusion import (HIDDEN_COVER, OCCLUDER_ID, SCENARIOS, TARGET_ID, build_scenario, build_suite,
                               write_scenario)
from refimpl.experiments.occlusion_bench import TOLERANCE, parse_variant, run_variant


@pytest.fixture(scope="module")
def suite():
    return build_suite(0)


def _covered(back, front) -> float:
    """Share of box `back` (x, y, w, h) inside box `front`, computed on its own here."""
    x1, y1 = max(back[0], front[0]), max(back[1], front[1])
    x2 = min(back[0] + back[2], front[0] + front[2])
    y2 = min(back[1] + back[3], front[1] + front[3])
    return max(x2 - x1, 0.0) * max(y2 - y1, 0.0) / (back[2] * back[3])


def _box(gt, obj_id, frame):
    sel = (gt.ids == obj_id) & (gt.frames == frame)
    return gt.boxes[sel][0] if sel.any() else None


def test_suite_covers_the_issue_range():
    lengths = sorted(s.length for s in SCENARIOS)
    # 12 occlusion lengths/directions/kinds, and the one target missed just before it hides
    assert lengths[0] == 30 and lengths[-1] == 150 and 8 <= len(SCENARIOS) <= 13
    assert {s.v_target > 0 for s in SCENARIOS} == {True, False}  # both directions
    assert all(s.occluder_size[0] > s.target_size[0] and s.occluder_size[1] > s.target_size[1] for s in SCENARIOS)
    assert all(s.v_occluder != 0 for s in SCENARIOS)  # the occluders move


def test_same_seed_same_suite_other_seed_other_detections(tmp_path):
    a, b = build_scenario(SCENARIOS[3], seed=7), build_scenario(SCENARIOS[3], seed=7)
    assert a.truth == b.truth
    assert all(np.array_equal(fa.boxes, fb.boxes) and np.array_equal(fa.scores, fb.scores)
               for fa, fb in zip(a.detections.frames, b.detections.frames))
    write_scenario(a, tmp_path / "a")
    write_scenario(b, tmp_path / "b")
    for rel in ("det/det.txt", "gt/gt.txt", "seqinfo.ini", "occlusion.ini"):
        assert (tmp_path / "a" / a.name / rel).read_bytes() == (tmp_path / "b" / b.name / rel).read_bytes()
    c = build_scenario(SCENARIOS[3], seed=8)
    assert not np.array_equal(np.concatenate([f.boxes for f in a.detections.frames]),
                              np.concatenate([f.boxes for f in c.detections.frames]))


def test_target_is_more_than_half_covered_exactly_in_the_recorded_frames(suite):
    for spec, sc in zip(SCENARIOS, suite):
        gt, t = sc.ground_truth, sc.truth
        hidden = []
        for f in range(gt.first_frame, gt.last_frame + 1):
            tb, ob = _box(gt, TARGET_ID, f), _box(gt, OCCLUDER_ID, f)
            assert tb is not None  # the target stays in the image for the whole sequence
            if ob is not None and _covered(tb, ob) > HIDDEN_COVER:
                hidden.append(f)
            if ob is not None:  # the occluder stands in front: its bottom edge is lower
                assert ob[1] + ob[3] > tb[1] + tb[3]
        assert hidden == list(range(t.hide_frame, t.reappear_frame)), spec.name
        assert t.length == spec.length


def test_cover_at_the_hiding_frame_is_the_designed_one(suite):
    # occl030-ped-right-opposite: target 36 px wide, occluder 240 px wide, L = 30 frames, so the
    # relative speed is 240 / 30 = 8 px/frame.  At the hiding frame the centres are 240/2 - 8/2 =
    # 116 px apart: the overlap is (240 + 36)/2 - 116 = 22 px of 36, cover 22/36 = 0.611; a frame
    # earlier they are 124 px apart: overlap 14 px, cover 14/36 = 0.389 (<= 0.5, still detected).
    sc = suite[0]
    gt, t = sc.ground_truth, sc.truth
    h = t.hide_frame
    assert _covered(_box(gt, TARGET_ID, h), _box(gt, OCCLUDER_ID, h)) == pytest.approx(22 / 36, abs=1e-3)
    assert _covered(_box(gt, TARGET_ID, h - 1), _box(gt, OCCLUDER_ID, h - 1)) == pytest.approx(14 / 36, abs=1e-3)
    # the visibility column says the same
    row = (gt.ids == TARGET_ID) & (gt.frames == h)
    assert gt.visibility[row][0] == pytest.approx(1 - 22 / 36, abs=1e-3)


def test_hidden_target_is_never_detected_and_is_mostly_detected_otherwise(suite):
    for sc in suite:
        gt, t = sc.ground_truth, sc.truth
        seen = 0
        for f in range(gt.first_frame, gt.last_frame + 1):
            boxes = sc.detections.frame(f).boxes
            best = iou_matrix(_box(gt, TARGET_ID, f).reshape(1, 4), boxes).max() if len(boxes) else 0.0
            if t.hide_frame <= f < t.reappear_frame:
                # a true detection (3 % centre / size jitter) overlaps its box by IoU > 0.8; a false
                # positive placed near the occluder may overlap the hidden target a little (0.43 seen)
                assert best < 0.5, (sc.name, f)
            else:
                seen += best >= 0.5
        visible = gt.num_frames - t.length
        # p_max = 0.98 and 3 % jitter: about 98 % of the visible frames; at least 90 % on every seed-0 scenario
        assert seen >= 0.9 * visible, sc.name


def test_written_files_read_back_as_the_in_memory_sequence(tmp_path, suite):
    sc = suite[1]
    folder = write_scenario(sc, tmp_path)
    # the suite's sequences carry their scores as probabilities (docs/occlusion.md): read so
    dets = io.read_mot_detections(folder / "det" / "det.txt", scores_rule="probability")
    gt = io.read_mot_ground_truth(folder / "gt" / "gt.txt")
    assert dets.image_size == (1280, 720) and dets.num_frames == sc.detections.num_frames
    for a, b in zip(dets.frames, sc.detections.frames):
        assert np.array_equal(a.boxes, b.boxes) and np.array_equal(a.scores, b.scores)
        assert np.array_equal(a.confidences, b.confidences)
    g = sc.ground_truth
    for name in ("frames", "ids", "boxes", "visibility", "considered"):
        assert np.array_equal(getattr(gt, name), getattr(g, name)), name


def test_baseline_loses_the_identity_in_a_long_occlusion(suite):
    # SORT deletes a track after max_age = 1 frame without a detection; the target goes 150
    # frames undetected, so it must come back under a new id.
    sc = next(s for s in suite if s.truth.length == 150)
    r = run_variant(sc, "baseline")
    assert not r.one_identity and len(r.target_ids) >= 2 and r.idsw >= 1


def test_abduction_hides_the_target_on_time_in_a_long_occlusion(suite):
    # today's model: hides_behind at the first undetected frame, when the prediction is covered
    # > 10 % by the nearer occluder; the truth's hide_frame is the first frame covered > 50 %,
    # i.e. the first undetected frame unless a random miss came just before it.
    sc = next(s for s in suite if s.truth.length == 90)
    r = run_variant(sc, "cpsat")
    assert r.hide_offset is not None and abs(r.hide_offset) <= TOLERANCE


def test_abduction_keeps_the_identity_through_a_30_frame_occlusion(suite):
    # the shortest occlusion of the suite: kept since the first tracker (lost_after_hidden = 30
    # frames was just long enough: the unhide at the reappearance frame is cheaper than `lost`)
    r = run_variant(suite[0], "cpsat")
    assert r.one_identity and r.on_time and r.passed


def test_abduction_keeps_the_identity_through_a_150_frame_occlusion(suite):
    # main 9a69e46 (a hidden track persists while its occluder covers its prediction; resume
    # by evidence): the car hidden 150 frames behind a truck comes back as itself, on time
    sc = next(s for s in suite if s.name == "occl150-car-right-overtakes")
    r = run_variant(sc, "cpsat")
    assert r.one_identity and r.on_time and r.passed


def test_parse_variant():
    assert parse_variant("cpsat+hold+oru") == ("cpsat", {"hold_hidden": True, "reupdate_on_resume": True})
    assert parse_variant("baseline") == ("baseline", {})
    assert parse_variant("cpsat+persist")[1] == {"constants": {"lost_after_hidden": 1000}}
    for bad in ("baseline+hold", "cpsat+fast", "sort"):
        with pytest.raises(ValueError):
            parse_variant(bad)


def test_cli_writes_the_suite_and_never_overwrites_without_force(tmp_path, capsys):
    assert main(["occlusion-suite", "--out", str(tmp_path)]) == 0
    first = SCENARIOS[0].name
    info = io.read_seqinfo(tmp_path / first / "seqinfo.ini")
    assert info["imWidth"] == 1280 and info["seqLength"] > SCENARIOS[0].length
    text = (tmp_path / first / "occlusion.ini").read_text()
    assert "hide_frame=" in text and "reappear_frame=" in text
    (tmp_path / first / "det" / "det.txt").write_text("mine\n")
    assert main(["occlusion-suite", "--out", str(tmp_path)]) == 2
    assert (tmp_path / first / "det" / "det.txt").read_text() == "mine\n"
    assert "--force" in capsys.readouterr().err
    assert main(["bench-occlusion", "--trackers", "cpsat+nope", "--out", "-"]) == 2


def test_bench_occlusion_command_writes_its_section(tmp_path, capsys):
    out = tmp_path / "occlusion.md"
    out.write_text("# Mine\n\nkept text\n")
    assert main(["bench-occlusion", "--trackers", "baseline", "--out", str(out), "--quiet"]) == 0
    text = out.read_text()
    assert text.startswith("# Mine\n\nkept text\n") and "<!-- bench-occlusion:begin -->" in text
    # SORT (max_age 1) cannot bridge any of the 30..150-frame occlusions
    assert f"baseline: 0/{len(SCENARIOS)} scenarios pass" in text
    assert sum(line.startswith("| occl") for line in text.splitlines()) == len(SCENARIOS)
    assert "Command: `refimpl bench-occlusion --trackers baseline --seed 0`" in text
    assert "### baseline" in capsys.readouterr().out


EXPLAIN_IGNORE = ":- ignore_trk(Trk), holds_at(clipped(Trk), true, curr_time), poss(hides_behind(Trk, _)), not reexplained(Trk).\n"


def test_a_target_missed_just_before_it_hides_needs_the_reexplained_ignore(tmp_path):
    # occl030-ped-right-missed: the detector misses the target from hide_frame - 3 on.  Then its
    # box is not covered at all (the cover grows by 8/36 = 0.22 a frame and is 0.61 at
    # hide_frame), so it halts by missing_detections; a frame later, still missed, it is covered
    # 0.17 > hide_overlap 10 % from the front, and explain_ignore re-explains its ignore as
    # hides_behind: at hide_frame - 2.  Dropping that constraint from a copy of model/*.lp makes
    # the ignore go unexplained, one unit cheaper at level 1: the copy's answer differs on exactly
    # the frames whose oracle answer holds a re-explained ignore (ignore_trk(T) with
    # hides_behind(T, _)): elsewhere the oracle's answer is admissible in the copy too, and no
    # answer the copy adds is cheaper (an end beats an ignore at level 3, a resume at level 5).
    pytest.importorskip("clingo")
    import dataclasses

    from refimpl.runs.diff import diff_sequence
    from refimpl.core.hypothesis import parse_action
    from refimpl.tracking.pipeline import Setup, run_sequence
    from refimpl.solvers.asp_model import load_asp_model

    spec = next(s for s in SCENARIOS if s.missed_before)
    sc = build_scenario(spec)
    hide = sc.truth.hide_frame
    seq = dataclasses.replace(sc.detections, frames=tuple(f for f in sc.detections.frames if f.frame <= hide + 5))
    reexplained = []

    def observe(problem, hyp):
        ignored = {args[0] for name, args in map(parse_action, hyp.actions) if name == "ignore_trk"}
        if any(name == "hides_behind" and args[0] in ignored for name, args in hyp.event_terms):
            reexplained.append(problem.time)

    run_sequence(seq, Setup("cpsat-full", ()), observer=observe)
    assert reexplained == [hide - 2]
    # the whole scenario with the fast path: hidden at -2, back on time, one identity
    r = run_variant(sc, "cpsat")
    assert r.hide_offset == -2 and r.unhide_offset == 0 and r.passed

    folder = tmp_path / "no_explain_ignore"
    folder.mkdir()
    for lp in sorted((Path(__file__).resolve().parent.parent / "model").glob("*.lp")):
        text = lp.read_text()
        if lp.name == "events.lp":
            assert text.count(EXPLAIN_IGNORE) == 1
            text = text.replace(EXPLAIN_IGNORE, "")
        (folder / lp.name).write_text(text)
    model = load_asp_model(folder)
    report = diff_sequence(seq, asp_model=model)
    assert report.disagreement_frames == reexplained
    assert "breaks explain_ignore" in report.first_divergence.explanation
    assert "only in cpsat-full: occurs_at(hides_behind(" in report.first_divergence.describe()
    # tracked with the copy, the target stays a clipped, merely missed track: no hides_behind, and
    # it comes back by recover, not unhides_from_behind, so the scenario fails
    from refimpl.experiments.occlusion_bench import score
    from refimpl.solvers import get_solver
    copy = get_solver("clingo", model_files=model.files)
    result = run_sequence(sc.detections, Setup("clingo"), solver=copy)
    r = score(sc, "clingo", result.rows, result.events)
    assert r.hide_offset is None and r.unhide_offset is None and r.ended.startswith("recover ") and not r.passed
