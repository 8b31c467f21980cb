"""The confidence of a detection (refimpl.core.confidence): the evidence rule (the default) and the rank
rule, online, and results that do not depend on a detector's score scale."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import refimpl
from refimpl import io
from refimpl.cli import main
from refimpl.core.confidence import (EVIDENCE_FLOOR, RANK_LOW, SEED_SIZE, STREAK_MAX, OnlineRank, PersistenceEvidence,
                                    RankFrames, RunEvidence, pooled, sequence_evidence)
from refimpl.io import DetectionFrame

RESCALES = {
    "0.5*s-1.5": lambda s: 0.5 * s - 1.5,
    "s**3": lambda s: s ** 3,
    "100*s": lambda s: 100 * s,
}



def bare_ranks(frames_scores) -> list[np.ndarray]:
    """The bare rank (times 100) over a whole sequence, frame by frame in order, as the evidence prior reads it."""
    ranker = OnlineRank()
    return [ranker.confidences(s) for s in frames_scores]


def evidence_confidences(frames) -> list[np.ndarray]:
    """The evidence rule over a whole sequence's frames (each with boxes, scores, types), in order."""
    rule = PersistenceEvidence()
    return [rule.confidences(f.boxes, f.scores, f.types) for f in frames]


def test_bare_rank_on_two_frames():
    r = OnlineRank()
    # frame 1 sees 0.3, 0.1, 0.2: n = 3; 0.3 has 3 scores <= it -> 100, 0.1 has 1 -> floor(33.3 + .5)
    # = 33, 0.2 has 2 -> floor(66.7 + .5) = 67
    assert r.confidences([0.3, 0.1, 0.2]).tolist() == [100, 33, 67]
    # frame 2 adds 0.2 and 0.25: n = 5, seen 0.1 0.2 0.2 0.25 0.3; 0.2 has 3 <= it -> 60, 0.25 has 4 -> 80
    assert r.confidences([0.2, 0.25]).tolist() == [60, 80]
    assert r.confidences([]).tolist() == []
    # half up: 1 of 8 -> 12.5 -> 13 (the rule is exact integer arithmetic, no float rounding)
    assert bare_ranks([[1, 2, 3, 4, 5, 6, 7, 8]])[0].tolist() == [13, 25, 38, 50, 63, 75, 88, 100]


def test_rank_of_asks_a_score_s_rank_so_far_without_adding_it():
    r = OnlineRank(prior=2)
    r.confidences([0.3, 0.1, 0.2])
    # seen 0.1 0.2 0.3 and 2 below every one: n = 5; 0.2 has 2 + 2 = 4 <= it -> 80, 0.05 has the
    # prior's 2 -> 40, 0.3 has 5 -> 100; asking adds nothing, so asking again gives the same
    assert [r.rank_of(0.2), r.rank_of(0.05), r.rank_of(0.3), r.rank_of(0.2)] == [80, 40, 100, 80]
    # one more frame of two higher scores: n = 7, 0.2 now 4 of 7 -> floor(57.1 + .5) = 57
    r.confidences([0.5, 0.6])
    assert r.rank_of(0.2) == 57


def test_the_rank_rule_maps_ranks_linearly_onto_twenty_to_a_hundred():
    # --scores rank reads RankFrames: eight scores in one frame rank k / 8 for k = 1..8, mapped onto
    # RANK_LOW 20 .. 100 (docs/model.md 3.19, "The rank rule's map"): 20 + 80 k / 8 = 20 + 10 k,
    # 30 40 ... 100, exact; the order of the scores still decides alone (x 0.6 gives the same)
    assert RANK_LOW == 20
    for scale in (1.0, 0.6):
        got = RankFrames().confidences(np.zeros((8, 4)), scale * np.arange(1.0, 9.0), ("car",) * 8)
        assert got.tolist() == [30, 40, 50, 60, 70, 80, 90, 100]
    # three scores: 20 + 80 k / 3 = 46.67, 73.33, 100 -> rounded half up 47, 73, 100
    assert RankFrames().confidences(None, [0.1, 0.5, 0.9]).tolist() == [47, 73, 100]


