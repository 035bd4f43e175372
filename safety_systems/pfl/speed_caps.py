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
pressed against a fixed object (the cell's tables, walls and fixtures, declared as boxes:
``safety.fixed_surfaces``) cannot, and its quasi-static limits are half the transient
ones or less; we keep **pure SSM** for such a segment rather than a quasi-static cap:
the quasi-static limit holds for a force sustained by a robot pushing, which a speed cap
does not bound (that needs force sensing, not modelled here). A segment counts as
clampable when its capsule comes within :data:`CLAMP_GAP` of a declared surface (the
truth the property measures: :func:`clampable`); the override drops the segment's cap to
0 when the monitor's envelope of it comes within ``CLAMP_GAP + clamp_margin`` (the
configuration's ``clamp_margin``, room for the operator's and the robot's travel while
the robot slows; :func:`clamp_caps`). Too little room shows as a counterexample of the
permitted contact property, not as a proof.

Distances to a box are bounded below through samples along the segment (the distance
to a convex set is 1-Lipschitz, so the least sampled distance less half the sample
spacing bounds the segment's), so a segment is only ever thought closer to a surface
than it is: clampable errs towards pure SSM in the override and towards a stricter
property in the truth.
"""

import math

import numba
import numpy as np

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
def clamp_caps(ends, radii, caps, boxes, reach, out):
    """The caps in force now: ``caps`` (M,), and 0 for every segment whose capsule
    (``ends`` (M, 2, 3), ``radii`` (M,): the monitor's envelopes) may lie within
    ``reach`` of a fixed surface (:func:`clampable`), into ``out`` (M,)."""
    for i in range(caps.size):
        out[i] = caps[i]
        if caps[i] > 0.0 and boxes.shape[0] > 0 and clampable(ends[i, 0], ends[i, 1],
                                                               radii[i], boxes, reach):
            out[i] = 0.0


def surface_boxes(surfaces) -> np.ndarray:
    """The declared fixed surfaces (``Box`` entries with ``min`` and ``max``) as an
    (S, 2, 3) array."""
    return np.array([[s.min, s.max] for s in surfaces], dtype=float).reshape(-1, 2, 3)


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
