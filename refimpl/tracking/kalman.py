"""A linear Kalman filter with the arithmetic of filterpy's ``KalmanFilter`` (SORT's filter).

SORT (and refimpl before this module) runs each track's motion model on
``filterpy.kalman.KalmanFilter``.  Importing filterpy costs about 1.5 s (its package imports
filterpy.stats, which imports scipy.stats), more than tracking a whole KITTI sequence, and its
``predict``/``update`` spend most of their time on bookkeeping the tracker never reads (prior
and posterior copies, a deep copy of z, the log-likelihood fields).  ``LinearKalman`` keeps only
the state: x (dim_x, 1), P, and the model F, H, Q, R.

Its ``predict`` and ``update`` perform the *same floating-point operations in the same order*
as filterpy 1.4.5 / 2.0.0 without a control input: the same ``numpy.dot`` calls on operands of
the same shapes and memory layouts (so the same BLAS routines: gemv for a matrix times the
(n, 1) state, gemm otherwise, the transposes as views), numpy.linalg.inv's kernel for S^-1 (``_inv``), and the
Joseph form of the covariance update.  So the filtered states are bit for bit filterpy's, and
refimpl's results files did not change when it replaced filterpy
(tests/test_kalman.py drives both with the same inputs and compares every bit of x and P).
``predict_many`` / ``update_many`` do the same arithmetic for a frame's filters as one batch
(numpy.matmul on the stacks: per slice the BLAS routine numpy.dot runs, the same bits).

    predict:  x = F x
              P = F P F^T + Q          (filterpy: alpha_sq * F P F^T + Q with alpha_sq = 1.0;
                                        multiplying by 1.0 changes no float, so it is left out)
    update:   y = z - H x
              PHT = P H^T;  S = H PHT + R;  SI = inv(S);  K = PHT SI
              x = x + K y
              I_KH = I - K H
              P = (I_KH P) I_KH^T + (K R) K^T

Do not "simplify" an expression here (e.g. H x as x[:4], F P as a few additions, P H^T as a
slice): mathematically equal, such a rewrite rounds differently or treats 0 * inf differently,
and the tracker's outputs would change.
"""

from __future__ import annotations

import math

import numpy as np

_dot = np.dot

try:  # numpy.linalg.inv's own kernel (LAPACK gesv against the identity), without its wrapper
    from numpy.linalg import _umath_linalg as _linalg_kernels
    _KERNEL_INV = _linalg_kernels.inv
except (ImportError, AttributeError):  # a numpy without it: the public function, same numbers
    _KERNEL_INV = None


def _inv(S: np.ndarray) -> np.ndarray:
    """numpy.linalg.inv(S) for a float64 matrix (or a stack of them), bit for bit: the same gufunc numpy.linalg.inv
    calls, without the ``errstate`` context it enters on every call (about three quarters of
    its time on a 4 x 4 matrix, and inv was a quarter of an update).  S = H P H^T + R is
    positive definite for a finite P (R > 0), so gesv never reports it singular; should it (or
    should P hold a non-finite value), the result is not finite and numpy.linalg.inv is called
    after all: it raises LinAlgError for a singular S as before."""
    if _KERNEL_INV is not None and S.dtype == np.float64:
        out = _KERNEL_INV(S)  # float64 in: the kernel's d->d loop, which numpy.linalg.inv names
        # the cheapest test that every entry is finite: a finite sum (a NaN or an infinity makes it
        # NaN or infinite; so may an overflow of finite entries, which then takes the slow path too)
        if math.isfinite(out.sum()):
            return out
    return np.linalg.inv(S)