def test_a_rank_prior_counts_scores_below_every_real_one():
    r = OnlineRank(prior=50)
    # frame 1 sees 0.2 alone: (50 + 1) / (50 + 1) -> 100: a first score ranks at the top
    assert r.confidences([0.2]).tolist() == [100]
    # frame 2 adds 0.9 and 0.1: n = 3 + 50; 0.9 has 3 + 50 at most it -> 100, 0.1 has 1 + 50 ->
    # floor(100 * 51 / 53 + 1/2) = floor(96.7) = 96
    assert r.confidences([0.9, 0.1]).tolist() == [100, 96]
    # a thousand more at 0.5: 0.1 is then floor(100 * 52 / 1054 + 1/2) = floor(5.4) = 5: the prior fades
    r.confidences(np.full(1000, 0.5))
    assert r.confidences([0.1]).tolist() == [5]


def test_ties_share_the_highest_rank_and_bad_scores_are_refused():
    assert OnlineRank().confidences([5, 5, 5]).tolist() == [100, 100, 100]
    with pytest.raises(ValueError, match="NaN or infinite"):
        OnlineRank().confidences([0.5, float("nan")])


@pytest.mark.parametrize("name", list(RESCALES))
def test_any_strictly_increasing_rescale_gives_the_same_confidences(name):
    rng = np.random.default_rng(7)
    frames = [rng.normal(size=rng.integers(0, 12)) for _ in range(40)]
    f = RESCALES[name]
    assert all(np.array_equal(a, b) for a, b in zip(bare_ranks(frames), bare_ranks([f(s) for s in frames])))


def _rescaled_kitti(src, dst, f) -> None:
    """The KITTI detection file with column 7 (the score) replaced by f(score), full precision."""
    lines = []
    for line in src.read_text().splitlines():
        cells = line.split(",")
        cells[6] = repr(float(f(float(cells[6]))))
        lines.append(",".join(cells))
    dst.write_text("\n".join(lines) + "\n")


def _persistent_and_flickering(n: int) -> list[DetectionFrame]:
    """n frames of two detections: one box that stays put (score 0.8 + t/1000) and one that jumps
    to a new place every frame, overlapping nothing (score 0.1 + t/1000)."""
    out = []
    for t in range(n):
        boxes = np.array([[0.0, 0.0, 10.0, 10.0], [100.0 + 50.0 * t, 100.0, 10.0, 10.0]])
        out.append(DetectionFrame(t, boxes, np.array([0.8 + t / 1000, 0.1 + t / 1000]), np.zeros(2, np.int64),
                                  ("pedestrian", "pedestrian")))
    return out


def test_evidence_rule_learns_which_scores_persist():
    conf = evidence_confidences(_persistent_and_flickering(12))
    # frame t labels frame t-1 (overlapped in t-2 and in t): frames 1..t-1 are labelled, n = 2(t-1).
    # Frame 10: n = 18 < 20 bins, so the rank prior alone: of the 22 scores seen, the steady box's
    # 0.810 is the highest -> 100, the jumping box's 0.110 has 11 <= it -> 50
    assert conf[10].tolist() == [100, 50]
    # frame 11: n = 20, 20 bins of one: the 10 low scores never persisted (0), the 10 high always (1),
    # already non-decreasing, top bin 1.  0.811 is above every labelled score: bin 19, learned 100,
    # rank prior 100 (highest of 24) -> 100.  0.111: 10 labelled scores <= it, bin 9, learned 0; rank
    # prior 12 of 24 -> 50; blended (20 * 0 + 50 * 50) / (20 + 50) = 35.7 -> 36
    assert conf[11].tolist() == [100, 36]


