"""Power and force limiting beside speed and separation monitoring (``safety.mode:
ssm_pfl``): the speed cap each operator segment allows the robot near it, and the
clamping rule, as plain functions the SpeedOverride, the batched evaluator and the
properties share.

**The cap.** Under ``ssm`` the override's k is Eq. 12 of seed 000 over the segments (the
least over them, with S_max the largest S: ``ssm.formulas.override_row``). Under
``ssm_pfl`` each segment i may hold k up at a floor c_i instead of 0 (Eq. 12 keeps
ruling above it):

    k = min over usable segments i of max(Eq. 12(d_i, S_max), c_i)

(``ssm.formulas.override_row_caps``). c_i is a path rate: at rate sigma every point of
the robot's capsule axes moves at most sigma V_R (V_R: ``cell.path_speed.path_speed_bound``
of the monitor's capsules on the job's path), so with

    c_i = min(1, min(v_pfl, v_i) / V_R)                              (:func:`segment_caps`)

(v_i the segment's permissible relative speed, ISO/TS 15066 Annex A:
``pfl.segment_regions.permitted_speeds`` for the configured payload; v_pfl the
configuration's ``pfl_speed``, the robot's speed cap near an operator, None: v_i) no axis
point moves towards the segment faster than v_i once the rate is down to c_i. A segment
that presents the head, the face or the neck has v_i = 0, so c_i = 0: pure SSM, as
Eq. 12. With every c_i = 0 the formula is Eq. 12's k exactly (Eq. 12 is nondecreasing in
d: the least over the segments is the closest segment's), which the tests hold bit for
bit.

Interpretation (ours): the relative speed at a contact is the robot's speed towards the
segment, v_R^d of seed 000's Eq. 7 at the pair's nearest points, not the closing speed of
both bodies. ISO 13855's approach speeds (1.6-2.0 m/s) exceed every region's permissible
speed for these robots (the most lenient, the hand, about 1.2 m/s with the UR5e), so
counting the operator's own speed would forbid every contact and PFL could not exist; a
robot cannot control how fast a person strikes it.

**Clamping.** Annex A's transient limits assume the body region can recoil. A region
pressed against a fixed object cannot, and its quasi-static limits are half the transient
ones or less; we keep **pure SSM** for such a segment rather than a quasi-static cap.
What a segment can be pressed against needs no one to declare it (issue 46): the surface
the robot stands on (``robot.mounting_size``: the table or floor plane under the base,
by default a square over the robot's reach, as the robot can press nothing onto it
beyond; :func:`mounting_box`), every declared fixture (``safety.fixed_surfaces``:
tables, walls, fixtures), and the robot's own body: a segment within reach of the
capsules of two different links (:func:`between_links`: caught between two links, or
between a link and the first link that turns about the base; the tool counts as its
flange's link). A segment counts as clampable when its capsule comes within
:data:`CLAMP_GAP` of any of these (the truth the property measures: :func:`clampable`,
:func:`between_links`); the override drops the segment's cap to 0 when the monitor's
envelope of it comes within ``CLAMP_GAP + clamp_margin`` of them (the configuration's
``clamp_margin``, room for the operator's and the robot's travel while the robot slows;
:func:`clamp_caps`). Too little room shows as a counterexample of the permitted contact
property, not as a proof. A contact that lasts is bounded as well:
``pfl.contact_limits`` (transient and quasi-static compressions, the robot's contact
detection).

Distances to a box are bounded below through samples along the segment (the distance
to a convex set is 1-Lipschitz, so the least sampled distance less half the sample
spacing bounds the segment's), so a segment is only ever thought closer to a surface
than it is: clampable errs towards pure SSM in the override and towards a stricter
property in the truth.
"""

import math

import numba
import numpy as np

from safety_systems.cell.robot_geometry import segments_pair

# ``safety.mode``: speed and separation monitoring only (seed 000), or with power and
# force limiting near the permitted body regions.
SAFETY_MODES = ("ssm", "ssm_pfl")

# A segment whose capsule is within this of a declared fixed surface can be pressed
# against it (m). Our choice: about a hand's thickness; a region this close cannot recoil
# out of a robot that keeps moving at a PFL speed for the tenths of a second it takes to
# stop.
CLAMP_GAP = 0.05

