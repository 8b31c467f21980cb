"""What both backends take from one place: tie-break weights (docs/model-spec.md section 5)."""

from __future__ import annotations

from functools import lru_cache
from typing import NamedTuple, Sequence

import numpy as np

from ..spec import Box, FrameProblem, natural_key


class TiebreakWeights(NamedTuple):
    pair: dict[tuple[str, str], int]
    """w[(trk, det)] for the chosen assign/resume pairs."""
    hides: dict[tuple[str, str], int]
    """r[(trk1, trk2)] for the chosen hides_behind occluder."""
    track: dict[str, int]
    """k[trk2] for unhides_from_behind(trk1, trk2): trk2's index in natural order."""


def intersection_matrix(boxes: Sequence[Box]) -> np.ndarray:
    """inter[i, j] = refimpl.geometry.intersection_area(boxes[i], boxes[j]) for integer boxes,
    all pairs at once (int64, exact: the same integer arithmetic, vectorised)."""
    b = np.asarray(boxes, dtype=np.int64).reshape(-1, 4)
    x1, y1 = b[:, 0], b[:, 1]
    x2, y2 = x1 + b[:, 2], y1 + b[:, 3]
    iw = np.minimum(x2[:, None], x2[None, :]) - np.maximum(x1[:, None], x1[None, :])
    ih = np.minimum(y2[:, None], y2[None, :]) - np.maximum(y1[:, None], y1[None, :])
    return np.maximum(iw, 0) * np.maximum(ih, 0)


@lru_cache(maxsize=1 << 16)
def _natural_key(ident: str) -> tuple:
    """spec.natural_key, memoised: the same ids come back frame after frame."""
    return natural_key(ident)


def tiebreak_weights(problem: FrameProblem, inter: np.ndarray | None = None) -> TiebreakWeights:
    """(w, r, k): w[(trk, det)] for assign/resume pairs, r[(trk1, trk2)] for hides_behind occluders,
    k[trk2] for the track unhidden from.

    w = (k+1)^2 with k the index of the pair among the iou/3 pairs in natural (trk, det) order;
    r = rank of trk2 among the other tracks overlapping trk1 (only those can occlude it) by decreasing overlap with trk1, then natural order.

    ``inter`` optionally passes ``intersection_matrix`` of the track boxes (in problem.tracks
    order) when the caller has it already.  The pairwise overlaps are computed with numpy; the
    result is exactly that of the plain definition above (tests/test_fastpath.py compares them).
    """
    nat = _natural_key
    pairs = sorted(((t, d) for t, d, _ in problem.iou), key=lambda p: (nat(p[0]), nat(p[1])))
    w = {pair: (k + 1) ** 2 for k, pair in enumerate(pairs)}
    tracks = problem.tracks
    order = sorted(range(len(tracks)), key=lambda i: nat(tracks[i].id))
    k = {tracks[i].id: rank for rank, i in enumerate(order)}
    r: dict[tuple[str, str], int] = {}
    if len(tracks) > 1:
        if inter is None:
            inter = intersection_matrix([t.box for t in tracks])
        pos = np.empty(len(tracks), dtype=np.int64)
        pos[order] = np.arange(len(tracks))  # natural-order position of each track
        overlapping = inter > 0
        np.fill_diagonal(overlapping, False)
        rows, cols = np.nonzero(overlapping)
        if len(rows):
            # sort every row's overlapping tracks by (-inter, natural order): one lexsort for all rows
            sel = np.lexsort((pos[cols], -inter[rows, cols], rows))
            rows, cols = rows[sel].tolist(), cols[sel].tolist()
            prev, rank = -1, 0
            for i, j in zip(rows, cols):
                rank = rank + 1 if i == prev else 0
                prev = i
                r[(tracks[i].id, tracks[j].id)] = rank
    return TiebreakWeights(w, r, k)


def tiebreak_facts(problem: FrameProblem) -> str:
    """The tie-break weights as ASP facts for the clingo backend."""
    w, r, k = tiebreak_weights(problem)
    lines = [f"tiebreak_pair({t},{d},{v})." for (t, d), v in w.items()]
    lines += [f"tiebreak_hides({a},{b},{v})." for (a, b), v in r.items()]
    lines += [f"tiebreak_track({t},{v})." for t, v in k.items()]
    return "\n".join(lines) + ("\n" if lines else "")
