"""The safety properties and their robustness, defined once for the whole project.

Robustness convention: a value >= 0 means the property holds (safe), a value < 0 means
it is violated; its size says by how much. Falsifiers minimise robustness.

Contact is as the scenario's ``contact_geometry`` defines it
(``safety_systems.outputs.metrics``): a body's sphere against any of the real robot's capsules
(clearance: axis distance - capsule radius - body radius), or, on the seed's
``tool_point``, a body's centre against the tool flange.

- **Stopped before contact** (primary): whenever an operator body is within the contact
  distance of the robot, the robot is at rest. Robustness = the smallest true clearance
  over the instants when the robot moves faster than ``MOVING_SPEED``, minus the
  contact distance (+inf when the robot never moves while a body is present).
- **Separation invariant** (ISO/TS 15066's own requirement, which an assessor checks):
  at every control tick where the controller permits motion, the true separation
  d_true of every body from the robot is at least S_true, seed 000's Eqs. 9-11 on the
  true speeds with the simulated robot's own stopping data
  (``safety_systems.outputs.metrics``: the separation margin, and why Z_d and Z_r are not in
  S_true). Robustness = the smallest d_true - S_true over those ticks and every pair
  of a body present and a capsule of the real robot (+inf when motion is never
  permitted while a body is present); the time motion was permitted with some pair
  inside S_true is reported beside it. Under ``safety.mode: ssm_pfl`` it holds for the
  speed and separation monitoring part only: a pair counts at the ticks where the
  command exceeds its segment's power and force limiting cap in force
  (``true_measures.is_ssm_permitted``); at or below it, contact is the permitted contact
  property's to judge.
- **Permitted contact** (ISO/TS 15066's power and force limiting,
  ``safety_systems.pfl``): every contact while the robot moves touches a segment whose
  body regions all permit transient contact, not clampable (against the robot's mounting
  surface, a declared fixed surface, or between two of the robot's links), at a relative
  speed (the robot's speed towards the segment at the pair's nearest points, Eq. 7's
  v_R^d: ``pfl.speed_caps``) at or below the least permissible speed of those regions
  (Annex A, for the robot's effective mass with the configured payload); and the contact
  is transient: from its impact the robot's indentation of the segment stays within the
  transient compression for the transient window and within the quasi-static one after
  (``pfl.contact_limits``: a robot that keeps pressing into a hand violates it, one
  that comes off or stops within the limits does not). Robustness: over the contacts'
  ticks, the least of limit - relative speed while the robot moves (m/s; minus infinity
  for the head, face or neck, or a clampable segment) and allowed - indentation (m);
  with no contact while the robot moves, the stopped-before-contact figure (m: how far
  from any contact the moving robot stayed). Under ``ssm`` it follows from stopped
  before contact, and its figure is the impact rule alone (the contacts' speeds);
  ``verify`` checks it under ``ssm_pfl``, in place of stopped before contact.
"""

import dataclasses

import numpy as np

from safety_systems.outputs.metrics import min_separation_while_moving, separation_margins
from safety_systems.pfl.segment_regions import permitted_contact_robustness
from safety_systems.ssm.true_measures import MOVING_SPEED, moving

__all__ = ["MOVING_SPEED", "PROPERTIES", "Robustness", "stopped_before_contact",
           "separation_invariant", "permitted_contact", "permitted_contact_of",
           "mode_properties"]

# The properties by name, and the Robustness field of each.
PROPERTIES = {"contact": "stopped_before_contact", "separation": "separation",
              "permitted_contact": "permitted_contact"}
# The properties ``verify`` checks under each ``safety.mode``.
MODE_PROPERTIES = {"ssm": ("contact", "separation"),
                   "ssm_pfl": ("permitted_contact", "separation")}


def mode_properties(mode: str) -> tuple[str, ...]:
    """The properties a configuration of ``safety.mode`` ``mode`` is verified for."""
    return MODE_PROPERTIES[mode]


@dataclasses.dataclass(frozen=True)
class Robustness:
    """Both properties' figures for one scenario (robustness >= 0 means safe)."""

    stopped_before_contact: float  # m
    min_separation_while_moving: float  # m (inf if never moving near a body)
    separation: float  # m, smallest d_true - S_true while motion is permitted (inf: never)
    separation_violation_time: float  # s permitted with some pair inside S_true
    permitted_contact: float = np.inf  # m/s at a contact, or m without one (see above)

    @property
    def safe(self) -> bool:
        return self.stopped_before_contact >= 0.0 and self.separation >= 0.0


def stopped_before_contact(separations: np.ndarray, robot_speed: np.ndarray,
                           contact_distance: float) -> float:
    """Robustness of "stopped before contact" from (T, N) true clearances (NaN where a
    body is absent) and (T,) true robot speeds."""
    return min_separation_while_moving(separations, robot_speed) - contact_distance


def separation_invariant(clearances: np.ndarray, s_true: np.ndarray, allowed: np.ndarray,
                         dt: float) -> tuple[float, float]:
    """(robustness, violation time) of the separation invariant from the (T, N, K) true
    clearances and S_true of every body-capsule pair (NaN where a body is absent) and
    whether the controller permits motion at each of the T ticks (period ``dt``)."""
    margins = separation_margins(clearances, s_true, allowed)
    return float(np.min(margins, initial=np.inf)), float(np.count_nonzero(margins < 0.0) * dt)


def permitted_contact(clearances: np.ndarray, v_robot: np.ndarray, robot_speed: np.ndarray,
                      limits: np.ndarray, clamped: np.ndarray, contact_distance: float
                      ) -> float:
    """Robustness of "permitted contact" from the (T, M, K) true clearances and the
    robot's directed speeds towards the segments (NaN where a segment is absent), the
    (T,) true robot speeds, each segment's permissible speed ``limits`` (M,) (0:
    forbidden) and whether it is clampable at each tick ``clamped`` (T, M)."""
    moving_now = moving(np.asarray(robot_speed))
    touch = (np.nan_to_num(clearances, nan=np.inf) < contact_distance) \
        & moving_now[:, None, None]
    if not touch.any():
        return stopped_before_contact(clearances.min(axis=-1), robot_speed,
                                      contact_distance)
    t, i, _ = np.nonzero(touch)
    limit = np.where(clamped[t, i], 0.0, limits[i])  # a clampable segment: none
    return float(np.min(permitted_contact_robustness(limit, v_robot[touch])))


def permitted_contact_of(figures: np.ndarray, stopped: float) -> float:
    """Robustness of "permitted contact" under ``safety.mode: ssm_pfl`` from the (T, M)
    figures of every contact episode's ticks (``pfl.contact_limits.lasting_contact``, +inf
    outside one): their least, or, with no contact while the robot moved, the
    stopped-before-contact figure ``stopped`` (m)."""
    least = float(np.min(figures, initial=np.inf))
    return least if least < np.inf else float(stopped)
