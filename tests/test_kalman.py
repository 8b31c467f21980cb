"""refimpl.tracking.kalman.LinearKalman against its reference, filterpy's KalmanFilter: every bit of x and P.

LinearKalman claims filterpy's floating-point operations in filterpy's order (refimpl/tracking/kalman.py),
so the tracker's results did not change when it replaced filterpy.  These tests check the claim
bit for bit (``tobytes``: -0.0 and 0.0 differ, NaNs compare), after every call:

* on dense random models (every entry of F, H, P, Q, R non-zero: with SORT's sparse F and H many
  different operation orders round alike, a dense model tells them apart);
* the boxes BoxKalman computes on Python floats against numpy's arithmetic (x_to_xywh below);
* through refimpl.tracking.motion.BoxKalman on random box sequences (gaps, hold mode, re-updates, the
  presets' noise factors) and on the real tracks of KITTI 0011 and MOT15 TUD-Campus: the
  reference is a BoxKalman whose ``kf`` is a filterpy KalmanFilter set up with the same matrices
  (BoxKalman uses only x, P, predict() and update(z) of its filter, which both classes have).
"""

from __future__ import annotations

import numpy as np
import pytest

from refimpl import io
from refimpl.tracking.kalman import LinearKalman, update_many
from refimpl.tracking.motion import BoxKalman, InvalidPrediction, xywh_to_z

filterpy_kalman = pytest.importorskip("filterpy.kalman")  # the reference (the test extra)


def _bits(a: np.ndarray) -> tuple:
    return a.shape, a.dtype.str, a.tobytes()


def _twin(kf: LinearKalman):
    """A filterpy KalmanFilter with LinearKalman kf's state and model (copies)."""
    dim_z, dim_x = kf.H.shape
    ref = filterpy_kalman.KalmanFilter(dim_x=dim_x, dim_z=dim_z)
    ref.x, ref.P = kf.x.copy(), kf.P.copy()
    ref.F, ref.H, ref.Q, ref.R = kf.F.copy(), kf.H.copy(), kf.Q.copy(), kf.R.copy()
    return ref


def _same(ours, ref, where: str) -> None:
    assert _bits(ours.x) == _bits(ref.x), f"x differs {where}: {ours.x.ravel()} vs {ref.x.ravel()}"
    assert _bits(ours.P) == _bits(ref.P), f"P differs {where}"


def _spd(rng: np.random.Generator, n: int, scale: float) -> np.ndarray:
    a = rng.normal(size=(n, n)) * scale
    return a @ a.T + n * scale * scale * np.eye(n)


@pytest.mark.parametrize("seed", range(6))
def test_dense_random_models_match_filterpy_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    dim_x, dim_z = 7, 4
    F = np.eye(dim_x) + rng.normal(size=(dim_x, dim_x)) * 0.1
    H = rng.normal(size=(dim_z, dim_x))
    kf = LinearKalman(rng.normal(size=(dim_x, 1)) * 100, _spd(rng, dim_x, 3.0), F, H,
                      _spd(rng, dim_x, 0.1), _spd(rng, dim_z, 1.0))
    ref = _twin(kf)
    x0 = kf.x.copy()
    assert np.count_nonzero(kf.F) == dim_x * dim_x and np.count_nonzero(kf.H) == dim_z * dim_x  # dense
    for step in range(60):
        if rng.random() < 0.6:
            z = rng.normal(size=(dim_z, 1)) * 100
            kf.update(z)
            ref.update(z)
        else:
            kf.predict()
            ref.predict()
        _same(kf, ref, f"after step {step} (seed {seed})")
    assert not np.array_equal(kf.x, x0)  # the state moved: two untouched arrays would prove nothing


def test_shapes_are_checked():
    F, H = np.eye(7), np.eye(4, 7)
    with pytest.raises(ValueError):
        LinearKalman(np.zeros(7), np.eye(7), F, H, np.eye(7), np.eye(4))  # x must be (7, 1)
    with pytest.raises(ValueError):
        LinearKalman(np.zeros((7, 1)), np.eye(7), F, H, np.eye(7), np.eye(3))  # R must be (4, 4)


def _reference_box(box, velocity_noise=1.0, velocity=None, area_noise=1.0) -> BoxKalman:
    ref = BoxKalman(box, velocity_noise, velocity, area_noise)
    ref.kf = _twin(ref.kf)
    return ref


