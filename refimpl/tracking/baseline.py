"""The paper's baseline (tracking without abduction): SORT, Bewley et al., ICIP 2016.

Each frame:
  1. predict every track with its Kalman filter (refimpl.tracking.motion); drop tracks whose
     prediction is not a valid box;
  2. IoU between every predicted box and every detection (refimpl.core.geometry.iou_matrix);
  3. optimal assignment maximising the summed IoU (Hungarian, scipy's linear_sum_assignment);
     assigned pairs with IoU < iou_threshold are rejected (IoU == threshold is kept);
  4. update matched tracks with their detection; start a track for every unmatched detection;
  5. output the tracks updated this frame (their filtered box) whose hit_streak >= min_hits,
     or every such track while the frame count is still <= min_hits (start-up);
  6. delete tracks not updated for more than max_age frames.

Track ids are 1, 2, 3, ... in order of creation; new tracks in one frame are numbered in
detection order.  Everything is deterministic.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.assignment import linear_sum_assignment
from ..core.geometry import iou_matrix
from .motion import BoxKalman, InvalidPrediction

SORT_MAX_AGE = 1
"""Frames a track may go without a detection before it is deleted (SORT's published value)."""

SORT_MIN_HITS = 3
"""Consecutive updates before a track is output (SORT's published value)."""

SORT_IOU_THRESHOLD = 0.3
"""Minimum IoU of an assigned (prediction, detection) pair (SORT's published IoU_min)."""


def associate(predicted_xywh: np.ndarray, detections_xywh: np.ndarray, iou_threshold: float = SORT_IOU_THRESHOLD):
    """Match predictions to detections by maximal summed IoU; drop pairs with IoU < iou_threshold.

    Returns (matches, unmatched_tracks, unmatched_detections): matches an (k, 2) int array of
    (track index, detection index) rows sorted by track index; the others sorted int arrays.
    """
    predicted = np.asarray(predicted_xywh, dtype=float).reshape(-1, 4)
    detections = np.asarray(detections_xywh, dtype=float).reshape(-1, 4)
    n, m = len(predicted), len(detections)
    matches = np.zeros((0, 2), dtype=int)
    if n and m:
        iou = iou_matrix(predicted, detections)
        rows, cols = linear_sum_assignment(iou, maximize=True)  # rows come sorted (scipy's contract)
        keep = iou[rows, cols] >= iou_threshold
        matches = np.stack([rows[keep], cols[keep]], axis=1).astype(int)
    unmatched_tracks = _others(n, matches[:, 0])
    unmatched_detections = _others(m, matches[:, 1])
    return matches, unmatched_tracks, unmatched_detections


def _others(n: int, taken: np.ndarray) -> np.ndarray:
    """The sorted indices 0..n-1 not in ``taken`` (np.setdiff1d(np.arange(n), taken), without its sort)."""
    free = np.ones(n, dtype=bool)
    free[taken] = False
    return np.flatnonzero(free).astype(int)


@dataclass
class SortTrack:
    """A SORT track: its id and its motion model (which carries the counters)."""

    id: int
    motion: BoxKalman


class SortTracker:
    """SORT: Kalman prediction + Hungarian IoU assignment, frame by frame (online)."""

    def __init__(self, max_age: int = SORT_MAX_AGE, min_hits: int = SORT_MIN_HITS, iou_threshold: float = SORT_IOU_THRESHOLD):
        self.max_age = int(max_age)
        self.min_hits = int(min_hits)
        self.iou_threshold = float(iou_threshold)
        self.tracks: list[SortTrack] = []
        self.frame_count = 0
        self._next_id = 1

    def update(self, boxes_xywh) -> np.ndarray:
        """Process one frame of detections ((n, 4) xywh; n may be 0). Returns (k, 5) rows (id, x, y, w, h), by id.

        Detections that are not finite or have w <= 0 or h <= 0 are ignored (they have no
        area or aspect ratio to filter).
        """
        dets = np.asarray(boxes_xywh, dtype=float).reshape(-1, 4)
        good = np.all(np.isfinite(dets), axis=1) & (dets[:, 2] > 0) & (dets[:, 3] > 0)
        dets = dets[good]
        self.frame_count += 1

        # 1. predict; a track whose prediction is not a box is dropped
        kept: list[SortTrack] = []
        predicted = []
        for track in self.tracks:
            try:
                predicted.append(track.motion.predict())
            except InvalidPrediction:
                continue
            kept.append(track)
        self.tracks = kept

        # 2-3. associate
        matches, _, unmatched_dets = associate(np.array(predicted).reshape(-1, 4), dets, self.iou_threshold)

        # 4. update matched, start new tracks
        for t, d in matches:
            self.tracks[t].motion.update(dets[d])
        for d in unmatched_dets:
            self.tracks.append(SortTrack(self._next_id, BoxKalman(dets[d])))
            self._next_id += 1

        # 5. output, 6. delete
        rows = []
        for track in self.tracks:
            m = track.motion
            if m.time_since_update < 1 and (m.hit_streak >= self.min_hits or self.frame_count <= self.min_hits):
                rows.append([track.id, *m.box])
        self.tracks = [t for t in self.tracks if t.motion.time_since_update <= self.max_age]
        return np.array(rows, dtype=float).reshape(-1, 5)


def stream_sequence(seq, max_age: int = SORT_MAX_AGE, min_hits: int = SORT_MIN_HITS,
                    iou_threshold: float = SORT_IOU_THRESHOLD):
    """SORT frame by frame: yields each frame's (k, 6) rows (frame, id, x, y, w, h) as soon as it
    is decided (SORT never revises a written frame), so a caller can stream them to a file."""
    tracker = SortTracker(max_age=max_age, min_hits=min_hits, iou_threshold=iou_threshold)
    for fr in seq.frames:
        rows = tracker.update(fr.boxes)
        out = np.empty((len(rows), 6))
        out[:, 0] = fr.frame
        out[:, 1:] = rows
        yield out


def track_sequence(seq, max_age: int = SORT_MAX_AGE, min_hits: int = SORT_MIN_HITS, iou_threshold: float = SORT_IOU_THRESHOLD) -> np.ndarray:
    """Run SORT over every frame of a detection sequence (anything with `.frames`, each with `.frame` and `.boxes` xywh).

    Frames are processed in the given order, empty ones included. Returns an (n, 6) float
    array of rows (frame, id, x, y, w, h) with the sequence's own frame numbers.
    """
    out = [rows for rows in stream_sequence(seq, max_age, min_hits, iou_threshold) if len(rows)]
    if not out:
        return np.zeros((0, 6))
    return np.vstack(out)
