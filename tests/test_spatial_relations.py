"""Commonsense relations of Table 2 on boxes (refimpl.knowledge.relations), on hand-made boxes and properties."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from refimpl.knowledge.relations import (
    ALLEN_CONVERSE,
    ALLEN_RELATIONS,
    TOPOLOGY_CONVERSE,
    TOPOLOGY_RELATIONS,
    allen,
    area,
    centre_distance,
    contact,
    coverage,
    discrete,
    far,
    first_time_moves_out_of,
    in_front_of,
    interval_relation,
    motion,
    movement,
    near,
    near_border,
    orientation,
    overlap,
    overlapped_from_the_top,
    overlapping_top,
    part_of,
    proper_part,
    rectangle_relation,
    size_relation,
    topology,
)

# ---------------------------------------------------------------------------------------------
# Allen
# ---------------------------------------------------------------------------------------------

ALLEN_CASES = [
    # (a, b, expected, derivation)
    ((0, 5), (10, 20), "before", "a2=5 < b1=10"),
    ((10, 20), (0, 5), "after", "b2=5 < a1=10"),
    ((0, 10), (10, 20), "meets", "a2 == b1 == 10"),
    ((10, 20), (0, 10), "met_by", "b2 == a1 == 10"),
    ((0, 10), (5, 20), "overlaps", "a1=0 < b1=5 < a2=10 < b2=20"),
    ((5, 20), (0, 10), "overlapped_by", "b1=0 < a1=5 < b2=10 < a2=20"),
    ((0, 5), (0, 10), "starts", "a1 == b1 == 0, a2=5 < b2=10"),
    ((0, 10), (0, 5), "started_by", "a1 == b1 == 0, a2=10 > b2=5"),
    ((3, 7), (0, 10), "during", "b1=0 < a1=3, a2=7 < b2=10"),
    ((0, 10), (3, 7), "contains", "a1=0 < b1=3, b2=7 < a2=10"),
    ((5, 10), (0, 10), "finishes", "a2 == b2 == 10, a1=5 > b1=0"),
    ((0, 10), (5, 10), "finished_by", "a2 == b2 == 10, a1=0 < b1=5"),
    ((2, 8), (2, 8), "equals", "same endpoints"),
]


@pytest.mark.parametrize("a, b, expected, why", ALLEN_CASES, ids=[c[2] for c in ALLEN_CASES])
def test_allen_each_relation(a, b, expected, why):
    assert allen(*a, *b) == expected, why


def test_allen_cases_cover_all_thirteen():
    assert sorted(c[2] for c in ALLEN_CASES) == sorted(ALLEN_RELATIONS)
    assert len(set(ALLEN_RELATIONS)) == 13


def test_allen_rejects_reversed_interval():
    with pytest.raises(ValueError):
        allen(5, 0, 0, 1)


def _allen_predicates(a1, a2, b1, b2):
    """Allen's endpoint definitions, written independently of refimpl.knowledge.relations.allen."""
    return {
        "before": a2 < b1,
        "after": b2 < a1,
        "meets": a2 == b1,
        "met_by": b2 == a1,
        "overlaps": a1 < b1 < a2 < b2,
        "overlapped_by": b1 < a1 < b2 < a2,
        "starts": a1 == b1 and a2 < b2,
        "started_by": a1 == b1 and b2 < a2,
        "during": b1 < a1 and a2 < b2,
        "contains": a1 < b1 and b2 < a2,
        "finishes": a2 == b2 and b1 < a1,
        "finished_by": a2 == b2 and a1 < b1,
        "equals": a1 == b1 and a2 == b2,
    }


proper_interval = st.tuples(st.integers(-6, 6), st.integers(1, 6)).map(lambda p: (p[0], p[0] + p[1]))


@settings(max_examples=400, deadline=None)
@given(proper_interval, proper_interval)
def test_allen_exactly_one_relation_holds_and_converse(a, b):
    holding = [r for r, ok in _allen_predicates(*a, *b).items() if ok]
    assert len(holding) == 1
    assert allen(*a, *b) == holding[0]
    assert allen(*b, *a) == ALLEN_CONVERSE[allen(*a, *b)]


@settings(max_examples=200, deadline=None)
@given(st.tuples(st.integers(-4, 4), st.integers(0, 3)), st.tuples(st.integers(-4, 4), st.integers(0, 3)))
def test_allen_converse_also_for_point_intervals(p, q):
    a, b = (p[0], p[0] + p[1]), (q[0], q[0] + q[1])
    assert allen(*b, *a) == ALLEN_CONVERSE[allen(*a, *b)]