class _Pair:
    """One BoxKalman on LinearKalman and its filterpy twin, driven with the same calls."""

    def __init__(self, box, **kwargs):
        self.ours, self.ref = BoxKalman(box, **kwargs), _reference_box(box, **kwargs)
        self.calls = 0

    def _both(self, name: str, *args):
        results = []
        for k in (self.ours, self.ref):
            try:
                results.append(("ok", getattr(k, name)(*args)))
            except InvalidPrediction:
                results.append(("invalid", None))
        self.calls += 1
        where = f"after call {self.calls} ({name})"
        _same(self.ours.kf, self.ref.kf, where)
        assert results[0][0] == results[1][0], where
        if results[0][1] is not None:
            assert _bits(results[0][1]) == _bits(results[1][1]), where
        for counter in ("age", "hits", "hit_streak", "time_since_update"):
            assert getattr(self.ours, counter) == getattr(self.ref, counter)
        return results[0][0]

    def predict(self, hold=False):
        return self._both("predict", hold)

    def update(self, box):
        return self._both("update", box)

    def reupdate(self, box):
        return self._both("reupdate", box)


# (velocity_noise, area_noise): the presets' (model/presets.json: KITTI Car 10, 100; KITTI
# Pedestrian 10, 1; MOT15 and SORT 1, 1) and two others of the calibration grids' range
NOISE = [(1.0, 1.0), (10.0, 1.0), (10.0, 100.0), (3.0, 10000.0), (0.5, 1.0)]


@pytest.mark.parametrize("seed", range(8))
def test_random_box_sequences_match_filterpy_bit_for_bit(seed):
    rng = np.random.default_rng(100 + seed)
    vn, an = NOISE[seed % len(NOISE)]
    hold = seed % 2 == 1
    scale = [1.0, 1e-2, 1e3][seed % 3]  # tiny and huge boxes round differently
    box = np.array([rng.uniform(0, 1000), rng.uniform(0, 300), rng.uniform(5, 200), rng.uniform(5, 200)]) * scale
    velocity = rng.normal(size=2) * 5 if seed % 4 == 2 else None
    pair = _Pair(box, velocity_noise=vn, area_noise=an, velocity=velocity)
    speed = rng.normal(size=4) * np.array([3, 2, 0.5, 0.5]) * scale
    outcomes = set()
    for _ in range(120):
        gap = int(rng.choice([0, 0, 0, 0, 1, 2, 5, 12]))
        for _ in range(gap + 1):
            outcomes.add(pair.predict(hold))
        speed += rng.normal(size=4) * np.array([1, 1, 0.3, 0.3]) * scale
        box = box + speed
        box[2:] = np.maximum(box[2:], 0.5 * scale)
        if rng.random() < 0.05:  # a jump: the detector found another object
            box = box + rng.normal(size=4) * np.array([100, 50, 20, 20]) * scale
            box[2:] = np.abs(box[2:]) + scale
        if gap and rng.random() < 0.5:
            pair.reupdate(box)
        else:
            pair.update(box)
    assert "ok" in outcomes
    assert pair.ours.hits == 120


def test_a_collapsing_area_is_caught_alike():
    # s + ds <= 0 sets ds = 0 before predict (motion.BoxKalman.predict); here the filter is pushed
    # into predictions with a negative area (w = sqrt(s * r) is NaN): both raise InvalidPrediction
    # on the same call, with the same state
    pair = _Pair(np.array([100.0, 100.0, 50.0, 50.0]))
    for w in (40.0, 30.0, 20.0, 10.0, 5.0, 2.0, 1.0):
        pair.predict()
        pair.update(np.array([100.0, 100.0, w, w]))
    pair.ours.kf.x[3, 0] = pair.ref.kf.x[3, 0] = -1.0  # aspect ratio < 0: s * r < 0
    assert pair.predict() == "invalid"


