"""tests/tools/shift_decompose.py: each repair adds exactly the frames its docstring names."""

import numpy as np

from refimpl.io import DetectionFrame, DetectionSequence, GroundTruth
from refimpl.tracking.tracker import TrackRecord
from tools.shift_decompose import OFFSET, handovers, repaired

BOX = [10.0, 10.0, 20.0, 20.0]
FAR = [100.0, 100.0, 20.0, 20.0]


def _scene():
    """One object (id 5) in frames 0..9, detected in frames 1..8."""
    frames = tuple(DetectionFrame(t, np.array([BOX] if 1 <= t <= 8 else np.zeros((0, 4))),
                                  np.ones(1 if 1 <= t <= 8 else 0), np.full(1 if 1 <= t <= 8 else 0, 90),
                                  ("car",) * (1 if 1 <= t <= 8 else 0)) for t in range(10))
    seq = DetectionSequence("toy", frames, 0, (640, 480), 10.0)
    gt = GroundTruth("toy", np.arange(10), np.full(10, 5), np.array([BOX] * 10), np.ones(10, dtype=bool),
                     np.zeros(10, dtype=bool), np.zeros((0, 5)), 0, 10)
    return seq, gt


def test_fragments_are_joined_and_gaps_heads_and_tails_filled_from_the_ground_truth():
    seq, gt = _scene()
    # track 7 writes the object in frames 3-4, track 8 in 6-7; track 9 is a false row in frame 5
    rows = np.array([[3, 7, *BOX], [4, 7, *BOX], [5, 9, *FAR], [6, 8, *BOX], [7, 8, *BOX]], dtype=float)
    steps, added = repaired(rows, seq, gt)
    # joined: 7 and 8 each write object 5 most often -> both renamed OFFSET + 5; 9 matches nothing, kept
    assert sorted(set(steps["joined"][:, 1].astype(int).tolist())) == [9, OFFSET + 5]
    # written frames 3, 4, 6, 7 (first 3, last 7); detections 1..8:
    #   inner = frames in (3, 7) not written = {5}; head = [1, 3) = {1, 2}; tail = (7, 8] = {8}
    assert (added["inner"], added["head"], added["tail"]) == (1, 2, 1)
    final = steps["tail"]
    mine = final[final[:, 1] == OFFSET + 5]
    assert sorted(mine[:, 0].astype(int).tolist()) == list(range(1, 9))  # frames 0 and 9 had no detection
    assert final[final[:, 1] == 9][:, 0].tolist() == [5]  # the false row stays: nothing removes it
    assert steps["rows"] is rows  # the first step is the tracker's output itself


def test_a_handover_is_counted_as_far_as_its_causes_hold():
    seq, gt = _scene()
    small = [12.0, 12.0, 5.0, 5.0]  # inside BOX (20 x 20): 25 px^2, IoU 25 / 400 < 0.5
    # track 1 writes the object in frames 1-2, then takes the small box in frame 3; track 2 starts on
    # the object's full box in frame 5 and writes it to frame 8
    rows = np.array([[1, 1, *BOX], [2, 1, *BOX], [3, 1, *small]] + [[f, 2, *BOX] for f in range(5, 9)], dtype=float)

    def records(ended_at):
        first = TrackRecord("trk_1", "car", ((1, tuple(BOX)), (2, tuple(BOX)), (3, tuple(small))), (), ended_at)
        second = TrackRecord("trk_2", "car", tuple((f, tuple(BOX)) for f in range(5, 9)), (), None)
        return (first, second)

    # the object is written by track 1 last in frame 2 and by track 2 first in frame 5: a gap of 2;
    # track 1 alive; track 2 started in frame 5 > 2; 400 >= 2 x 25; frame 3's box 100 % inside, IoU 0.0625
    assert handovers(rows, records(None), seq, gt) == {"changes": 1, "alive": 1, "started": 1, "grown": 1, "inside": 1}
    # ended in frame 4, before the object's next written frame: a handover, not a track still alive
    assert handovers(rows, records(4), seq, gt) == {"changes": 1}
    # a tracker that keeps no track records (the SORT baseline) has no handovers to explain
    assert handovers(rows, (), seq, gt) == {}
