"""Scripted operators: timed straight-line waypoint paths with bounded speed and acceleration.

An operator's reference point follows timed waypoints. Waypoint 0 is the start position,
held until the departure time of waypoint 1. At each later waypoint's departure time
t_j the operator leaves p_{j-1} for p_j along a straight line with a trapezoidal
(or, for short segments, triangular) speed profile bounded by ``max_speed`` and
``max_acceleration``, arrives as early as the limits allow and holds there until the
next departure. The time of waypoint 0 only orders the list (the start is held for
all t before t_1).

Tracked bodies (gloves, head) are rigid world-frame offsets from the reference point
(the operator does not rotate). All functions accept an array of times (leading axis)
so the batched verifier can evaluate many instants at once; scalar times take a fast path
because the simulation calls them at the robot rate.
"""

import dataclasses
import math
from collections.abc import Sequence

import numba
import numpy as np

from safety_systems.cell.human_body import NUM_POINTS as NUM_BODY_POINTS
from safety_systems.cell.operators import MAX_BODIES_PER_OPERATOR


def _frozen(array: np.ndarray) -> np.ndarray:
    array = np.array(array, dtype=float)
    array.setflags(write=False)
    return array


@dataclasses.dataclass(frozen=True, eq=False)
class OperatorPath:
    """Precomputed segments of a waypoint path; build it with ``make_operator_path``.

    Segment k goes from waypoint k to waypoint k + 1 and departs at
    ``departure_times[k]``; it accelerates for ``accel_durations[k]`` seconds, cruises at
    ``peak_speeds[k]`` (metres per second) for ``cruise_durations[k]`` seconds and brakes
    for ``accel_durations[k]`` seconds.
    """

    waypoint_times: np.ndarray  # (M,) seconds
    waypoint_positions: np.ndarray  # (M, 3) metres, world frame
    max_speed: float  # metres per second
    max_acceleration: float  # metres per second squared
    departure_times: np.ndarray  # (M-1,)
    directions: np.ndarray  # (M-1, 3) unit vectors (zero for zero-length segments)
    lengths: np.ndarray  # (M-1,)
    accel_durations: np.ndarray  # (M-1,)
    cruise_durations: np.ndarray  # (M-1,)
    peak_speeds: np.ndarray  # (M-1,)

    @property
    def durations(self) -> np.ndarray:
        """Travel time of each segment, in seconds."""
        return 2.0 * self.accel_durations + self.cruise_durations


