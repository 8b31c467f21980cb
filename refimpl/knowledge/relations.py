"""Commonsense spatio-temporal relations on boxes (the paper's Sigma_st, Table 2), as the model uses them.

Boxes are (x, y, w, h) sequences in image pixels: top-left corner, width, height, y growing
downwards.  A box spans the closed extent [x, x + w] x [y, y + h]; for integer boxes this is the
pixel grid with pixels x .. x + w - 1, so two boxes with x + w == x' share an edge but no pixel.

The first seven functions (overlapping_top and overlapped_from_the_top, its any() over many
boxes; near_border, outside_fov, visible_area, out_of_view, area) are pure integer functions that give
exactly what the ASP encoding computes from box2d/5 facts.  The rest implement the relations of
Table 2 that apply to axis-aligned boxes over time and accept integers or floats:

* Allen's interval algebra per axis and the rectangle algebra (pairs of Allen relations);
* mereotopology: RCC-8 on boxes (dc, ec, po, tpp, ntpp, tppi, ntppi, eq) and the derived
  relations part of (p), proper part (pp), overlap (o), discrete (dr), contact (c);
* orientation in the image (left_of, right_of, above, below) and the ground-plane depth cue
  (in_front_of);
* distance and size (near, far, smaller, same_size, larger);
* motion between two time points, single object (moving_left .., growing, shrinking, stationary)
  and pairs (moving_towards, moving_away, moving_parallel, approaching), plus moves_out_of for the
  anticipation rule of Section 4 (first_time_moves_out_of);
* time: Allen on track intervals (interval_relation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

from ..core.geometry import intersection_area
from ..core.spec import Box

BoxLike = Sequence[float]
"""A box (x, y, w, h) of ints or floats (a tuple, a list or a numpy row)."""


def overlapping_top(b1: Box, b2: Box, hide_overlap: int) -> bool:
    """position(overlapping_top, T1, T2): b2 covers more than hide_overlap % of b1 and is not behind it.

    "Not behind" is the ground-plane depth cue: b2's bottom edge is at or below b1's in the image.
    """
    return (
        100 * intersection_area(b1, b2) > hide_overlap * b1[2] * b1[3]
        and b2[1] + b2[3] >= b1[1] + b1[3]
    )


def overlapped_from_the_top(b1: Box, others, hide_overlap: int, skip: object = None) -> bool:
    """any(key != skip and overlapping_top(b1, b2, hide_overlap) for key, b2 in others): whether
    some box of ``others`` ((key, box) pairs) covers b1 from the top.  The same integer tests in a
    cheaper order (the depth cue, two comparisons, before the overlap's area) and without a call
    per pair: a crowd's halted tracks ask it of every other track every frame (kept_in_mind)."""
    x, y, w, h = b1
    right, bottom, least = x + w, y + h, hide_overlap * w * h
    for key, (x2, y2, w2, h2) in others:
        if y2 + h2 >= bottom and key != skip:
            iw = min(right, x2 + w2) - max(x, x2)
            ih = min(bottom, y2 + h2) - max(y, y2)
            if 100 * (iw if iw > 0 else 0) * (ih if ih > 0 else 0) > least:
                return True
    return False


def near_border(b: Box, img_width: int, img_height: int, margin: int) -> bool:
    """The box is within margin px of (or beyond) a border of the field of view; 0 = size unknown."""
    x, y, w, h = b
    return (
        x <= margin
        or y <= margin
        or (img_width > 0 and x + w >= img_width - margin)
        or (img_height > 0 and y + h >= img_height - margin)
    )


def outside_fov(b: Box, img_width: int, img_height: int) -> bool:
    """The box lies entirely outside the field of view (no pixel inside a known border); 0 = size unknown."""
    x, y, w, h = b
    return (
        x + w <= 0
        or y + h <= 0
        or (img_width > 0 and x >= img_width)
        or (img_height > 0 and y >= img_height)
    )


def visible_area(b: Box, img_width: int, img_height: int) -> int:
    """The area of the part of the box inside the field of view (0 = size unknown: that border does not clip)."""
    x, y, w, h = b
    right = min(x + w, img_width) if img_width > 0 else x + w
    bottom = min(y + h, img_height) if img_height > 0 else y + h
    return max(0, right - max(x, 0)) * max(0, bottom - max(y, 0))


def out_of_view(b: Box, img_width: int, img_height: int, leave_visible: int) -> bool:
    """At most leave_visible % of the box lies inside the field of view (model/spatial.lp
    [out_of_view], docs/model.md 3.25)."""
    return 100 * visible_area(b, img_width, img_height) <= leave_visible * b[2] * b[3]


def area(b: Box) -> int:
    """Area w * h of a box (px^2)."""
    return b[2] * b[3]


# ---------------------------------------------------------------------------------------------
# Allen's interval algebra and the rectangle algebra
# ---------------------------------------------------------------------------------------------

ALLEN_RELATIONS = (
    "before", "after", "meets", "met_by", "overlaps", "overlapped_by", "starts", "started_by",
    "during", "contains", "finishes", "finished_by", "equals",
)
"""Allen's 13 jointly exhaustive, pairwise disjoint relations between proper intervals."""

ALLEN_CONVERSE = {
    "before": "after", "after": "before", "meets": "met_by", "met_by": "meets",
    "overlaps": "overlapped_by", "overlapped_by": "overlaps", "starts": "started_by",
    "started_by": "starts", "during": "contains", "contains": "during",
    "finishes": "finished_by", "finished_by": "finishes", "equals": "equals",
}
"""allen(b, a) == ALLEN_CONVERSE[allen(a, b)]."""


def allen(a1: float, a2: float, b1: float, b2: float) -> str:
    """Allen's relation of interval [a1, a2] to interval [b1, b2] (needs a1 <= a2, b1 <= b2)."""
    if a1 > a2 or b1 > b2:
        raise ValueError(f"allen needs ordered intervals, got [{a1}, {a2}] and [{b1}, {b2}]")
    # Checked in converse pairs, equals first, so that the answer is unique and allen(b, a) is the
    # converse of allen(a, b) also for degenerate (point) intervals; for proper intervals
    # (a1 < a2, b1 < b2) at most one of the tests can hold, so the order does not matter there.
    if a1 == b1 and a2 == b2:
        return "equals"
    if a2 < b1:
        return "before"
    if b2 < a1:
        return "after"
    if a2 == b1:
        return "meets"
    if b2 == a1:
        return "met_by"
    if a1 == b1:
        return "starts" if a2 < b2 else "started_by"
    if a2 == b2:
        return "finishes" if a1 > b1 else "finished_by"
    if b1 < a1 and a2 < b2:
        return "during"
    if a1 < b1 and b2 < a2:
        return "contains"
    return "overlaps" if a1 < b1 else "overlapped_by"


def rectangle_relation(box_a: BoxLike, box_b: BoxLike) -> tuple[str, str]:
    """Rectangle algebra: (Allen on the x extents, Allen on the y extents); y grows downwards, so y "before" = above."""
    ax, ay, aw, ah = box_a
    bx, by, bw, bh = box_b
    return allen(ax, ax + aw, bx, bx + bw), allen(ay, ay + ah, by, by + bh)


# ---------------------------------------------------------------------------------------------
# Mereotopology (RCC-8 on closed boxes)
# ---------------------------------------------------------------------------------------------

TOPOLOGY_RELATIONS = (
    "disconnected", "externally_connected", "partially_overlapping", "tangential_proper_part",
    "non_tangential_proper_part", "tangential_proper_part_inverse",
    "non_tangential_proper_part_inverse", "equal",
)

TOPOLOGY_CONVERSE = {
    "disconnected": "disconnected",
    "externally_connected": "externally_connected",
    "partially_overlapping": "partially_overlapping",
    "tangential_proper_part": "tangential_proper_part_inverse",
    "tangential_proper_part_inverse": "tangential_proper_part",
    "non_tangential_proper_part": "non_tangential_proper_part_inverse",
    "non_tangential_proper_part_inverse": "non_tangential_proper_part",
    "equal": "equal",
}
"""topology(b, a) == TOPOLOGY_CONVERSE[topology(a, b)]."""


@dataclass(frozen=True)
class RelationCode:
    """One code of the frame listings (``refimpl plot --frame``, the report's relations list):
    ``A B code`` reads "box A code box B"."""

    code: str
    """As the listings print it (RCC-8's short names: dc, ec, po, ...)."""
    relation: str
    """The relation of this module it names: topology()'s answer, an orientation word, ..."""
    meaning: str
    """What it says about A and B, in words (the report's legend)."""


RELATION_CODES: tuple[RelationCode, ...] = (
    RelationCode("dc", "disconnected", "A and B share no point (RCC-8 disconnected)"),
    RelationCode("ec", "externally_connected",
                 "A and B touch at an edge or a corner but share no area (externally connected)"),
    RelationCode("po", "partially_overlapping",
                 "A and B share area and neither lies inside the other (partially overlapping)"),
    RelationCode("tpp", "tangential_proper_part", "A lies inside B and touches B's border (tangential proper part)"),
    RelationCode("ntpp", "non_tangential_proper_part",
                 "A lies inside B, clear of B's border (non-tangential proper part)"),
    RelationCode("tppi", "tangential_proper_part_inverse", "B lies inside A and touches A's border (tpp inverse)"),
    RelationCode("ntppi", "non_tangential_proper_part_inverse", "B lies inside A, clear of A's border (ntpp inverse)"),
    RelationCode("eq", "equal", "A and B are the same box (equal)"),
    RelationCode("overlapping_top", "overlapping_top",
                 "B covers more than hide_overlap % of A and is not behind A: what the model calls "
                 "B in front of A, the position a hides_behind needs"),
    RelationCode("left_of", "left_of", "A lies entirely left of B (A's right edge at or left of B's left edge)"),
    RelationCode("right_of", "right_of", "A lies entirely right of B"),
    RelationCode("above", "above", "A lies entirely above B in the image"),
    RelationCode("below", "below", "A lies entirely below B in the image"),
    RelationCode("in_front_of", "in_front_of", "A's bottom edge is lower in the image than B's: on a ground plane, "
                 "A is nearer the camera"),
    RelationCode("behind", "behind", "B's bottom edge is lower in the image than A's: A is further from the camera"),
    RelationCode("near", "near", "the centres are closer than the mean of the two box diagonals"),
    RelationCode("far", "far", "the centres are further apart than 3 x the mean of the two box diagonals"),
)
"""Every code a frame listing prints for a pair of boxes, the one table of them: the listings
(refimpl.scene.queries.frame_relations) spell RCC-8 by these codes and the report's legend is
made from it.  Pairs with neither near nor far are between the two."""

RCC8_CODE = {r.relation: r.code for r in RELATION_CODES if r.relation in TOPOLOGY_RELATIONS}
"""topology()'s answer -> its short code (disconnected -> dc, ...)."""


def _edges(b: BoxLike) -> tuple[float, float, float, float]:
    x, y, w, h = b
    return x, y, x + w, y + h


def _region(b: BoxLike) -> tuple[float, float, float, float]:
    x1, y1, x2, y2 = _edges(b)
    if not (x2 > x1 and y2 > y1):
        raise ValueError(f"topology needs a box with w > 0 and h > 0 (a region), got {tuple(b)}")
    return x1, y1, x2, y2


def topology(box_a: BoxLike, box_b: BoxLike) -> str:
    """RCC-8 relation of box a to box b as closed regions (touching edges or corners = externally_connected)."""
    ax1, ay1, ax2, ay2 = _region(box_a)
    bx1, by1, bx2, by2 = _region(box_b)
    ix = min(ax2, bx2) - max(ax1, bx1)  # overlap of the x extents (< 0: gap, 0: touch)
    iy = min(ay2, by2) - max(ay1, by1)
    if ix < 0 or iy < 0:
        return "disconnected"
    if ix == 0 or iy == 0:
        return "externally_connected"
    if (ax1, ay1, ax2, ay2) == (bx1, by1, bx2, by2):
        return "equal"
    if bx1 <= ax1 and ax2 <= bx2 and by1 <= ay1 and ay2 <= by2:
        touches = ax1 == bx1 or ax2 == bx2 or ay1 == by1 or ay2 == by2
        return "tangential_proper_part" if touches else "non_tangential_proper_part"
    if ax1 <= bx1 and bx2 <= ax2 and ay1 <= by1 and by2 <= ay2:
        touches = ax1 == bx1 or ax2 == bx2 or ay1 == by1 or ay2 == by2
        return "tangential_proper_part_inverse" if touches else "non_tangential_proper_part_inverse"
    return "partially_overlapping"


def proper_part(a: BoxLike, b: BoxLike) -> bool:
    """topology(proper_part, a, b): a lies inside b and differs from it (tpp or ntpp)."""
    return topology(a, b) in ("tangential_proper_part", "non_tangential_proper_part")


def part_of(a: BoxLike, b: BoxLike) -> bool:
    """RCC part of (p): a lies inside b (proper part or equal)."""
    return proper_part(a, b) or topology(a, b) == "equal"


def overlap(a: BoxLike, b: BoxLike) -> bool:
    """RCC overlap (o): the interiors share area (po, tpp, ntpp, their inverses, equal)."""
    return topology(a, b) not in ("disconnected", "externally_connected")


def discrete(a: BoxLike, b: BoxLike) -> bool:
    """RCC discrete (dr): the interiors are disjoint (dc or ec)."""
    return not overlap(a, b)


def contact(a: BoxLike, b: BoxLike) -> bool:
    """RCC contact (c): the closed boxes share at least one point (anything but dc)."""
    return topology(a, b) != "disconnected"


def coverage(a: BoxLike, b: BoxLike) -> float:
    """Share of a's area that b covers, in [0, 1] (0.0 for a box of zero area)."""
    a_area = a[2] * a[3]
    return intersection_area(a, b) / a_area if a_area > 0 else 0.0


# ---------------------------------------------------------------------------------------------
# Orientation in the image and the depth cue
# ---------------------------------------------------------------------------------------------


def orientation(a: BoxLike, b: BoxLike) -> set[str]:
    """Image orientation of a w.r.t. b among left_of, right_of, above, below, by box extents; touching counts."""
    # a is left_of b when a's right edge is at or left of b's left edge (ax2 <= bx1): boxes that
    # share an edge share no pixel, so a is entirely to the left.  Diagonal placements give two
    # relations (e.g. {left_of, above}); boxes whose extents overlap on both axes give the empty set.
    ax1, ay1, ax2, ay2 = _edges(a)
    bx1, by1, bx2, by2 = _edges(b)
    out = set()
    if ax2 <= bx1:
        out.add("left_of")
    if bx2 <= ax1:
        out.add("right_of")
    if ay2 <= by1:
        out.add("above")
    if by2 <= ay1:
        out.add("below")
    return out


def in_front_of(a: BoxLike, b: BoxLike) -> bool:
    """Depth cue: a is nearer the camera than b when a's bottom edge is strictly lower in the image."""
    # Under a ground-plane view (camera above the road, objects standing on it) the contact point
    # with the ground of a nearer object projects lower in the image.  This is the cue of
    # overlapping_top: there "b2 is not behind b1" is exactly `not in_front_of(b1, b2)`.
    # Equal bottom edges: neither is in front.  No overlap of the boxes is required.
    return a[1] + a[3] > b[1] + b[3]


# ---------------------------------------------------------------------------------------------
# Distance and size
# ---------------------------------------------------------------------------------------------


def centre(b: BoxLike) -> tuple[float, float]:
    """Centre point (x + w/2, y + h/2) of a box."""
    return b[0] + b[2] / 2, b[1] + b[3] / 2


def diagonal(b: BoxLike) -> float:
    """Length of the box diagonal sqrt(w^2 + h^2)."""
    return math.hypot(b[2], b[3])


def centre_distance(a: BoxLike, b: BoxLike) -> float:
    """Euclidean distance between the box centres (px)."""
    (ax, ay), (bx, by) = centre(a), centre(b)
    return math.hypot(ax - bx, ay - by)


def _scale(a: BoxLike, b: BoxLike) -> float:
    return (diagonal(a) + diagonal(b)) / 2


def near(a: BoxLike, b: BoxLike, factor: float = 1.0) -> bool:
    """Centre distance strictly below factor x the mean of the two box diagonals (scale-invariant)."""
    return centre_distance(a, b) < factor * _scale(a, b)


def far(a: BoxLike, b: BoxLike, factor: float = 3.0) -> bool:
    """Centre distance strictly above factor x the mean of the two box diagonals (between near and far: neither)."""
    return centre_distance(a, b) > factor * _scale(a, b)


def size_relation(a: BoxLike, b: BoxLike, tolerance: float = 0.1) -> str:
    """smaller / larger / same_size of a w.r.t. b by area; same_size when |A_a - A_b| <= tolerance x max(A_a, A_b)."""
    area_a, area_b = a[2] * a[3], b[2] * b[3]
    if abs(area_a - area_b) <= tolerance * max(area_a, area_b):
        return "same_size"
    return "smaller" if area_a < area_b else "larger"


# ---------------------------------------------------------------------------------------------
# Motion between two time points
# ---------------------------------------------------------------------------------------------


def motion(a0: BoxLike, a1: BoxLike, eps: float = 1.0) -> set[str]:
    """Single-object motion from a0 (t0) to a1 (t1): moving_left/right/up/down or stationary, growing/shrinking."""
    # Direction from the centre displacement per axis, beyond eps px (image y down: +dy = moving_down).
    # stationary = no moving_* label: it is about position only, so a box that stays in place while
    # it grows (an object coming straight at the camera) is {stationary, growing}.
    # Size from the change of the mean side length sqrt(w h) (px, comparable with eps):
    # growing when it increases by more than eps, shrinking when it decreases by more than eps.
    (x0, y0), (x1, y1) = centre(a0), centre(a1)
    dx, dy = x1 - x0, y1 - y0
    out = set()
    if dx > eps:
        out.add("moving_right")
    elif dx < -eps:
        out.add("moving_left")
    if dy > eps:
        out.add("moving_down")
    elif dy < -eps:
        out.add("moving_up")
    if not out:
        out.add("stationary")
    ds = math.sqrt(a1[2] * a1[3]) - math.sqrt(a0[2] * a0[3])
    if ds > eps:
        out.add("growing")
    elif ds < -eps:
        out.add("shrinking")
    return out


def movement(a0: BoxLike, a1: BoxLike, b0: BoxLike, b1: BoxLike, eps: float = 1.0) -> set[str]:
    """Relative motion of a w.r.t. b from t0 to t1: moving_towards, moving_away, moving_parallel, approaching."""
    # d0, d1 = centre distance at t0, t1.
    #   moving_towards:  d1 < d0 - eps (the gap shrinks; symmetric in a and b)
    #   moving_away:     d1 > d0 + eps (the gap grows; symmetric)
    #   moving_parallel: both centres move by more than eps and their displacements differ by at
    #                    most eps (same direction, same speed; the gap stays, symmetric)
    #   approaching:     a is the one closing the gap (asymmetric): moving_towards, and a's own
    #                    displacement (b held at t0) brings it closer than d0 - eps, and b's own
    #                    displacement (a held at t0) does not take b further than d0 + eps, i.e. b is
    #                    not moving away from a.  Two objects heading for each other both approach.
    d0 = centre_distance(a0, b0)
    d1 = centre_distance(a1, b1)
    out = set()
    if d1 < d0 - eps:
        out.add("moving_towards")
        if centre_distance(a1, b0) < d0 - eps and centre_distance(a0, b1) <= d0 + eps:
            out.add("approaching")
    elif d1 > d0 + eps:
        out.add("moving_away")
    (ax0, ay0), (ax1, ay1) = centre(a0), centre(a1)
    (bx0, by0), (bx1, by1) = centre(b0), centre(b1)
    da = (ax1 - ax0, ay1 - ay0)
    db = (bx1 - bx0, by1 - by0)
    if math.hypot(*da) > eps and math.hypot(*db) > eps and math.hypot(da[0] - db[0], da[1] - db[1]) <= eps:
        out.add("moving_parallel")
    return out


def first_time_moves_out_of(
    a_boxes: Mapping[int, BoxLike], b_boxes: Mapping[int, BoxLike], covered_share: float = 0.5
) -> int | None:
    """movement(moves_out_of, a, b, T): first time T (in both dicts) at which b covers less than covered_share of a."""
    # For the anticipation rule: a is hidden by b now (topology(proper_part, a, b)), a_boxes and
    # b_boxes are their predicted boxes at future times.  a counts as still behind b while
    # coverage(a, b) >= covered_share; the answer is the earliest common time with coverage below it
    # (also when that is the earliest time given: a left b between now and then).  covered_share=1.0
    # gives "a is no longer part of b".  Times in only one dict are skipped; None = never out.
    for t in sorted(set(a_boxes) & set(b_boxes)):
        if coverage(a_boxes[t], b_boxes[t]) < covered_share:
            return t
    return None


# ---------------------------------------------------------------------------------------------
# Time
# ---------------------------------------------------------------------------------------------


def interval_relation(i: tuple[int, int], j: tuple[int, int], inclusive: bool = True) -> str:
    """Allen relation of time interval i to j; inclusive=True reads (first, last) frames as [first, last + 1)."""
    # Track intervals are sets of frames: with inclusive=True a track on frames 0..9 and one on
    # 10..19 meet (no frame between them, none shared), tracks sharing frame 10 overlap, and a
    # single-frame track (5, 5) is the proper interval [5, 6).  inclusive=False reads (s, e) as the
    # continuous interval [s, e] (then (0, 10) meets (10, 20)).
    (s1, e1), (s2, e2) = i, j
    if inclusive:
        e1, e2 = e1 + 1, e2 + 1
    return allen(s1, e1, s2, e2)
