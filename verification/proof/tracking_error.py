"""E, the bound on the distance between a tracked body and its estimate at the
estimate's capture time (``verification.proof.theorems``), by running the filter's
deterministic gain recursion from a new track until it converges and propagating
worst-case error and velocity bounds (linear in the noise bound and v_max)."""


import numba
import numpy as np

from safety_systems.config.scenario import ControllerConfig
from safety_systems.sensing.kalman import axis_predict, axis_update
from safety_systems.sensing.tracks import MIN_MEASUREMENT_STD

ERROR_HORIZON = 4000  # frames of the tracker's error recursion


CONVERGED = 1e-12  # m per unit of noise or speed: the recursion's last frames change less


@numba.njit(cache=True)

def _error_run(R, q2, v0, period, horizon, out):
    """The error coefficients after each frame of a new track seen in consecutive frames
    (per axis; ``out`` (horizon, 2): E . (n, v_max) bounds |estimate - true position| at
    that frame's capture time, for noise bounded by n and speed by v_max), compiled.

    One axis of the tracker's filter: covariance P = [[p, c], [c, w]] of (position,
    velocity), predicted and updated by ``kalman.axis_predict`` and ``axis_update`` (the
    tracker's own equations; gain (k_p, k_v) = P[:, 0] / (p + R)). With error e and
    velocity estimate m bounded by E . (n, v_max) and M . (n, v_max): the prior error is
    at most e + (m + v_max) dt (the body moves at most v_max dt), the posterior
    (1 - k_p) prior + k_p n (the measurement is within n), and the new velocity estimate
    |1 - k_v dt| m + |k_v| (e + v_max dt + n)."""
    p, c, w = R, 0.0, v0 * v0  # after the first measurement: x = [z, 0]
    e_n, e_v = 1.0, 0.0
    m_n, m_v = 0.0, 0.0
    out[0, 0], out[0, 1] = e_n, e_v
    dt = period
    for j in range(1, horizon):
        p, c, w = axis_predict(p, c, w, dt, q2)
        prior_n, prior_v = e_n + m_n * dt, e_v + (m_v + 1.0) * dt
        k_p, k_v, p, c, w = axis_update(p, c, w, R)
        m_n = abs(1.0 - k_v * dt) * m_n + abs(k_v) * (e_n + 1.0)
        m_v = abs(1.0 - k_v * dt) * m_v + abs(k_v) * (e_v + dt)
        e_n = (1.0 - k_p) * prior_n + k_p * 1.0
        e_v = (1.0 - k_p) * prior_v + k_p * 0.0
        out[j, 0], out[j, 1] = e_n, e_v


def estimate_error_coefficients(config: ControllerConfig, horizon: int = ERROR_HORIZON
                                ) -> tuple[float, float, bool]:
    """(alpha, beta, converged): per axis, |estimate - true position| <= alpha n +
    beta v_max at every accepted measurement, for noise bound n and speed bound v_max.

    Under ``hidden_bodies: hazard`` a track's filter restarts after every gap (an
    occlusion, a rejected entry, a dropped or bad frame: ``safety_systems.sensing.tracks``), so
    every accepted measurement is the j-th of a run of consecutive frames since a new
    track, and the bound is the largest over j of :func:`_error_run`. It is taken over
    ``horizon`` frames; ``converged`` says the coefficients' last tenth changed by less
    than ``CONVERGED`` (the gains and the linear recursion have reached their fixed
    point, so later frames add nothing)."""
    period = 1.0 / config.sensor.rate_hz
    m_std = config.sensor.noise_std if config.tracker.measurement_std is None \
        else config.tracker.measurement_std
    R = max(m_std, MIN_MEASUREMENT_STD) ** 2
    out = np.empty((horizon, 2))
    _error_run(R, config.tracker.velocity_process_noise, config.tracker.initial_velocity_std,
               period, horizon, out)
    tail = out[horizon - max(horizon // 10, 2):]
    converged = bool(horizon >= 20 and np.all(np.ptp(tail, axis=0) < CONVERGED))
    alpha, beta = out.max(axis=0)
    return float(alpha), float(beta), converged