def segment_profile(
    lengths: np.ndarray, max_speed: float, max_acceleration: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fastest rest-to-rest profile for straight segments of the given lengths (metres).

    Returns (accel_durations, cruise_durations, peak_speeds): trapezoidal when the segment
    is long enough to reach ``max_speed``, otherwise triangular.
    """
    lengths = np.asarray(lengths, dtype=float)
    peak = np.minimum(max_speed, np.sqrt(lengths * max_acceleration))
    accel = peak / max_acceleration
    cruise = np.where(peak > 0.0, (lengths - peak * accel) / np.where(peak > 0, peak, 1.0), 0.0)
    return accel, np.maximum(cruise, 0.0), peak


def _check_paths(t: np.ndarray, p: np.ndarray, max_speed: np.ndarray,
                 max_acceleration: np.ndarray) -> None:
    """The checks of P paths' waypoints (times t (P, M), positions p, limits (P,)); an
    error names the path when there are several."""
    P, M = t.shape

    def of(i: int) -> str:
        return f" (path {i})" if P > 1 else ""

    bad = ~np.all(np.isfinite(t), axis=1)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise ValueError(f"times{of(i)}={t[i].tolist()}: need finite seconds")
    bad = np.any(np.diff(t, axis=1) <= 0.0, axis=1)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise ValueError(f"times{of(i)}={t[i].tolist()}: must be strictly increasing")
    if p.shape != (P, M, 3) or not np.all(np.isfinite(p)):
        shape = p.shape[1:] if P == 1 else p.shape
        raise ValueError(f"positions has shape {shape}: need ({M}, 3) finite metres, one per "
                         f"time" + ("" if P == 1 else f" for each of {P} paths"))
    for name, values in (("max_speed", max_speed), ("max_acceleration", max_acceleration)):
        bad = ~(np.isfinite(values) & (values > 0.0))
        if np.any(bad):
            i = int(np.argmax(bad))
            raise ValueError(f"{name}{of(i)}={values[i]}: must be finite and > 0")


def _segments(t: np.ndarray, p: np.ndarray, max_speed: np.ndarray,
              max_acceleration: np.ndarray) -> tuple[np.ndarray, ...]:
    """Segments of P paths at once (times t (P, M), positions p (P, M, 3), limits (P,)):
    lengths, unit directions (zero for zero-length segments), accel, cruise and peak
    speed (see :func:`segment_profile`), each (P, M - 1[, 3]). Raises ValueError if a
    segment cannot finish before the next waypoint's departure."""
    delta = np.diff(p, axis=1)
    lengths = np.linalg.norm(delta, axis=2)
    directions = np.divide(
        delta, lengths[..., None], out=np.zeros_like(delta), where=lengths[..., None] > 0.0
    )
    accel, cruise, peak = segment_profile(lengths, max_speed[:, None], max_acceleration[:, None])
    needed = 2.0 * accel + cruise
    given = np.diff(t, axis=1)[:, 1:]  # segment k (to waypoint k+1) must end by t_{k+2}
    late = needed[:, :given.shape[1]] > given + 1e-12
    if np.any(late):
        path, k = np.argwhere(late)[0]
        which = f" (path {path})" if t.shape[0] > 1 else ""
        raise ValueError(
            f"waypoint {k + 1}{which}: reaching it needs {needed[path, k]:.4f} s but only "
            f"{given[path, k]:.4f} s are given before waypoint {k + 2} departs"
        )
    return lengths, directions, accel, cruise, peak


def make_operator_path(
    times: Sequence[float] | np.ndarray,
    positions: Sequence[Sequence[float]] | np.ndarray,
    max_speed: float,
    max_acceleration: float,
) -> OperatorPath:
    """Checks the waypoints and precomputes the path segments.

    Args:
        times: departure time of each waypoint, seconds, strictly increasing.
        positions: (M, 3) waypoint positions, metres, world frame.
        max_speed: walking speed limit, metres per second (> 0).
        max_acceleration: acceleration limit, metres per second squared (> 0).

    Raises:
        ValueError: bad argument, or a segment that cannot finish before the next
            waypoint's departure (names the waypoint, the time needed and the time given).
    """
    t = np.asarray(times, dtype=float)
    p = np.asarray(positions, dtype=float)
    if t.ndim != 1 or t.size < 1:
        raise ValueError(f"times={times!r}: need a non-empty 1-D sequence of finite seconds")
    v, a = np.array([max_speed], dtype=float), np.array([max_acceleration], dtype=float)
    _check_paths(t[None], p[None], v, a)
    lengths, directions, accel, cruise, peak = (x[0] for x in _segments(t[None], p[None], v, a))
    return OperatorPath(
        waypoint_times=_frozen(t),
        waypoint_positions=_frozen(p),
        max_speed=float(max_speed),
        max_acceleration=float(max_acceleration),
        departure_times=_frozen(t[1:]),
        directions=_frozen(directions),
        lengths=_frozen(lengths),
        accel_durations=_frozen(accel),
        cruise_durations=_frozen(cruise),
        peak_speeds=_frozen(peak),
    )


def operator_position_velocity(
    path: OperatorPath, t: float | np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Reference-point position (metres) and velocity (metres per second) at time(s) t.

    A scalar t gives two (3,) arrays; an array of shape (T,) gives two (T, 3) arrays.
    Compiled (:func:`_path_rows`).
    """
    t = np.asarray(t, dtype=float)
    stack = stack_paths([path])
    out = np.empty((2, t.size, 3))
    _path_rows(stack.departure_times, stack.accel_durations, stack.cruise_durations,
               stack.peak_speeds, stack.lengths, stack.max_acceleration, stack.directions,
               stack.waypoint_positions, np.zeros(t.size, dtype=np.intp), t.reshape(-1), out)
    return out[0].reshape(t.shape + (3,)), out[1].reshape(t.shape + (3,))


@dataclasses.dataclass(frozen=True, eq=False)
class PathStack:
    """P operator paths stacked for batch evaluation (see :func:`stack_paths`).

    Every array has the paths on its first axis (see ``OperatorPath`` for the fields).
    """

    departure_times: np.ndarray  # (P, M-1)
    accel_durations: np.ndarray
    cruise_durations: np.ndarray
    peak_speeds: np.ndarray
    lengths: np.ndarray
    directions: np.ndarray  # (P, M-1, 3)
    waypoint_positions: np.ndarray  # (P, M, 3)
    max_acceleration: np.ndarray  # (P,)


def stack_paths(paths: Sequence[OperatorPath]) -> PathStack:
    """Stacks paths for batch evaluation. Paths with fewer waypoints are padded with
    segments that never depart (departure at +inf), so they rest at their last
    waypoint as they do alone."""
    segments = max(1, max(p.departure_times.size for p in paths))

    def pad(a: np.ndarray, value: float) -> np.ndarray:  # (segments, ...) per path
        extra = segments - a.shape[0]
        return np.concatenate([a, np.full((extra,) + a.shape[1:], value)]) if extra else a

    arrays = {f: np.stack([pad(getattr(p, f), math.inf if f == "departure_times" else 0.0)
                           for p in paths])
              for f in ("departure_times", "accel_durations", "cruise_durations",
                        "peak_speeds", "lengths", "directions")}
    waypoints = np.stack([np.concatenate([p.waypoint_positions, np.repeat(
        p.waypoint_positions[-1:], segments + 1 - len(p.waypoint_positions), axis=0)])
        for p in paths])
    return PathStack(**arrays, waypoint_positions=waypoints,
                     max_acceleration=np.array([p.max_acceleration for p in paths]))


def stack_operator_paths(times: np.ndarray, positions: np.ndarray, max_speed: np.ndarray,
                         max_acceleration: np.ndarray) -> PathStack:
    """The :class:`PathStack` of P paths with the same number of waypoints, built at once
    (times (P, M), positions (P, M, 3), limits (P,)), equal to ``stack_paths`` of their
    ``make_operator_path``s and checked as it checks them."""
    t, p = np.asarray(times, dtype=float), np.asarray(positions, dtype=float)
    v, a = np.asarray(max_speed, dtype=float), np.asarray(max_acceleration, dtype=float)
    if t.ndim != 2 or t.shape[1] < 1:
        raise ValueError(f"times has shape {t.shape}: need (P, M) seconds, M >= 1")
    P, M = t.shape
    _check_paths(t, p, v, a)
    lengths, directions, accel, cruise, peak = _segments(t, p, v, a)
    if M == 1:  # no segment: one that never departs (as stack_paths pads)
        return stack_paths([make_operator_path(t[i], p[i], v[i], a[i]) for i in range(P)])
    return PathStack(departure_times=np.ascontiguousarray(t[:, 1:]), accel_durations=accel,
                     cruise_durations=cruise, peak_speeds=peak, lengths=lengths,
                     directions=directions, waypoint_positions=p, max_acceleration=a)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def path_point_one(departures, ta, tc, vp, lengths, a_max, directions, waypoints, p, t):
    """Position and velocity (6 floats) of path ``p`` of a stack (see :class:`PathStack`)
    at time t, compiled and callable from other compiled code: on its current segment
    (the last one departed; at the first waypoint, at rest, before that) the distance and
    speed of the trapezoidal profile ``tau`` = t - departure seconds in (clipped to the
    segment): a tau^2 / 2 and a tau while accelerating, then cruising at the peak speed,
    then the length minus a rest^2 / 2 and a rest while braking (rest = time to the
    segment's end)."""
    k = -1
    for j in range(departures.shape[1]):
        if departures[p, j] <= t:
            k += 1
    waiting = k < 0  # the first departure is to come: at the first waypoint, at rest
    k = max(k, 0)
    a, t_a, t_c, v_p = a_max[p], ta[p, k], tc[p, k], vp[p, k]
    total = 2.0 * t_a + t_c
    tau = min(max(t - departures[p, k], 0.0), total)
    rest = total - tau
    if waiting:
        dist, speed = 0.0, 0.0
    elif tau < t_a:
        dist, speed = 0.5 * a * (tau * tau), a * tau
    elif tau < t_a + t_c:
        dist, speed = 0.5 * a * (t_a * t_a) + v_p * (tau - t_a), v_p
    else:
        dist, speed = lengths[p, k] - 0.5 * a * (rest * rest), a * rest
    return (waypoints[p, k, 0] + dist * directions[p, k, 0],
            waypoints[p, k, 1] + dist * directions[p, k, 1],
            waypoints[p, k, 2] + dist * directions[p, k, 2], speed * directions[p, k, 0],
            speed * directions[p, k, 1], speed * directions[p, k, 2])


@numba.njit(cache=True)
def _path_rows(departures, ta, tc, vp, lengths, a_max, directions, waypoints, which, t, out):
    """:func:`path_point_one` of path ``which[r]`` at time t[r] into out[0, r] (position)
    and out[1, r] (velocity)."""
    for r in range(t.size):
        (out[0, r, 0], out[0, r, 1], out[0, r, 2], out[1, r, 0], out[1, r, 1],
         out[1, r, 2]) = path_point_one(departures, ta, tc, vp, lengths, a_max, directions,
                                        waypoints, which[r], t[r])


def stacked_position_velocity(
    stack: PathStack, t: float | np.ndarray, which: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Positions and velocities (P, 3) of every stacked path's reference point at time t
    (a scalar, or one time per path, shape (P,)); compiled (numba). With ``which`` (R,)
    path indices: those paths' points (R, 3) at t (a scalar or (R,) times)."""
    which = np.arange(stack.max_acceleration.size) if which is None else np.asarray(which)
    R = which.size
    t = np.asarray(t, dtype=float)
    t = np.full(R, float(t)) if t.ndim == 0 else np.ascontiguousarray(np.broadcast_to(t, (R,)))
    out = np.empty((2, R, 3))
    _path_rows(stack.departure_times, stack.accel_durations, stack.cruise_durations,
               stack.peak_speeds, stack.lengths, stack.max_acceleration, stack.directions,
               stack.waypoint_positions, np.ascontiguousarray(which, dtype=np.int64), t, out)
    return out[0], out[1]


def check_bodies(offsets: np.ndarray, enter_time: float, leave_time: float) -> None:
    """An operator's tracked bodies (offsets (m, 3), metres) and presence window, as
    :class:`ScriptedOperator` takes them; raises ValueError naming what is wrong."""
    if (
        offsets.ndim != 2
        or offsets.shape[1] != 3
        or not 1 <= offsets.shape[0] <= MAX_BODIES_PER_OPERATOR
        or not np.all(np.isfinite(offsets))
    ):
        raise ValueError(
            f"body_offsets has shape {offsets.shape}: need (m, 3) finite metres with "
            f"1 <= m <= {MAX_BODIES_PER_OPERATOR}"
        )
    if math.isnan(enter_time) or enter_time == math.inf:
        raise ValueError(f"enter_time={enter_time}: must be a number < +inf")
    if not leave_time > enter_time:
        raise ValueError(f"leave_time={leave_time}: must be > enter_time={enter_time}")


@dataclasses.dataclass(frozen=True, eq=False)
class ScriptedOperator:
    """One scripted operator: a path, its tracked bodies and when it is in the cell.

    Args:
        path: motion of the operator's reference point.
        body_offsets: (m, 3) offsets of the m tracked bodies (1 to 10) from the reference
            point, metres, world frame.
        enter_time: seconds; the operator is present for enter_time <= t < leave_time.
        leave_time: seconds, may be +inf.
        point_offsets: (10, 3) offsets of every body point (``human_body.POINTS``), the
            whole posture moving with the reference point; None: not given (NaN).
    """

    path: OperatorPath
    body_offsets: np.ndarray
    enter_time: float = 0.0
    leave_time: float = math.inf
    point_offsets: np.ndarray | None = None

    def __post_init__(self) -> None:
        offsets = np.asarray(self.body_offsets, dtype=float)
        check_bodies(offsets, self.enter_time, self.leave_time)
        object.__setattr__(self, "body_offsets", _frozen(offsets))
        points = np.full((NUM_BODY_POINTS, 3), np.nan) if self.point_offsets is None \
            else np.asarray(self.point_offsets, dtype=float)
        if points.shape != (NUM_BODY_POINTS, 3):
            raise ValueError(f"point_offsets has shape {points.shape}: need "
                             f"({NUM_BODY_POINTS}, 3) metres")
        object.__setattr__(self, "point_offsets", _frozen(points))

    @property
    def num_bodies(self) -> int:
        return self.body_offsets.shape[0]


@dataclasses.dataclass(frozen=True, eq=False)
class BodyLayout:
    """Flat body-slot layout of a list of operators (slots numbered operator by operator)."""

    operator_index: np.ndarray  # (N,) int: which operator each body slot belongs to
    offsets: np.ndarray  # (N, 3) metres
    enter_times: np.ndarray  # (K,) seconds
    leave_times: np.ndarray  # (K,) seconds
    paths: "PathStack | None" = None  # the K operators' paths, stacked


def body_layout(operators: Sequence[ScriptedOperator], *, points: bool = False) -> BodyLayout:
    """Precomputes the body-slot layout used by ``operators_bodies_state``: of the tracked
    bodies, or with ``points`` of every body point (10 per operator, operator k's point
    p in slot 10 k + p)."""
    counts = [NUM_BODY_POINTS if points else op.num_bodies for op in operators]
    index = np.concatenate([np.full(n, k) for k, n in enumerate(counts)])
    index.setflags(write=False)
    return BodyLayout(
        operator_index=index,
        offsets=_frozen(np.concatenate([op.point_offsets if points else op.body_offsets
                                        for op in operators])),
        enter_times=_frozen([op.enter_time for op in operators]),
        leave_times=_frozen([op.leave_time for op in operators]),
        paths=stack_paths([op.path for op in operators]),
    )


@numba.njit(cache=True)
def _bodies_state_at(departures, ta, tc, vp, lengths, a_max, directions, waypoints,
                     operator_index, offsets, enter_times, leave_times, t):
    """:func:`operators_bodies_state` at one time t, compiled: each operator's reference
    point by :func:`path_point_one`, plus each body's offset; present while
    enter_time <= t < leave_time."""
    n = operator_index.size
    p, v, present = np.empty(3 * n), np.empty(3 * n), np.empty(n)
    for b in range(n):
        k = operator_index[b]
        x0, x1, x2, v[3 * b], v[3 * b + 1], v[3 * b + 2] = path_point_one(
            departures, ta, tc, vp, lengths, a_max, directions, waypoints, k, t)
        p[3 * b], p[3 * b + 1], p[3 * b + 2] = (x0 + offsets[b, 0], x1 + offsets[b, 1],
                                                x2 + offsets[b, 2])
        present[b] = 1.0 if (t >= enter_times[k] and t < leave_times[k]) else 0.0
    return p, v, present


def operators_bodies_state(
    operators: Sequence[ScriptedOperator],
    t: float | np.ndarray,
    layout: BodyLayout | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """True body positions (3N), velocities (3N) and presence (N, 1.0/0.0) at time(s) t.

    Body slots are numbered operator by operator; body i's xyz is at [3i:3i+3]. A time
    array of shape (T,) gives arrays of shape (T, 3N), (T, 3N) and (T, N). Pass a
    precomputed ``layout`` (from ``body_layout``) to save work on repeated calls.
    """
    if layout is None:
        layout = body_layout(operators)
    if np.ndim(t) == 0:  # one time (the OperatorMotion system, 500 Hz): compiled
        s = layout.paths
        return _bodies_state_at(s.departure_times, s.accel_durations, s.cruise_durations,
                                s.peak_speeds, s.lengths, s.max_acceleration, s.directions,
                                s.waypoint_positions, layout.operator_index, layout.offsets,
                                layout.enter_times, layout.leave_times, float(t))
    states = [operator_position_velocity(op.path, t) for op in operators]
    p = np.stack([s[0] for s in states], axis=-2)[..., layout.operator_index, :]
    v = np.stack([s[1] for s in states], axis=-2)[..., layout.operator_index, :]
    t_col = np.asarray(t, dtype=float)[..., None]
    inside = (t_col >= layout.enter_times) & (t_col < layout.leave_times)
    lead = np.shape(t)
    return (
        (p + layout.offsets).reshape(lead + (-1,)),
        v.reshape(lead + (-1,)),
        inside[..., layout.operator_index].astype(float),
    )
