"""Sound bounds on the robot's motion that both theorems rest on
(``verification.proof.theorems``): V_R, the fastest point of the monitor's capsule axes,
and D, the longest travel of any of them in a stop, by a Lipschitz covering of the path
(grid values of every capsule end's speed, whose maximum bounds every axis point's, plus
the largest change between grid points, from a bound on a rigid point's acceleration);
T_stop by running the braking model from the commanded rate; the bound on any axis
point's acceleration; and the premise that braking preserves the order of speeds."""

import dataclasses
import math

import numpy as np

from safety_systems.cell.braking import BrakingTable, braking_deceleration
from safety_systems.cell.joint_path import JointPath, SplinePath
from safety_systems.cell.path_speed import (  # noqa: F401 (REACH_BOUND, joint_rate_bounds: read from here)
    REACH_BOUND,
    capsule_reach,
    joint_rate_bounds,
    speed_cover,
    tool_acceleration_bound,
)
from safety_systems.cell.robot_geometry import Capsules
from safety_systems.cell.robot_model import RobotModel
from safety_systems.cell.stopping import stop_from
from safety_systems.config.resolved_cell import ResolvedCell
from verification.spaces.box import ScenarioSpace


@dataclasses.dataclass(frozen=True)

class RobotBounds:
    """Sound bounds on the robot's motion (see the module docstring)."""

    tool_speed: float  # V_R, m/s at nominal path speed: the fastest capsule axis point
    stop_time: float  # T_stop, s
    stop_travel: float  # D, m
    grid_spacing: float  # s of path parameter between covering points


def revolute_only(model: RobotModel) -> bool:
    """Whether every joint of ``model``'s chain turns (the acceleration bound's premise)."""
    return bool(np.all(np.asarray(model.kinds) == 0))


def robot_bounds(path: JointPath, cell: ResolvedCell, *, period: float,
                 braking_time_scale: float, capsules: Capsules | None = None,
                 cells: int = 20000, rate: float = 1.0) -> RobotBounds:
    """V_R, T_stop and D for ``path`` under the cell's braking table scaled by
    ``braking_time_scale``, over the axis ends of ``capsules`` (None: the cell's monitor
    capsules; see the module docstring), the stop commanded at path rate ``rate`` (1: from
    full speed) and D over the tick before it at that rate."""
    return robot_bounds_by_rate(path, cell, period=period,
                                braking_time_scale=braking_time_scale, capsules=capsules,
                                cells=cells, rates=(rate,))[0]


def robot_bounds_by_rate(path: JointPath, cell: ResolvedCell, *, period: float,
                         braking_time_scale: float, rates, capsules: Capsules | None = None,
                         cells: int = 20000) -> list[RobotBounds]:
    """:func:`robot_bounds` at each path rate of ``rates``, the path covered once: V_R (at
    nominal rate, the same for all), T_stop the ticks of a stop commanded at the rate (as
    the PathFollower runs it, the robot's stopping data: the cell's, ``cell.braking``) and
    D the largest travel of any capsule axis point over a window of path parameter as
    long as that stop's plus one tick at the rate."""
    capsules = cell.capsules if capsules is None else capsules
    table = cell.braking
    cell_bound, delta = speed_cover(path, capsules, cells)
    tiled = np.tile(cell_bound, 2)
    out = []
    for rate in rates:
        # A stop commanded at ``rate``, as the PathFollower runs it.
        stop_time, travelled = stop_from(float(rate), table, braking_time_scale, period)
        window = int(math.ceil((travelled + rate * period) / delta)) + 1  # + the tick after t'
        arcs = np.convolve(tiled, np.ones(window), "valid")[:cells] * delta
        out.append(RobotBounds(float(cell_bound.max()), stop_time, float(arcs.max()), delta))
    return out


def robot_acceleration_bound(path: JointPath | SplinePath, cell: ResolvedCell,
                             space: ScenarioSpace, tool_speed: float, *,
                             rate: float = 1.0) -> float:
    """A bound (m/s^2) on the acceleration of any point of the monitor's capsule axes:
    |d2p/ds2| sigma^2 + |dp/ds| |d sigma/dt| with sigma <= ``rate`` and the path rate changing
    no faster than the robot's acceleration limit or the brakes' fastest deceleration
    (at the space's shortest braking time scale); ``tool_speed`` bounds |dp/ds|. The
    capsules and the braking table are the cell's (resolved for the space's robot)."""
    rate_change = max(space.robot.acceleration_limit,
                      float(np.max(cell.braking.deceleration))
                      / space.parameters.braking_time_scale.min)
    return (tool_acceleration_bound(path, capsule_reach(cell.capsules)) * rate * rate
            + tool_speed * rate_change)


def braking_is_monotone(table: BrakingTable, period: float, scale: float) -> bool:
    """One braking step of the stopping data ``table`` (a cell's ``braking``) preserves
    the order of path speeds (so a stop from a lower speed takes no longer and travels no
    farther than one from full speed)."""
    sigma = np.linspace(0.0, 1.0, 10001)
    after = np.maximum(sigma - braking_deceleration(table, sigma)
                       / scale * period, 0.0)
    return bool(np.all(np.diff(after) >= -1e-15))