_SAMPLES = 17  # points along a segment for the distance to a box


def segment_caps(limits, pfl_speed, speed_bound: float) -> np.ndarray:
    """c_i = min(1, min(v_pfl, v_i) / V_R) for every segment (module docstring):
    ``limits`` the segments' permissible speeds v_i (m/s, 0: forbidden), ``pfl_speed``
    the configured cap v_pfl (m/s; None: each segment's own limit), ``speed_bound``
    V_R (m/s at full path rate). 0 where the limit is 0; a non-finite or non-positive
    V_R gives 0 everywhere (fail safe: pure SSM)."""
    v = np.asarray(limits, dtype=float)
    if pfl_speed is not None:
        v = np.minimum(v, float(pfl_speed))
    if not (math.isfinite(speed_bound) and speed_bound > 0.0):
        return np.zeros(v.shape)
    return np.where(v > 0.0, np.minimum(v / speed_bound, 1.0), 0.0)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def point_box_distance(x0, x1, x2, box):
    """Distance (m) from a point to the box ``box`` ((2, 3): min and max corners); 0
    inside."""
    g0 = max(box[0, 0] - x0, 0.0, x0 - box[1, 0])
    g1 = max(box[0, 1] - x1, 0.0, x1 - box[1, 1])
    g2 = max(box[0, 2] - x2, 0.0, x2 - box[1, 2])
    return math.sqrt(g0 * g0 + g1 * g1 + g2 * g2)


@numba.njit(cache=True)
def capsule_box_gap(p, q, radius, box):
    """A lower bound on the clearance (m) between the capsule of axis p-q (3-vectors)
    and ``radius``, and the box ``box`` ((2, 3)): the least distance of
    :data:`_SAMPLES` points along the axis, less half their spacing and the radius. NaN
    for a NaN input."""
    l0, l1, l2 = q[0] - p[0], q[1] - p[1], q[2] - p[2]
    spacing = math.sqrt(l0 * l0 + l1 * l1 + l2 * l2) / (_SAMPLES - 1)
    least = np.inf
    for n in range(_SAMPLES):
        t = n / (_SAMPLES - 1)
        g = point_box_distance(p[0] + t * l0, p[1] + t * l1, p[2] + t * l2, box)
        if not g >= least:  # (keeps a NaN)
            least = g
    return least - 0.5 * spacing - radius


@numba.njit(cache=True)
def clampable(p, q, radius, boxes, reach):
    """Whether the capsule of axis p-q and ``radius`` may lie within ``reach`` (m) of any
    of ``boxes`` ((S, 2, 3)); a NaN input counts as within (fail safe)."""
    for n in range(boxes.shape[0]):
        if not capsule_box_gap(p, q, radius, boxes[n]) > reach:
            return True
    return False


@numba.njit(cache=True)
def between_links(p, q, radius, ends, end_velocities, radii, links, reach):
    """Whether the capsule of axis p-q and ``radius`` may lie within ``reach`` (m) of the
    capsules of two different links of the robot (``ends`` (J, 2, 3) and their
    velocities, ``radii`` (J,), ``links`` (J,): each capsule's link, the tool its
    flange's: :func:`capsule_links`), so that the two could close on it: a segment
    caught between two links, or between a link and the base's (the first link turns
    about the base). A NaN input counts as within (fail safe). Clearances as the
    properties take them (``robot_geometry.segments_pair``'s axis distance less both
    radii)."""
    first = -1
    zero = (0.0, 0.0, 0.0)
    for j in range(radii.size):
        A, B = ends[j, 0], ends[j, 1]
        gap = segments_pair((p[0], p[1], p[2]), (q[0], q[1], q[2]), zero, zero,
                            (A[0], A[1], A[2]), (B[0], B[1], B[2]),
                            (end_velocities[j, 0, 0], end_velocities[j, 0, 1],
                             end_velocities[j, 0, 2]),
                            (end_velocities[j, 1, 0], end_velocities[j, 1, 1],
                             end_velocities[j, 1, 2]))[0] - radii[j] - radius
        if not gap > reach:
            if first < 0:
                first = links[j]
            elif links[j] != first:
                return True
    return False


