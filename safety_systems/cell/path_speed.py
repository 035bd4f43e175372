"""A sound bound on how fast any point of a robot's capsule axes moves along its path at
nominal path speed (rate 1), by a Lipschitz covering of the path: every capsule end's
speed on a grid of the path parameter (an axis point is a convex combination of its
capsule's ends, so the faster end bounds it), plus the most the speed can change between
grid points, from a bound on a rigid point's acceleration (:func:`tool_acceleration_bound`).

Shared by the proofs (``verification.proof.robot_bounds``: V_R and the stop travel D) and
by power and force limiting's speed caps (``config.configuration.pfl_caps``: a path rate
at or below cap / V keeps every axis point at or below the cap's speed).
"""

import math

import numpy as np

from safety_systems.cell.joint_path import JointPath, SplinePath, joint_path_state
from safety_systems.cell.robot_geometry import Capsules, capsule_ends
from safety_systems.cell.robot_model import KIND_UR, RobotModel, default_model
from safety_systems.cell.ur5e import DH_A, DH_D

# The UR5e's longest distance from any joint axis to the tool flange, bounded by the link
# lengths (every model has its own: ``RobotModel.reach_bound``; this is the UR5e's).
REACH_BOUND = sum(abs(a) for a in DH_A) + sum(DH_D[1:])


_MAX_BLEND_ACCEL = 10.0 / math.sqrt(3.0)  # max |h''| of the minimum-jerk blend
_MAX_BLEND_RATE = 1.875


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


def speed_cover(path: JointPath | SplinePath, capsules: Capsules, cells: int = 20000
                ) -> tuple[np.ndarray, float]:
    """(bounds, spacing): a bound on the speed of every point of ``capsules``' axes at
    nominal path speed on each of ``cells`` cells of one cycle of ``path`` (m/s; the grid
    values of the capsule ends' speeds at the cell's two ends, plus half the spacing
    times :func:`tool_acceleration_bound`), and the cells' spacing in path parameter."""
    delta = path.cycle_time / cells
    s = np.arange(cells + 1) * delta
    # The path as it is: its last grid point is the cycle's end (a one-way path's last
    # state; a cyclic path's start again), not the start of a cycle a one-way path
    # never runs.
    q, dq, _ = joint_path_state(path, s)
    _, end_v = capsule_ends(q, capsules, dq)
    speed = np.linalg.norm(end_v, axis=-1).reshape(len(s), -1).max(axis=1)
    slack = tool_acceleration_bound(path, capsule_reach(capsules)) * delta / 2.0
    return np.maximum(speed[:-1], speed[1:]) + slack, delta


def path_speed_bound(path: JointPath | SplinePath, capsules: Capsules, cells: int = 20000
                     ) -> float:
    """V_R: a bound on the speed of any point of ``capsules``' axes anywhere on ``path`` at
    nominal path speed, m/s (:func:`speed_cover`'s largest cell bound). At path rate
    sigma every such point moves at most sigma V_R."""
    return float(speed_cover(path, capsules, cells)[0].max())
