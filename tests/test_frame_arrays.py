"""The per-frame loop's array helpers give exactly what the per-object code they replaced gave
(issue 27, item 2), on every frame of real sequences: the fast path's tie-break numbers
(LazyTiebreak) against tiebreak_weights, the top matrix's rows against np.flatnonzero per row,
integer_boxes against integer_box, and the tracker's clipping of predictions (refimpl.tracking.bounds,
on arrays and on Python floats) against the np.clip formulation it had before."""

from __future__ import annotations

import math

import numpy as np
import pytest

from refimpl import io
from refimpl.core.geometry import integer_box, integer_boxes
from refimpl.tracking.pipeline import new_tracker, setup_for
from refimpl.solvers.common import LazyTiebreak, candidate_pairs, intersection_matrix, tiebreak_weights
from refimpl.solvers.cpsat_model import _overlapping_top_matrix
from refimpl.solvers.fast_path import _inter_and_top, _rows
from refimpl.core.constants import resolve_constants
from refimpl.core.hypothesis import parse_action
from refimpl.io.datasets import benchmark_sequences
from refimpl.tracking.bounds import MAX_BOX_AREA, PredictionBounds

# (benchmark, sequence, format, class): a KITTI Car sequence with the Car preset and a MOT15 one
# with occlusions (hides_behind / unhides_from_behind in its history) and the default preset
SEQUENCES = [("kitti-car", "0011", "kitti", "Car"), ("mot15", "TUD-Campus", "mot", None)]


def _track(shared_data, bench, name, fmt, cls):
    """Every frame problem of the sequence and every (prediction, bounded box) of the tracker."""
    seq = io.load_detections(next(b for b in benchmark_sequences(bench, shared_data) if b.name == name))
    tracker = new_tracker(setup_for(fmt, cls, "cpsat"), seq.image_size, getattr(seq, "fps", None))
    clipped: list[tuple[np.ndarray, np.ndarray]] = []

    class Recording(PredictionBounds):  # this one tracker's bounds, recording: nothing global
        def boxes(self, boxes):
            out = super().boxes(boxes)
            clipped.extend(zip(boxes.copy(), out.copy()))
            return out

    tracker.bounds = Recording(tracker.bounds.width, tracker.bounds.height, tracker.bounds.cap)
    problems = []
    for fr in seq.frames:
        tracker.step(fr.frame, fr.boxes, fr.confidences, fr.types, lambda p, h: problems.append(p))
    return seq, tracker, problems, clipped


@pytest.fixture(scope="module", params=SEQUENCES, ids=[s[1] for s in SEQUENCES])
def tracked(request, shared_data):
    return _track(shared_data, *request.param)


def test_lazy_tiebreak_equals_tiebreak_weights_on_every_frame(tracked):
    _, _, problems, _ = tracked
    binary_seen = 0
    for p in problems:
        tb = tiebreak_weights(p)
        t_index = {t.id: i for i, t in enumerate(p.tracks)}
        d_index = {d.id: j for j, d in enumerate(p.detections)}
        pairs = [(t_index[t], d_index[d]) for t, d in candidate_pairs(p)]
        lazy = LazyTiebreak(p, intersection_matrix([t.box for t in p.tracks]), pairs)
        assert lazy.shift == tb.shift
        assert lazy.pair == tb.pair
        for term, idx in tb.event.items():
            name, args = parse_action(term)
            assert lazy.index(name, args) == idx, (p.time, term)
            binary_seen += len(args) == 2
        # an event tiebreak_weights does not list weighs 0 there (.get(term, 0)), and here too
        for a in p.tracks:
            for b in p.tracks:
                if a.id != b.id and f"hides_behind({a.id},{b.id})" not in tb.event:
                    assert lazy.index("hides_behind", (a.id, b.id)) == 0
        assert lazy.index("enters_fov", ("det_999999",)) == 0
    assert binary_seen > 0  # the sequences have overlapping tracks: the pair events were compared


def test_top_rows_equal_flatnonzero_per_row(tracked):
    _, _, problems, _ = tracked
    nonempty = 0
    for p in problems:
        inter = intersection_matrix([t.box for t in p.tracks])
        top = _overlapping_top_matrix(p.tracks, inter, resolve_constants(p)["hide_overlap"])
        rows = _rows(top)
        assert rows == [np.flatnonzero(top[i]).tolist() for i in range(len(p.tracks))]
        nonempty += any(rows)
    assert nonempty > 0