def test_evidence_rules_prior_never_falls_below_the_floor():
    # Nothing labelled yet, so the prior alone: the bare rank gives 0.3, 0.1, 0.2 100, 33, 67
    # (test_bare_rank_on_two_frames); EVIDENCE_FLOOR 40 lifts the 33: a detection the sequence has not
    # yet shown to flicker may continue a track (assign, resume at 30), not start one (> 50)
    assert PersistenceEvidence().confidences(np.zeros((3, 4)) + [0, 0, 10, 10], [0.3, 0.1, 0.2]).tolist() == [100, 40, 67]
    # Blended: frame 11 of the steady / jumping pair (n = 20 labelled, the curve 0 for the low scores,
    # as in test_evidence_rule_learns_which_scores_persist) with a third, far box scored 0.0.  It is
    # the lowest of the 25 scores seen: rank floor(100 / 25 + 1/2) = 4, lifted to 40; no labelled score
    # is <= 0.0, so bin 0, learned 0: (20 * 0 + 50 * 40) / 70 = 28.6 -> 29 (rank alone: 200 / 70 -> 3)
    frames = _persistent_and_flickering(12)
    last = frames[11]
    frames[11] = DetectionFrame(11, np.vstack([last.boxes, [[900.0, 900.0, 10.0, 10.0]]]),
                                np.append(last.scores, 0.0), np.zeros(3, np.int64), last.types + ("pedestrian",))
    assert evidence_confidences(frames)[11].tolist()[2] == 29


def test_evidence_rule_counts_only_an_overlap_of_the_same_type():
    frames = _persistent_and_flickering(12)
    # the steady box's neighbours are cars while it is a pedestrian in frames 1..10: nothing persists,
    # the learned curve is 0 everywhere, so the rule keeps its prior (frame 11: the rank rule's 100, 50)
    frames = [DetectionFrame(f.frame, f.boxes, f.scores, f.confidences,
                             (("car" if f.frame % 2 else "pedestrian"), "pedestrian")) for f in frames]
    assert evidence_confidences(frames)[11].tolist() == [100, 50]


@pytest.mark.parametrize("name", list(RESCALES))
def test_evidence_rule_reads_the_order_of_the_scores_only(name):
    rng = np.random.default_rng(11)
    frames = []
    for t in range(60):
        k = int(rng.integers(0, 8))
        boxes = np.column_stack([rng.integers(0, 5, size=(k, 2)) * 20.0, np.full((k, 2), 25.0)])
        frames.append(DetectionFrame(t, boxes, rng.normal(size=k), np.zeros(k, np.int64), ("car",) * k))
    f = RESCALES[name]
    rescaled = [DetectionFrame(fr.frame, fr.boxes, f(fr.scores), fr.confidences, fr.types) for fr in frames]
    a, b = evidence_confidences(frames), evidence_confidences(rescaled)
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    assert len({int(c) for x in a for c in x}) > 5  # the curve is learned, not one value
    with pytest.raises(ValueError, match="NaN or infinite"):
        PersistenceEvidence().confidences(np.zeros((1, 4)), [float("inf")])


