"""The integer range both backends compute in: a frame problem either fits it or is refused.

clingo computes with 32-bit integers (-2^31..2^31-1) and wraps silently beyond them; CP-SAT and
Python compute exactly.  So an input whose arithmetic leaves the 32-bit range would make the two
backends answer differently (issue 17: ``--const iou_thresh=2147483648``, boxes whose x+w or w*h
exceed 2^31, a level-0 cost that wraps on large frames).  :func:`check_ranges` refuses such a
problem with one line naming the value, before any backend sees it.  What the model computes
(model/*.lp, the same in refimpl/relations.py and refimpl/solvers):

* every ``#const`` value itself (compared with other integers);
* box edges ``X + W``, ``Y + H`` and the overlap formulas of model/spatial.lp, which add two edges
  and an absolute difference: every coordinate and size must stay within +-2^28 (``BOX_LIMIT``);
* areas: ``W * H`` of every box and ``100 * I > hide_overlap * W * H`` for track boxes, so
  ``max(100, hide_overlap) * W * H`` must fit;
* ``img_width - border_margin`` (and height) and ``curr_time - T`` for every history time ``T``
  (model/events.lp, lost and noise): each operand within +-2^30 (``TIME_LIMIT``), and the
  difference itself checked, since 2^30 - (-2^30) is one beyond the range (found by
  tools/fuzz_agreement.py: clingo wrapped it, abduced an impossible ``noise`` and missed a ``lost``);
* ``hide_overlap`` >= 0: it is a percentage, and below 0 ``100 * I > hide_overlap * W * H``
  holds for tracks that do not overlap at all, so any track could hide behind any other and the
  canonical tie-break (refimpl/solvers/common.py, which ranks only overlapping or
  history-named pairs) would no longer make the optimum unique (the backends then chose
  different occluders at equal cost; a large negative value also overflowed ``hide_overlap * W
  * H``);
* the optimisation sums, bounded from above over every possible answer: level 10 (IoU x 100000
  per assignment plus one per assignment), level 3 (10 per ignored object), level 2, level 1
  (the largest event cost times the number of events an answer can abduce) and level 0 (the
  tie-break weights of refimpl/solvers/common.py: (k+1)^2 for the k-th IoU pair, so an answer's
  sum is at most the sum of the largest min(tracks, detections) squares, plus track ranks).
"""

from __future__ import annotations

from .spec import ASP_INT_MAX, ASP_INT_MIN, IOU_SCALE, FrameProblem, ProblemFormatError

BOX_LIMIT = 2 ** 28
TIME_LIMIT = 2 ** 30
_TEMPORAL = ("lost_after_missing", "lost_after_hidden", "noise_max_age", "mintime")
_BORDER = ("img_width", "img_height", "border_margin")


def check_constant(name: str, value: int, source: str = "--const") -> None:
    """One constant value fits the 32-bit range (and the tighter one its use needs)."""
    if not ASP_INT_MIN <= value <= ASP_INT_MAX:
        raise ProblemFormatError(f"{name}={value} is outside the 32-bit range {ASP_INT_MIN}..{ASP_INT_MAX} "
                                 "that clingo computes in", source)
    if (name in _TEMPORAL or name in _BORDER or name == "curr_time") and abs(value) > TIME_LIMIT:
        raise ProblemFormatError(f"{name}={value} is outside -{TIME_LIMIT}..{TIME_LIMIT} (times and image "
                                 "sizes are added to other values in 32-bit arithmetic)", source)
    if name == "hide_overlap" and value < 0:
        raise ProblemFormatError(f"hide_overlap={value} must be >= 0 (a percentage of the track's box; below 0 "
                                 "every pair of tracks would count as overlapping)", source)


def _sum_of_largest_squares(pairs: int, count: int) -> int:
    """(pairs)^2 + (pairs-1)^2 + ... over the ``count`` largest of 1..pairs."""
    def squares(n: int) -> int:
        return n * (n + 1) * (2 * n + 1) // 6
    return squares(pairs) - squares(max(pairs - count, 0))


def check_ranges(problem: FrameProblem, source: str = "<problem>") -> None:
    """Raise ProblemFormatError (one line) if any value or sum of the problem leaves the range."""
    from .constants import resolve_constants
    consts = resolve_constants(problem)
    for name, value in consts.items():
        check_constant(name, value, source)
    hide = max(100, consts.get("hide_overlap", 100))
    for kind, objects in (("detection", problem.detections), ("track", problem.tracks)):
        for o in objects:
            x, y, w, h = o.box
            if max(abs(x), abs(y), w, h) > BOX_LIMIT or max(abs(x + w), abs(y + h)) > BOX_LIMIT:
                raise ProblemFormatError(f"box of {kind} {o.id} ({x},{y},{w},{h}) leaves -{BOX_LIMIT}..{BOX_LIMIT} "
                                         "(the overlap formulas add two box edges in 32-bit arithmetic)", source)
            factor = hide if kind == "track" else 1
            if factor * w * h > ASP_INT_MAX:
                what = f"{factor} * w * h" if factor > 1 else "w * h"
                raise ProblemFormatError(f"box of {kind} {o.id}: {what} = {factor * w * h} exceeds {ASP_INT_MAX} "
                                         "(clingo's 32-bit integers)", source)
    for size in ("img_width", "img_height"):
        if not ASP_INT_MIN <= consts[size] - consts["border_margin"] <= ASP_INT_MAX:
            raise ProblemFormatError(f"{size} - border_margin = {consts[size] - consts['border_margin']} is outside "
                                     "the 32-bit range that clingo computes in", source)
    for h in problem.history:
        if abs(h.time) > TIME_LIMIT:
            raise ProblemFormatError(f"history time {h.time} of {h} is outside -{TIME_LIMIT}..{TIME_LIMIT}", source)
        if problem.time - h.time > ASP_INT_MAX:
            raise ProblemFormatError(f"curr_time - {h.time} (history event {h}) = {problem.time - h.time} exceeds "
                                     f"{ASP_INT_MAX} (clingo's 32-bit integers)", source)
    nt, nd, pairs = len(problem.tracks), len(problem.detections), len(problem.iou)
    matched = min(nt, nd)
    costs = [abs(v) for k, v in consts.items() if k.startswith("cost_")]
    events = nt * nt + 3 * nt + nd  # hides/unhides per pair, one event per track, enters_fov per detection
    bounds = {
        10: (IOU_SCALE + 1) * matched,
        3: 10 * (nt + nd),
        2: nt + 5 * (nt + nd),
        1: max(costs, default=0) * events,
        0: _sum_of_largest_squares(pairs, matched) + 2 * nt * nt,
    }
    for level, bound in bounds.items():
        if bound > ASP_INT_MAX:
            raise ProblemFormatError(
                f"the level-{level} cost of this frame can reach {bound}, beyond clingo's 32-bit range "
                f"({nt} tracks, {nd} detections, {pairs} IoU pairs): split the problem", source)