def _real_tracks(boxes_by_id: dict[int, list[tuple[int, np.ndarray]]], every: int):
    """Drive one pair per track over its frames: predict every frame, update where observed, every
    ``every``-th observation left out (a gap), the observation after a gap a re-update on odd ids."""
    updates = 0
    for tid, obs in boxes_by_id.items():
        (f0, b0), rest = obs[0], obs[1:]
        pair = _Pair(b0, velocity_noise=10.0 if tid % 3 == 0 else 1.0, area_noise=100.0 if tid % 2 else 1.0)
        frame, missed = f0, False
        for k, (f, box) in enumerate(rest):
            while frame < f:
                pair.predict(hold=tid % 4 == 1)
                frame += 1
            if (k + 1) % every == 0:
                missed = True
                continue
            (pair.reupdate if missed and tid % 2 else pair.update)(box)
            updates += 1
            missed = False
    return updates


def _by_id(gt) -> dict[int, list[tuple[int, np.ndarray]]]:
    out: dict[int, list[tuple[int, np.ndarray]]] = {}
    for f, i, b in zip(gt.frames.tolist(), gt.ids.tolist(), gt.boxes):
        out.setdefault(int(i), []).append((int(f), np.asarray(b, dtype=float)))
    return {i: sorted(v, key=lambda fb: fb[0]) for i, v in sorted(out.items())}


def test_real_kitti_tracks_match_filterpy_bit_for_bit(shared_data):
    gt = io.read_kitti_ground_truth(shared_data / "KITTI/tracking/training/label_02/0011.txt", "Car")
    tracks = _by_id(gt)
    assert len(tracks) > 20
    # 3587 Car boxes of 55 ids in label_02/0011 (read above), minus each id's first (the start)
    # and every 7th of the rest (left out): thousands of updates
    assert _real_tracks(tracks, every=7) > 2500


def test_real_mot15_tracks_match_filterpy_bit_for_bit(shared_data):
    gt = io.read_mot_ground_truth(shared_data / "MOT15/train/TUD-Campus/gt/gt.txt")
    tracks = _by_id(gt)
    # gt.txt: 359 boxes of 8 pedestrians
    assert len(tracks) == 8
    assert _real_tracks(tracks, every=5) > 250


def x_to_xywh(x) -> np.ndarray:
    """The numpy reference of BoxKalman.box: state (or observation) [u, v, s, r, ...] -> (x, y, w, h) with w = sqrt(s*r), h = s/w, shape (4,).

    No validity check: s * r <= 0 gives NaN (or w = 0); `BoxKalman.predict` is where that is caught.
    """
    v = np.asarray(x, dtype=float).reshape(-1)
    u, c, s, r = v[0], v[1], v[2], v[3]
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.sqrt(s * r)
        h = s / w
    return np.array([u - w / 2.0, c - h / 2.0, w, h])


def test_boxes_on_python_floats_are_numpys_bit_for_bit():
    # BoxKalman.box and xywh_to_z compute on Python floats (motion.py); x_to_xywh (above) keeps the numpy
    # scalar arithmetic they replaced: the same IEEE operations must give the same bits, and the
    # validity rule (state and box finite, w > 0, h > 0) the same verdict
    rng = np.random.default_rng(7)
    k = BoxKalman(np.array([1.0, 2.0, 3.0, 4.0]))
    verdicts = set()
    for i in range(3000):
        x = rng.normal(size=(7, 1)) * 10.0 ** rng.integers(-6, 8, size=(7, 1))
        if i % 10 == 0:
            x[rng.integers(0, 7), 0] = [np.inf, -np.inf, np.nan, 0.0, -0.0][i % 5]
        k.kf.x = x
        with np.errstate(all="ignore"):
            box = x_to_xywh(x[:, 0])
            valid = bool(np.all(np.isfinite(x)) and np.all(np.isfinite(box)) and box[2] > 0 and box[3] > 0)
        verdicts.add(valid)
        if valid:
            assert _bits(k.box) == _bits(box)
        else:
            with pytest.raises(InvalidPrediction):
                k.box
        b = np.abs(x[:4, 0]) + 1e-3
        if np.all(np.isfinite(b)):
            ref = np.array([b[0] + b[2] / 2.0, b[1] + b[3] / 2.0, b[2] * b[3], b[2] / b[3]])  # numpy scalars
            assert _bits(xywh_to_z(b)) == _bits(ref)
    assert verdicts == {True, False}