@pytest.mark.parametrize("name", list(RESCALES))
@pytest.mark.parametrize("rule", ["auto", "rank"])
def test_track_and_the_api_write_the_same_rows_whatever_the_score_scale(name, rule, shared_data, tmp_path):
    # KITTI Pedestrian 0010, a tuning sequence (not in evaluate_tracking.seqmap.val): its PointRCNN
    # logits rescaled; `refimpl track --scores RULE` writes the same bytes for both files under the
    # default rule (evidence) and the rank rule, and the API fed the rescaled scores gives those rows
    # too.  The folder layout keeps the label file beside it.
    src = shared_data / "KITTI" / "tracking" / "training" / "det_02_pointrcnn" / "Pedestrian" / "0010.txt"
    scores = np.array([float(line.split(",")[6]) for line in src.read_text().splitlines()])
    f = RESCALES[name]
    s = np.sort(scores)
    assert np.array_equal(np.sign(np.diff(s)), np.sign(np.diff(f(s))))  # in floats too: no new tie
    folder = tmp_path / "training" / "det_02_pointrcnn" / "Pedestrian"
    folder.mkdir(parents=True)
    (tmp_path / "training" / "label_02").mkdir()
    (tmp_path / "training" / "label_02" / "0010.txt").symlink_to(src.parent.parent.parent / "label_02" / "0010.txt")
    rescaled = folder / "0010.txt"
    _rescaled_kitti(src, rescaled, f)
    flags = ["--format", "kitti", "--class", "Pedestrian", "--scores", rule, "--quiet"]
    assert main(["track", "--dets", str(src), *flags, "--out", str(tmp_path / "orig.txt")]) == 0
    assert main(["track", "--dets", str(rescaled), *flags, "--out", str(tmp_path / "new.txt")]) == 0
    original = (tmp_path / "orig.txt").read_bytes()
    assert original and (tmp_path / "new.txt").read_bytes() == original
    seq = io.read_kitti_detections(rescaled, "pedestrian", scores_rule=rule)
    tracker = refimpl.Tracker(format="kitti", object_type="pedestrian", scores=rule, history=True)
    for fr in seq.frames:
        b = fr.boxes
        tracker.update(np.column_stack([b[:, 0], b[:, 1], b[:, 0] + b[:, 2], b[:, 1] + b[:, 3], fr.scores]))
    api = tmp_path / "api.txt"
    io.write_mot_results(api, tracker.result().rows, first_frame=0)
    assert api.read_bytes() == original


def test_a_detector_whose_scores_sit_lower_gets_the_same_tracks(tmp_path):
    # the bundled TUD-Campus with every score x 0.6 (the same boxes): the default rule reads the
    # scores' order only, so `refimpl track` writes the same rows as for the original scores (on
    # the probability scale the preset's conf_thresh_new_track 50 would need an original score above
    # 0.5 / 0.6 = 0.83 to start a track: there the scale changes the tracks)
    demo = Path(__file__).resolve().parent.parent / "data" / "demo" / "TUD-Campus" / "det" / "det.txt"
    low = tmp_path / "TUD-Campus" / "det" / "det.txt"
    low.parent.mkdir(parents=True)
    (tmp_path / "TUD-Campus" / "seqinfo.ini").write_bytes((demo.parent.parent / "seqinfo.ini").read_bytes())
    rows = [line.split(",") for line in demo.read_text().splitlines()]
    low.write_text("".join(",".join(r[:6] + [repr(float(r[6]) * 0.6)] + r[7:]) + "\n" for r in rows))
    assert main(["track", "--dets", str(demo), "--out", str(tmp_path / "a.txt"), "--quiet"]) == 0
    assert main(["track", "--dets", str(low), "--out", str(tmp_path / "b.txt"), "--quiet"]) == 0
    original = (tmp_path / "a.txt").read_bytes()
    assert original.count(b"\n") > 200 and (tmp_path / "b.txt").read_bytes() == original
    assert main(["track", "--dets", str(low), "--scores", "probability", "--out", str(tmp_path / "c.txt"),
                 "--quiet"]) == 0
    assert (tmp_path / "c.txt").read_bytes() != original


def _rewrite_scores(src: Path, dst: Path, column: int, f) -> None:
    dst.parent.mkdir(parents=True, exist_ok=True)
    rows = [line.split(",") for line in src.read_text().splitlines()]
    dst.write_text("".join(",".join(r[:column] + [repr(float(f(float(r[column]))))] + r[column + 1:]) + "\n"
                           for r in rows))