class LinearKalman:
    """State x (dim_x, 1) and covariance P of a linear model x' = F x + noise(Q), z = H x + noise(R).

    The attributes are plain arrays and may be assigned (as filterpy's): x, P, F, H, Q, R.
    F and H are read on every call, so a new matrix takes effect at the next predict/update.
    """

    __slots__ = ("x", "P", "F", "H", "Q", "R", "_I")

    def __init__(self, x: np.ndarray, P: np.ndarray, F: np.ndarray, H: np.ndarray, Q: np.ndarray,
                 R: np.ndarray):
        dim_x = F.shape[0]
        if (x.shape != (dim_x, 1) or F.shape != (dim_x, dim_x) or P.shape != F.shape or Q.shape != F.shape
                or H.shape[1:] != (dim_x,) or R.shape != (H.shape[0], H.shape[0])):
            raise ValueError(f"inconsistent shapes: x {x.shape}, P {P.shape}, F {F.shape}, H {H.shape}, "
                             f"Q {Q.shape}, R {R.shape}")
        self.x, self.P, self.F, self.H, self.Q, self.R = x, P, F, H, Q, R
        self._I = np.eye(dim_x)

    def predict(self) -> None:
        """Advance one step: filterpy's ``KalmanFilter.predict()`` (no control input)."""
        F = self.F
        self.x = _dot(F, self.x)
        self.P = _dot(_dot(F, self.P), F.T) + self.Q

    def update(self, z: np.ndarray) -> None:
        """Correct with the measurement z, shape (dim_z, 1): filterpy's ``KalmanFilter.update(z)``."""
        H, R, P = self.H, self.R, self.P
        y = z - _dot(H, self.x)
        PHT = _dot(P, H.T)
        S = _dot(H, PHT) + R
        SI = _inv(S)
        K = _dot(PHT, SI)
        self.x = self.x + _dot(K, y)
        I_KH = self._I - _dot(K, H)
        self.P = _dot(_dot(I_KH, P), I_KH.T) + _dot(_dot(K, R), K.T)


def predict_many(filters: "list[LinearKalman]") -> np.ndarray | None:
    """``f.predict()`` for every filter, computed as one batch: the same numbers bit for bit (see
    update_many; F shared, each filter's own Q added to its own slice).  Filters that do not share F
    (or fewer than two) are advanced one by one.  Returns the batch's stacked states, shape
    (n, dim_x, 1) (each filter's x is a view of it), or None where they were advanced one by one."""
    if len(filters) < 2 or any(f.F is not filters[0].F for f in filters):
        for f in filters:
            f.predict()
        return None
    F = filters[0].F
    mm = np.matmul
    X = mm(F, np.array([f.x for f in filters]))
    P = mm(mm(F, np.array([f.P for f in filters])), F.T) + np.array([f.Q for f in filters])
    for k, f in enumerate(filters):
        f.x, f.P = X[k], P[k]
    return X


def update_many(filters: "list[LinearKalman]", zs: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """``f.update(zs[k])`` for every filter k, computed as one batch (``zs``: shape (n, dim_z, 1)).

    The same numbers bit for bit: ``numpy.matmul`` on the stacks runs, slice by slice, the BLAS
    routine ``numpy.dot`` runs on each pair of matrices (gemm, with the transposes as strided
    views, as in ``update``), and the inverse kernel inverts each S on its own; tests/test_kalman.py
    compares every bit of x and P with one ``update`` per filter, on random and on real states.
    A tracker updates a handful of filters a frame, so one batch replaces ~9 small numpy calls per
    filter by ~9 per frame.  Filters that do not share H and R (or fewer than two) are updated one
    by one.  Returns the batch's stacked states and covariances, shapes (n, dim_x, 1) and (n, dim_x,
    dim_x) (each filter's x and P are views of them), or None where they were updated one by one."""
    n = len(filters)
    if n < 2 or any(f.H is not filters[0].H or f.R is not filters[0].R for f in filters):
        for f, z in zip(filters, zs):
            f.update(z)
        return None
    first = filters[0]
    H, R, I = first.H, first.R, first._I
    X = np.array([f.x for f in filters])
    P = np.array([f.P for f in filters])
    mm = np.matmul
    y = zs - mm(H, X)
    PHT = mm(P, H.T)
    S = mm(H, PHT) + R
    SI = _inv(S)
    K = mm(PHT, SI)
    X = X + mm(K, y)
    I_KH = I - mm(K, H)
    P = mm(mm(I_KH, P), I_KH.transpose(0, 2, 1)) + mm(mm(K, R), K.transpose(0, 2, 1))
    for k, f in enumerate(filters):
        f.x, f.P = X[k], P[k]
    return X, P
