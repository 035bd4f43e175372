"""Stopping data for one path, derived from a robot's published per-joint stops.

The placeholder table (``braking.default_braking_table``) gives every path the stop of
the robot's slowest joint from the manufacturer's test speed (183 deg/s), whatever the
path's own speed: a path whose joints peak at 100 deg/s is assumed to need 530 ms to
stop from its full speed, as the UR5's shoulder does from 183 deg/s. This module derives
the stops of a given path from the same published figures, by the same rule the
placeholder's 33 % and 66 % rows already use (constant deceleration):

- Published figures (stop category 0, 100 % speed = 183 deg/s at every joint, full
  extension, full payload): UR5/CB3 User Manual v3.4.5, Appendix A: base 0.31 rad in
  244 ms, shoulder 0.70 rad in 530 ms, elbow 0.22 rad in 164 ms (the UR5e's placeholder
  source); UR3/CB3 User Manual v3.10, Appendix A: base 0.18 rad in 159 ms, shoulder
  0.20 rad in 154 ms, elbow 0.15 rad in 92 ms.
- Each published joint j decelerates at least at a_j = min(w / T_j, w^2 / (2 theta_j)),
  w the test speed: the lesser of the rates its time and its angle imply, so a stop at
  a_j from w takes at least T_j and turns at least theta_j. The wrists (no figure
  published) at the least a_j of the three (a lighter joint is not assumed to brake
  harder than the slowest published one).
- A stop that keeps the path (the braking model: the path rate falls at a constant
  rate, the joints stay on the path) from path rate sigma takes sigma * max_j(v_j / a_j),
  v_j the joint's peak speed on the path at rate 1: no joint's speed then falls faster
  than its a_j allows from the fastest it reaches on the path.
- Rows at 33 %, 66 % and 100 % of the path rate: the time as above, the distance the
  tool flange travels on this path while the braking model stops it from that rate with
  those times (``braking.tool_stopping_distance``, the worst of 400 start points).

Interpretation (stated as the certificate's trusted premise "the stopping data describes
the real robot's stops"): the published stop from 183 deg/s includes the controller's
onset; scaled by speed, that onset is scaled with it, as in the placeholder's lower rows;
and the path's own acceleration during the stop (its curvature) is not budgeted against
the published rates, which were measured from a constant speed.
Valid for the path it was derived from and for slower ones only. THESE ARE NOT MEASURED
STOPS: an integrator measures the stops of their own cell, tool and payload.
"""

import dataclasses
import math

import numpy as np

from safety_systems.cell.braking import DEFAULT_SPEED_FRACTIONS, BrakingTable, tool_stopping_distance

TEST_SPEED = math.radians(183.0)  # rad/s: every joint's speed in the published stops


@dataclasses.dataclass(frozen=True)
class JointStops:
    """A robot's published stops from ``speed`` (rad/s): (angle rad, time s) of base,
    shoulder and elbow, and where they come from."""

    robot: str
    stops: tuple  # ((theta, T) of base, shoulder, elbow)
    source: str
    speed: float = TEST_SPEED

    @property
    def decelerations(self) -> np.ndarray:
        """a_j of the published joints (rad/s^2), the module's rule."""
        w = self.speed
        return np.array([min(w / t, w * w / (2.0 * theta)) for theta, t in self.stops])


PUBLISHED_STOPS = {
    "ur5e": JointStops("ur5e", ((0.31, 0.244), (0.70, 0.530), (0.22, 0.164)),
                       "UR5/CB3 User Manual v3.4.5, App. A, stop category 0"),
    "ur3e": JointStops("ur3e", ((0.18, 0.159), (0.20, 0.154), (0.15, 0.092)),
                       "UR3/CB3 User Manual v3.10, App. A, stop category 0"),
}


def joint_decelerations(robot: str, joints: int) -> np.ndarray:
    """Each of ``joints`` joints' deceleration (rad/s^2) by the module's rule."""
    if robot not in PUBLISHED_STOPS:
        raise ValueError(f"robot = {robot!r}: published per-joint stops are known for "
                         f"{', '.join(PUBLISHED_STOPS)} only")
    a = PUBLISHED_STOPS[robot].decelerations
    return np.concatenate([a, np.full(max(0, joints - a.size), a.min())])[:joints]


def path_stop_time(peak_speeds: np.ndarray, robot: str = "ur5e") -> float:
    """The stop from path rate 1 on a path whose joints peak at ``peak_speeds`` (rad/s),
    seconds: max_j v_j / a_j."""
    v = np.abs(np.asarray(peak_speeds, dtype=float))
    return float(np.max(v / joint_decelerations(robot, v.size)))


def path_stops(path, peak_speeds: np.ndarray, robot: str = "ur5e",
               tool_position=None) -> BrakingTable:
    """The stopping table of ``path`` (a JointPath or SplinePath whose joints peak at
    ``peak_speeds``, rad/s at rate 1) by the module's rules: rows at 33, 66 and 100 %."""
    f = np.array(DEFAULT_SPEED_FRACTIONS)
    t = path_stop_time(peak_speeds, robot) * f
    times = BrakingTable(f, t, f * f)  # (the distances are not used to brake)
    d = np.array([tool_stopping_distance(path, times, rate=float(x),
                                         tool_position=tool_position) for x in f])
    return BrakingTable(f, t, d)


def peak_speeds_of(path) -> np.ndarray:
    """Each joint's peak speed on ``path`` at rate 1 (rad/s): a waypoint path's blends'
    or a logged path's spline's."""
    if hasattr(path, "peak_joint_speeds"):
        return np.asarray(path.peak_joint_speeds, dtype=float)
    from safety_systems.cell.robot_log import peak_joint_speeds
    return peak_joint_speeds(path)


def _up(x: float, quantum: float) -> float:
    """``x`` rounded up to a multiple of ``quantum`` (a float's last bit aside)."""
    return round(math.ceil(x / quantum - 1e-9) * quantum, 6)


def rounded_path_stops(paths: list, robot: str = "ur5e", tool_position=None
                       ) -> tuple[BrakingTable, float, float]:
    """Stops valid on every one of ``paths`` (each run no faster than it is written): the
    times from the joints' peaks over them all, each distance the farthest any path's
    tool travels in that stop; the rows rounded up to 0.1 ms and 0.1 mm, and (T_s, B) the
    full-speed row rounded up to 10 ms and 1 cm, as a configuration carries them."""
    peaks = np.max([peak_speeds_of(p) for p in paths], axis=0)
    tables = [path_stops(p, peaks, robot, tool_position) for p in paths]
    f = tables[0].speed_fraction
    t = np.array([_up(x, 1e-4) for x in tables[0].stopping_time])
    d = np.array([_up(x, 1e-4) for x in np.max([x.stopping_distance for x in tables],
                                                 axis=0)])
    return BrakingTable(f, t, d), _up(t[-1], 0.01), _up(d[-1], 0.01)