def test_a_fixed_scale_reads_every_format(shared_data, tmp_path):
    # KITTI Car 0001 (a val sequence, only run here) with each logit l written as the probability
    # sigmoid(l): --scores probability on it writes the bytes --scores sigmoid writes for the logits
    # (both confidences are floor(100 * sigmoid(l) + 1/2)); and the TUD-Campus probabilities p written
    # as logits log(p / (1 - p)) under --format mot --scores sigmoid give the rows of --scores
    # probability on the original
    src = shared_data / "KITTI" / "tracking" / "training" / "det_02_pointrcnn" / "Car" / "0001.txt"
    probs = tmp_path / "k" / "0001.txt"
    _rewrite_scores(src, probs, 6, lambda s: 1.0 / (1.0 + np.exp(-s)))
    kitti = ["--format", "kitti", "--class", "Car", "--quiet"]
    assert main(["track", "--dets", str(src), *kitti, "--scores", "sigmoid", "--out", str(tmp_path / "a.txt")]) == 0
    assert main(["track", "--dets", str(probs), *kitti, "--scores", "probability", "--out", str(tmp_path / "b.txt")]) == 0
    assert (tmp_path / "a.txt").read_bytes() == (tmp_path / "b.txt").read_bytes() != b""
    demo = Path(__file__).resolve().parent.parent / "data" / "demo" / "TUD-Campus"
    logits = tmp_path / "TUD-Campus" / "det" / "det.txt"
    _rewrite_scores(demo / "det" / "det.txt", logits, 6, lambda p: np.log(p / (1.0 - p)))
    (tmp_path / "TUD-Campus" / "seqinfo.ini").write_bytes((demo / "seqinfo.ini").read_bytes())
    assert main(["track", "--dets", str(demo / "det" / "det.txt"), "--scores", "probability", "--quiet",
                 "--out", str(tmp_path / "c.txt")]) == 0
    assert main(["track", "--dets", str(logits), "--scores", "sigmoid", "--quiet", "--out", str(tmp_path / "d.txt")]) == 0
    assert (tmp_path / "c.txt").read_bytes() == (tmp_path / "d.txt").read_bytes() != b""


def _steady(n: int, score: float) -> list[DetectionFrame]:
    """n frames of one box that stays put, scored ``score`` every frame."""
    return [DetectionFrame(t, np.array([[0.0, 0.0, 10.0, 10.0]]), np.array([score]), np.zeros(1, np.int64),
                           ("pedestrian",)) for t in range(n)]


def test_other_files_of_the_run_tell_a_file_that_its_best_detection_is_weak():
    # A file whose one detection (score 0.2) persists: alone, it is the best this detector has shown
    # (rank 1 of 1 -> 100), enough to start a track.  Seeded with another file of the run (the
    # steady 0.80x box that always persisted and the jumping 0.10x box that never did): frame 0
    # has seen the other file's 24 scores and its own, 13 of 25 <= 0.2 -> rank floor(100 * 13 / 25
    # + 1/2) = 52 (above the floor 40); the 20 labelled scores of frames 1..10 (frame 11 has no
    # frame after it) make the curve 0 for the ten low ones and 1 for the ten high ones; 0.2 has ten
    # labelled scores <= it, bin 9, learned 0: (20 * 0 + 50 * 52) / 70 = 37.1 -> 37, below a new
    # track's 50.
    other = sequence_evidence(_persistent_and_flickering(12))
    assert (len(other.seen), len(other.labelled), int(other.persistent.sum())) == (24, 20, 10)
    assert PersistenceEvidence().confidences(*_frame_args(_steady(1, 0.2)[0])).tolist() == [100]
    assert PersistenceEvidence(other).confidences(*_frame_args(_steady(1, 0.2)[0])).tolist() == [37]
    # the rank rule seeded alike: 13 of 25 -> 20 + 80 * 13 / 25 = 61.6 -> 62 (RANK_LOW 20)
    assert RankFrames(other).confidences(None, [0.2]).tolist() == [62]


def _frame_args(f: DetectionFrame):
    return f.boxes, f.scores, f.types


