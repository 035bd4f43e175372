"""The simulated robot's true stopping data: how long a stop from full speed takes, and
how far the robot travels in it, under its real brakes on its own path.

ISO/TS 15066 Eq. 1 (seed 000, Eqs. 9-11) takes the robot's stopping time T_s and
stopping distance S_s = B as constants; a configuration states them
(``safety.stopping_time``, ``stopping_distance``, or the braking table's full-speed row),
and the integrator measures them. The separation invariant
(``verification.properties``) needs what the *simulated* robot really does instead, and
the proof bounds the same quantities; both come from here:

- **time**: a stop commanded at full path speed, as the PathFollower runs it (one
  ``braking.path_rate_step`` per control period with a command of 0, the table's
  decelerations divided by the robot's ``braking_time_scale``), counted in control
  periods until the path rate is 0;
- **distance**: the farthest any point of the robot's capsule axes travels in such a
  stop, over every point of the path where it may begin (two cycles, so a stop may run
  on into the next). A rigid link's velocity is affine along its axis, so no axis point
  moves faster than the faster of the axis' ends: the travel of the fastest end at each
  instant, integrated over the stop, bounds every axis point's. The travel is taken
  along the path parameter (a point's path does not depend on how fast the robot runs
  along it), on a grid of ``cells`` per cycle.
"""

import dataclasses
import functools
import math

import numpy as np

from safety_systems.cell.braking import BrakingTable, path_rate_step


@dataclasses.dataclass(frozen=True)
class StoppingData:
    """A stop from full speed: its time (s), the path parameter it covers (s of path
    at nominal speed) and the farthest travel of any capsule axis point in it (m)."""

    time: float
    path_travel: float
    distance: float


def stop_from_full_speed(table: BrakingTable, braking_time_scale: float,
                         period: float) -> tuple[float, float]:
    """(time, path_travel) of a stop commanded at full path speed, as the PathFollower
    runs it: whole control periods until the rate is 0, and the path parameter covered
    (trapezoid rule, as ``braking.path_follower_step``). Kept for the next calls (a sweep
    asks for the same few)."""
    return _stop(tuple(table.speed_fraction), tuple(table.stopping_time),
                 tuple(table.stopping_distance), float(braking_time_scale), float(period))


def stop_from(rate: float, table: BrakingTable, braking_time_scale: float,
              period: float) -> tuple[float, float]:
    """(time, path_travel) of a stop commanded at path rate ``rate`` (in [0, 1]), as
    :func:`stop_from_full_speed` runs it from 1."""
    return _stop(tuple(table.speed_fraction), tuple(table.stopping_time),
                 tuple(table.stopping_distance), float(braking_time_scale), float(period),
                 float(rate))


@functools.lru_cache(maxsize=4096)
def _stop(fractions, times, distances, braking_time_scale, period, start=1.0):
    table = BrakingTable(np.array(fractions), np.array(times), np.array(distances))
    rate, travelled, ticks = start, 0.0, 0
    while rate > 0.0:
        new = float(path_rate_step(rate, 0.0, period, table=table, acceleration_limit=1.0,
                                   time_scale=braking_time_scale))
        travelled += 0.5 * (rate + new) * period
        rate, ticks = new, ticks + 1
    return ticks * period, travelled


def fastest_point_speed(path, capsules, cells: int) -> tuple[np.ndarray, float]:
    """(speed, spacing): the speed at nominal path rate of the fastest capsule axis end
    at ``cells`` + 1 evenly spaced path parameters of one cycle (and ``cells`` more of the
    next), m/s, and their spacing, s of path."""
    from safety_systems.cell.joint_path import joint_path_state
    from safety_systems.cell.robot_geometry import capsule_ends

    delta = path.cycle_time / cells
    s = np.arange(2 * cells + 1) * delta
    q, dq, _ = joint_path_state(dataclasses.replace(path, cycles=2), s)
    _, end_velocities = capsule_ends(q, capsules, dq)
    speed = np.linalg.norm(end_velocities, axis=-1).reshape(len(s), -1).max(axis=1)
    return speed, delta


def travel_in(speed: np.ndarray, delta: float, path_travel: float) -> float:
    """The largest travel, m, of the fastest point (``speed`` on a grid of spacing
    ``delta`` over two cycles, from :func:`fastest_point_speed`) over any window of
    ``path_travel`` seconds of path that starts in the first cycle (trapezoid rule)."""
    cells = (len(speed) - 1) // 2
    cumulative = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * delta)])
    starts = np.arange(cells + 1) * delta
    ends = np.minimum(starts + path_travel, 2 * cells * delta)
    grid = np.arange(len(speed)) * delta
    return float(np.max(np.interp(ends, grid, cumulative) - cumulative[:cells + 1]))