def capsule_links(capsules) -> np.ndarray:
    """Each capsule's link (``robot_geometry.Capsules``): the link capsules their own
    index, the tool the last link's (it is fixed to the flange), so a segment touching the
    tool and the last link only is not caught between two links. The seed's tool point
    (one capsule): 0."""
    n = len(capsules.names)
    links = np.arange(n, dtype=np.int64)
    if n > 1 and capsules.names[-1] == "tool":
        links[-1] = n - 2
    return links


@numba.njit(cache=True)
def clamp_caps(ends, radii, caps, boxes, reach, robot_ends, robot_velocities, robot_radii,
               robot_links, out):
    """The caps in force now: ``caps`` (M,), and 0 for every segment whose capsule
    (``ends`` (M, 2, 3), ``radii`` (M,): the monitor's envelopes) may lie within
    ``reach`` of a fixed surface (:func:`clampable`: the robot's mounting surface and the
    declared ones) or of two links of the robot (:func:`between_links`, of the monitor's
    capsules ``robot_ends`` (J, 2, 3), their velocities, radii and links), into ``out``
    (M,)."""
    for i in range(caps.size):
        out[i] = caps[i]
        if caps[i] > 0.0 and ((boxes.shape[0] > 0 and clampable(
                ends[i, 0], ends[i, 1], radii[i], boxes, reach)) or between_links(
                ends[i, 0], ends[i, 1], radii[i], robot_ends, robot_velocities, robot_radii,
                robot_links, reach)):
            out[i] = 0.0


def surface_boxes(surfaces) -> np.ndarray:
    """The declared fixed surfaces (``Box`` entries with ``min`` and ``max``) as an
    (S, 2, 3) array."""
    return np.array([[s.min, s.max] for s in surfaces], dtype=float).reshape(-1, 2, 3)


MOUNTING_THICKNESS = 0.05  # m: the mounting surface's box below its top (any will do)


def mounting_box(size, reach: float) -> np.ndarray:
    """(1, 2, 3) the surface the robot stands on, as a box whose top is the base frame's
    z = 0 plane (the robot's base frame sits on its mounting surface): ``size`` [x, y]
    (m, centred on the base), or, empty, a square of half side ``reach`` (m: as far as
    any point of the robot and its tool gets from the base origin, so every place the
    robot could press a body onto the plane)."""
    if len(size):
        hx, hy = 0.5 * float(size[0]), 0.5 * float(size[1])
    else:
        hx = hy = float(reach)
    return np.array([[[-hx, -hy, -MOUNTING_THICKNESS], [hx, hy, 0.0]]])


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def contact_robustness(limit, relative_speed, clamped):
    """The permitted contact property's figure for one contact while the robot moves:
    ``limit`` - ``relative_speed`` (m/s), minus infinity for a forbidden segment (limit
    0) or a clampable one (``clamped``), whatever the speed
    (``pfl.segment_regions.permitted_contact_robustness``, compiled)."""
    if clamped or not limit > 0.0:
        return -np.inf
    return limit - relative_speed


@numba.njit(cache=True)
def _clampable_rows(ends, radius, boxes, reach, out):
    for t in range(ends.shape[0]):
        for i in range(ends.shape[1]):
            out[t, i] = clampable(ends[t, i, 0], ends[t, i, 1], radius[t, i], boxes, reach)


def clampable_segments(ends: np.ndarray, radius: np.ndarray, boxes: np.ndarray,
                       reach: float = CLAMP_GAP) -> np.ndarray:
    """(T, M) :func:`clampable` of every segment (``ends`` (T, M, 2, 3), ``radius``
    (T, M)) against the fixed surfaces ``boxes`` (S, 2, 3): all False without surfaces."""
    ends = np.ascontiguousarray(ends, dtype=float)
    out = np.zeros(ends.shape[:2], dtype=bool)
    if len(boxes):
        _clampable_rows(ends, np.ascontiguousarray(np.broadcast_to(radius, ends.shape[:2]),
                                                   dtype=float),
                        np.ascontiguousarray(boxes, dtype=float), float(reach), out)
    return out