def test_rectangle_relation():
    # a x: [0,10], y: [0,10]; b x: [10,30], y: [5,8]
    # x: a2 == b1 -> meets; y: b1=5 > a1=0, b2=8 < a2=10 -> contains
    assert rectangle_relation((0, 0, 10, 10), (10, 5, 20, 3)) == ("meets", "contains")
    # y "before" is above in the image: a y [0,4], b y [10,20]
    assert rectangle_relation((0, 0, 4, 4), (0, 10, 4, 10)) == ("equals", "before")


# ---------------------------------------------------------------------------------------------
# Topology
# ---------------------------------------------------------------------------------------------

B = (0, 0, 10, 10)  # x [0,10], y [0,10]
TOPOLOGY_CASES = [
    ((20, 0, 5, 5), "disconnected", "x [20,25] after [0,10]: gap"),
    ((10, 10, 5, 5), "externally_connected", "touches B only at corner (10,10)"),
    ((10, 2, 5, 5), "externally_connected", "x [10,15] meets B's right edge, y inside"),
    ((5, 5, 10, 10), "partially_overlapping", "overlap [5,10]x[5,10], neither inside the other"),
    ((0, 2, 5, 5), "tangential_proper_part", "inside B, left edges coincide at x=0"),
    ((2, 2, 5, 5), "non_tangential_proper_part", "x [2,7], y [2,7] strictly inside [0,10]"),
    ((0, 0, 20, 10), "tangential_proper_part_inverse", "contains B, shares top/left/bottom edges"),
    ((-5, -5, 20, 20), "non_tangential_proper_part_inverse", "[-5,15]^2 strictly contains [0,10]^2"),
    ((0, 0, 10, 10), "equal", "same box"),
]


@pytest.mark.parametrize("a, expected, why", TOPOLOGY_CASES, ids=[c[1] + str(i) for i, c in enumerate(TOPOLOGY_CASES)])
def test_topology_each_relation(a, expected, why):
    assert topology(a, B) == expected, why
    assert topology(B, a) == TOPOLOGY_CONVERSE[expected]


def test_topology_cases_cover_all_eight():
    assert {c[1] for c in TOPOLOGY_CASES} == set(TOPOLOGY_RELATIONS)
    assert len(TOPOLOGY_RELATIONS) == 8


def test_topology_needs_regions():
    with pytest.raises(ValueError):
        topology((0, 0, 0, 5), B)


def test_derived_mereology():
    inner, tangent, po, ec, dc = (2, 2, 5, 5), (0, 2, 5, 5), (5, 5, 10, 10), (10, 2, 5, 5), (20, 0, 5, 5)
    assert proper_part(inner, B) and proper_part(tangent, B)
    assert not proper_part(B, B) and part_of(B, B) and not proper_part(B, inner)
    assert overlap(po, B) and not overlap(ec, B) and discrete(ec, B) and discrete(dc, B)
    assert contact(ec, B) and not contact(dc, B)
    # po: overlap [5,10]x[5,10] = 25 of a's 100 px^2
    assert coverage(po, B) == 0.25 and coverage(inner, B) == 1.0 and coverage(dc, B) == 0.0


box_strategy = st.tuples(st.integers(-5, 5), st.integers(-5, 5), st.integers(1, 6), st.integers(1, 6))


def _topology_from_rectangle_algebra(rx, ry):
    """RCC-8 from the pair of Allen relations (an independent derivation)."""
    inside = {"starts", "during", "finishes", "equals"}
    contains = {"started_by", "contains", "finished_by", "equals"}
    if rx in ("before", "after") or ry in ("before", "after"):
        return "disconnected"
    if rx in ("meets", "met_by") or ry in ("meets", "met_by"):
        return "externally_connected"
    if rx == ry == "equals":
        return "equal"
    if rx in inside and ry in inside:
        return "non_tangential_proper_part" if rx == ry == "during" else "tangential_proper_part"
    if rx in contains and ry in contains:
        return "non_tangential_proper_part_inverse" if rx == ry == "contains" else "tangential_proper_part_inverse"
    return "partially_overlapping"


@settings(max_examples=400, deadline=None)
@given(box_strategy, box_strategy)
def test_topology_converse_and_rectangle_algebra(a, b):
    assert topology(b, a) == TOPOLOGY_CONVERSE[topology(a, b)]
    assert topology(a, b) == _topology_from_rectangle_algebra(*rectangle_relation(a, b))


