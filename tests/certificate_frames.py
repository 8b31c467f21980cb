"""Fact texts of frames the certificate tests of both backends share (tests/test_certificate.py for
clingo's, tests/test_cpsat_certificate.py for cpsat-full's)."""

OUTSIDE_THE_WITNESS = """#const curr_time=100.
det(det_1, car, 90).
box2d(det_1, 0, 0, 50, 50).
trk(trk_1, car).
trk_state(trk_1, active).
box2d(trk_1, 0, 0, 50, 50).
trk(trk_2, car).
trk_state(trk_2, active).
box2d(trk_2, 500, 0, 50, 50).
iou(trk_1,det_1,80000).
iou(trk_2,det_1,40000).
occurs_at(missing_detections(trk_2),95).
"""
"""Two active tracks and one detection: trk_1 over det_1 (IoU 0.8), trk_2 far away but with IoU
0.4 in the facts, and missed at 95, so missing_detections is no longer possible for it and it cannot
halt: its only action is its pair with det_1.  The relaxation's optimum {(trk_1, det_1)} leaves
trk_2 outside the witness without a solo action (each test derives what follows)."""

# assignable, with level-10 weight w = IoU + 1:
#   w(1,1) = 80001   w(1,2) = 50001
#   w(2,1) = 60001   w(2,2) = 40001
# The two perfect matchings weigh {11, 22} = 120002 and {12, 21} = 110002; a single pair at most
# 80001.  So M = {(trk_1,det_1), (trk_2,det_2)} is the unique level-10 optimum.
TWO_CARS = """#const curr_time=100.
det(det_1, car, 90).
box2d(det_1, 0, 0, 50, 50).
det(det_2, car, 90).
box2d(det_2, 500, 0, 50, 50).
trk(trk_1, car).
trk_state(trk_1, active).
box2d(trk_1, 0, 0, 50, 50).
trk(trk_2, car).
"""
"""Two detections and two tracks of the 2 x 2 frames below (trk_2's state and the ious follow)."""
TWO_BY_TWO = TWO_CARS + """trk_state(trk_2, active).
box2d(trk_2, 500, 0, 50, 50).
iou(trk_1,det_1,80000).
iou(trk_1,det_2,50000).
iou(trk_2,det_1,60000).
iou(trk_2,det_2,40000).
"""
