"""KalmanTracker: one constant-velocity Kalman filter per tracked body (seed Eqs. 2-4)."""

import math

import numba
import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (
    BasicVector,
    Context,
    DiscreteValues,
    LeafSystem,
    ValueProducer,
)

from safety_systems import kalman
from safety_systems.compiled_cache import drop_stale_builds
from safety_systems.kalman import axis_predict, axis_update
from safety_systems.systems.separation_monitor import (
    TRACK_COASTING,
    TRACK_LOST,
    TRACK_NONE,
    TRACK_TRACKING,
)

# Per-body state slot: x (6), P (36), status, time of the last predict/update, time last seen.
_X, _P, _STATUS, _T_LAST, _T_SEEN = slice(0, 6), slice(6, 42), 42, 43, 44
TRACK_SLOT = 45
MIN_MEASUREMENT_STD = 1e-6  # m; keeps R positive definite for a noise-free sensor

# Its compiled functions inline kalman's (see compiled_cache).
drop_stale_builds(__file__, (kalman,))


@numba.njit(cache=True)
def _track_rows(tracks, rows, frame_time, z, valid, measurement_std, velocity_process_noise,
                initial_velocity_std, max_coast_time, exit_radius):
    """:func:`track_step` of the track rows ``rows`` of ``tracks`` (in place), their frame
    times, measurements (R, 3) and valid flags (R,); compiled. The filter is isotropic
    (see ``kalman``): one axis' covariance is predicted (Eqs. 2 and 4) and updated
    (Eq. 3) and the 6 x 6 covariance rebuilt from it; a new track's covariance is
    ``kalman.initial_covariance``."""
    r2 = measurement_std**2
    for r in range(rows.size):
        track, t = tracks[rows[r]], frame_time[r]
        status = track[_STATUS]
        active = status == TRACK_TRACKING or status == TRACK_COASTING
        seen = (valid[r] and math.isfinite(z[r, 0]) and math.isfinite(z[r, 1])
                and math.isfinite(z[r, 2]))
        if active:  # Eqs. 2 and 4, then Eq. 3 if measured
            dt = t - track[_T_LAST]
            p, c, w = axis_predict(track[6], track[6 + 3], track[6 + 21], dt,
                                   velocity_process_noise)
            if seen:
                k_p, k_v, p, c, w = axis_update(p, c, w, r2)
            for i in range(3):
                track[i] += dt * track[i + 3]
                if seen:
                    innovation = z[r, i] - track[i]
                    track[i] += k_p * innovation
                    track[i + 3] += k_v * innovation
            track[_T_LAST] = t
        elif seen:  # a new track at the measurement, velocity unknown
            p, c, w = r2, 0.0, initial_velocity_std**2
            for i in range(3):
                track[i], track[i + 3] = z[r, i], 0.0
            track[_T_LAST] = t
        if active or seen:
            for i in range(36):
                track[6 + i] = 0.0
            for i in range(3):  # [[p I3, c I3], [c I3, w I3]]
                track[6 + 7 * i], track[6 + 7 * (i + 3)] = p, w
                track[6 + 6 * i + i + 3], track[6 + 6 * (i + 3) + i] = c, c
        if seen:
            track[_STATUS], track[_T_SEEN] = TRACK_TRACKING, t
        elif active:
            track[_STATUS] = TRACK_COASTING
            if t - track[_T_SEEN] > max_coast_time:
                outside = np.hypot(track[0], track[1]) > exit_radius
                track[_STATUS] = TRACK_NONE if outside else TRACK_LOST


def track_step(
    tracks: np.ndarray,
    frame_time: float | np.ndarray,
    z: np.ndarray,
    valid: np.ndarray,
    *,
    measurement_std: float,
    velocity_process_noise: float,
    initial_velocity_std: float,
    max_coast_time: float,
    exit_radius: float,
) -> np.ndarray:
    """Process one sensor frame for every body slot; returns the new (N, 45) track array.

    Tracks that exist (tracking or coasting) are predicted to ``frame_time`` with their
    own dt (Eqs. 2 and 4) and updated where the body is ``valid`` (Eq. 3). A valid body
    without a track starts one at the measured position with zero velocity and
    ``initial_velocity_std``. A track not seen for more than ``max_coast_time`` ends
    (status none) if its last estimate lies more than ``exit_radius`` from the robot
    base horizontally (the operator walked out of the cell), and is otherwise marked
    lost (it vanished near the robot: the SpeedOverride stops). A lost track stays
    lost until its body is seen again. ``frame_time`` is the frame's capture time, s:
    one for all rows, or one per row (the batched verifier steps many cells at once).
    """
    out = np.array(tracks, dtype=float, order="C")
    rows = np.arange(out.shape[0])
    frame_time = np.ascontiguousarray(np.broadcast_to(np.asarray(frame_time, dtype=float),
                                                      rows.shape))
    _track_rows(out, rows, frame_time, np.ascontiguousarray(z, dtype=float),
                np.ascontiguousarray(valid, dtype=bool), float(measurement_std),
                float(velocity_process_noise), float(initial_velocity_std),
                float(max_coast_time), float(exit_radius))
    return out