def test_inter_and_top_equal_the_two_matrices(tracked):
    _, _, problems, _ = tracked
    for p in problems:
        hide = resolve_constants(p)["hide_overlap"]
        inter, top = _inter_and_top(p.tracks, hide)
        want = intersection_matrix([t.box for t in p.tracks])
        assert inter.dtype == want.dtype and np.array_equal(inter, want)
        assert np.array_equal(top, _overlapping_top_matrix(p.tracks, want, hide))


def test_integer_boxes_equal_integer_box_on_real_boxes(tracked):
    seq, _, problems, clipped = tracked
    for fr in seq.frames:
        b = np.asarray(fr.boxes, dtype=float).reshape(-1, 4)
        assert integer_boxes(b) == [integer_box(x) for x in b]
    predicted = np.array([out for _, out in clipped])
    assert integer_boxes(predicted) == [integer_box(x) for x in predicted]
    # and the frame problems hold exactly those boxes (Python ints)
    assert all(type(v) is int for p in problems for o in p.detections + p.tracks for v in o.box)


def test_integer_boxes_by_hand_and_outside_the_exact_range():
    # floor(v + 0.5): 0.5 -> 1, -0.5 -> 0, width 0.4 -> 0 -> at least 1, 2.5 -> 3
    assert integer_boxes(np.array([[0.5, -0.5, 0.4, 2.5], [-1.5, 3.49, 10.0, 0.0]])) == [(1, 0, 1, 3), (-1, 3, 10, 1)]
    assert integer_boxes(np.zeros((0, 4))) == []
    # 2^53 + 2 is beyond the vectorised range: the scalar path converts it exactly
    big = float(2 ** 53 + 2)
    assert integer_boxes(np.array([[big, 0.0, 1.0, 1.0]])) == [(2 ** 53 + 2, 0, 1, 1)]
    with pytest.raises(ValueError):  # int(nan), as integer_box raises
        integer_boxes(np.array([[math.nan, 0.0, 1.0, 1.0]]))


def _bounded_with_np_clip(box: np.ndarray, w: float, h: float, cap: float = MAX_BOX_AREA) -> np.ndarray:
    """The tracker's clipping as it was written before (np.clip on numpy scalars); ``cap``: the area cap
    in the image's pixels (MAX_BOX_AREA is in working pixels: divided by the working scale squared)."""
    x1, y1 = np.clip(box[0], -w, 2 * w), np.clip(box[1], -h, 2 * h)
    x2, y2 = np.clip(box[0] + box[2], -w, 2 * w), np.clip(box[1] + box[3], -h, 2 * h)
    bw, bh = max(x2 - x1, 1.0), max(y2 - y1, 1.0)
    if bw * bh > cap:
        shrink = float(np.sqrt(cap / (bw * bh)))
        cx, cy = x1 + bw / 2, y1 + bh / 2
        bw, bh = bw * shrink, bh * shrink
        x1, y1 = cx - bw / 2, cy - bh / 2
    return np.array([x1, y1, bw, bh])


def test_bounded_equals_np_clip_bit_for_bit(tracked):
    _, tracker, _, clipped = tracked
    # the image size in the constants is in working pixels (camera.working_scale: 2 for TUD-Campus's
    # 640 x 480, 1 for KITTI's 1242 x 375); the clipping is in the image's
    scale = tracker.pixel_scale
    w, h = tracker.constant_map["img_width"] / scale, tracker.constant_map["img_height"] / scale
    cap = MAX_BOX_AREA / (scale * scale)
    assert len(clipped) > 100
    for box, out in clipped:
        assert out.tobytes() == _bounded_with_np_clip(box, w, h, cap).tobytes()
    # boxes that the clipping and the area cap change: beyond every side, huge, thinner than 1 px
    extreme = [np.array(b, dtype=float) for b in (
        [-5 * w, -5 * h, 20 * w, 20 * h], [3 * w, 0.3, 10.0, 10.0], [0.25, 0.75, 0.1, 0.2],
        [-w - 0.5, 2 * h - 0.25, 1e9, 1e9], [10.1, 20.2, 30000.3, 9000.7])]
    for box in extreme:
        expected = _bounded_with_np_clip(box, w, h, cap).tobytes()
        assert tracker.bounds.boxes(box[None])[0].tobytes() == expected
        assert np.array(tracker.bounds.box(*box.tolist())).tobytes() == expected


