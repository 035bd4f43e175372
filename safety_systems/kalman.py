"""Constant-velocity linear Kalman filter for tracked bodies (seed Section 5.1, Eqs. 2-4).

State x = [p, p_dot] (metres, metres per second), measurement y = p (metres).
``predict``/``update`` are the single-body reference built on filterpy;
``batch_predict``/``batch_update`` are the same equations in numpy over a leading batch
axis (bodies, scenarios), used by the KalmanTracker system and by the batched verifier.
Tests check the two agree. A missing measurement (None, NaN or masked out) means
predict only.
"""

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


def batch_predict(
    x: np.ndarray, P: np.ndarray, F: np.ndarray, Q: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``predict`` over a leading batch axis: x (B, 6), P (B, 6, 6), F and Q (6, 6) or
    (B, 6, 6). Returns new arrays."""
    x_new = np.einsum("...ij,...j->...i", F, x)
    P_new = F @ P @ np.swapaxes(F, -1, -2) + Q
    return x_new, P_new


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

    Returns new arrays (Joseph form, as filterpy).
    """
    z = np.asarray(z, dtype=float)
    mask = np.all(np.isfinite(z), axis=-1)
    if valid_mask is not None:
        mask &= np.asarray(valid_mask, dtype=bool)
    S = P[..., :3, :3] + R
    PHt = P[..., :, :3]
    # K = P H^T S^-1 (S symmetric): solve S K^T = (P H^T)^T.
    K = np.swapaxes(np.linalg.solve(S, np.swapaxes(PHt, -1, -2)), -1, -2)
    y = np.where(mask[..., None], z - x[..., :3], 0.0)
    x_new = x + np.einsum("...ij,...j->...i", K, y)
    I_KH = np.broadcast_to(np.eye(6), P.shape).copy()
    I_KH[..., :, :3] -= K
    P_new = I_KH @ P @ np.swapaxes(I_KH, -1, -2) + K @ R @ np.swapaxes(K, -1, -2)
    P_new = np.where(mask[..., None, None], P_new, P)
    return x_new, P_new


def initial_covariance(
    measurement_std: float, velocity_std: float, batch: tuple[int, ...] = ()
) -> np.ndarray:
    """Covariance of a track started from one measurement with unknown velocity:
    blockdiag(measurement_std^2 I3, velocity_std^2 I3); metres, metres per second."""
    diag = np.r_[np.full(3, measurement_std**2), np.full(3, velocity_std**2)]
    return np.broadcast_to(np.diag(diag), batch + (6, 6)).copy()
