"""The operator's twelve segments (``cell/human_body.py``) mapped to the body regions of
ISO/TS 15066 Annex A, each segment's permissible relative speed at a transient contact,
and the robustness of the *permitted contact* property for one contact.

**Which regions a segment presents** (:data:`SEGMENT_REGIONS`, aligned with
``SEGMENT_NAMES``; the first region is the segment's own, for reports): every region whose
body surface the segment's capsule may hold, since where on the capsule a contact falls is
not known (our interpretation, from the segments' points in ``human_body.py``):

- ``head`` (a ball about the head's centre): the skull/forehead and the face;
- ``neck``: the neck;
- ``upper_trunk`` (neck base at the top of the sternum, to mid-sternum): the chest in
  front, the back and shoulders behind;
- ``lower_trunk`` (mid-sternum to the hip joints' midpoint): the abdomen, the lower half
  of the sternum (chest), the pelvis, the lower back (its fifth lumbar vertebra is a
  back location in Table A.2) and the tops of the thighs about the hip joints (the
  operator has no leg segments: the thighs' and lower legs' regions serve no other);
- ``shoulder_*`` (neck base to shoulder joint): the back and shoulders (the shoulder joint
  is one of its locations) and the top of the sternum (chest) at the neck base;
- ``upper_arm_*`` (shoulder to elbow): the upper arm and elbow, and the shoulder joint at
  its inner end;
- ``forearm_*`` (elbow to hand centre): the lower arm and wrist, and the elbow joint (an
  upper-arm location in Annex A) at its inner end;
- ``hand_*`` (a 0.12 m ball about the hand's centre, which reaches the wrist): the hand and
  fingers, and the wrist (a lower-arm location).

A segment's permissible speed is the least of its regions' (:func:`permitted_speed`); a
segment presenting a forbidden region (head, neck) permits none: 0.

**Robustness** of the permitted contact property for one contact
(:func:`permitted_contact_robustness`): the segment's limit minus the relative speed at
contact, >= 0 safe (the project's sign convention); minus infinity for a forbidden
segment, whatever the speed. The property's robustness is the least over its contacts.
"""

import numpy as np

from safety_systems.cell.human_body import NUM_SEGMENTS, SEGMENT_NAMES
from safety_systems.pfl.body_regions import BodyRegion, body_region
from safety_systems.pfl.contact_speed import transient_speed

_TRUNK_UP = ("chest", "back_shoulders")
_SHOULDER = ("back_shoulders", "chest")
_UPPER_ARM = ("upper_arms_elbows", "back_shoulders")
_FOREARM = ("lower_arms_wrists", "upper_arms_elbows")
_HAND = ("hands_fingers", "lower_arms_wrists")
SEGMENT_REGIONS = (
    ("skull_forehead", "face"),  # head
    ("neck",),  # neck
    _TRUNK_UP,  # upper_trunk
    ("abdomen", "chest", "pelvis", "back_shoulders", "thighs_knees"),  # lower_trunk
    _SHOULDER, _SHOULDER,  # shoulder_left, shoulder_right
    _UPPER_ARM, _UPPER_ARM,  # upper_arm_left, upper_arm_right
    _FOREARM, _FOREARM,  # forearm_left, forearm_right
    _HAND, _HAND,  # hand_left, hand_right
)
if len(SEGMENT_REGIONS) != NUM_SEGMENTS:
    raise AssertionError(f"SEGMENT_REGIONS has {len(SEGMENT_REGIONS)} rows for "
                         f"{NUM_SEGMENTS} segments {SEGMENT_NAMES}")
# Whether a segment presents a region where no transient contact is permitted.
SEGMENT_FORBIDDEN = np.array([any(not body_region(r).transient_contact for r in regions)
                              for regions in SEGMENT_REGIONS])
SEGMENT_FORBIDDEN.setflags(write=False)


def segment_regions(segment: int) -> tuple[BodyRegion, ...]:
    """The body regions segment ``segment`` (an index of ``SEGMENT_NAMES``) presents, its
    own first."""
    if not 0 <= segment < NUM_SEGMENTS:
        raise ValueError(f"segment = {segment!r}; need an index 0 ... {NUM_SEGMENTS - 1} of "
                         f"{SEGMENT_NAMES}")
    return tuple(body_region(name) for name in SEGMENT_REGIONS[segment])


def permitted_speed(segment: int, robot_effective_mass, *, contact_area=None):
    """The permissible relative speed of a transient contact with segment ``segment``,
    metres per second: the least over its regions of ``contact_speed.transient_speed``
    for a robot of effective mass ``robot_effective_mass`` (m_R = M / 2 + m_L, kilograms:
    the payload enters here; ``robot_masses.effective_mass``), the pressure limit too when
    ``contact_area`` (square metres) is given. 0 for a segment presenting a forbidden
    region."""
    return np.min([transient_speed(region, robot_effective_mass, contact_area=contact_area)
                   for region in segment_regions(segment)], axis=0)


def permitted_speeds(robot_effective_mass: float, *, contact_area: float | None = None
                     ) -> np.ndarray:
    """:func:`permitted_speed` of every segment, aligned with ``SEGMENT_NAMES`` (12,)."""
    return np.array([permitted_speed(i, robot_effective_mass, contact_area=contact_area)
                     for i in range(NUM_SEGMENTS)], dtype=float)


def permitted_contact_robustness(limit, relative_speed):
    """The permitted contact property's robustness for contacts with permissible speeds
    ``limit`` at relative speeds ``relative_speed`` (metres per second; arrays
    broadcast): ``limit - relative_speed``, and minus infinity where the limit is 0 (a
    forbidden segment, whatever the speed). >= 0 means safe."""
    limit = np.asarray(limit, dtype=float)
    return np.where(limit > 0.0, limit - np.asarray(relative_speed, dtype=float), -np.inf)