def test_bounded_caps_the_area_as_np_clip_did():
    # in a 10000 x 10000 image a box may grow to 30000 x 30000 px (one image size beyond every
    # side, -10000..20000): 9e8 px^2, shrunk about its centre (5000, 5000) by sqrt(2e7 / 9e8) = 1/sqrt(45) to
    # 4472.1 x 4472.1 px, the MAX_BOX_AREA of 2e7 px^2
    from refimpl.solvers import get_solver
    from refimpl.tracking.tracker import AbductionTracker
    tracker = AbductionTracker(get_solver("cpsat"), {"img_width": 10000, "img_height": 10000})
    box = np.array([-20000.0, -15000.0, 60000.0, 50000.0])
    out = tracker.bounds.boxes(box[None])[0]
    assert out.tobytes() == _bounded_with_np_clip(box, 10000, 10000).tobytes()
    side = 30000 / math.sqrt(45)
    assert out == pytest.approx([5000 - side / 2, 5000 - side / 2, side, side], rel=1e-12)
    assert out[2] * out[3] == pytest.approx(MAX_BOX_AREA, rel=1e-12)


def test_column_medians_equal_np_median_bit_for_bit(tracked):
    # the scene velocity's median (issue 38: np.median's first call imported numpy.ma, ~14 ms in
    # the middle of a run): on the velocities of every frame's moving tracks, and on odd and even
    # counts of random values with signed zeros, repeats and a NaN (np.median's NaN, as before)
    from refimpl.tracking.tracker import column_medians
    _, tracker, _, _ = tracked
    velocities = [t.kalman.velocity for t in tracker.tracks.values()]
    samples = [np.array(velocities[:k]) for k in range(1, len(velocities) + 1)]
    rng = np.random.default_rng(38)
    for n in range(1, 30):
        v = rng.normal(size=(n, 2)) * 10.0 ** rng.integers(-4, 4)
        samples += [v, np.round(v), np.full((n, 2), -0.0), np.where(v > 0, v, -0.0)]
    assert len(samples) > 100
    for v in samples:
        ref = np.median(v, axis=0)
        out = column_medians(v)
        assert out.dtype == ref.dtype and out.shape == ref.shape and out.tobytes() == ref.tobytes()
    with_nan = np.array([[np.nan, 1.0], [2.0, 3.0], [4.0, 5.0]])
    assert np.isnan(column_medians(with_nan)[0]) and column_medians(with_nan)[1] == 3.0


def test_event_terms_split_as_event_of_parses():
    # Hypothesis.event_terms splits a flat 'occurs_at(name(args),t)' without making Terms; every
    # other shape goes to event_of: the same (name, argument names), or the same error
    from refimpl.core.hypothesis import _event_name_args
    from refimpl.core.spec import event_of
    atoms = ["occurs_at(hides_behind(trk_1,trk_2),5)", "occurs_at(enters_fov(det_3),12)", "occurs_at(foo,5)",
             "occurs_at(a,b,5)", "occurs_at(e(a),x(b),5)", "occurs_at(e(a)b,5)", "occurs_at(e(a),5(x))",
             "occurs_at(e(a, b),5)", "occurs_at(e(f(a)),5)", "hides_behind(trk_1,trk_2)", "occurs_at(e(),5)",
             "occurs_at(e(a,),5)", "occurs_at((a),5)", 'occurs_at(e("a,b"),5)', "occurs_at(,5)",
             "occurs_at(e(a),)", "occurs_at(e(a),5)x)", "occurs_at(e(a))", "occurs_at()", "occurs_at(e(a),5,6)"]
    for atom in atoms:
        try:
            e = event_of(atom)
            want = (e.name, e.arg_names)
        except ValueError:
            with pytest.raises(ValueError):
                _event_name_args(atom)
            continue
        assert _event_name_args(atom) == want, atom
