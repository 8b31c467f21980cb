"""The SORT motion model: box <-> observation conversion, one predict/update step by hand, guards."""

from __future__ import annotations

import numpy as np
import pytest

from refimpl.tracking.motion import (
    BoxKalman,
    InvalidPrediction,
    initial_covariance,
    measurement_noise,
    process_noise,
    transition_matrix,
    xywh_to_z,
)

BOX = np.array([10.0, 20.0, 30.0, 60.0])
# centre u = 10 + 30/2 = 25, v = 20 + 60/2 = 50; area s = 30 * 60 = 1800; aspect r = 30/60 = 0.5
Z = np.array([25.0, 50.0, 1800.0, 0.5])


def test_xywh_to_z_gives_centre_area_and_aspect_ratio():
    np.testing.assert_allclose(xywh_to_z(BOX), Z)


def test_the_state_of_a_box_reads_back_as_that_box():
    # the filter starts at z = Z: w = sqrt(s * r) = sqrt(900) = 30, h = s / w = 60, x = u - w/2 = 10,
    # y = v - h/2 = 20; the velocities (3, -2, 7 here) do not enter the box
    k = BoxKalman(BOX)
    np.testing.assert_allclose(k.box, BOX)
    k.kf.x[4:, 0] = [3.0, -2.0, 7.0]
    np.testing.assert_allclose(k.box, BOX)


def test_xywh_to_z_rejects_boxes_without_area():
    for bad in ([0, 0, 0, 10], [0, 0, 10, -1], [np.nan, 0, 10, 10]):
        with pytest.raises(ValueError):
            xywh_to_z(bad)


def test_published_noise_matrices_are_diagonal_with_sort_values():
    # SORT: P = I; P[velocities] *= 1000; P *= 10 -> 10 on u, v, s, r and 10000 on du, dv, ds
    np.testing.assert_array_equal(np.diag(initial_covariance()), [10, 10, 10, 10, 1e4, 1e4, 1e4])
    # R = I; R[s, r] *= 10
    np.testing.assert_array_equal(np.diag(measurement_noise()), [1, 1, 10, 10])
    # Q = I; Q[ds] *= 0.01; Q[velocities] *= 0.01 -> ds gets 0.01 * 0.01
    np.testing.assert_allclose(np.diag(process_noise()), [1, 1, 1, 1, 0.01, 0.01, 1e-4])
    for m in (initial_covariance(), measurement_noise(), process_noise()):
        assert np.count_nonzero(m - np.diag(np.diag(m))) == 0


def test_new_track_starts_at_the_detection_with_zero_velocity_and_zero_counters():
    k = BoxKalman(BOX)
    np.testing.assert_allclose(k.state, np.concatenate([Z, [0, 0, 0]]))
    np.testing.assert_allclose(k.box, BOX)
    np.testing.assert_array_equal(k.velocity, [0.0, 0.0])
    assert (k.age, k.hits, k.hit_streak, k.time_since_update) == (0, 0, 0, 0)


def test_first_predict_keeps_the_box_and_inflates_covariance_by_F_P_Ft_plus_Q():
    k = BoxKalman(BOX)
    predicted = k.predict()
    # velocity 0: the centre moves by 0, the area by 0 -> same box
    np.testing.assert_allclose(predicted, BOX)
    P = k.covariance
    # P' = F P0 F^T + Q with F[0,4] = F[1,5] = F[2,6] = 1, P0 = diag(10,10,10,10,1e4,1e4,1e4):
    #   P'[0,0] = P0[0,0] + 2 P0[0,4] + P0[4,4] + Q[0,0] = 10 + 0 + 10000 + 1 = 10011 (same for v, s)
    #   P'[0,4] = P0[0,4] + P0[4,4] = 10000              (position-velocity correlation appears)
    #   P'[3,3] = P0[3,3] + Q[3,3] = 10 + 1 = 11          (aspect ratio has no velocity)
    #   P'[4,4] = 10000 + 0.01, P'[6,6] = 10000 + 0.0001
    #   P'[0,1] = 0                                        (u and v stay independent)
    assert P[0, 0] == pytest.approx(10011.0)
    assert P[1, 1] == pytest.approx(10011.0)
    assert P[2, 2] == pytest.approx(10011.0)
    assert P[0, 4] == pytest.approx(10000.0)
    assert P[4, 0] == pytest.approx(10000.0)
    assert P[2, 6] == pytest.approx(10000.0)
    assert P[3, 3] == pytest.approx(11.0)
    assert P[4, 4] == pytest.approx(10000.01)
    assert P[6, 6] == pytest.approx(10000.0001)
    assert P[0, 1] == 0.0
    # and in full, against the matrices
    P0, F, Q = initial_covariance(), transition_matrix(), process_noise()
    np.testing.assert_allclose(P, F @ P0 @ F.T + Q)
    assert (k.age, k.time_since_update, k.hit_streak) == (1, 1, 0)


def test_predict_moves_the_centre_by_the_velocity():
    k = BoxKalman(BOX)
    k.kf.x[4, 0], k.kf.x[5, 0] = 3.0, -2.0  # du, dv
    p = k.predict()
    np.testing.assert_allclose(p, BOX + [3.0, -2.0, 0.0, 0.0])