@numba.njit(cache=True)
def _estimate_rows(tracks, rows, p, v, status, unseen):
    """The outputs of the track rows ``rows`` (see :func:`track_estimates`, all but the
    position std) into the same rows of p, v (., 3), status and unseen (.); compiled."""
    for r in range(rows.size):
        row = rows[r]
        track = tracks[row]
        status[row] = track[_STATUS]
        none = track[_STATUS] == TRACK_NONE
        for i in range(3):
            p[row, i] = np.nan if none else track[i]
            v[row, i] = np.nan if none else track[i + 3]
        unseen[row] = 0.0 if none else track[_T_LAST] - track[_T_SEEN]


def position_std(tracks: np.ndarray) -> np.ndarray:
    """Root of the largest eigenvalue of each (..., 45) track's position covariance, m."""
    P_pos = tracks[..., _P].reshape(tracks.shape[:-1] + (6, 6))[..., :3, :3]
    return np.sqrt(np.maximum(np.linalg.eigvalsh(P_pos)[..., -1], 0.0))


def track_estimates(
    tracks: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The tracker's outputs from a (..., 45) track array: states x (..., 6) (NaN without
    a track), status (...), position std (...), the root of the largest eigenvalue of
    the position covariance in metres, and unseen time (...), the seconds between the
    track's last measurement and its newest frame (0 when seen in it or untracked)."""
    lead = tracks.shape[:-1]
    flat = np.ascontiguousarray(tracks, dtype=float).reshape(-1, TRACK_SLOT)
    n = flat.shape[0]
    p, v, status, unseen = np.empty((n, 3)), np.empty((n, 3)), np.empty(n), np.empty(n)
    _estimate_rows(flat, np.arange(n), p, v, status, unseen)
    x = np.concatenate([p, v], axis=1).reshape(lead + (6,))
    return x, status.reshape(lead), position_std(tracks), unseen.reshape(lead)