def _box_filters(rng: np.random.Generator, n: int) -> list[BoxKalman]:
    """n BoxKalman filters with different noise, each a few predict/update steps into a track
    (so x and P are full, not the initial diagonal)."""
    out = []
    for k in range(n):
        box = np.array([rng.uniform(0, 1200), rng.uniform(0, 350), rng.uniform(8, 300), rng.uniform(8, 300)])
        f = BoxKalman(box, velocity_noise=(1.0, 10.0)[k % 2], area_noise=(1.0, 100.0)[k % 3 == 0])
        for _ in range(int(rng.integers(1, 6))):
            f.predict()
            box = box + rng.normal(size=4) * np.array([4, 4, 1, 1])
            box[2:] = np.maximum(box[2:], 2.0)
            f.update(box)
        f.predict()
        out.append(f)
    return out


@pytest.mark.parametrize("seed", range(5))
def test_a_batch_update_is_one_update_per_filter_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    n = 2 + seed * 3  # 2, 5, 8, 11, 14 filters: one batch each
    batch = _box_filters(rng, n)
    single = _box_filters(np.random.default_rng(seed), n)  # the same draws: the same filters
    boxes = [np.array([rng.uniform(0, 1200), rng.uniform(0, 350), rng.uniform(8, 300), rng.uniform(8, 300)])
             for _ in range(n)]
    before = [f.kf.x.copy() for f in batch]
    states = BoxKalman.update_many(batch, boxes)
    for f, box in zip(single, boxes):
        f.update(box)
    for k, (a, b) in enumerate(zip(batch, single)):
        _same(a.kf, b.kf, f"filter {k} of {n}")
        assert (a.hits, a.hit_streak, a.time_since_update) == (b.hits, b.hit_streak, b.time_since_update)
        assert not np.array_equal(a.kf.x, before[k])  # the batch did correct every filter
        # the state kept for reupdate, and the written box from the returned floats, are update()'s
        assert all(_bits(x) == _bits(y) and x.shape == y.shape for x, y in zip(a._last_obs, b._last_obs))
        assert _bits(BoxKalman.box_of_state(states[k])) == _bits(b.box)
    a = batch[0]
    kept = a.kf.x.copy()
    a.kf.x[6, 0] = 123.0  # an in-place edit (SORT's style) leaves the kept state alone
    assert np.array_equal(a._last_obs[0], kept)


def test_a_batch_update_matches_filterpy_on_real_tracks(shared_data):
    # every Car of KITTI label_02/0011 present in a frame is updated in that frame's one batch;
    # filterpy's KalmanFilter, one per id, takes the same boxes one by one
    gt = io.read_kitti_ground_truth(shared_data / "KITTI/tracking/training/label_02/0011.txt", "Car")
    ours: dict[int, BoxKalman] = {}
    refs: dict[int, object] = {}
    batches = 0
    for f in sorted(set(gt.frames.tolist())):
        rows = [(int(i), np.asarray(b, dtype=float)) for fr, i, b in zip(gt.frames.tolist(), gt.ids.tolist(), gt.boxes)
                if fr == f]
        for i, _ in rows:  # predict the live ones (a new id starts below, after this frame's batch)
            if i in ours:
                ours[i].predict()
                refs[i].predict()
        seen = [(i, b) for i, b in rows if i in ours]
        BoxKalman.update_many([ours[i] for i, _ in seen], [b for _, b in seen])
        for i, b in seen:
            refs[i].update(xywh_to_z(b).reshape(4, 1))
            _same(ours[i].kf, refs[i], f"id {i} at frame {f}")
        batches += len(seen) >= 2
        for i, b in rows:
            if i not in ours:
                ours[i] = BoxKalman(b)
                refs[i] = _twin(ours[i].kf)
    assert batches > 300  # 0011 has 373 frames, most with several cars: real batches, not singles


def test_filters_without_a_shared_model_are_updated_one_by_one():
    # a filter with its own R (a copy, not the shared array) leaves the batch path: the same
    # numbers as update() either way, so this pins only that nothing breaks and all are updated
    rng = np.random.default_rng(3)
    fs = _box_filters(rng, 3)
    fs[1].kf.R = fs[1].kf.R * 2.0
    ref = _box_filters(np.random.default_rng(3), 3)
    ref[1].kf.R = ref[1].kf.R * 2.0
    zs = np.stack([xywh_to_z(np.array([50.0 + 9 * k, 60.0, 40.0, 80.0])).reshape(4, 1) for k in range(3)])
    update_many([f.kf for f in fs], zs)
    for f, r, z in zip(fs, ref, zs):
        r.kf.update(z)
        _same(f.kf, r.kf, "outside the batch")