# ---------------------------------------------------------------------------------------------
# Orientation and depth
# ---------------------------------------------------------------------------------------------


def test_orientation():
    # a x [0,10], b x [10,20]: a's right edge == b's left edge -> touching counts: left_of
    assert orientation((0, 0, 10, 10), (10, 0, 10, 10)) == {"left_of"}
    assert orientation((10, 0, 10, 10), (0, 0, 10, 10)) == {"right_of"}
    # a y [0,5], b y [20,30], x extents overlap -> above only
    assert orientation((0, 0, 10, 5), (5, 20, 10, 10)) == {"above"}
    assert orientation((5, 20, 10, 10), (0, 0, 10, 5)) == {"below"}
    # diagonal: a x [0,5] y [0,5], b x [10,15] y [10,15] -> left_of and above
    assert orientation((0, 0, 5, 5), (10, 10, 5, 5)) == {"left_of", "above"}
    # overlapping on both axes -> no orientation
    assert orientation((0, 0, 10, 10), (5, 5, 10, 10)) == set()


@settings(max_examples=200, deadline=None)
@given(box_strategy, box_strategy)
def test_orientation_converse(a, b):
    conv = {"left_of": "right_of", "right_of": "left_of", "above": "below", "below": "above"}
    assert orientation(b, a) == {conv[r] for r in orientation(a, b)}
    assert not (in_front_of(a, b) and in_front_of(b, a))


def test_in_front_of_by_bottom_edge():
    car_near = (100, 300, 80, 60)  # bottom edge y = 360
    car_far = (120, 250, 40, 30)  # bottom edge y = 280, higher in the image -> further away
    assert in_front_of(car_near, car_far) and not in_front_of(car_far, car_near)
    # equal bottom edges (y 10+20 = 0+30 = 30): neither is in front
    assert not in_front_of((0, 10, 5, 20), (50, 0, 5, 30)) and not in_front_of((50, 0, 5, 30), (0, 10, 5, 20))


def test_in_front_of_is_the_overlapping_top_depth_cue():
    hidden = (10, 10, 10, 10)  # 100 px^2, bottom y = 20
    occluder_behind = (10, 5, 10, 10)  # covers y [10,15] = 50 px^2, bottom 15 < 20: behind
    occluder_front = (10, 15, 10, 10)  # covers y [15,20] = 50 px^2, bottom 25 > 20: in front
    assert in_front_of(hidden, occluder_behind) and not overlapping_top(hidden, occluder_behind, 10)
    assert not in_front_of(hidden, occluder_front) and overlapping_top(hidden, occluder_front, 10)


# ---------------------------------------------------------------------------------------------
# Distance and size
# ---------------------------------------------------------------------------------------------


def test_centre_distance_near_far():
    a = (0, 0, 6, 8)  # centre (3, 4), diagonal 10
    b = (6, 8, 6, 8)  # centre (9, 12), diagonal 10
    # distance sqrt(6^2 + 8^2) = 10; mean diagonal 10 -> not near (strict <) at factor 1
    assert centre_distance(a, b) == 10.0
    assert not near(a, b) and near(a, b, factor=1.01)
    assert not far(a, b)  # 10 < 3 x 10
    c = (30, 40, 6, 8)  # centre (33, 44): distance to a = sqrt(30^2 + 40^2) = 50 > 30 -> far
    assert centre_distance(a, c) == 50.0 and far(a, c) and not far(a, c, factor=5.0)
    # between near and far: neither
    d = (12, 16, 6, 8)  # centre (15, 20): distance 20, 10 <= 20 <= 30
    assert not near(a, d) and not far(a, d)


def test_size_relation():
    # 10x10 = 100 vs 10x11 = 110: |diff| 10 <= 0.1 x 110 = 11 -> same_size
    assert size_relation((0, 0, 10, 10), (0, 0, 10, 11)) == "same_size"
    # 100 vs 10x12 = 120: 20 > 12 -> smaller / larger
    assert size_relation((0, 0, 10, 10), (0, 0, 10, 12)) == "smaller"
    assert size_relation((0, 0, 10, 12), (0, 0, 10, 10)) == "larger"
    assert size_relation((0, 0, 10, 10), (0, 0, 10, 12), tolerance=0.2) == "same_size"


# ---------------------------------------------------------------------------------------------
# Motion
# ---------------------------------------------------------------------------------------------


