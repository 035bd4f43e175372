"""The safety properties and their robustness, defined once for the whole project.

Robustness convention: a value >= 0 means the property holds (safe), a value < 0 means
it is violated; its size says by how much. Falsifiers minimise robustness.

Contact is as the scenario's ``contact_geometry`` defines it
(``safety_systems.metrics``): a body's sphere against any of the real robot's capsules
(clearance: axis distance - capsule radius - body radius), or, on the seed's
``tool_point``, a body's centre against the tool flange.

- **Stopped before contact** (primary): whenever an operator body is within the contact
  distance of the robot, the robot is at rest. Robustness = the smallest true clearance
  over the instants when the robot moves faster than ``MOVING_SPEED``, minus the
  contact distance (+inf when the robot never moves while a body is present).
- **Protective distance respected** (reported beside it): the time the robot spends
  moving while the true clearance of some body-capsule pair is below the ISO/TS 15066
  protective distance S computed from that pair's true speeds (Eq. 1 with the true
  directed speeds and the configuration's T_r, T_s, B, C, Z_d, Z_r), and the deepest
  such intrusion, metres.
"""

import dataclasses

import numpy as np

from safety_systems.metrics import MOVING_SPEED, min_separation_while_moving
from safety_systems.ssm import monitor_protective_distances

__all__ = ["MOVING_SPEED", "Robustness", "stopped_before_contact", "protective_intrusion"]


@dataclasses.dataclass(frozen=True)
class Robustness:
    """Both properties' figures for one scenario (robustness >= 0 means safe)."""

    stopped_before_contact: float  # m
    min_separation_while_moving: float  # m (inf if never moving near a body)
    protective_violation_time: float  # s moving inside the true-speed S
    protective_deepest_intrusion: float  # m, max of S_true - d_true while moving (0 if none)

    @property
    def safe(self) -> bool:
        return self.stopped_before_contact >= 0.0


def stopped_before_contact(separations: np.ndarray, robot_speed: np.ndarray,
                           contact_distance: float) -> float:
    """Robustness of "stopped before contact" from (T, N) true clearances (NaN where a
    body is absent) and (T,) true robot speeds."""
    return min_separation_while_moving(separations, robot_speed) - contact_distance


def protective_intrusion(clearances: np.ndarray, robot_speed: np.ndarray,
                         v_human_directed: np.ndarray, v_robot_directed: np.ndarray,
                         dt: float, **s_args) -> tuple[float, float]:
    """(time, deepest intrusion) of the robot moving inside the protective distance
    computed from the true directed speeds, from the (T, N, K) clearances and directed
    speeds of every body-capsule pair (NaN where a body is absent); ``s_args`` are the
    configuration's ``reaction_time``, ``stopping_time``, ``stopping_distance`` and
    margins."""
    s_true = monitor_protective_distances(v_human_directed, v_robot_directed,
                                          mode="estimated", **s_args)
    moving = (robot_speed > MOVING_SPEED)[:, None, None]
    intrusion = np.where(moving & np.isfinite(clearances), s_true - clearances, -np.inf)
    inside = intrusion > 0.0
    time = float(np.count_nonzero(np.any(inside, axis=(1, 2))) * dt)
    deepest = float(max(np.max(intrusion, initial=-np.inf), 0.0))
    return time, deepest
