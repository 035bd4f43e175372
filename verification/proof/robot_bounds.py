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

from safety_systems.cell.braking import braking_deceleration
from safety_systems.cell.joint_path import JointPath, SplinePath, joint_path_state
from safety_systems.cell.robot_geometry import Capsules, capsule_ends
from safety_systems.cell.robot_model import KIND_UR, RobotModel, default_model
from safety_systems.cell.stopping import stop_from
from safety_systems.cell.ur5e import DH_A, DH_D
from safety_systems.config.configuration import (
    braking_table,
    monitor_capsules,
)
from safety_systems.config.scenario import ControllerConfig, robot_model_of
from verification.spaces.box import ScenarioSpace

# The UR5e's longest distance from any joint axis to the tool flange, bounded by the link
# lengths (every model has its own: ``RobotModel.reach_bound``; this is the UR5e's).
REACH_BOUND = sum(abs(a) for a in DH_A) + sum(DH_D[1:])


_MAX_BLEND_ACCEL = 10.0 / math.sqrt(3.0)  # max |h''| of the minimum-jerk blend


_MAX_BLEND_RATE = 1.875


@dataclasses.dataclass(frozen=True)

class RobotBounds:
    """Sound bounds on the robot's motion (see the module docstring)."""

    tool_speed: float  # V_R, m/s at nominal path speed: the fastest capsule axis point
    stop_time: float  # T_stop, s
    stop_travel: float  # D, m
    grid_spacing: float  # s of path parameter between covering points


def joint_rate_bounds(path: JointPath | SplinePath) -> tuple[np.ndarray, np.ndarray]:
    """Per piece of the path, bounds on the sum over the joints of |dq/ds| and of
    |d2q/ds2| at nominal speed (rad/s, rad/s^2). A JointPath's segments are minimum-jerk
    blends (their peak rate and acceleration per unit of travel are constants); a
    SplinePath's pieces are cubics: q'' is linear on a piece (its largest size at an
    end) and q' quadratic (at an end or at its vertex). Running a spline backwards flips
    the signs only."""
    if isinstance(path, SplinePath):
        c, breaks = path.spline.c, path.spline.x  # c (4, pieces, 6): c0 x^3 + ... + c3
        h = np.diff(breaks)[:, None]
        accel = np.maximum(np.abs(2.0 * c[1]), np.abs(6.0 * c[0] * h + 2.0 * c[1]))
        rate = np.maximum(np.abs(c[2]), np.abs(3.0 * c[0] * h * h + 2.0 * c[1] * h + c[2]))
        with np.errstate(divide="ignore", invalid="ignore"):
            vertex = np.where(c[0] != 0.0, -c[1] / (3.0 * c[0]), -1.0)
        inside = (vertex > 0.0) & (vertex < h)
        rate = np.maximum(rate, np.where(inside, np.abs(c[2] - c[1] ** 2 / (3.0 * np.where(
            c[0] != 0.0, c[0], 1.0))), 0.0))
        return rate.sum(axis=1), accel.sum(axis=1)
    d = np.abs(path.deltas)
    return ((_MAX_BLEND_RATE * d / path.durations[:, None]).sum(axis=1),
            (_MAX_BLEND_ACCEL * d / path.durations[:, None] ** 2).sum(axis=1))


def tool_acceleration_bound(path: JointPath | SplinePath, reach: float = REACH_BOUND) -> float:
    """Bound on |d2p/ds2| at nominal speed of a rigid point of the arm within ``reach``
    of every joint axis, m/s^2 (revolute chain: the sum of joint accelerations plus twice
    the squared sum of joint speeds, times the reach; :func:`joint_rate_bounds`; a
    prismatic joint is not covered: :func:`revolute_only` is the theorems' premise)."""
    rate, accel = joint_rate_bounds(path)
    return float(reach * np.max(accel + 2.0 * rate**2))


def revolute_only(model: RobotModel) -> bool:
    """Whether every joint of ``model``'s chain turns (the acceleration bound's premise)."""
    return bool(np.all(np.asarray(model.kinds) == 0))


def _ur_lengths(model: RobotModel) -> tuple[np.ndarray, np.ndarray]:
    """A UR's standard DH a and d (6 each) from its closed form's constants (d1, a2, a3,
    d4, d5, d6): every UR has a1 = a4 = a5 = a6 = 0 and d2 = d3 = 0."""
    d1, a2, a3, d4, d5, d6 = (float(x) for x in model.dh)
    return np.array([0.0, a2, a3, 0.0, 0.0, 0.0]), np.array([d1, 0.0, 0.0, d4, d5, d6])