def test_motion_single_object():
    a0 = (100, 100, 20, 20)  # centre (110, 110)
    # centre +5 in x, -3 in y (up in the image), same size
    assert motion(a0, (105, 97, 20, 20), eps=1.0) == {"moving_right", "moving_up"}
    assert motion(a0, (95, 103, 20, 20), eps=1.0) == {"moving_left", "moving_down"}
    # same centre, side 20 -> 30: sqrt(area) grows by 10 > 1 -> stationary and growing
    assert motion(a0, (95, 95, 30, 30), eps=1.0) == {"stationary", "growing"}
    # same centre, side 20 -> 10: shrinking
    assert motion(a0, (105, 105, 10, 10), eps=1.0) == {"stationary", "shrinking"}
    # a 1 px move is within eps=1 (strict >): stationary
    assert motion(a0, (101, 100, 20, 20), eps=1.0) == {"stationary"}


def test_movement_towards_away_approaching():
    a0, b0 = (0, 0, 10, 10), (100, 0, 10, 10)  # centres 5 and 105: d0 = 100
    # a moves 10 right, b stays: d1 = 90 -> towards; a's own move closes, b not moving away -> approaching
    m = movement(a0, (10, 0, 10, 10), b0, b0)
    assert m == {"moving_towards", "approaching"}
    # the converse view: b is the one being approached, it does not approach
    assert movement(b0, b0, a0, (10, 0, 10, 10)) == {"moving_towards"}
    # a moves 20 right, b flees 5 right: d1 = 85 -> towards, but b moves away from a -> not approaching
    assert movement(a0, (20, 0, 10, 10), b0, (105, 0, 10, 10)) == {"moving_towards"}
    # both heading for each other (10 each): both approach
    assert "approaching" in movement(a0, (10, 0, 10, 10), b0, (90, 0, 10, 10))
    assert "approaching" in movement(b0, (90, 0, 10, 10), a0, (10, 0, 10, 10))
    # a moves 10 left: d1 = 110 -> away
    assert movement(a0, (-10, 0, 10, 10), b0, b0) == {"moving_away"}
    # both move 7 down: d unchanged, same displacement -> parallel
    assert movement(a0, (0, 7, 10, 10), b0, (100, 7, 10, 10)) == {"moving_parallel"}
    # nothing moves: empty set
    assert movement(a0, a0, b0, b0) == set()


def test_first_time_moves_out_of_constructed_occlusion():
    # occluder b static: x [100,200], y [0,50]; hidden a: 40x30 at y 10 (inside b's y extent),
    # at frame 180 + k its x is 120 + 5k (moving right at 5 px/frame).
    # covered width = min(160 + 5k, 200) - max(120 + 5k, 100):
    #   k <= 8: 40 (a inside b; k = 8 -> a x [160,200] touches b's right edge: tangential proper part)
    #   k > 8:  200 - 120 - 5k = 80 - 5k -> share (80 - 5k) / 40
    #   k = 12: 20/40 = 0.5 exactly -> still covered by half (not below 0.5)
    #   k = 13: 15/40 = 0.375 < 0.5 -> first frame below half: 180 + 13 = 193
    b = (100, 0, 100, 50)
    a_boxes = {180 + k: (120 + 5 * k, 10, 40, 30) for k in range(25)}
    b_boxes = {t: b for t in a_boxes}
    assert coverage(a_boxes[192], b) == 0.5 and coverage(a_boxes[193], b) == 0.375
    assert first_time_moves_out_of(a_boxes, b_boxes) == 193
    # covered_share = 1.0: out as soon as not fully covered, k = 9 (share 35/40) -> 189
    assert first_time_moves_out_of(a_boxes, b_boxes, covered_share=1.0) == 189
    assert proper_part(a_boxes[188], b) and not part_of(a_boxes[189], b)
    # times only in one dict are skipped; never out -> None
    assert first_time_moves_out_of({k: a_boxes[k] for k in range(180, 189)}, b_boxes) is None
    assert first_time_moves_out_of(a_boxes, {t: b for t in range(180, 190)}) is None


# ---------------------------------------------------------------------------------------------
# Time
# ---------------------------------------------------------------------------------------------