class KalmanTracker(LeafSystem):
    """Tracks every body slot from the sensor's frames and flags sensor faults.

    At each of its updates (every sensor period, ``processing_time`` after a frame is
    due to be delivered) it takes the newest delivered frame, if it is new, through
    :func:`track_step`. Outputs are the filtered estimates at the frame's capture time.
    ``fault`` is 1 when the newest processed frame is older than ``frame_timeout`` (a
    missing frame, or no frame yet) or the newest frame was bad (capture time not moving
    forward, or a body flagged valid without a finite position), and 0 otherwise; a
    stale frame is never extrapolated.

    .. pydrake_system::

        name: KalmanTracker
        input_ports:
        - positions_measured
        - valid
        - sample_time
        output_ports:
        - positions_estimated
        - velocities_estimated
        - track_status
        - position_std
        - unseen_time
        - fault

    Untracked slots (status none) output NaN positions and velocities. ``position_std``
    is the root of the largest eigenvalue of each track's position covariance, metres;
    ``unseen_time`` the seconds since each track was last measured, as of its newest frame.

    Args:
        num_bodies: body slots N.
        period_sec: the sensor's capture period, seconds.
        latency_sec: the sensor's delivery latency, seconds.
        processing_time: seconds from delivery to the tracker's update (> 0).
        frame_timeout: seconds after capture after which a frame is stale.
        measurement_std: the measurement noise per axis (N = std^2 I3), metres.
        velocity_process_noise: q2 of Eq. 4, metres squared per second squared.
        initial_velocity_std: velocity uncertainty of a new track, metres per second.
        max_coast_time: seconds a track survives without measurements.
        exit_radius: metres from the robot base beyond which an unseen track ends.
    """

    def __init__(self, *, num_bodies: int, period_sec: float, latency_sec: float,
                 processing_time: float, frame_timeout: float, measurement_std: float,
                 velocity_process_noise: float, initial_velocity_std: float,
                 max_coast_time: float, exit_radius: float) -> None:
        super().__init__()
        for name, value in dict(period_sec=period_sec, processing_time=processing_time,
                                frame_timeout=frame_timeout,
                                velocity_process_noise=velocity_process_noise,
                                initial_velocity_std=initial_velocity_std,
                                max_coast_time=max_coast_time, exit_radius=exit_radius).items():
            if not (np.isfinite(value) and value > 0.0):
                raise ValueError(f"{name}: got {value}; allowed: a finite number > 0")
        if not (np.isfinite(latency_sec) and latency_sec >= 0.0):
            raise ValueError(f"latency_sec: got {latency_sec}; allowed: a finite number >= 0")
        n = self._n = num_bodies
        self._timeout = float(frame_timeout)
        self._args = dict(
            measurement_std=max(float(measurement_std), MIN_MEASUREMENT_STD),
            velocity_process_noise=velocity_process_noise,
            initial_velocity_std=initial_velocity_std, max_coast_time=max_coast_time,
            exit_radius=exit_radius,
        )
        # Tracks, the capture time of the newest processed frame, and a bad-frame flag.
        self._state = self.DeclareDiscreteState(np.r_[np.zeros(n * TRACK_SLOT), -np.inf, 0.0])
        self._z = self.DeclareVectorInputPort("positions_measured", 3 * n)
        self._valid = self.DeclareVectorInputPort("valid", n)
        self._time = self.DeclareVectorInputPort("sample_time", 1)
        self.DeclarePeriodicDiscreteUpdateEvent(
            period_sec=period_sec, offset_sec=latency_sec + processing_time, update=self._update)
        self._out = self.DeclareCacheEntry(
            description="estimates",
            value_producer=ValueProducer(allocate=AbstractValue.Make(np.zeros((9, n))).Clone,
                                         calc=self._calc_estimates),
            prerequisites_of_calc={self.xd_ticket()},
        )
        for name, rows in (("positions_estimated", slice(0, 3)),
                           ("velocities_estimated", slice(3, 6)), ("track_status", 6),
                           ("position_std", 7), ("unseen_time", 8)):
            size = 3 * n if isinstance(rows, slice) else n
            self.DeclareVectorOutputPort(
                name, size, lambda c, o, r=rows: o.SetFromVector(np.ravel(self._out.Eval(c)[r], "F")),
                prerequisites_of_calc={self._out.ticket()},
            )
        self.DeclareVectorOutputPort("fault", 1, self._calc_fault,
                                     prerequisites_of_calc={self.xd_ticket(), self.time_ticket()})

    def _update(self, context: Context, discrete_state: DiscreteValues) -> None:
        t_frame = self._time.Eval(context)[0]
        state = context.get_discrete_state(self._state).get_value()
        if t_frame == state[-2] or t_frame == -np.inf:
            return  # no new frame: nothing to process (the fault output sees the age)
        n = self._n
        z = np.asarray(self._z.Eval(context)).reshape(n, 3)
        valid = self._valid.Eval(context) > 0.5
        if not (np.isfinite(t_frame) and t_frame > state[-2]) or not np.all(np.isfinite(z[valid])):
            # A bad frame (time not moving forward, or a valid body without a finite
            # position) is not used, and raises the fault until a good frame comes.
            discrete_state.get_mutable_value(self._state)[-1] = 1.0
            return
        tracks = state[:-2].reshape(n, TRACK_SLOT)
        new = track_step(tracks, t_frame, z, valid, **self._args)
        discrete_state.set_value(self._state, np.r_[new.ravel(), t_frame, 0.0])

    def _calc_estimates(self, context: Context, value: AbstractValue) -> None:
        tracks = context.get_discrete_state(self._state).get_value()[:-2].reshape(self._n, TRACK_SLOT)
        x, status, std, unseen = track_estimates(tracks)
        out = value.get_mutable_value()
        out[0:6] = x.T
        out[6] = status
        out[7] = std
        out[8] = unseen

    def _calc_fault(self, context: Context, output: BasicVector) -> None:
        t_frame, bad = context.get_discrete_state(self._state).get_value()[-2:]
        stale = not (context.get_time() - t_frame <= self._timeout)
        output.SetAtIndex(0, float(stale or bad != 0.0))