@pytest.mark.parametrize("hold", [False, True])
def test_a_batch_predict_is_one_predict_per_filter_bit_for_bit(hold):
    batch, single = _twin_batches()
    got = BoxKalman.predict_many(batch, hold)
    for k, want in enumerate(_each_predicted(batch, single, hold)):
        assert (got[k] is None) == (want is None) and (want is None or _bits(got[k]) == _bits(want))
    assert got[7] is None and sum(g is None for g in got) == 1


def _twin_batches() -> tuple[list[BoxKalman], list[BoxKalman]]:
    """Two equal batches of nine filters: a third went a frame without an update (hold mode
    applies), filter 4 has s + ds <= 0 (ds is zeroed), filter 7 a negative area (an invalid
    prediction)."""
    batch, single = _box_filters(np.random.default_rng(11), 9), _box_filters(np.random.default_rng(11), 9)
    for f in batch[::3] + single[::3]:
        f.time_since_update = 2
    batch[4].kf.x[6, 0] = single[4].kf.x[6, 0] = -batch[4].kf.x[2, 0] * 2
    batch[7].kf.x[2, 0] = single[7].kf.x[2, 0] = -5.0
    return batch, single


def _each_predicted(batch: list[BoxKalman], single: list[BoxKalman], hold: bool) -> list:
    """Each filter of ``single`` predicted on its own (None where it raises InvalidPrediction), after
    checking that the batch left every filter (state, counters) as its own predict() leaves it."""
    out = []
    for k, (a, b) in enumerate(zip(batch, single)):
        try:
            out.append(b.predict(hold))
        except InvalidPrediction:
            out.append(None)
        _same(a.kf, b.kf, f"filter {k}")
        assert (a.age, a.hit_streak, a.time_since_update) == (b.age, b.hit_streak, b.time_since_update)
    return out


@pytest.mark.parametrize("hold", [False, True])
def test_the_batch_prediction_as_an_array_is_each_predict_bit_for_bit(hold):
    # the tracker's frame problem takes a frame's predictions as one array (predict_box_array): each
    # valid row the bits of that filter's own predict(), the invalid one (a negative area: no
    # w = sqrt(s * r)) masked out, the filters advanced as predict() advances them
    batch, single = _twin_batches()
    boxes, ok = BoxKalman.predict_box_array(batch, hold)
    assert boxes.shape == (9, 4) and ok.tolist() == [k != 7 for k in range(9)]
    for k, want in enumerate(_each_predicted(batch, single, hold)):
        assert (want is None) == (not ok[k]) and (want is None or _bits(boxes[k]) == _bits(want))


def test_a_batch_with_one_invalid_box_changes_no_filter():
    # the third box has w = 0 (no area, no aspect ratio): ValueError before any filter is corrected
    rng = np.random.default_rng(11)
    batch = _box_filters(rng, 4)
    before = [(f.kf.x.copy(), f.kf.P.copy(), f.hits) for f in batch]
    boxes = np.array([[10.0, 20.0, 30.0, 40.0], [50.0, 60.0, 20.0, 20.0], [5.0, 5.0, 0.0, 9.0], [1.0, 2.0, 3.0, 4.0]])
    with pytest.raises(ValueError, match="w > 0 and h > 0"):
        BoxKalman.update_many(batch, boxes)
    for f, (x, P, hits) in zip(batch, before):
        assert np.array_equal(f.kf.x, x) and np.array_equal(f.kf.P, P) and f.hits == hits


def test_the_state_kept_for_reupdate_survives_an_in_place_edit():
    # SORT's code changes kf.x in place (x[6] *= 0); the state kept at the last observation is a
    # copy, so a later reupdate starts from the state the update left, not the edited one
    f = BoxKalman(np.array([100.0, 100.0, 40.0, 80.0]))
    f.update(np.array([102.0, 100.0, 40.0, 80.0]))
    kept = f.kf.x.copy()
    f.kf.x[6, 0] = 123.0
    assert np.array_equal(f._last_obs[0], kept)
