"""Placeholder stopping data for every shipped robot, built as ``braking.default_braking_table``
builds the UR5's: one stop from full speed (time T, joint angle theta), rows at 33 %, 66 %
and 100 % speed under constant deceleration (time proportional to speed, distance to its
square), the angle turned into a tool distance over the robot's reach.

Sources and rules (``models/README.md`` repeats them):

- **ur5e**: UR5/CB3 User Manual v3.4.5, App. A, stop category 0 (the project's default
  table, unchanged): shoulder 0.70 rad in 530 ms at 183 deg/s, over the 0.85 m reach.
- **ur3e**: UR3/CB3 User Manual v3.10, App. A, stop category 0 at 183 deg/s, full
  extension, 3 kg: base 0.18 rad in 159 ms, shoulder 0.20 rad in 154 ms, elbow 0.15 rad in
  92 ms; we take the longest time (159 ms) and the largest angle (0.20 rad), over the
  UR3e's 0.5 m reach.
- **ur10e, ur16e, ur20, ur30, panda**: no numeric figure found (the e-Series manuals give
  stopping data as graphs only; none found for the Panda). Rule: the UR5/CB3 shoulder's
  stop scaled by the robot's shoulder speed (its second joint's) and reach: the time kept
  at 530 ms (a heavier arm is not assumed to brake faster), the angle 0.70 rad times the
  shoulder speed over 183 deg/s (the same time from a lower speed), over the reach.

THESE ARE PLACEHOLDERS, exactly as ``braking.default_braking_table``: integrators must enter
the stopping time and distance measured on their own cell, tool and payload.
"""

import dataclasses
import math

import numpy as np

from safety_systems.cell import braking, ur_family
from safety_systems.cell.braking import DEFAULT_SPEED_FRACTIONS, BrakingTable

UR5_TEST_SPEED = math.radians(183.0)  # rad/s, the UR5/CB3 table's joint speed
PANDA_SHOULDER_SPEED = 2.175  # rad/s, Franka's joint 2 limit (models/panda/README.md)
PANDA_REACH = 0.855  # m, Franka's datasheet


@dataclasses.dataclass(frozen=True, kw_only=True)
class PlaceholderStop:
    """A robot's full-speed stop: ``stop_time`` (s), ``stop_angle`` (rad), ``reach`` (m)
    and the ``source`` or rule they come from."""

    robot: str
    stop_time: float
    stop_angle: float
    reach: float
    source: str
    speed: float = UR5_TEST_SPEED  # rad/s: the joint speed the stop is from (its full speed)


def _scaled(robot: str, shoulder_speed: float, reach: float) -> PlaceholderStop:
    return PlaceholderStop(
        robot=robot, stop_time=braking.UR5_SHOULDER_STOP_TIME,
        stop_angle=braking.UR5_SHOULDER_STOP_ANGLE * shoulder_speed / UR5_TEST_SPEED,
        reach=reach, source="UR5/CB3 shoulder stop (0.70 rad, 530 ms at 183 deg/s) scaled by "
        "shoulder speed and reach (no published figure found)", speed=shoulder_speed)


PLACEHOLDER_STOPS = {
    "ur3e": PlaceholderStop(robot="ur3e", stop_time=0.159, stop_angle=0.20,
                            reach=ur_family.UR3E.reach,
                            source="UR3/CB3 User Manual v3.10 App. A, stop category 0"),
    "ur5e": PlaceholderStop(robot="ur5e", stop_time=braking.UR5_SHOULDER_STOP_TIME,
                            stop_angle=braking.UR5_SHOULDER_STOP_ANGLE,
                            reach=braking.UR5_REACH,
                            source="UR5/CB3 User Manual v3.4.5 App. A, stop category 0"),
    **{r.name: _scaled(r.name, r.velocity_limits[1], r.reach)
       for r in (ur_family.UR10E, ur_family.UR16E, ur_family.UR20, ur_family.UR30)},
    "panda": _scaled("panda", PANDA_SHOULDER_SPEED, PANDA_REACH),
}


def placeholder_braking_table(robot: str) -> BrakingTable:
    """The placeholder stopping table of ``robot`` (a key of ``PLACEHOLDER_STOPS``)."""
    if robot not in PLACEHOLDER_STOPS:
        raise ValueError(f"robot = {robot!r}; allowed: {', '.join(PLACEHOLDER_STOPS)}")
    stop = PLACEHOLDER_STOPS[robot]
    f = np.array(DEFAULT_SPEED_FRACTIONS)
    return BrakingTable(speed_fraction=f, stopping_time=stop.stop_time * f,
                        stopping_distance=stop.stop_angle * stop.reach * f * f)


def placeholder_warning(robot: str) -> str:
    """The warning to print beside a result computed with ``robot``'s placeholder table."""
    stop = PLACEHOLDER_STOPS[robot]
    return (f"The stopping data is the built-in placeholder for the {robot} ({stop.source}), "
            "not data measured on this cell: enter the measured stopping times and distances "
            "(controller.braking) before relying on this result.")
