"""What both backends take from one place: tie-break weights (docs/model-spec.md section 5)."""

from __future__ import annotations

from ..geometry import intersection_area
from ..spec import FrameProblem, natural_key


def tiebreak_weights(problem: FrameProblem) -> tuple[dict[tuple[str, str], int], dict[tuple[str, str], int]]:
    """(w, r): w[(trk, det)] for assign/resume pairs, r[(trk1, trk2)] for hides_behind occluders.

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
    return w, r


def tiebreak_facts(problem: FrameProblem) -> str:
    """The tie-break weights as ASP facts for the clingo backend."""
    w, r = tiebreak_weights(problem)
    lines = [f"tiebreak_pair({t},{d},{v})." for (t, d), v in w.items()]
    lines += [f"tiebreak_hides({a},{b},{v})." for (a, b), v in r.items()]
    return "\n".join(lines) + ("\n" if lines else "")