def capsule_reach(capsules: Capsules) -> float:
    """A bound on any capsule end's distance from any joint axis, m. A UR's: the link
    lengths, the tool, and the longest extension of a link's axis past its joints (for
    the UR5e exactly as before robots could be chosen). A chain's (its capsules' ends are
    rigid points of their links, ``RobotModel.point_reach``, the tip tool0's plus the
    tool length): the larger of a capsule's two points' bounds plus its extension past
    them (0 for the fitted links: their ends are the points themselves)."""
    model = capsules.model or default_model()
    if model.kind == KIND_UR:
        dh_a, dh_d = _ur_lengths(model)
        lengths = np.hypot(np.r_[dh_a, 0.0], np.r_[dh_d, capsules.tool_length])
        length = lengths[np.minimum(capsules.a, 6)]
        overhang = np.maximum(np.maximum(-capsules.t0, capsules.t1 - 1.0), 0.0) * length
        return model.reach_bound + capsules.tool_length + float(np.max(overhang, initial=0.0))
    reach = np.r_[model.point_reach, model.point_reach[-1] + capsules.tool_length]
    span = 2.0 * (model.base_reach + capsules.tool_length)  # any two points' distance
    extension = np.maximum(np.maximum(-capsules.t0, capsules.t1 - 1.0), 0.0)
    ends = np.maximum(reach[capsules.a], reach[capsules.b])
    return float(np.max(ends + extension * span, initial=0.0))


def robot_bounds(path: JointPath, config: ControllerConfig, *, period: float,
                 braking_time_scale: float, capsules: Capsules | None = None,
                 cells: int = 20000, rate: float = 1.0,
                 model: RobotModel | None = None) -> RobotBounds:
    """V_R, T_stop and D for ``path`` under the configured table scaled by
    ``braking_time_scale``, over the axis ends of ``capsules`` (None: the configuration's
    monitor capsules on ``model``, None: the UR5e; see the module docstring), the stop
    commanded at path rate ``rate`` (1: from full speed) and D over the tick before it at
    that rate."""
    return robot_bounds_by_rate(path, config, period=period,
                                braking_time_scale=braking_time_scale, capsules=capsules,
                                cells=cells, rates=(rate,), model=model)[0]


def robot_bounds_by_rate(path: JointPath, config: ControllerConfig, *, period: float,
                         braking_time_scale: float, rates, capsules: Capsules | None = None,
                         cells: int = 20000, model: RobotModel | None = None
                         ) -> list[RobotBounds]:
    """:func:`robot_bounds` at each path rate of ``rates``, the path covered once: V_R (at
    nominal rate, the same for all), T_stop the ticks of a stop commanded at the rate (as
    the PathFollower runs it, the robot's stopping data: the capsules' robot's) and D the
    largest travel of any capsule axis point over a window of path parameter as long as
    that stop's plus one tick at the rate."""
    capsules = monitor_capsules(config, model) if capsules is None else capsules
    table = braking_table(config, capsules.model)
    delta = path.cycle_time / cells
    s = np.arange(cells + 1) * delta
    q, dq, _ = joint_path_state(dataclasses.replace(path, cycles=2), s)
    _, end_v = capsule_ends(q, capsules, dq)
    speed = np.linalg.norm(end_v, axis=-1).reshape(len(s), -1).max(axis=1)
    slack = tool_acceleration_bound(path, capsule_reach(capsules)) * delta / 2.0
    cell_bound = np.maximum(speed[:-1], speed[1:]) + slack  # |p'| on each cell, any end
    tiled = np.tile(cell_bound, 2)
    out = []
    for rate in rates:
        # A stop commanded at ``rate``, as the PathFollower runs it.
        stop_time, travelled = stop_from(float(rate), table, braking_time_scale, period)
        window = int(math.ceil((travelled + rate * period) / delta)) + 1  # + the tick after t'
        arcs = np.convolve(tiled, np.ones(window), "valid")[:cells] * delta
        out.append(RobotBounds(float(cell_bound.max()), stop_time, float(arcs.max()), delta))
    return out


def robot_acceleration_bound(path: JointPath | SplinePath, config: ControllerConfig,
                             space: ScenarioSpace, tool_speed: float, *,
                             rate: float = 1.0) -> float:
    """A bound (m/s^2) on the acceleration of any point of the monitor's capsule axes:
    |d2p/ds2| sigma^2 + |dp/ds| |d sigma/dt| with sigma <= ``rate`` and the path rate changing
    no faster than the robot's acceleration limit or the brakes' fastest deceleration
    (at the space's shortest braking time scale); ``tool_speed`` bounds |dp/ds|."""
    model = robot_model_of(space.robot)
    capsules = monitor_capsules(config, model)
    rate_change = max(space.robot.acceleration_limit,
                      float(np.max(braking_table(config, model).deceleration))
                      / space.parameters.braking_time_scale.min)
    return (tool_acceleration_bound(path, capsule_reach(capsules)) * rate * rate
            + tool_speed * rate_change)


def braking_is_monotone(config: ControllerConfig, period: float, scale: float,
                        model: RobotModel | None = None) -> bool:
    """One braking step of ``model``'s stopping data (None: the UR5e's) preserves the
    order of path speeds (so a stop from a lower speed takes no longer and travels no
    farther than one from full speed)."""
    sigma = np.linspace(0.0, 1.0, 10001)
    after = np.maximum(sigma - braking_deceleration(braking_table(config, model), sigma)
                       / scale * period, 0.0)
    return bool(np.all(np.diff(after) >= -1e-15))
