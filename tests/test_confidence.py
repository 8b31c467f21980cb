"""The confidence of a detection (refimpl.core.confidence): the rank rule, online, and results that do
not depend on a detector's score scale (issue 25)."""

from __future__ import annotations

import numpy as np
import pytest

import refimpl
from refimpl import io
from refimpl.cli import main
from refimpl.core.confidence import OnlineRank, rank_confidences

RESCALES = {
    "0.5*s-1.5": lambda s: 0.5 * s - 1.5,
    "s**3": lambda s: s ** 3,
    "100*s": lambda s: 100 * s,
}


def test_rank_rule_on_two_frames():
    r = OnlineRank()
    # frame 1 sees 0.3, 0.1, 0.2: n = 3; 0.3 has 3 scores <= it -> 100, 0.1 has 1 -> floor(33.3 + .5)
    # = 33, 0.2 has 2 -> floor(66.7 + .5) = 67
    assert r.confidences([0.3, 0.1, 0.2]).tolist() == [100, 33, 67]
    # frame 2 adds 0.2 and 0.25: n = 5, seen 0.1 0.2 0.2 0.25 0.3; 0.2 has 3 <= it -> 60, 0.25 has 4 -> 80
    assert r.confidences([0.2, 0.25]).tolist() == [60, 80]
    assert r.confidences([]).tolist() == []
    # half up: 1 of 8 -> 12.5 -> 13 (the rule is exact integer arithmetic, no float rounding)
    assert rank_confidences([[1, 2, 3, 4, 5, 6, 7, 8]])[0].tolist() == [13, 25, 38, 50, 63, 75, 88, 100]


def test_ties_share_the_highest_rank_and_bad_scores_are_refused():
    assert OnlineRank().confidences([5, 5, 5]).tolist() == [100, 100, 100]
    with pytest.raises(ValueError, match="NaN or infinite"):
        OnlineRank().confidences([0.5, float("nan")])


@pytest.mark.parametrize("name", list(RESCALES))
def test_any_strictly_increasing_rescale_gives_the_same_confidences(name):
    rng = np.random.default_rng(7)
    frames = [rng.normal(size=rng.integers(0, 12)) for _ in range(40)]
    f = RESCALES[name]
    assert all(np.array_equal(a, b) for a, b in zip(rank_confidences(frames), rank_confidences([f(s) for s in frames])))


def _rescaled_kitti(src, dst, f) -> None:
    """The KITTI detection file with column 7 (the score) replaced by f(score), full precision."""
    lines = []
    for line in src.read_text().splitlines():
        cells = line.split(",")
        cells[6] = repr(float(f(float(cells[6]))))
        lines.append(",".join(cells))
    dst.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("name", list(RESCALES))
def test_track_and_the_api_write_the_same_rows_whatever_the_score_scale(name, shared_data, tmp_path):
    # KITTI Pedestrian 0010, a tuning sequence (not in evaluate_tracking.seqmap.val): its PointRCNN
    # logits rescaled; `refimpl track --scores rank` writes the same bytes, and the API fed the
    # rescaled scores gives those rows too.  The folder layout keeps the label file beside it.
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
    flags = ["--format", "kitti", "--class", "Pedestrian", "--scores", "rank", "--quiet"]
    assert main(["track", "--dets", str(src), *flags, "--out", str(tmp_path / "orig.txt")]) == 0
    assert main(["track", "--dets", str(rescaled), *flags, "--out", str(tmp_path / "new.txt")]) == 0
    original = (tmp_path / "orig.txt").read_bytes()
    assert original and (tmp_path / "new.txt").read_bytes() == original
    seq = io.read_kitti_detections(rescaled, "pedestrian", scores_rule="rank")
    tracker = refimpl.Tracker(format="kitti", object_type="pedestrian", scores="rank")
    for fr in seq.frames:
        b = fr.boxes
        tracker.update(np.column_stack([b[:, 0], b[:, 1], b[:, 0] + b[:, 2], b[:, 1] + b[:, 3], fr.scores]))
    api = tmp_path / "api.txt"
    io.write_mot_results(api, tracker.result().rows, first_frame=0)
    assert api.read_bytes() == original
