"""Seed 004's measures of a run (Table 1, Figs. 9 and 11): the largest danger index over
the robot's and the operators' ellipsoids at every tick, and the jerk of the tool's speed
along the path sampled at the controller's period. The seed takes jerk from the selected
velocity; we take it from the speed the robot actually ran, which the PathFollower makes
follow the selection (and which every controller, the SSM override included, has)."""

import numpy as np

from safety_systems.config.configuration import joint_path
from safety_systems.diagrams.simulation import Run
from safety_systems.diagrams.workcell import body_roles
from safety_systems.speed_alteration.ellipsoids import danger_index, robot_ellipsoids
from safety_systems.speed_alteration.methods import (
    operator_ellipsoids_over_time,
    preprogrammed_speed,
)


def danger_over_run(run: Run) -> np.ndarray:
    """(T,) largest DI over every robot-operator ellipsoid pair at each tick."""
    sizes = run.scenario.controller.alteration.ellipsoids
    operator_of, is_hand = body_roles(run.scenario)
    robot = robot_ellipsoids(run["q"], sizes.link_radii, sizes.tool_radius, sizes.tool_offset)
    humans = operator_ellipsoids_over_time(run.bodies("operators.positions_true"),
                                           run["operators.present"] > 0.5, operator_of,
                                           is_hand, sizes)
    return danger_index(robot, humans).max(axis=(1, 2))


def sampled_speed(run: Run) -> tuple[np.ndarray, float]:
    """The tool's signed speed along the path (path rate times Eq. 8's V_pre), m/s,
    sampled every controller period, and that period."""
    period = 1.0 / run.scenario.controller.alteration.rate_hz
    step = max(1, int(round(period * run.scenario.robot.control_rate_hz)))
    v_pre = preprogrammed_speed(joint_path(run.scenario.robot))
    return run["follower.path_state"][::step, 1] * v_pre, period


def jerk(speed: np.ndarray, period: float) -> np.ndarray:
    """Second difference of the speed over the period squared, m/s^3."""
    return np.diff(speed, 2) / period**2
