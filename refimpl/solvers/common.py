"""What both backends take from one place: tie-break weights (docs/model-spec.md section 5)."""

from __future__ import annotations

from typing import NamedTuple

from ..geometry import intersection_area
from ..spec import FrameProblem, natural_key


class TiebreakWeights(NamedTuple):
    pair: dict[tuple[str, str], int]
    """w[(trk, det)] for the chosen assign/resume pairs."""
    hides: dict[tuple[str, str], int]
    """r[(trk1, trk2)] for the chosen hides_behind occluder."""
    track: dict[str, int]
    """k[trk2] for unhides_from_behind(trk1, trk2): trk2's index in natural order."""


def tiebreak_weights(problem: FrameProblem) -> TiebreakWeights:
    """(w, r, k): w[(trk, det)] for assign/resume pairs, r[(trk1, trk2)] for hides_behind occluders,
    k[trk2] for the track unhidden from.

    w = (k+1)^2 with k the index of the pair among the iou/3 pairs in natural (trk, det) order;
    r = rank of trk2 among the other tracks overlapping trk1 (only those can occlude it) by decreasing overlap with trk1, then natural order.
    """
    pairs = sorted(((t, d) for t, d, _ in problem.iou), key=lambda p: (natural_key(p[0]), natural_key(p[1])))
    w = {pair: (k + 1) ** 2 for k, pair in enumerate(pairs)}
    r: dict[tuple[str, str], int] = {}
    for t1 in problem.tracks:
        others = sorted(
            (t2 for t2 in problem.tracks if t2.id != t1.id and intersection_area(t1.box, t2.box) > 0),
            key=lambda t2: (-intersection_area(t1.box, t2.box), natural_key(t2.id)),
        )
        for rank, t2 in enumerate(others):
            r[(t1.id, t2.id)] = rank
    k = {t.id: i for i, t in enumerate(sorted(problem.tracks, key=lambda t: natural_key(t.id)))}
    return TiebreakWeights(w, r, k)


def tiebreak_facts(problem: FrameProblem) -> str:
    """The tie-break weights as ASP facts for the clingo backend."""
    w, r, k = tiebreak_weights(problem)
    lines = [f"tiebreak_pair({t},{d},{v})." for (t, d), v in w.items()]
    lines += [f"tiebreak_hides({a},{b},{v})." for (a, b), v in r.items()]
    lines += [f"tiebreak_track({t},{v})." for t, v in k.items()]
    return "\n".join(lines) + ("\n" if lines else "")
