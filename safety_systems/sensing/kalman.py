"""Constant-velocity linear Kalman filter for tracked bodies (seed Section 5.1, Eqs. 2-4).

State x = [p, p_dot] (metres, metres per second), measurement y = p (metres).
The filter is isotropic (Q of Eq. 4, R = std^2 I3 and a new track's covariance treat the three axes
alike, and every frame measures all three or none), so its 6 x 6 covariance is the same
2 x 2 (position, velocity) covariance on each axis: ``axis_predict``/``axis_update`` are
that axis' equations, compiled (numba), used by the KalmanTracker system and the
batched verifier, and held to filterpy's 6-D filter by the tests (``tests/kalman_reference.py``;
filterpy is a test dependency only). A missing measurement means predict only.
"""

import numba
import numpy as np

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


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def axis_predict(p, c, w, dt, q2):
    """One axis of Eqs. 2 and 4's prediction F P F^T + Q, F = [[1, dt], [0, 1]] and
    Q = diag(dt^2, q2) (the (0, 3) block of ``transition_matrix`` and ``process_noise``):
    the axis' covariance P = [[p, c], [c, w]] of (position, velocity) -> (p, c, w).
    Compiled and callable from other compiled code."""
    fp, fc = p + dt * c, c + dt * w  # first row of F P
    return fp + dt * fc + dt * dt, fc, w + q2


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def axis_update(p, c, w, r):
    """One axis of Eq. 3's update, H = [1, 0] and measurement variance r, in Joseph form
    (as filterpy): the gains (k_p, k_v) = P H^T / (p + r) and the new (p, c, w) of
    (I - K H) P (I - K H)^T + r K K^T. Compiled and callable from other compiled code."""
    s = p + r
    k_p, k_v = p / s, c / s
    a = 1.0 - k_p
    b = c - k_v * p  # (I - K H) P's lower-left entry
    return (k_p, k_v, a * p * a + r * k_p * k_p, -(a * p) * k_v + a * c + r * k_p * k_v,
            -b * k_v + (w - k_v * c) + r * k_v * k_v)


def initial_covariance(
    measurement_std: float, velocity_std: float, batch: tuple[int, ...] = ()
) -> np.ndarray:
    """Covariance of a track started from one measurement with unknown velocity:
    blockdiag(measurement_std^2 I3, velocity_std^2 I3); metres, metres per second."""
    diag = np.r_[np.full(3, measurement_std**2), np.full(3, velocity_std**2)]
    return np.broadcast_to(np.diag(diag), batch + (6, 6)).copy()