def content_key(obj) -> tuple:
    """A hashable key of a value's content: dataclasses field by field, arrays by their
    bytes (``repr`` shortens long arrays, so it cannot key them)."""
    if dataclasses.is_dataclass(obj):
        return (type(obj).__name__,) + tuple(content_key(getattr(obj, f.name))
                                             for f in dataclasses.fields(obj))
    if isinstance(obj, np.ndarray):
        return (obj.dtype.str, obj.shape, obj.tobytes())
    if isinstance(obj, (list, tuple)):
        return tuple(content_key(x) for x in obj)
    return (repr(obj),)


_PROFILES: dict = {}  # a few (path, capsules, cells) speed profiles, newest last


def _kept(cache: dict, size: int, key, make):
    """``cache[key]``, made by ``make()`` when absent; the ``size`` newest kept."""
    found = cache.pop(key, None)
    if found is None:
        found = make()
    cache[key] = found
    while len(cache) > size:
        cache.pop(next(iter(cache)))
    return found


def _speed_profile(path, capsules, cells: int) -> tuple[np.ndarray, float]:
    key = (content_key(dataclasses.replace(path, cycles=1)), content_key(capsules), cells)
    return _kept(_PROFILES, 8, key, lambda: fastest_point_speed(path, capsules, cells))


def true_stopping(path, capsules, table: BrakingTable, braking_time_scale: float,
                  period: float, *, cells: int = 20000) -> StoppingData:
    """The robot's stopping data on ``path`` (a ``JointPath``) for the axes of
    ``capsules`` (``robot_geometry.Capsules``) under ``table`` scaled by
    ``braking_time_scale``, stops run at the control ``period`` (see the module)."""
    if not (math.isfinite(braking_time_scale) and braking_time_scale > 0.0):
        raise ValueError(f"braking_time_scale: got {braking_time_scale}; allowed: a finite "
                         "number > 0")
    time, path_travel = stop_from_full_speed(table, braking_time_scale, period)
    speed, delta = _speed_profile(path, capsules, cells)
    return StoppingData(time, path_travel, travel_in(speed, delta, path_travel))


# The rates at which the separation invariant's S_true takes the simulated robot's stop
# when the configuration's S follows the robot's speed (``safety.stopping: by_speed``):
# j / TRUTH_RATES, j = 0..TRUTH_RATES; a rate between two is taken at the one above.
TRUTH_RATES = 64


@dataclasses.dataclass(frozen=True)
class StoppingByRate:
    """Stops commanded at the path rates ``rate`` (j / TRUTH_RATES): their times (s) and
    the farthest travel of any capsule axis point in each (m), both non-decreasing in
    the rate (checked: a stop from a lower rate runs through fewer ticks, the rate map
    of one braking tick being monotonic, see :func:`stops_by_rate`)."""

    rate: np.ndarray
    time: np.ndarray
    distance: np.ndarray

    def at(self, rate: float) -> tuple[float, float]:
        """(time, distance) of the grid rate at or above ``rate`` (clipped to [0, 1])."""
        j = rate_index(rate)
        return float(self.time[j]), float(self.distance[j])


def rate_index(rate: float) -> int:
    """Index of the grid rate j / TRUTH_RATES at or above ``rate`` (clipped to [0, 1];
    a NaN counts as full speed)."""
    from safety_systems.ssm.formulas import level_at_or_above

    return int(level_at_or_above(float(rate), TRUTH_RATES))


_BY_RATE: dict = {}  # a few stops_by_rate results, newest last


def stops_by_rate(path, capsules, table: BrakingTable, braking_time_scale: float,
                  period: float, *, cells: int = 20000) -> StoppingByRate:
    """:func:`stops_by_rate_uncached`, kept for the next calls (a sweep asks for the same
    few)."""
    key = (content_key(dataclasses.replace(path, cycles=1)), content_key(capsules),
           content_key(table), float(braking_time_scale), float(period), cells)
    return _kept(_BY_RATE, 16, key, lambda: stops_by_rate_uncached(
        path, capsules, table, braking_time_scale, period, cells=cells))


def stops_by_rate_uncached(path, capsules, table: BrakingTable, braking_time_scale: float,
                           period: float, *, cells: int = 20000) -> StoppingByRate:
    """:func:`true_stopping`'s time and distance for stops commanded at every grid rate
    j / TRUTH_RATES (the rate 0: no stop, 0 and 0). Raises if they are not
    non-decreasing in the rate (a table whose deceleration falls faster than the rate
    within one tick), which the by-speed bounds rely on."""
    rates = np.arange(TRUTH_RATES + 1) / TRUTH_RATES
    speed, delta = _speed_profile(path, capsules, cells)
    time, distance = np.zeros(rates.size), np.zeros(rates.size)
    for j, rate in enumerate(rates[1:], start=1):
        time[j], travel = stop_from(rate, table, braking_time_scale, period)
        distance[j] = travel_in(speed, delta, travel)
    if np.any(np.diff(time) < 0.0) or np.any(np.diff(distance) < 0.0):
        raise ValueError("the braking table's stops do not grow with the speed they start "
                         "from; the by-speed protective distance needs them to")
    for a in (rates, time, distance):
        a.setflags(write=False)
    return StoppingByRate(rates, time, distance)
