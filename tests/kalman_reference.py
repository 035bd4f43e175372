"""The single-body reference of the tracker's Kalman filter (seed 000, Eqs. 2-4), built on
filterpy's 6-D filter: the oracle that ``safety_systems.sensing.kalman``'s compiled
per-axis equations are held to (filterpy is a test dependency, not the product's)."""

import numpy as np
from filterpy.kalman import predict as _filterpy_predict
from filterpy.kalman import update as _filterpy_update

from safety_systems.sensing.kalman import measurement_matrix


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
