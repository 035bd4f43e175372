"""Constant-velocity linear Kalman filter for tracked bodies (seed Section 5.1, Eqs. 2-4).

State x = [p, p_dot] (metres, metres per second), measurement y = p (metres).
``predict``/``update`` are the single-body reference built on filterpy;
``batch_predict``/``batch_update`` are the same equations over a leading batch axis
(bodies, scenarios), compiled with numba, used by the KalmanTracker system and by the
batched verifier.
Tests check the two agree. A missing measurement (None, NaN or masked out) means
predict only.
"""

import numba
import numpy as np
from filterpy.kalman import predict as _filterpy_predict
from filterpy.kalman import update as _filterpy_update

_I3 = np.eye(3)
_O3 = np.zeros((3, 3))


def transition_matrix(dt: float | np.ndarray) -> np.ndarray:
    """Eq. 2: F = [[I3, dt I3], [O3, I3]] for a sampling time dt in seconds.

    An array of dt of shape D gives shape D + (6, 6).
    """
    dt = np.asarray(dt, dtype=float)
    F = np.broadcast_to(np.eye(6), dt.shape + (6, 6)).copy()
    F[..., [0, 1, 2], [3, 4, 5]] = dt[..., None]
    return F


def measurement_matrix() -> np.ndarray:
    """Eq. 3: H = [I3, O3] (the sensor measures position only)."""
    return np.hstack([_I3, _O3])


def process_noise(dt: float, q2: float) -> np.ndarray:
    """Eq. 4: Q = blockdiag(I3 dt^2, Q2) with Q2 = q2 I3.

    The seed leaves Q2 unspecified ("uncertainty on the velocity dynamics"); we take it
    isotropic, q2 in metres squared per second squared per step. The position block
    I3 dt^2 is used exactly as printed (units: seconds squared, read as metres squared).
    An array of dt of shape D gives shape D + (6, 6).
    """
    dt = np.asarray(dt, dtype=float)
    Q = np.zeros(dt.shape + (6, 6))
    Q[..., [0, 1, 2], [0, 1, 2]] = (dt * dt)[..., None]
    Q[..., [3, 4, 5], [3, 4, 5]] = q2
    return Q


def _missing(z: np.ndarray | None) -> bool:
    return z is None or not np.all(np.isfinite(z))


