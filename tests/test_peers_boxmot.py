"""BoxMOT's motion-only peers (refimpl.experiments.peers, extra ``peers-boxmot``) and the peer registry.

The registry tests run everywhere; the ones that track need BoxMOT (which brings torch) and skip
cleanly without it: the ``test`` extra does not install it."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from refimpl import io

from refimpl.experiments import peers
from refimpl.cli import main
from refimpl.io.detections import DetectionFrame, DetectionSequence

BOXMOT = tuple(p for p in peers.PEERS if peers.PEERS[p].package == "boxmot")


@pytest.fixture
def boxmot():
    return pytest.importorskip("boxmot")


def _still_object(gap: int, fps: float, conf: int = 90) -> DetectionSequence:
    """One still box, detected in frames 1..10, missed for ``gap`` frames, then detected for 10 more."""
    frames = []
    for f in range(1, 21 + gap):
        b = np.array([[100.0, 100.0, 40.0, 80.0]]) if f <= 10 or f > 10 + gap else np.zeros((0, 4))
        n = len(b)
        frames.append(DetectionFrame(f, b, np.full(n, conf / 100), np.full(n, conf), ("pedestrian",) * n))
    return DetectionSequence("still", tuple(frames), 1, (640, 480), fps)


def test_the_registry_holds_boxmots_eight_motion_only_trackers_and_all_means_every_peer():
    # every tracker BoxMOT 25.0.0 can run from boxes alone (StrongSort needs embeddings, Sam2Mot masks)
    assert BOXMOT == ("boxmot-bytetrack", "boxmot-ocsort", "boxmot-botsort", "boxmot-hybridsort",
                      "boxmot-boosttrack", "boxmot-deepocsort", "boxmot-sfsort", "boxmot-occluboost")
    assert peers.parse_peers("all") == tuple(peers.PEERS) and len(peers.PEERS) == 11
    assert peers.parse_peers(" sort, boxmot-ocsort ") == ("sort", "boxmot-ocsort")
    # no ReID and no camera-motion compensation wherever the constructor has them (they need images):
    # each switch is off, whichever way its constructor spells it
    off = {"use_embeddings": False, "use_cmc": False, "cmc_method": None, "cmc_off": True}
    for name in BOXMOT:
        settings = peers.PEERS[name].settings
        assert all(off[k] == v for k, v in settings.items())
    assert dict(peers.PEERS["boxmot-hybridsort"].settings) == {"use_embeddings": False, "cmc_method": None}
    assert dict(peers.PEERS["boxmot-deepocsort"].settings) == {"use_embeddings": False, "cmc_off": True}
    # SFSORT is told the image size (it would read it off the image); nobody else is
    assert [p.name for p in peers.PEERS.values() if p.image_size] == ["boxmot-sfsort"]
    for bad in ("", "all,sort", "deepocsort"):
        with pytest.raises(ValueError, match="--peers takes 'all' or"):
            peers.parse_peers(bad)


def test_a_missing_boxmot_is_one_line_before_any_data_is_read(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "boxmot", None)  # this test only: `import boxmot` raises ImportError
    # a peer asked for by name must run: its missing package is the one line, exit 2
    assert main(["benchmark", "kitti-cyc", "--peers", "sort,boxmot-ocsort", "--data", "/nonexistent"]) == 2
    err = capsys.readouterr().err.strip()
    assert "pip install 'refimpl[peers-boxmot]'" in err and "boxmot==25.0.0" in err and "\n" not in err
    # 'all' is every peer whose package is installed: the five BoxMOT ones are named as not run, and
    # the run goes on with the others, here into the missing data root (its own one line, exit 2)
    pytest.importorskip("trackers")
    assert main(["benchmark", "kitti-cyc", "--peers", "all", "--data", "/nonexistent"]) == 2
    first, *rest = capsys.readouterr().err.strip().splitlines()
    assert first == ("refimpl benchmark: not run: boxmot-bytetrack, boxmot-ocsort, boxmot-botsort, "
                     "boxmot-hybridsort, boxmot-boosttrack, boxmot-deepocsort, boxmot-sfsort, "
                     "boxmot-occluboost (package not installed: boxmot)")
    assert len(rest) == 1 and "/nonexistent" in rest[0]


def test_boxmot_peers_run_on_detections_alone_and_write_the_detections_box(boxmot):
    seq = io.load_detections(io.demo_sequence_paths())  # TUD-Campus, 71 frames, 25 fps
    for name in BOXMOT:
        run = peers.run_peer(seq, name)
        assert len(run.rows) > 100 and run.rows[:, 1].min() == 1  # ids 0, 1, ... written as 1, 2, ...
        for f, _, x, y, w, h in run.rows:  # every written box is a detection box of its frame (xyxy and back)
            assert np.abs(seq.frame(int(f)).boxes - [x, y, w, h]).max(axis=1).min() < 1e-9
        assert np.array_equal(run.rows, peers.run_peer(seq, name).rows)  # deterministic
    # ByteTrack returns its Kalman state: the same rows per frame as the package, but the detection's box;
    # the package is fed as run_peer feeds it: the scores as probabilities (probability_scale)
    tracker = peers.peer_class("boxmot-bytetrack")(frame_rate=25)
    written = peers.run_peer(seq, "boxmot-bytetrack").rows
    moved = 0
    for fr in peers.probability_scale(seq).frames:
        b = fr.boxes
        dets = np.column_stack([b[:, :2], b[:, :2] + b[:, 2:], fr.confidences / 100, np.zeros(len(b))])
        raw = tracker.update(dets)
        assert len(raw) == int(np.sum(written[:, 0] == fr.frame))
        moved += int(np.sum(np.abs(raw[:, :4] - dets[raw[:, 7].astype(int), :4]).max(axis=1) > 1e-3))
    assert moved > 100  # so the conversion mattered: most state boxes are not the detection's


def test_boxmot_peers_see_confidence_over_100_and_the_frame_rate_where_they_take_one(boxmot):
    # ByteTrack's high-score pass takes conf > track_thresh = 0.45 (strict), and only it starts
    # tracks: confidence 45 -> 0.45 starts none, 46 -> 0.46 starts the track
    assert len(peers.run_peer(_still_object(4, 10.0, conf=45), "boxmot-bytetrack").rows) == 0
    assert len(peers.run_peer(_still_object(4, 10.0, conf=46), "boxmot-bytetrack").rows) == 20
    # a track lost for 20 frames: ByteTrack (track_buffer 25) and BoT-SORT (30) keep it for
    # int(frame_rate / 30 * buffer) frames: 8 / 10 at KITTI's 10 fps (a new id), 25 / 30 at 30 fps
    # (the same id); OC-SORT, HybridSORT and BoostTrack keep it max_age = 30 frames whatever the rate
    def ids(name, fps):
        return len(np.unique(peers.run_peer(_still_object(20, fps), name).rows[:, 1]))
    for name in ("boxmot-bytetrack", "boxmot-botsort"):
        assert (ids(name, 10.0), ids(name, 30.0)) == (2, 1)
        assert peers.peer_parameters(name, 10.0)["frame_rate"] == 10.0
    for name in ("boxmot-ocsort", "boxmot-hybridsort", "boxmot-boosttrack", "boxmot-deepocsort",
                 "boxmot-occluboost"):
        assert (ids(name, 10.0), ids(name, 30.0)) == (1, 1)
        assert "frame_rate" not in peers.peer_parameters(name, 10.0)
    # SFSORT's defaults keep no lost track (marginal_timeout = central_timeout = 0 frames): one
    # missed frame is a new id at any rate; and it starts a track at once (new_track_th 0.7 < 0.9),
    # so every one of the 20 detections is written
    one_missed = peers.run_peer(_still_object(1, 10.0), "boxmot-sfsort").rows
    assert len(one_missed) == 20 and len(np.unique(one_missed[:, 1])) == 2
    assert ids("boxmot-sfsort", 30.0) == 2


def test_sfsort_is_told_the_image_size_or_the_extent_of_the_boxes(boxmot):
    seq = _still_object(1, 10.0)  # image 640 x 480
    assert peers.image_extent(seq) == (640, 480)
    params = peers.peer_parameters("boxmot-sfsort", image_size=peers.image_extent(seq))
    assert (params["frame_width"], params["frame_height"]) == (640, 480)
    # without one: the largest x + w and y + h of the boxes, 100 + 40 and 100 + 80
    from dataclasses import replace
    assert peers.image_extent(replace(seq, image_size=None)) == (140, 180)
    with pytest.raises(ValueError, match="SFSORT needs the image size"):
        peers.peer_parameters("boxmot-sfsort")


def test_boxmot_parameters_are_the_constructor_defaults_listed_under_the_table(boxmot):
    params = peers.peer_parameters("boxmot-ocsort")
    # OcSort's own defaults and the base tracker's (which it receives through **kwargs)
    assert (params["delta_t"], params["inertia"], params["max_age"], params["min_hits"]) == (3, 0.2, 30, 3)
    text = peers.describe_parameters("boxmot-botsort", peers.peer_parameters("boxmot-botsort", 10.0))
    assert text.startswith("BotSort(track_high_thresh=0.5, ") and "frame_rate=10" in text
    assert text.endswith("use_embeddings=False, use_cmc=False)")
    with pytest.raises(ValueError, match="HybridSort has no parameter 'nosuch'"):
        peers.peer_parameters("boxmot-hybridsort", nosuch=1)


def test_the_comparison_table_has_ids_and_frag_apart_and_every_trackers_id_switches_against_the_baseline():
    def score(label, idsw, frag, params=""):
        o = {"hota": 0.5, "deta": 0.5, "assa": 0.5, "mota": 0.6, "idf1": 0.7, "idsw": idsw, "frag": frag,
             "fp": 10, "fn": 20}
        return peers.TrackerScore(label, o, {}, 100, 1.0, params)
    c = peers.Comparison("kitti-cyc", "t", (score("refimpl baseline (SORT)", 80, 120),
                                            score("refimpl abduction (cpsat)", 30, 90),
                                            score("boxmot-ocsort (boxmot 25.0.0)", 100, 60, "OcSort(delta_t=3)")), {})
    lines = peers.comparison_table(c).splitlines()
    assert lines[0] == "| tracker | HOTA | DetA | AssA | MOTA | IDF1 | IDs | Frag | FP | FN | fps | p50 ms | p99 ms |"
    assert lines[3] == "| refimpl abduction (cpsat) | 50.0 | 50.0 | 50.0 | 60.0 | 70.0 | 30 | 90 | 10 | 20 | 100 | - | - |"  # no per-frame times given: no latency
    # 80 -> 30: -50 / 80 = -62.5 %; 80 -> 100: +25.0 %
    assert ("- ID switches against refimpl baseline (SORT) (the paper's headline metric): refimpl abduction "
            "(cpsat) 80 -> 30 (-62.5 %); boxmot-ocsort (boxmot 25.0.0) 80 -> 100 (+25.0 %)") in lines
    assert "- boxmot-ocsort (boxmot 25.0.0): `OcSort(delta_t=3)`" in lines
