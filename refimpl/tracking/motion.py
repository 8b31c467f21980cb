"""Movement prediction: one constant-velocity Kalman filter per track, as in SORT.

The paper (Section 3, Step 1, "Movement Prediction") predicts each track's position and
size with a Kalman filter "as described in" SORT (Bewley et al., ICIP 2016).  SORT models a
box by its centre (u, v), its area s = w * h and its aspect ratio r = w / h; centre and
area move with constant velocity, the aspect ratio is taken as constant:

    state        x = [u, v, s, r, du, dv, ds]
    observation  z = [u, v, s, r]

    x_t = F x_{t-1} (+ noise Q),  F = I_7 with F[0,4] = F[1,5] = F[2,6] = 1 (one frame = one step)
    z_t = H x_t     (+ noise R),  H = [I_4 | 0]

A new track starts at the detection with zero velocity; because the velocity is unobserved
its covariance starts large.  The noise values are the ones SORT published (see the
constants below).

Boxes going in and out are (x, y, w, h) pixels (top-left corner, width, height), as
everywhere in refimpl.  A prediction can never leak a non-finite box or one with w, h <= 0:
`BoxKalman.predict` raises `InvalidPrediction` instead, and the caller drops the track
(SORT drops tracks whose prediction contains NaN).
"""

from __future__ import annotations

import math

import numpy as np

from .kalman import LinearKalman, predict_many, update_many

DIM_X = 7
"""State size: [u, v, s, r, du, dv, ds]."""

DIM_Z = 4
"""Observation size: [u, v, s, r]."""

# Initial state covariance P0 (diagonal).  SORT starts from the identity, multiplies the
# velocity block by 1000 ("large values, reflecting this uncertainty" on the unobserved
# velocities) and then the whole matrix by 10.
INITIAL_STATE_VARIANCE = 10.0
"""P0 for the observed components u, v, s, r: 1 * 10 (pixels^2, pixels^2, pixels^4, 1)."""

INITIAL_VELOCITY_VARIANCE = 10_000.0
"""P0 for the unobserved velocities du, dv, ds: 1 * 1000 * 10 -- a new track's velocity is unknown."""

# Measurement noise R (diagonal): identity, with the area and aspect-ratio block times 10.
MEASUREMENT_POSITION_VARIANCE = 1.0
"""R for the measured centre u, v (pixels^2): detections place centres to about a pixel."""

MEASUREMENT_SHAPE_VARIANCE = 10.0
"""R for the measured area s and aspect ratio r: 1 * 10, detected sizes are noisier than centres."""

# Process noise Q (diagonal): identity, with the velocity block times 0.01 and, on top of
# that, the area velocity ds times 0.01 again.
PROCESS_STATE_VARIANCE = 1.0
"""Q for u, v, s, r per frame: the random-walk part of position, area and aspect ratio."""

PROCESS_VELOCITY_VARIANCE = 0.01
"""Q for the velocities du, dv per frame: 1 * 0.01, velocities change slowly."""

PROCESS_AREA_VELOCITY_VARIANCE = 0.0001
"""Q for the area velocity ds per frame: 1 * 0.01 * 0.01, the growth rate of the area changes slowest."""

# Motion while hidden (issue 12, item 4; refimpl decision, off by default in the tracker)
HIDDEN_MAX_SPEED = 0.5
"""While unobserved (hold mode) the centre moves at most this many box sizes (sqrt of the area) per
frame: a velocity estimated from a few jittery detections cannot carry a hidden track away."""


def column_medians(values: np.ndarray) -> np.ndarray:
    """``np.median(values, axis=0)`` of an (n, k) float array, n >= 1, bit for bit: the middle
    value of each sorted column, or the mean of the two middle ones as np.mean takes it (their sum
    from 0.0, divided by 2).  np.median's first call imports numpy.ma for its NaN check (~14 ms, once per
    process, in the middle of a run: the slowest frame of a short run); a column with a NaN goes
    to np.median, which then answers NaN as before."""
    if not np.isfinite(values).all():
        return np.median(values, axis=0)
    s = np.sort(values, axis=0)
    half = len(s) // 2
    if len(s) % 2:  # np.mean's sum starts at 0.0: a lone -0.0 becomes 0.0
        return (0.0 + s[half]) / 1
    return (0.0 + s[half - 1] + s[half]) / 2


class InvalidPrediction(ValueError):
    """A Kalman prediction that is not a finite box with positive width and height."""