def predict(
    x: np.ndarray, P: np.ndarray, F: np.ndarray, Q: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Prior of one body: x (6,), P (6, 6) -> F x, F P F^T + Q (filterpy)."""
    return _filterpy_predict(x, P, F, Q)


def update(
    x: np.ndarray, P: np.ndarray, z: np.ndarray | None, R: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Posterior of one body given a position measurement z (3,) with covariance R (3, 3).

    z None or non-finite: no measurement, x and P returned unchanged. Uses filterpy's
    Joseph-form update with H of Eq. 3.
    """
    if _missing(z):
        return x, P
    return _filterpy_update(x, P, np.asarray(z, dtype=float), R, measurement_matrix())


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def predict_one(x, P, F, Q, x_out, P_out, FP):
    """F x and F P F^T + Q of one body (x (6,), P, F, Q (6, 6)) into x_out, P_out, with
    FP (6, 6) as scratch; compiled and callable from other compiled code."""
    for i in range(6):
        acc = 0.0
        for j in range(6):
            acc += F[i, j] * x[j]
        x_out[i] = acc
    for i in range(6):
        for j in range(6):
            fp_ij = 0.0
            for k in range(6):
                fp_ij += F[i, k] * P[k, j]
            FP[i, j] = fp_ij
    for i in range(6):
        for j in range(6):
            acc = 0.0
            for k in range(6):
                acc += FP[i, k] * F[j, k]
            P_out[i, j] = acc + Q[i, j]


@numba.njit(cache=True)
def _predict_rows(x, P, F, Q, x_out, P_out):
    """:func:`predict_one` of every row (all arrays 2-D/3-D per row)."""
    FP = np.empty((6, 6))
    for b in range(x.shape[0]):
        predict_one(x[b], P[b], F[b], Q[b], x_out[b], P_out[b], FP)


def _rows3(a: np.ndarray, n: int, shape: tuple) -> np.ndarray:
    """``a`` of shape ``shape`` or (n,) + ``shape``, as a contiguous (n,) + ``shape`` array."""
    a = np.asarray(a, dtype=float)
    return np.ascontiguousarray(np.broadcast_to(a, (n,) + shape))


def batch_predict(
    x: np.ndarray, P: np.ndarray, F: np.ndarray, Q: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``predict`` over a leading batch axis: x (B, 6), P (B, 6, 6), F and Q (6, 6) or
    (B, 6, 6). Returns new arrays (compiled)."""
    x = np.ascontiguousarray(x, dtype=float)
    n = x.shape[0]
    x_new, P_new = np.empty((n, 6)), np.empty((n, 6, 6))
    _predict_rows(x, _rows3(P, n, (6, 6)), _rows3(F, n, (6, 6)), _rows3(Q, n, (6, 6)), x_new,
                  P_new)
    return x_new, P_new


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def update_one(x, P, z, R, x_out, P_out, S, S_inv, K, A):
    """The Joseph-form update with H = [I3, O3] of one body (see :func:`batch_update`)
    into x_out, P_out, with S, S_inv (3, 3), K (6, 3), A (6, 6) as scratch; compiled
    and callable from other compiled code."""
    for i in range(3):
        for j in range(3):
            S[i, j] = P[i, j] + R[i, j]
    # S^-1 by cofactors (S is symmetric positive definite, 3 x 3).
    c00 = S[1, 1] * S[2, 2] - S[1, 2] * S[2, 1]
    c01 = S[1, 2] * S[2, 0] - S[1, 0] * S[2, 2]
    c02 = S[1, 0] * S[2, 1] - S[1, 1] * S[2, 0]
    det = S[0, 0] * c00 + S[0, 1] * c01 + S[0, 2] * c02
    S_inv[0, 0], S_inv[1, 0], S_inv[2, 0] = c00 / det, c01 / det, c02 / det
    S_inv[0, 1] = (S[0, 2] * S[2, 1] - S[0, 1] * S[2, 2]) / det
    S_inv[1, 1] = (S[0, 0] * S[2, 2] - S[0, 2] * S[2, 0]) / det
    S_inv[2, 1] = (S[0, 1] * S[2, 0] - S[0, 0] * S[2, 1]) / det
    S_inv[0, 2] = (S[0, 1] * S[1, 2] - S[0, 2] * S[1, 1]) / det
    S_inv[1, 2] = (S[0, 2] * S[1, 0] - S[0, 0] * S[1, 2]) / det
    S_inv[2, 2] = (S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]) / det
    for i in range(6):  # K = P H^T S^-1
        for j in range(3):
            acc = 0.0
            for k in range(3):
                acc += P[i, k] * S_inv[k, j]
            K[i, j] = acc
    for i in range(6):  # x + K (z - H x)
        acc = x[i]
        for k in range(3):
            acc += K[i, k] * (z[k] - x[k])
        x_out[i] = acc
    for i in range(6):  # A = (I - K H) P = P - K P[:3]
        for j in range(6):
            acc = P[i, j]
            for k in range(3):
                acc -= K[i, k] * P[k, j]
            A[i, j] = acc
    for i in range(6):  # A (I - K H)^T + K R K^T
        for j in range(6):
            acc = A[i, j]
            for k in range(3):
                acc -= A[i, k] * K[j, k]
            for k in range(3):
                for m in range(3):
                    acc += K[i, k] * R[k, m] * K[j, m]
            P_out[i, j] = acc


@numba.njit(cache=True)
def _update_rows(x, P, z, R, mask, x_out, P_out):
    """:func:`update_one` of the rows in ``mask``; the others are copied."""
    S, S_inv, K, A = np.empty((3, 3)), np.empty((3, 3)), np.empty((6, 3)), np.empty((6, 6))
    for b in range(x.shape[0]):
        if mask[b]:
            update_one(x[b], P[b], z[b], R[b], x_out[b], P_out[b], S, S_inv, K, A)
        else:
            x_out[b] = x[b]
            P_out[b] = P[b]


def batch_update(
    x: np.ndarray,
    P: np.ndarray,
    z: np.ndarray,
    R: np.ndarray,
    valid_mask: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """``update`` over a leading batch axis with H of Eq. 3.

    Args:
        x: (B, 6) prior states. P: (B, 6, 6) prior covariances.
        z: (B, 3) measured positions, metres (rows with NaN count as missing).
        R: (3, 3) or (B, 3, 3) measurement covariance, metres squared.
        valid_mask: (B,) bool, rows to update; others are returned unchanged.

    Returns new arrays (Joseph form, as filterpy; compiled).
    """
    x = np.ascontiguousarray(x, dtype=float)
    z = np.ascontiguousarray(z, dtype=float)
    n = x.shape[0]
    mask = np.all(np.isfinite(z), axis=-1)
    if valid_mask is not None:
        mask &= np.asarray(valid_mask, dtype=bool)
    x_new, P_new = np.empty((n, 6)), np.empty((n, 6, 6))
    _update_rows(x, _rows3(P, n, (6, 6)), z, _rows3(R, n, (3, 3)), mask, x_new, P_new)
    return x_new, P_new


def initial_covariance(
    measurement_std: float, velocity_std: float, batch: tuple[int, ...] = ()
) -> np.ndarray:
    """Covariance of a track started from one measurement with unknown velocity:
    blockdiag(measurement_std^2 I3, velocity_std^2 I3); metres, metres per second."""
    diag = np.r_[np.full(3, measurement_std**2), np.full(3, velocity_std**2)]
    return np.broadcast_to(np.diag(diag), batch + (6, 6)).copy()