def test_a_seed_weighs_at_most_seed_size_detections():
    # 5,000 labelled scores of another file: the seed keeps SEED_SIZE of them, every k-th in score
    # order (k = 5,000 / SEED_SIZE), so the seeded rule counts SEED_SIZE labelled detections
    n = 5 * SEED_SIZE
    values = np.arange(n, dtype=float)
    big = RunEvidence(values, values, (values % 2 == 0).astype(float))
    rule = PersistenceEvidence(big)
    assert len(rule._labelled) == SEED_SIZE and len(rule._rank._seen) == SEED_SIZE
    assert rule._labelled.values.tolist() == values[::5].tolist()


def test_a_run_calibrates_each_file_on_the_others_in_any_order():
    a = io.DetectionSequence("a", tuple(_persistent_and_flickering(12)), 0, None, None)
    b = io.DetectionSequence("b", tuple(_steady(3, 0.2)), 0, None, None)
    c = io.DetectionSequence("c", tuple(_steady(3, 0.805)), 0, None, None)
    forward = io.calibrated_together([a, b, c], "evidence")
    backward = io.calibrated_together([c, b, a], "evidence")[::-1]
    for x, y in zip(forward, backward):
        assert [f.confidences.tolist() for f in x.frames] == [f.confidences.tolist() for f in y.frames]
    # b's steady 0.2 is weak beside a's detections (the test above, with c's three 0.805 seen too:
    # 13 of 28 <= 0.2 -> rank 46; labelled a's 20 and c's middle frame, 21: bins of one but the top
    # one of two, the ten low scores still bins 0..9, curve 0 there; 0.2 in bin 9, learned 0:
    # (21 * 0 + 50 * 46) / 71 = 32.4 -> 32)
    assert forward[1].frames[0].confidences.tolist() == [32]
    # one file, or a fixed scale: as read
    assert io.calibrated_together([b], "evidence")[0] is b
    assert io.calibrated_together([a, b], "probability")[1] is b


def _object_and_flicker(n: int, score_of=lambda t: (1.0, 1.0)) -> list[DetectionFrame]:
    """n frames: a box that stays put (A, first) and a box that jumps 50 px a frame (B), never
    overlapping where it was; scores (A, B) by frame."""
    return [DetectionFrame(t, np.array([[0.0, 0.0, 10.0, 10.0], [100.0 + 50 * t, 0.0, 10.0, 10.0]]),
                           np.array(score_of(t)), np.zeros(2, np.int64), ("car", "car")) for t in range(n)]


def test_scores_that_say_nothing_are_read_from_streaks():
    # Every score 1.0.  Frames 0..8 have shown 18 scores (< EVIDENCE_BINS 20): the tie's bare rank,
    # 100, for both.  From frame 9 (20 scores) the streaks: A's is 0, 1, then 2; B's always 0.  At
    # frame t >= 3 the counts (detections, seen again in the next frame) of frames 0..t-1 are:
    # streak 0: A at 0 and B at 0..t-1 = t + 1, of which 1 (A); streak 1: A at 1, seen again;
    # streak 2: A at 2..t-1 = t - 2, all seen again.  n = 2t; B's learned share (1 / (t + 1)) / 1.
    # Frame 9: n 18, (18 * 100 / 10 + 50 * 40) / 68 = 32.06 -> 32; A (streak 2) 100.
    # Frame 29: n 58, (58 * 100 / 30 + 50 * 40) / 108 = 20.31 -> 20.
    rule = PersistenceEvidence()
    got = [rule.confidences(f.boxes, f.scores, f.types).tolist() for f in _object_and_flicker(30)]
    assert got[:9] == [[100, 100]] * 9
    assert got[9] == [100, 32] and got[29] == [100, 20]
    assert rule.streak_score == 1.0
    assert STREAK_MAX == 2


