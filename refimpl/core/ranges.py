"""The integer ranges the backends compute in: a frame problem either fits them or is refused.

clingo computes with 32-bit integers (-2^31..2^31-1) and wraps silently beyond them; CP-SAT and
Python compute in 64 bits or exactly.  So an input whose arithmetic leaves the 32-bit range would
make the backends answer differently (issue 17: ``--const iou_thresh=2147483648``, boxes whose
x+w or w*h exceed 2^31).  Two checks, each where it belongs (issue 26):

* :func:`check_ranges`, for every backend, before any sees the problem: the *values* (constants,
  boxes, times).  They define what a frame problem is, whatever solves it, and they do not grow
  with the size of the frame.
* :func:`clingo_overflow`, for the clingo backend only, on each sub-problem it hands to clingo
  (after refimpl.solvers.decompose): the optimisation *sums*, which grow with the frame.  A
  frame with a component too large for clingo's sums is solved by the CP-SAT backends (whose
  objectives are exact, refimpl/solvers/cpsat_model.py: OBJECTIVE_BITS) and refused by clingo
  with one line (:class:`OutOfClingoRange`); ``refimpl diff`` counts such frames.

What the model computes (model/*.lp, the same in refimpl/knowledge/relations.py and refimpl/solvers):

* every ``#const`` value itself (compared with other integers);
* box edges ``X + W``, ``Y + H`` and the overlap formulas of model/spatial.lp, which add two edges
  and an absolute difference: every coordinate and size must stay within +-2^28 (``BOX_LIMIT``);
* areas: ``W * H`` of every box and ``100 * I > hide_overlap * W * H`` for track boxes, so
  ``max(100, hide_overlap) * W * H`` must fit;
* ``img_width - border_margin`` (and height) and ``curr_time - T`` for every history time ``T``
  (model/events.lp, lost and noise): each operand within +-2^30 (``TIME_LIMIT``), and the
  difference itself checked, since 2^30 - (-2^30) is one beyond the range (found by
  tests/tools/fuzz_agreement.py: clingo wrapped it, abduced an impossible ``noise`` and missed a ``lost``);
* ``leave_visible`` within 0..100: ``100 * VW * VH <= leave_visible * W * H`` (model/spatial.lp
  [out_of_view], VW <= W and VH <= H the box's part inside the image) then fits wherever
  ``100 * W * H`` does;
* ``likelihood_conf`` within 0..100: a pair's matching likelihood ``IOU * (10000 -
  likelihood_conf * (100 - Conf)) / 10000`` (model/optimisation.lp [matching_likelihood]) then
  stays within 0..IoU and its product within 10^9;
* ``hide_overlap`` >= 0: it is a percentage, and below 0 ``100 * I > hide_overlap * W * H``
  holds for tracks that do not overlap at all, so any track could hide behind any other and the
  canonical tie-break (refimpl/solvers/common.py, which ranks only overlapping or
  history-named pairs) would no longer make the optimum unique (the backends then chose
  different occluders at equal cost; a large negative value also overflowed ``hide_overlap * W
  * H``);
* (clingo only) the optimisation sums, bounded from above over every possible answer of a
  sub-problem (``clingo_sum_bounds``).  Level 0 no longer needs a frame-wide bound: the
  tie-break reaches clingo in chunks below 2^30 (docs/model.md 3.10, 3.11); an earlier bound
  for weights (k+1)^2 refused whole frames of 200 tracks and 7,000 IoU pairs on every backend.
"""

from __future__ import annotations

import operator
from functools import lru_cache

import numpy as np

from .spec import ASP_INT_MAX, ASP_INT_MIN, IOU_SCALE, MAX_LIKELIHOOD_HALVING, FrameProblem, ProblemFormatError
from .constants import resolve_constants

BOX_LIMIT = 2 ** 28
TIME_LIMIT = 2 ** 30

FPS_MIN, FPS_MAX = 0.1, 1000.0
"""The frame rates a sequence may have, frames per second (``--fps``, ``fps=``, seqinfo.ini's
frameRate): a preset's durations and per-frame rates are converted to the sequence's frame rate
(refimpl.tracking.camera), and beyond these bounds the conversions leave the ranges of the options
and constants they make (at 0.01 fps the KITTI Car preset's velocity noise would be 10^7, at
10^6 fps its likelihood_halving 10^6 frames) or a float's.  A camera from one frame in ten seconds
to a thousand a second."""


def fps_fits(value: float) -> bool:
    """A frame rate within FPS_MIN..FPS_MAX (a finite number)."""
    return FPS_MIN <= value <= FPS_MAX


FPS_RANGE_TEXT = f"a frame rate from {FPS_MIN:g} to {FPS_MAX:g} frames per second"
_TEMPORAL = ("lost_after_missing", "lost_after_hidden", "noise_max_age", "claim_after", "mintime")
_BORDER = ("img_width", "img_height", "border_margin")