def test_update_pulls_the_state_towards_the_measurement_by_the_kalman_gain():
    k = BoxKalman(BOX)
    k.predict()
    k.update(BOX + [10.0, 0.0, 0.0, 0.0])  # measured centre u = 35, predicted 25
    # the u/du block decouples: S = P'[0,0] + R[0,0] = 10011 + 1 = 10012
    #   u  = 25 + 10 * 10011 / 10012
    #   du = 10 * P'[4,0] / S = 10 * 10000 / 10012
    u, v, s, r, du, dv, ds = k.state
    assert u == pytest.approx(25.0 + 10.0 * 10011.0 / 10012.0)
    assert du == pytest.approx(10.0 * 10000.0 / 10012.0)
    assert 25.0 < u < 35.0
    assert (v, s, r, dv, ds) == pytest.approx((50.0, 1800.0, 0.5, 0.0, 0.0))
    np.testing.assert_allclose(k.velocity, [du, 0.0])
    assert (k.hits, k.hit_streak, k.time_since_update) == (1, 1, 0)


def test_hit_streak_resets_at_the_first_predict_after_a_missed_frame():
    k = BoxKalman(BOX)
    for _ in range(2):
        k.predict()
        k.update(BOX)
    assert (k.hits, k.hit_streak) == (2, 2)
    k.predict()  # this frame: no detection
    assert (k.hit_streak, k.time_since_update) == (2, 1)
    k.predict()  # previous frame was missed -> streak lost
    assert (k.age, k.hits, k.hit_streak, k.time_since_update) == (4, 2, 0, 2)


def test_area_velocity_is_zeroed_when_the_predicted_area_would_not_be_positive():
    k = BoxKalman(BOX)
    k.kf.x[6, 0] = -2000.0  # s + ds = 1800 - 2000 <= 0
    p = k.predict()
    assert k.state[6] == 0.0
    assert k.state[2] == pytest.approx(1800.0)  # area kept
    np.testing.assert_allclose(p, BOX)


def test_area_velocity_is_kept_when_the_predicted_area_stays_positive():
    k = BoxKalman(BOX)
    k.kf.x[6, 0] = -800.0  # s + ds = 1000 > 0
    k.predict()
    assert k.state[2] == pytest.approx(1000.0)
    assert k.state[6] == pytest.approx(-800.0)


def test_an_invalid_prediction_is_signalled_never_returned():
    k = BoxKalman(BOX)
    k.kf.x[3, 0] = -0.5  # negative aspect ratio: w = sqrt(s * r) is not a number
    with pytest.raises(InvalidPrediction):
        k.predict()
    with pytest.raises(InvalidPrediction):
        k.box  # the NaN box is not readable either


def test_area_noise_scales_only_the_process_noise_of_the_area():
    q = process_noise(10.0, area_noise=100.0)
    assert q[2, 2] == 100.0  # SORT's 1 px^4 times 100
    assert [q[i, i] for i in (0, 1, 3)] == [1.0, 1.0, 1.0]
    assert np.allclose([q[4, 4], q[5, 5], q[6, 6]], [0.1, 0.1, 0.001])  # velocity_noise 10 as before
    with pytest.raises(ValueError, match="area_noise"):
        BoxKalman([0, 0, 10, 10], area_noise=0.0)


# A car passing close by (KITTI val 0006, frames 36-56, PointRCNN boxes rounded to pixels): it
# first grows (119 -> 351 px wide) and then shrinks to 83 px, its area falling by 10-20 % a frame.
# With SORT's area noise (Q_s = 1 against R_s = 10) the filter weighs its area velocity ten times
# above a detected area: the filtered area lags the detections and the area velocity, learnt while
# the car shrank fast, keeps shrinking the prediction after the detections slow down.  Its
# prediction for frame 56 no longer overlaps that frame's detection by the 0.3 IoU an assignment
# needs (the tracker halted the track there and started a new identity).  With area_noise 1e4
# (Q_s = 1e4 >> R_s = 10, Kalman gain on s near 1) the filtered area is the detected one.
PASSING_CAR = [(1122, 176, 119, 198), (1048, 180, 193, 194), (991, 187, 250, 187), (958, 192, 283, 182),
               (914, 188, 327, 186), (890, 192, 351, 182), (854, 187, 343, 187), (833, 185, 279, 164),
               (814, 181, 249, 150), (799, 188, 217, 131), (789, 184, 186, 121), (775, 184, 160, 109),
               (759, 181, 151, 101), (750, 180, 136, 94), (742, 181, 123, 83), (733, 184, 117, 78),
               (726, 183, 102, 71), (719, 180, 92, 68), (712, 178, 87, 65), (704, 180, 83, 59)]
PASSING_CAR_NEXT = (699, 181, 77, 55)


def _follow(area_noise: float) -> tuple[BoxKalman, list[float]]:
    kf = BoxKalman(PASSING_CAR[0], 10.0, area_noise=area_noise)
    lag = []
    for box in PASSING_CAR[1:]:
        kf.predict()
        kf.update(box)
        lag.append(abs(kf.state[2] - box[2] * box[3]) / (box[2] * box[3]))
    return kf, lag


def test_sort_area_noise_loses_a_passing_car_that_a_large_area_noise_keeps():
    from refimpl.core.geometry import iou_matrix
    nxt = np.array([PASSING_CAR_NEXT], dtype=float)
    sort_kf, sort_lag = _follow(1.0)
    wide_kf, wide_lag = _follow(1e4)
    assert max(wide_lag) < 0.01  # gain on s >= 1e4 / (1e4 + 10 + ...) : the detected area
    assert max(sort_lag) > 0.25  # the lag that SORT's weighting builds up on this car
    assert iou_matrix(sort_kf.predict().reshape(1, 4), nxt)[0, 0] < 0.3
    assert iou_matrix(wide_kf.predict().reshape(1, 4), nxt)[0, 0] > 0.5