def test_two_different_scores_end_the_streak_reading_for_good():
    # As above, but B scores 0.5 in frame 15: from then on the scores say something; the score curve
    # reads them again (streak_score None) even when every later score is 1.0 again, and frames
    # before it are read as before (frame 9: 32)
    rule = PersistenceEvidence()
    frames = _object_and_flicker(30, lambda t: (1.0, 0.5 if t == 15 else 1.0))
    got = [rule.confidences(f.boxes, f.scores, f.types).tolist() for f in frames[:15]]
    assert got[9] == [100, 32] and rule.streak_score == 1.0
    for f in frames[15:]:
        rule.confidences(f.boxes, f.scores, f.types)
        assert rule.streak_score is None and rule.streak_counts() is None


def test_a_run_of_files_without_scores_pools_its_streaks():
    # The run's other file: the 30 frames above, whole: the counts of frames 0..28 (frame 29 has no
    # frame after it), streak 0 [30, 1], streak 1 [1, 1], streak 2 [27, 27].  Seeded with them, a
    # new file reads streaks from its first frame (62 scores of 1.0 seen):
    # frame 0, both streak 0: n 58, (58 * 100 / 30 + 50 * 40) / 108 = 20.31 -> 20 each;
    # frame 1: frame 0's A was seen again, B not: streak 0 [32, 2], n 60; A's streak 1 (share 1):
    # (60 * 100 + 50 * 40) / 110 = 72.7 -> 73; B (2 / 32): (60 * 6.25 + 2000) / 110 = 21.6 -> 22
    seed = sequence_evidence(_object_and_flicker(30))
    assert seed.streaks.tolist() == [[30, 1], [1, 1], [27, 27]]
    assert pooled([seed, seed]).streaks.tolist() == [[60, 2], [2, 2], [54, 54]]
    rule = PersistenceEvidence(seed)
    frames = _object_and_flicker(2)
    assert rule.confidences(frames[0].boxes, frames[0].scores, frames[0].types).tolist() == [20, 20]
    assert rule.confidences(frames[1].boxes, frames[1].scores, frames[1].types).tolist() == [73, 22]
    # a file whose scores differ from the seed's one score reads them by the score curve
    other = PersistenceEvidence(seed)
    other.confidences(frames[0].boxes, np.array([0.9, 0.3]), frames[0].types)
    assert other.streak_score is None


def test_a_file_without_scores_is_said_once_on_the_command_line_and_in_the_api(tmp_path, capsys):
    # the bundled TUD-Campus with every score 1: `refimpl track` names the one score and the rule it
    # falls back on instead of the preset's score-scale warning; the API warns once, at the caller
    demo = Path(__file__).resolve().parent.parent / "data" / "demo" / "TUD-Campus"
    same = tmp_path / "TUD-Campus" / "det" / "det.txt"
    _rewrite_scores(demo / "det" / "det.txt", same, 6, lambda s: 1.0)
    (tmp_path / "TUD-Campus" / "seqinfo.ini").write_bytes((demo / "seqinfo.ini").read_bytes())
    assert main(["track", "--dets", str(same), "--out", str(tmp_path / "a.txt")]) == 0
    err = capsys.readouterr().err
    assert err.count("every detection has the score 1: the scores say nothing") == 1
    assert "pass conf_thresh_new_track" not in err
    rows = (tmp_path / "a.txt").read_text().splitlines()
    assert len(rows) > 100  # tracks, from streaks
    dets = np.loadtxt(same, delimiter=",")
    tracker = refimpl.Tracker()
    with pytest.warns(UserWarning, match="every detection has the score 1: the scores say nothing") as caught:
        for f in range(1, int(dets[:, 0].max()) + 1):
            d = dets[dets[:, 0] == f]
            tracker.update(np.column_stack([d[:, 2], d[:, 3], d[:, 2] + d[:, 4], d[:, 3] + d[:, 5], d[:, 6]]))
    assert sum("scores say nothing" in str(w.message) for w in caught) == 1
    assert all(w.filename == __file__ for w in caught if "scores say nothing" in str(w.message))