def check_constant(name: str, value: int, source: str = "--const") -> None:
    """One constant value fits the 32-bit range (and the tighter one its use needs)."""
    if not ASP_INT_MIN <= value <= ASP_INT_MAX:
        raise ProblemFormatError(f"{name}={value} is outside the 32-bit range {ASP_INT_MIN}..{ASP_INT_MAX} "
                                 "that clingo computes in", source)
    if (name in _TEMPORAL or name in _BORDER or name == "curr_time") and abs(value) > TIME_LIMIT:
        raise ProblemFormatError(f"{name}={value} is outside -{TIME_LIMIT}..{TIME_LIMIT} (times and image "
                                 "sizes are added to other values in 32-bit arithmetic)", source)
    if name == "leave_visible" and not 0 <= value <= 100:
        raise ProblemFormatError(f"leave_visible={value} must be within 0..100 (a percentage of the track's box; "
                                 "model/spatial.lp [out_of_view] multiplies it by the box area)", source)
    if name == "likelihood_conf" and not 0 <= value <= 100:
        raise ProblemFormatError(f"likelihood_conf={value} must be within 0..100 (how much a detection's confidence "
                                 "weighs in the matching likelihood; outside it a pair's weight at level 10 could be "
                                 "negative or leave clingo's 32-bit integers)", source)
    if name == "likelihood_halving" and not 0 <= value <= MAX_LIKELIHOOD_HALVING:
        raise ProblemFormatError(f"likelihood_halving={value} must be within 0..{MAX_LIKELIHOOD_HALVING} (frames: a "
                                 "halted track's matching likelihood times it / (it + frames since the halt); "
                                 "beyond it the weight would leave clingo's 32-bit integers)", source)
    if name == "glimpse_frames" and value < 0:
        raise ProblemFormatError(f"glimpse_frames={value} must be >= 0 (frames of observation: a halted track missed "
                                 "within that many frames of its start is a glimpse; 0: none)", source)
    if name == "hide_overlap" and value < 0:
        raise ProblemFormatError(f"hide_overlap={value} must be >= 0 (a percentage of the track's box; below 0 "
                                 "every pair of tracks would count as overlapping)", source)


def check_ranges(problem: FrameProblem, source: str = "<problem>", boxes_checked: bool = False) -> None:
    """Raise ProblemFormatError (one line) if any value of the problem leaves the range (every
    backend; the optimisation sums are clingo's alone: ``clingo_overflow``).  ``boxes_checked``:
    the caller has found every box within the box tests already (``integer_boxes_fit``)."""
    consts = resolve_constants(problem)
    # a tracker's constants are the same on every frame but curr_time: checked once (every other
    # value of consts comes from problem.constants and the defaults)
    if _given_constants_fit(problem.constants):
        check_constant("curr_time", consts["curr_time"], source)
    else:
        for name, value in consts.items():
            check_constant(name, value, source)  # raises, naming this problem's source
    hide = max(100, consts.get("hide_overlap", 100))
    for kind, objects in () if boxes_checked else (("detection", problem.detections), ("track", problem.tracks)):
        if _boxes_fit(objects, hide if kind == "track" else 1):
            continue  # else the loop below names the first box that does not
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
    times = [h.time for h in problem.history]
    if not times or (max(map(abs, times)) <= TIME_LIMIT and problem.time - min(times) <= ASP_INT_MAX):
        return  # else the loop below names the first event that does not fit
    for h in problem.history:
        if abs(h.time) > TIME_LIMIT:
            raise ProblemFormatError(f"history time {h.time} of {h} is outside -{TIME_LIMIT}..{TIME_LIMIT}", source)
        if problem.time - h.time > ASP_INT_MAX:
            raise ProblemFormatError(f"curr_time - {h.time} (history event {h}) = {problem.time - h.time} exceeds "
                                     f"{ASP_INT_MAX} (clingo's 32-bit integers)", source)


def integer_boxes_fit(boxes: np.ndarray, detections: int, hide_overlap: int) -> bool:
    """Whether integer boxes given as one int64 array (n, 4) of values below 2^52 in absolute
    value (refimpl.core.geometry.integer_box_array), the first ``detections`` rows detections' and
    the others tracks', pass check_ranges' box tests (its ``hide``: max(100, hide_overlap))."""
    if not len(boxes):
        return True
    if np.abs(boxes).max() > BOX_LIMIT or np.abs(boxes[:, :2] + boxes[:, 2:]).max() > BOX_LIMIT:
        return False
    area = (boxes[:, 2] * boxes[:, 3]).tolist()  # w, h <= 2^28 now: exact in int64
    return (max(area[:detections], default=0) <= ASP_INT_MAX
            and max(100, hide_overlap) * max(area[detections:], default=0) <= ASP_INT_MAX)