def test_interval_relation_on_frames():
    # inclusive frames: (0,9) -> [0,10), (10,19) -> [10,20): meets (no gap frame, none shared)
    assert interval_relation((0, 9), (10, 19)) == "meets"
    # sharing frame 10: [0,11) vs [10,20) -> overlaps
    assert interval_relation((0, 10), (10, 19)) == "overlaps"
    # continuous reading: [0,10] vs [10,20] -> meets
    assert interval_relation((0, 10), (10, 20), inclusive=False) == "meets"
    # single-frame track at 5 inside 0..9: [5,6) during [0,10)
    assert interval_relation((5, 5), (0, 9)) == "during"
    # (0,4) vs (0,9): [0,5) starts [0,10); (12,15) after (0,9)
    assert interval_relation((0, 4), (0, 9)) == "starts"
    assert interval_relation((12, 15), (0, 9)) == "after"


# ---------------------------------------------------------------------------------------------
# The model's integer relations (unchanged)
# ---------------------------------------------------------------------------------------------


def test_overlapping_top_hand_computed():
    b1 = (0, 0, 10, 10)  # 100 px^2, bottom 10
    b2 = (0, 9, 10, 10)  # covers y [9,10] = 10 px^2 = 10 %; bottom 19 >= 10
    assert not overlapping_top(b1, b2, 10)  # 100*10 = 1000 > 10*100 = 1000? no (strict)
    assert overlapping_top(b1, b2, 9)  # 1000 > 900
    b3 = (0, -5, 10, 15)  # covers y [0,10] = 100 %, but bottom 10 >= 10 (equal counts as not behind)
    assert overlapping_top(b1, b3, 10)
    b4 = (0, -5, 10, 14)  # bottom 9 < 10: behind b1 -> False despite 90 % cover
    assert not overlapping_top(b1, b4, 10)


def test_overlapped_from_the_top_hand_computed():
    b1 = (0, 0, 10, 10)
    # the b2 .. b4 of the test above: only b3 (and b2 at 9 %) covers b1 from the top
    assert not overlapped_from_the_top(b1, [("b2", (0, 9, 10, 10)), ("b4", (0, -5, 10, 14))], 10)
    assert overlapped_from_the_top(b1, [("b2", (0, 9, 10, 10)), ("b4", (0, -5, 10, 14))], 9)
    assert overlapped_from_the_top(b1, [("b4", (0, -5, 10, 14)), ("b3", (0, -5, 10, 15))], 10)
    # the box itself covers itself from the top (100 % > 10 %, bottom equal): skipped by its key
    assert overlapped_from_the_top(b1, [("t1", b1)], 10)
    assert not overlapped_from_the_top(b1, [("t1", b1)], 10, skip="t1")
    # sharing only an edge (x + w == x'): no pixel in common, so not even at hide_overlap 0
    assert not overlapped_from_the_top(b1, [("e", (10, 0, 10, 10))], 0)
    assert overlapped_from_the_top(b1, [("p", (9, 0, 10, 10))], 0)  # one column: 10 px^2 > 0
    assert not overlapped_from_the_top(b1, [], 0)


_int_box = st.tuples(st.integers(-20, 40), st.integers(-20, 40), st.integers(1, 30), st.integers(1, 30))


@settings(max_examples=400, deadline=None)
@given(_int_box, st.lists(st.tuples(st.sampled_from("abcd"), _int_box), max_size=6),
       st.integers(0, 120), st.sampled_from([None, "a", "b"]))
def test_overlapped_from_the_top_is_any_overlapping_top(b1, others, hide_overlap, skip):
    # the cheaper loop kept_in_mind asks of every track must be the relation itself, pair by pair
    expected = any(key != skip and overlapping_top(b1, b2, hide_overlap) for key, b2 in others)
    assert overlapped_from_the_top(b1, others, hide_overlap, skip=skip) is expected


def test_near_border_hand_computed():
    # image 100x50, margin 5
    assert near_border((5, 20, 10, 10), 100, 50, 5)  # x = 5 <= 5
    assert not near_border((6, 20, 10, 10), 100, 50, 5)  # x 6, y 20, right 16, bottom 30: inside
    assert near_border((80, 20, 15, 10), 100, 50, 5)  # right 95 >= 100 - 5
    assert near_border((50, 30, 10, 15), 100, 50, 5)  # bottom 45 >= 50 - 5
    assert not near_border((80, 20, 15, 10), 0, 0, 5)  # size unknown: only the top/left borders
    assert near_border((-3, 20, 10, 10), 0, 0, 5)  # beyond the left border


def test_area():
    assert area((3, 4, 7, 6)) == 42
    assert math.isclose(area((0, 0, 2.5, 4)), 10.0)
