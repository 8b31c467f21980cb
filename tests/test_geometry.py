"""Boxes and the integer IoU scale (refimpl.core.geometry)."""

from __future__ import annotations

import numpy as np

from refimpl.core.geometry import intersection_area, integer_box, iou_matrix, scale_iou, xywh_to_xyxy


def test_iou_of_hand_computed_boxes():
    a = np.array([[0, 0, 10, 10]])
    b = np.array([[5, 5, 10, 10], [0, 0, 10, 10], [20, 20, 5, 5], [0, 0, 10, 5]])
    iou = iou_matrix(a, b)
    # overlap 5x5=25, union 100+100-25=175 -> 25/175; identical -> 1; disjoint -> 0; half -> 50/100
    np.testing.assert_allclose(iou[0], [25 / 175, 1.0, 0.0, 0.5])


def test_iou_matrix_shape_and_empty_inputs():
    assert iou_matrix(np.zeros((3, 4)) + [0, 0, 1, 1], np.zeros((0, 4))).shape == (3, 0)
    assert iou_matrix(np.zeros((0, 4)), np.zeros((2, 4)) + [0, 0, 1, 1]).shape == (0, 2)


def test_iou_scale_rounds_half_up_to_integers():
    # 25/175 = 0.142857.. -> 14285.7 -> 14286; 0.346245 -> 34624.5 -> 34625 (half up, not to even)
    assert scale_iou(np.array([25 / 175, 0.346245, 1.0, 0.0])).tolist() == [14286, 34625, 100000, 0]


def test_integer_iou_of_the_papers_bus_frame_boxes():
    # trk_13 (904,473,181,108) vs det_1 (8,305,992,333): overlap x 904..1000=96, y 473..581=108
    # inter 96*108=10368; union 181*108 + 992*333 - 10368 = 19548 + 330336 - 10368 = 339516
    iou = iou_matrix(np.array([[904, 473, 181, 108]]), np.array([[8, 305, 992, 333]]))
    assert scale_iou(iou)[0, 0] == int(10368 / 339516 * 100000 + 0.5) == 3054


def test_a_box_corner_is_its_origin_plus_its_size():
    # (x, y, w, h) -> (x, y, x + w, y + h): 1.5 + 3 = 4.5, 2 + 4 = 6; -10 + 20 = 10, 5 + 1 = 6
    boxes = np.array([[1.5, 2.0, 3.0, 4.0], [-10, 5, 20, 1]])
    assert xywh_to_xyxy(boxes).tolist() == [[1.5, 2.0, 4.5, 6.0], [-10, 5, 10, 6]]


def test_integer_box_rounds_and_keeps_size_positive():
    assert integer_box(np.array([1.5, -2.5, 10.4, 0.2])) == (2, -2, 10, 1)


def test_intersection_area_of_integer_boxes():
    assert intersection_area((0, 0, 10, 10), (5, 5, 10, 10)) == 25
    assert intersection_area((0, 0, 10, 10), (10, 0, 5, 5)) == 0  # touching edges do not overlap