def _boxes_fit(objects, factor: int) -> bool:
    """Whether every box passes check_ranges' tests (factor: the area's factor, > 0), each test
    taken as the largest value over all boxes (builtins over the columns, no Python loop per box)."""
    if not objects:
        return True
    xs, ys, ws, hs = zip(*[o.box for o in objects])
    return (max(max(map(abs, xs)), max(map(abs, ys)), max(ws), max(hs)) <= BOX_LIMIT
            and max(map(abs, map(operator.add, xs, ws))) <= BOX_LIMIT
            and max(map(abs, map(operator.add, ys, hs))) <= BOX_LIMIT
            and factor * max(map(operator.mul, ws, hs)) <= ASP_INT_MAX)


def _given_constants_fit(constants) -> bool:
    """Whether every constant but curr_time that resolve_constants makes of a problem's constants
    passes check_constant (memoised by the constants, where they are hashable)."""
    try:
        return _given_fit(constants)
    except TypeError:  # not hashable (a list, say): the merged values, without the memo
        return _constants_fit(tuple(kv for kv in resolve_constants(FrameProblem.unchecked(0, constants=constants)).items()
                                    if kv[0] != "curr_time"))


@lru_cache(maxsize=256)
def _given_fit(constants) -> bool:
    merged = resolve_constants(FrameProblem.unchecked(0, constants=constants))
    return _constants_fit(tuple(kv for kv in merged.items() if kv[0] != "curr_time"))


@lru_cache(maxsize=256)
def _constants_fit(items: tuple[tuple[str, int], ...]) -> bool:
    """Whether every (name, value) passes check_constant (memoised)."""
    try:
        for name, value in items:
            check_constant(name, value)
    except ProblemFormatError:
        return False
    return True


class OutOfClingoRange(ProblemFormatError):
    """Some sub-problem the clingo backend would hand to clingo has an optimisation sum beyond
    its 32-bit integers.  The CP-SAT backends solve the same frame (they sum in 64 bits)."""

    def __init__(self, message: str, source: str = "<problem>", components: int = 1):
        super().__init__(message, source)
        self.components = components


EXPLANATION_LIMIT = 1 << 30
"""The tie-break's explanation part must stay below this (one priority of clingo's sums;
refimpl/solvers/common.py: tiebreak_levels)."""


def clingo_sum_bounds(problem: FrameProblem, explanation_bits: int) -> dict[int, int]:
    """Upper bounds of |sum| per priority over every answer of ``problem`` as clingo is given it
    (one sub-problem of the clingo backend, refimpl.solvers.decompose): level 10 (IoU x 100000
    plus one per assignment or resume), level 5 (empty), level 3 (10 per ignored
    object), level 2 (5 per end or start), level 1 (the largest event cost times
    the number of events an answer can abduce, counted generously as one per ordered track pair
    and three per track), and level 0: the pair part reaches clingo in chunks that are below 2^30
    by construction (refimpl.solvers.common.tiebreak_levels), so only the explanation part's sum
    of indices is bounded here, by 2^E - 1 where E = ``explanation_bits`` (the bit length of
    its largest possible sum, refimpl.solvers.common.TiebreakWeights.shift)."""
    bounds = count_sum_bounds(resolve_constants(problem), len(problem.tracks), len(problem.detections))
    bounds[0] = (1 << explanation_bits) - 1
    return bounds


def count_sum_bounds(consts: dict[str, int], nt: int, nd: int) -> dict[int, int]:
    """The bounds of ``clingo_sum_bounds`` at levels 10 to 1, which depend only on the constants
    and on the numbers of tracks ``nt`` and detections ``nd`` (all grow with them)."""
    matched = min(nt, nd)
    costs = [abs(v) for k, v in consts.items() if k.startswith("cost_")]
    events = nt * nt + 3 * nt + nd  # hides/unhides per pair, one event per track, enters_fov per detection
    return {
        10: (IOU_SCALE + 1) * matched,
        5: 0,
        3: 10 * (nt + nd),
        2: 5 * (nt + nd),
        1: max(costs, default=0) * events,
    }


def counts_fit_clingo(consts: dict[str, int], nt: int, nd: int) -> bool:
    """Whether a sub-problem of ``nt`` tracks and ``nd`` detections has its sums at levels 10 to 1
    inside clingo's 32-bit integers (level 0 depends on more than the counts: ``clingo_overflow``
    decides it)."""
    return max(count_sum_bounds(consts, nt, nd).values()) <= ASP_INT_MAX


def clingo_overflow(problem: FrameProblem, explanation_bits: int) -> str | None:
    """Why clingo cannot represent this (sub-)problem's optimisation, or None if it can."""
    for level, bound in clingo_sum_bounds(problem, explanation_bits).items():
        if bound > (EXPLANATION_LIMIT - 1 if level == 0 else ASP_INT_MAX):
            return (f"the level-{level} cost can reach {bound}, beyond clingo's 32-bit range "
                    f"({len(problem.tracks)} tracks, {len(problem.detections)} detections, "
                    f"{len(problem.iou)} IoU pairs)")
    return None