# The per-box arithmetic below runs on Python floats: the same IEEE double operations as on numpy
# float64 scalars (+, -, *, / and sqrt are correctly rounded either way), so the same bits, at a
# fraction of numpy's per-call cost on four numbers.

def _valid_box(box) -> bool:
    x, y, w, h = box
    return math.isfinite(x) and math.isfinite(y) and math.isfinite(w) and math.isfinite(h) and w > 0 and h > 0


def xywh_to_z(box_xywh) -> np.ndarray:
    """(x, y, w, h) -> observation z = [u, v, s, r] (centre, area w*h, aspect ratio w/h), shape (4,).

    Raises ValueError for a box that is not finite or has w <= 0 or h <= 0 (no area, no aspect ratio).
    """
    b = np.asarray(box_xywh, dtype=float).reshape(-1)
    if b.shape != (4,):
        raise ValueError(f"expected one (x, y, w, h) box, got shape {np.shape(box_xywh)}")
    return np.array(_z_values(b.tolist()))


def _z_values(box: list[float]) -> tuple[float, float, float, float]:
    """xywh_to_z on the four Python floats of a box (the same IEEE operations as on float64)."""
    if not _valid_box(box):
        raise ValueError(f"box {box} must be finite with w > 0 and h > 0")
    x, y, w, h = box
    return (x + w / 2.0, y + h / 2.0, w * h, w / h)


def _state_box(x: np.ndarray) -> np.ndarray | None:
    """The (x, y, w, h) box of a (7, 1) state [u, v, s, r, ...] (w = sqrt(s * r), h = s / w) if every component of the state and of the box is finite and the
    box has w, h > 0 (BoxKalman.box's test), else None."""
    box = _state_box_values(x)
    return None if box is None else np.array(box)


def _state_box_values(x: np.ndarray) -> tuple[float, float, float, float] | None:
    """_state_box as a tuple of four Python floats (or None)."""
    return _box_values(x[:, 0].tolist())


def _box_values(v: list[float]) -> tuple[float, float, float, float] | None:
    """_state_box_values of a state given as its list of Python floats."""
    if not all(map(math.isfinite, v)):
        return None
    u, c, s, r = v[0], v[1], v[2], v[3]
    sr = s * r
    if not sr > 0:  # w = sqrt(s * r) would be NaN (s * r < 0) or 0: not w > 0
        return None
    w = math.sqrt(sr)
    h = s / w
    box = (u - w / 2.0, c - h / 2.0, w, h)
    return box if _valid_box(box) else None


def boxes_of_states(states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """_box_values of every row of ``states`` (n, DIM_X): the (n, 4) boxes and the mask of the
    rows _box_values makes a box of (every component finite, s * r > 0, the box finite with
    w, h > 0); the other rows hold no box."""
    finite = np.isfinite(states).all(axis=1)
    u, c, s, r = states[:, 0], states[:, 1], states[:, 2], states[:, 3]
    with np.errstate(all="ignore"):
        sr = s * r
        ok = finite & (sr > 0)
        w = np.sqrt(np.where(ok, sr, 1.0))
        h = s / w
        boxes = np.column_stack((u - w / 2.0, c - h / 2.0, w, h))
    ok &= np.isfinite(boxes).all(axis=1) & (w > 0) & (h > 0)
    return boxes, ok


def transition_matrix() -> np.ndarray:
    """F: constant velocity, one frame per step (u += du, v += dv, s += ds; r constant)."""
    F = np.eye(DIM_X)
    F[0, 4] = F[1, 5] = F[2, 6] = 1.0
    return F


def measurement_matrix() -> np.ndarray:
    """H: the first four state components are observed."""
    H = np.zeros((DIM_Z, DIM_X))
    H[:, :DIM_Z] = np.eye(DIM_Z)
    return H


def initial_covariance() -> np.ndarray:
    """P0 = diag(10, 10, 10, 10, 10000, 10000, 10000)."""
    return np.diag([INITIAL_STATE_VARIANCE] * 4 + [INITIAL_VELOCITY_VARIANCE] * 3)


def measurement_noise() -> np.ndarray:
    """R = diag(1, 1, 10, 10)."""
    return np.diag([MEASUREMENT_POSITION_VARIANCE] * 2 + [MEASUREMENT_SHAPE_VARIANCE] * 2)


def centre_noise(x: np.ndarray, share: float) -> np.ndarray:
    """R for a detection of a box that wanders (the tracker option ``wander_noise``; refimpl
    decision, docs/tracking.md 'A detector whose boxes wander'): the centre's variance
    (share * w)^2 and (share * h)^2, never below SORT's 1 px^2, w and h those of the state ``x``
    the detection corrects (the prediction, its box as ``BoxKalman.box`` reads it); the size block
    SORT's.  SORT's R where the state is no box or ``share`` is 0."""
    box = _state_box_values(x) if share > 0 else None
    if box is None:
        return _R
    w, h = box[2], box[3]
    return np.diag([max(MEASUREMENT_POSITION_VARIANCE, (share * w) ** 2),
                    max(MEASUREMENT_POSITION_VARIANCE, (share * h) ** 2)]
                   + [MEASUREMENT_SHAPE_VARIANCE] * 2)


def process_noise(velocity_noise: float = 1.0, area_noise: float = 1.0) -> np.ndarray:
    """Q = diag(1, 1, 1, 1, 0.01, 0.01, 0.0001), the velocity block (du, dv, ds) times
    ``velocity_noise`` and the area s times ``area_noise`` (1, 1: SORT's values)."""
    q = np.diag([PROCESS_STATE_VARIANCE] * 4 + [PROCESS_VELOCITY_VARIANCE] * 2 + [PROCESS_AREA_VELOCITY_VARIANCE])
    q[2, 2] *= float(area_noise)
    q[4:, 4:] *= float(velocity_noise)
    return q


_F = transition_matrix()
_H = measurement_matrix()
_R = measurement_noise()
# shared by every track's filter, never written (LinearKalman only reads its model matrices)
for _m in (_F, _H, _R):
    _m.flags.writeable = False


class BoxKalman:
    """The motion model of one track: a Kalman filter over [u, v, s, r, du, dv, ds] plus SORT's counters.

    Counters (all start at 0 when the track is created from its first detection):
      age                 predictions made (frames the track has lived through after its first)
      hits                updates (detections assigned) after creation
      hit_streak          consecutive frames with an update; reset at the first prediction after a miss
      time_since_update   predictions since the last update (0 right after an update or at creation)
    """

    def __init__(self, box_xywh, velocity_noise: float = 1.0, velocity=None, area_noise: float = 1.0,
                 size_change: float = 0.0):
        """velocity_noise: the factor on SORT's process noise of the velocities (process_noise):
        larger lets the velocity follow faster changes, e.g. a car at 10 fps (refimpl decision, a
        tracker option; 1 is SORT).  velocity: the centre's initial (du, dv) in pixels per frame
        (default zero, SORT's start; the tracker option scene_velocity gives the scene's); its
        covariance stays INITIAL_VELOCITY_VARIANCE, so the first updates still correct it.
        area_noise: the factor on SORT's process noise of the area s (process_noise).  SORT's 1 px^4
        against a measurement noise of 10 makes the filter trust its area velocity ten times more
        than a detected area, so a box whose size changes fast (a car passing close by at 10 fps)
        is followed with a lag, and the area velocity overshoots; a large factor (1e4) lets the
        filtered area follow the detections (refimpl decision, a tracker option; docs/tracking.md).
        size_change: 0 (SORT's filter), or a factor > 1: across a frame after one without an update
        the predicted area grows or shrinks by at most that factor (the area velocity ds clipped
        to [s / size_change - s, s * size_change - s]); a hidden object keeps roughly its size
        (refimpl decision, the tracker option size_change; docs/tracking.md "Motion while hidden")."""
        for name, value in (("velocity_noise", velocity_noise), ("area_noise", area_noise)):
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive finite number, got {value!r}")
        if not (size_change == 0 or (np.isfinite(size_change) and size_change > 1)):
            raise ValueError(f"size_change must be 0 or a finite factor > 1, got {size_change!r}")
        self.velocity_noise = float(velocity_noise)
        self.area_noise = float(area_noise)
        self.size_change = float(size_change)
        x = np.zeros((DIM_X, 1))
        x[:DIM_Z, 0] = xywh_to_z(box_xywh)
        if velocity is not None:
            v = np.asarray(velocity, dtype=float).reshape(-1)
            if v.shape != (2,) or not np.all(np.isfinite(v)):
                raise ValueError(f"velocity must be a finite (du, dv), got {velocity!r}")
            x[4:6, 0] = v
        kf = LinearKalman(x, initial_covariance(), _F, _H, process_noise(velocity_noise, area_noise), _R)
        self.kf = kf
        self._last_obs = (kf.x.copy(), kf.P.copy(), np.asarray(box_xywh, dtype=float).reshape(4).copy())
        self.age = 0
        self.hits = 0
        self.hit_streak = 0
        self.time_since_update = 0

    @property
    def state(self) -> np.ndarray:
        """The state vector [u, v, s, r, du, dv, ds], shape (7,) (a copy)."""
        return self.kf.x[:, 0].copy()

    @property
    def covariance(self) -> np.ndarray:
        """The state covariance P, shape (7, 7) (a copy)."""
        return self.kf.P.copy()

    @property
    def box(self) -> np.ndarray:
        """The current state as an (x, y, w, h) box: after `update` the filtered box, after `predict` the prediction.

        Raises InvalidPrediction if the state is not a finite box with w, h > 0 (only possible
        after `predict` raised it, or if the state was edited by hand).
        """
        box = _state_box(self.kf.x)
        if box is None:
            raise InvalidPrediction(f"state {self.kf.x[:, 0].tolist()} is not a valid box")
        return box

    @property
    def velocity(self) -> np.ndarray:
        """(du, dv): the centre's velocity in pixels per frame, shape (2,)."""
        return self.kf.x[4:6, 0].copy()

    def predict(self, hold: bool = False) -> np.ndarray:
        """Advance one frame; return the predicted (x, y, w, h) box.

        If the area velocity would make the area non-positive (s + ds <= 0) it is set to zero
        first, as SORT does, so the area stays where it is.  Counters: age += 1; a track that
        was not updated in the previous frame loses its hit streak; time_since_update += 1.

        hold=True (motion while hidden, off by default): once the track went a frame without an
        update (time_since_update > 0), the size is frozen (the area velocity ds is set to 0;
        the aspect ratio has no velocity anyway) and the centre keeps its velocity, capped at
        HIDDEN_MAX_SPEED * sqrt(area) px per frame: constant velocity, bounded, size held.

        Raises InvalidPrediction if the predicted box is not finite or has w <= 0 or h <= 0
        (the state is still advanced and the counters still move; the caller should drop the track).
        """
        self._before_predict(hold)
        self.kf.predict()
        self._after_predict()
        return self.box  # raises InvalidPrediction for a non-finite box or w, h <= 0

    @staticmethod
    def predict_many(filters: "list[BoxKalman]", hold: bool = False) -> "list[np.ndarray | None]":
        """``f.predict(hold)`` for every filter, the filters advanced as one batch
        (refimpl.tracking.kalman.predict_many: the same bits): each one's predicted box, or None
        where ``predict`` would raise InvalidPrediction (that filter is advanced all the same)."""
        boxes, ok = BoxKalman.predict_box_array(filters, hold)
        return [box if good else None for box, good in zip(boxes, ok.tolist())]

    @staticmethod
    def predict_box_array(filters: "list[BoxKalman]", hold: bool = False) -> "tuple[np.ndarray, np.ndarray]":
        """predict_many as one (n, 4) array and a mask of the rows that are boxes (where predict
        would raise InvalidPrediction the row is not one): per box the IEEE operations of
        _box_values, elementwise (numpy's float64 sqrt, products and quotients round as Python's do)."""
        for f in filters:
            f._before_predict(hold)
        X = predict_many([f.kf for f in filters])
        states = (np.array([f.kf.x[:, 0] for f in filters]) if X is None else X[:, :, 0]).reshape(-1, DIM_X)
        for f in filters:
            f._after_predict()
        return boxes_of_states(states)

    def _before_predict(self, hold: bool) -> None:
        x = self.kf.x
        if self.size_change and self.time_since_update > 0 and x[2, 0] > 0:
            s, bound = float(x[2, 0]), self.size_change
            x[6, 0] = min(max(float(x[6, 0]), s / bound - s), s * bound - s)
        if hold and self.time_since_update > 0:
            x[6, 0] = 0.0
            if x[2, 0] > 0:
                cap = HIDDEN_MAX_SPEED * float(np.sqrt(x[2, 0]))
                speed = float(np.hypot(x[4, 0], x[5, 0]))
                if speed > cap:
                    x[4:6, 0] *= cap / speed
        if x[2, 0] + x[6, 0] <= 0:
            x[6, 0] = 0.0

    def _after_predict(self) -> None:
        self.age += 1
        if self.time_since_update > 0:
            self.hit_streak = 0
        self.time_since_update += 1

    def update(self, box_xywh, wander: float = 0.0) -> None:
        """Correct the state with a detected (x, y, w, h) box. Counters: hits += 1, hit_streak += 1, time_since_update = 0.
        ``wander``: 0 (SORT's measurement noise R), or the share of the box by which the detector's
        centres wander (centre_noise)."""
        z = xywh_to_z(box_xywh)
        self.kf.R = centre_noise(self.kf.x, wander) if wander else _R
        self.kf.update(z.reshape(DIM_Z, 1))
        self._observed(box_xywh)

    @staticmethod
    def update_many(filters: "list[BoxKalman]", boxes, wander: float = 0.0) -> "list[list[float]] | None":
        """``f.update(box, wander)`` for every (filter, box) pair, the filters corrected as one batch
        (refimpl.tracking.kalman.update_many: the same bits; with ``wander`` each filter has its own
        R, and they are corrected one by one).  Every box is checked before any
        filter changes.  Returns each filter's new state as a list of Python floats where the batch
        left them stacked (for ``box_of_state``), else None."""
        b = np.asarray(boxes, dtype=float)
        if b.ndim != 2 or b.shape[1] != 4:  # not n boxes of four numbers: xywh_to_z says which is wrong
            zs = [xywh_to_z(v).reshape(DIM_Z, 1) for v in boxes]
        else:  # xywh_to_z of every row, each checked before any filter changes
            zs = [_z_values(v) for v in b.tolist()]
        if not len(zs):
            return None
        for f in filters:
            f.kf.R = centre_noise(f.kf.x, wander) if wander else _R
        stacked = update_many([f.kf for f in filters], np.array(zs, dtype=float).reshape(-1, DIM_Z, 1))
        if stacked is None or b.ndim != 2:
            for f, v in zip(filters, b if b.ndim == 2 else boxes):
                f._observed(v)
            return None
        # what _observed keeps, copied once for the batch: rows of private copies (kf.x and kf.P
        # are views of the stacks, which may be changed in place)
        X, P = stacked
        kept_x, kept_p, kept_b = X.copy(), P.copy(), b.copy()
        for k, f in enumerate(filters):
            f._last_obs = (kept_x[k], kept_p[k], kept_b[k])
            f._counted()
        return X[:, :, 0].tolist()

    @staticmethod
    def box_of_state(values: "list[float]") -> np.ndarray:
        """``box`` of a state given as its list of Python floats (update_many's answer)."""
        box = _box_values(values)
        if box is None:
            raise InvalidPrediction(f"state {values} is not a valid box")
        return np.array(box)

    def _observed(self, box_xywh) -> None:
        # the state right after the update, for reupdate: copies (kf.x may be changed in place, as
        # SORT's own code does)
        self._last_obs = (self.kf.x.copy(), self.kf.P.copy(), np.array(box_xywh, dtype=float).reshape(4))
        self._counted()

    def _counted(self) -> None:
        """SORT's counters after an update."""
        self.time_since_update = 0
        self.hits += 1
        self.hit_streak += 1

    def reupdate(self, box_xywh, wander: float = 0.0) -> None:
        """Update after a gap, observation-centric (the idea of OC-SORT's re-update; written here).

        After k = time_since_update predictions without an update (k >= 2: a gap of k-1 frames),
        the filter goes back to its state right after the last observation and is re-run along
        a virtual trajectory: at step i = 1 .. k-1 it predicts and is updated with the box
        linearly interpolated (x, y, w, h) between the last observed box and box_xywh at i / k,
        and at step k it predicts and is updated with box_xywh itself.  So the velocity after a
        long occlusion is the one the gap implies, not the one the unobserved drift left.  With
        k <= 1 this is update().  Counters as update(); age is unchanged (the predictions were
        counted when they were made).  ``wander``: as update's, at every step.
        """
        k = self.time_since_update
        if k <= 1:
            self.update(box_xywh, wander)
            return
        z2 = xywh_to_z(box_xywh)  # validates before the state is touched
        x0, p0, last = self._last_obs
        new = np.asarray(box_xywh, dtype=float).reshape(4)
        self.kf.x, self.kf.P = x0.copy(), p0.copy()
        for i in range(1, k + 1):
            x = self.kf.x
            if x[2, 0] + x[6, 0] <= 0:
                x[6, 0] = 0.0
            self.kf.predict()
            z = z2 if i == k else xywh_to_z(last + (new - last) * (i / k))
            self.kf.R = centre_noise(self.kf.x, wander) if wander else _R
            self.kf.update(z.reshape(DIM_Z, 1))
        self._observed(box_xywh)
