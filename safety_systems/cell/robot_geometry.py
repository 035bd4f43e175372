"""The UR5e as capsules: one geometry of the robot for the whole project.

Points P0 ... P6 are the origins of the standard-DH frames {0} ... {6} (P0 the fixed
base origin, P6 tool0 on the flange) and P7 = P6 + tool_length z6 the tool tip (z6,
tool0's z axis, equals (P6 - P5) / d6 and does not depend on q6). Capsule j is the
segment from A_j = (1 - t0_j) P[a_j] + t0_j P[b_j] to B_j (the same with t1_j), grown by
radius r_j (metres); t0 <= 0 <= 1 <= t1 extend a link's segment over its joint housings.
a_j and b_j lie on one rigid link, so A_j and B_j are rigid points of it and any axis
point A + t (B - A) moves at vA + t (vB - vA) exactly.

The six link capsules are fitted at import to the collision cylinders of
``models/ur5e/ur5e.urdf`` (:func:`model_link_capsules`). Those cylinders are a
simplified model of the arm, not UR's meshes (see ``models/ur5e/README.md``), so the
capsules are only as good as that model. The base_link's cylinder is fixed to the world
and gets no capsule: a static base cannot strike anyone.

Seed: Lettera, Costa, Callegari 2025 (``shared/seeds/000_*``) monitors one robot point,
the end effector: its velocity (Eq. 5, there a finite difference; here J(q) v), the
directed speeds (Eqs. 6-7) and the distance (Eq. 8, point to point). Our interpretation:
the robot point becomes the nearest point of the nearest capsule's axis, and Eq. 8's
distance the clearance to that capsule (axis distance - capsule radius - body radius;
negative = overlap). :func:`tool_point` keeps the seed's single point, bit for bit.
"""

import dataclasses
import math
from pathlib import Path

import numba
import numpy as np

from safety_systems.cell import ur5e
from safety_systems.cell.model_points import model_arrays, model_points_one, model_work
from safety_systems.cell.robot_model import RobotModel, default_model
from safety_systems.cell.ur_capsules import RADIUS_STEP, fit_ur_link_capsules  # noqa: F401
from safety_systems.cell.ur_kinematics import points_from_trig, trig_one, trig_reusing
from safety_systems.ssm.formulas import separation_pair

CAPSULE_NAMES = ("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3", "tool")
LINK_SEGMENTS = tuple((k, k + 1) for k in range(6))  # DH origin indices of each link
NUM_POINTS = 8  # P0 ... P6 and the tool tip P7



def _fit_link_capsules(urdf: Path) -> tuple[tuple[str, ...], tuple]:
    """``ur_capsules.fit_ur_link_capsules`` of a URDF written from the UR5e's DH data."""
    return fit_ur_link_capsules(urdf, ur5e.DH_D, ur5e.DH_A)


LINK_NAMES, _MODEL_LINK_CAPSULES = _fit_link_capsules(ur5e.UR5E_URDF)  # URDF link names


def model_link_capsules() -> tuple[tuple[int, int, float, float, float], ...]:
    """(a, b, t0, t1, radius) of the six link capsules, fitted to the URDF at import."""
    return _MODEL_LINK_CAPSULES


@dataclasses.dataclass(frozen=True, eq=False)
class Capsules:
    """K capsules (see the module docstring) of a robot ``model``
    (``robot_model.RobotModel``; None: the UR5e's): point indices a, b (K,) into its
    points (the UR's P0 ... P7), axis fractions t0, t1 (K,), radii (K,) in metres, and
    the tool length (metres) that places its tip. Arrays are stored read-only."""

    names: tuple[str, ...]
    a: np.ndarray
    b: np.ndarray
    t0: np.ndarray
    t1: np.ndarray
    radius: np.ndarray
    tool_length: float = 0.0
    model: RobotModel | None = None

    def __post_init__(self):
        for field, kind in (("a", np.int64), ("b", np.int64), ("t0", float), ("t1", float),
                            ("radius", float)):
            x = np.array(getattr(self, field), dtype=kind).reshape(-1)
            x.setflags(write=False)
            object.__setattr__(self, field, x)
            if x.size != len(self.names):
                raise ValueError(f"Capsules.{field} has {x.size} values for "
                                 f"{len(self.names)} names: need one per capsule")
        if self.model is None:
            object.__setattr__(self, "model", default_model())
        P = self.model.num_points
        if np.any((self.a < 0) | (self.a >= P) | (self.b < 0) | (self.b >= P)):
            raise ValueError(f"Capsules a = {self.a}, b = {self.b}: need indices in 0 ... "
                             f"{P - 1} (the {self.model.name}'s points)")
        object.__setattr__(self, "names", tuple(self.names))
        object.__setattr__(self, "tool_length", float(self.tool_length))


def robot_capsules(*, link_radii=None, payload_radius: float,
                   tool_length: float = 0.0, model: RobotModel | None = None) -> Capsules:
    """The capsules of ``model`` (None: the UR5e; ``CAPSULE_NAMES`` on a UR): its fitted
    link capsules (with ``link_radii``, one radius in metres per link, instead of the
    fitted ones if given) and the tool, tool0 -> tip (``tool_length`` metres along
    tool0's z axis), of ``payload_radius`` metres."""
    model = default_model() if model is None else model
    fitted = np.array(model.link_capsules)
    radii = fitted[:, 4]
    K = len(model.link_capsules)
    if link_radii is not None:
        radii = np.asarray(link_radii, dtype=float).reshape(-1)
        if radii.size != K:
            raise ValueError(f"link_radii = {link_radii!r}: need {K} radii (metres), one per "
                             f"link {model.link_names}, or None for the fitted ones")
        if not np.all(np.isfinite(radii) & (radii > 0.0)):
            raise ValueError(f"link_radii = {link_radii!r}: every radius must be finite and "
                             "> 0 metres")
    if not (math.isfinite(payload_radius) and payload_radius > 0.0):
        raise ValueError(f"payload_radius = {payload_radius!r}: need a finite radius > 0 "
                         "metres")
    if not (math.isfinite(tool_length) and tool_length >= 0.0):
        raise ValueError(f"tool_length = {tool_length!r}: need a finite length >= 0 metres")
    return Capsules(model.link_names + ("tool",), np.append(fitted[:, 0], model.tool0),
                    np.append(fitted[:, 1], model.tip), np.append(fitted[:, 2], 0.0),
                    np.append(fitted[:, 3], 1.0), np.append(radii, payload_radius),
                    tool_length, model)


def tool_point(model: RobotModel | None = None) -> Capsules:
    """One degenerate capsule, tool0 itself (radius 0), of ``model`` (None: the UR5e):
    the seed's Eq. 8 robot point."""
    model = default_model() if model is None else model
    return Capsules(("tool0",), [model.tool0], [model.tool0], [0.0], [0.0], [0.0], 0.0, model)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def _points_from_trig(trig, v, tool_length, p, pv):
    """:func:`robot_points_one` from trig = (cos, sin) of q1, q2, q2 + q3, q2 + q3 + q4,
    q5 (``ur_kinematics.points_from_trig`` with the UR5e's constants; P6 is
    ur5e.tool0_one's, bit for bit)."""
    points_from_trig(trig, v, tool_length, ur5e.UR5E_DH, p, pv)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def robot_points_one(q, v, tool_length, p, pv):
    """P0 ... P7 into p (8, 3) and their velocities J(q) v into pv (8, 3), metres and m/s,
    of one joint position q and velocity v (6,), compiled and callable from other compiled
    code. Closed form as ur5e.tool0_one (joints 2-4 parallel): P2 = P1 + a2 (c2, s2),
    P3 = P2 + a3 (c23, s23), P4 = P3 + d4 along joint 2's axis, P5 = P4 + d5 z4; P6 is
    tool0_one's, bit for bit; P7 = P6 + tool_length z6."""
    _points_from_trig(trig_one(q), v, tool_length, p, pv)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def robot_points_one_memo(q, v, tool_length, memo, p, pv):
    """:func:`robot_points_one`, equal bit for bit, reusing the trig kept in ``memo`` (15,)
    as ur5e.tool0_reusing_trig does (one memo can serve both)."""
    _points_from_trig(trig_reusing(q, memo), v, tool_length, p, pv)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def capsule_ends_one(p, pv, a, b, t0, t1, ends, end_velocities):
    """Capsule ends A, B into ends (K, 2, 3) and their velocities into end_velocities from
    the points p and velocities pv (8, 3): (1 - t) P_a + t P_b (exact at t = 0 and 1)."""
    for j in range(a.size):
        for i in range(3):
            pa, pb, va, vb = p[a[j], i], p[b[j], i], pv[a[j], i], pv[b[j], i]
            ends[j, 0, i] = (1.0 - t0[j]) * pa + t0[j] * pb
            ends[j, 1, i] = (1.0 - t1[j]) * pa + t1[j] * pb
            end_velocities[j, 0, i] = (1.0 - t0[j]) * va + t0[j] * vb
            end_velocities[j, 1, i] = (1.0 - t1[j]) * va + t1[j] * vb


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def segment_pair(p_B, v_B, A, B, vA, vB):
    """(axis_distance, v_human_directed, v_robot_directed) of a body at p_B moving at v_B
    and the segment AB moving rigidly (ends' velocities vA, vB): seed Eqs. 6-8 as
    ssm.separation_pair takes them, with the robot point the nearest point
    x = (1 - t) A + t B of AB, t = clamp((p_B - A).(B - A) / |B - A|^2, 0, 1), moving at
    (1 - t) vA + t vB. A point segment (|B - A|^2 = 0) is separation_pair(A, vA, ...) bit
    for bit. Positive speeds close in; a NaN input gives NaN.

    Why x's velocity: the distance to a rigid segment is a minimum over its points; by the
    envelope (Danskin's) theorem its rate is that of the minimising pair's offset, so
    d/dt distance = -(v_human_directed + v_robot_directed) with x moving as a rigid point.
    """
    e0, e1, e2 = B[0] - A[0], B[1] - A[1], B[2] - A[2]
    ee = e0 * e0 + e1 * e1 + e2 * e2
    x0, x1, x2, w0, w1, w2 = A[0], A[1], A[2], vA[0], vA[1], vA[2]
    if ee != 0.0:  # else a point: A itself (B and vB unread; a NaN goes on to NaN)
        t = ((p_B[0] - A[0]) * e0 + (p_B[1] - A[1]) * e1 + (p_B[2] - A[2]) * e2) / ee
        if t < 0.0:
            t = 0.0
        elif t > 1.0:
            t = 1.0  # a NaN t stays NaN
        s = 1.0 - t
        x0, x1, x2 = s * A[0] + t * B[0], s * A[1] + t * B[1], s * A[2] + t * B[2]
        w0, w1, w2 = s * vA[0] + t * vB[0], s * vA[1] + t * vB[1], s * vA[2] + t * vB[2]
    return separation_pair((x0, x1, x2), (w0, w1, w2), p_B, v_B)


_PARALLEL = 1e-12  # relative size of |d1 x d2|^2 below which two axes count as parallel


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def _point_on_segment(p, A, e, ee):
    """The parameter in [0, 1] of the point of segment A + t e (|e|^2 = ee > 0) nearest
    to p."""
    t = ((p[0] - A[0]) * e[0] + (p[1] - A[1]) * e[1] + (p[2] - A[2]) * e[2]) / ee
    return min(max(t, 0.0), 1.0)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def _gap2(P, d1, s, A, d2, t):
    """|(A + t d2) - (P + s d1)|^2."""
    x0 = A[0] + t * d2[0] - P[0] - s * d1[0]
    x1 = A[1] + t * d2[1] - P[1] - s * d1[1]
    x2 = A[2] + t * d2[2] - P[2] - s * d1[2]
    return x0 * x0 + x1 * x1 + x2 * x2


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def nearest_parameters(P, Q, A, B):
    """(s, t): the points P + s (Q - P) and A + t (B - A) (s, t in [0, 1]) nearest to each
    other on the two segments.

    Minimising |A + t d2 - P - s d1|^2 over the unit square, a convex quadratic: where
    the axes are not parallel, the unconstrained minimum's s clamped to [0, 1], the t
    best for it clamped, and s made best for a clamped t (the minimum over the square
    lies on the boundary the clamping reaches). Where they are parallel (|d1 x d2|^2 at
    most ``_PARALLEL`` |d1|^2 |d2|^2, where that formula's division loses its digits) the
    nearest pair always includes an end of one segment, so the four end-to-segment pairs
    are compared and the nearest kept. A point segment (Q = P or B = A) takes the
    point-to-segment rule."""
    d1 = (Q[0] - P[0], Q[1] - P[1], Q[2] - P[2])
    d2 = (B[0] - A[0], B[1] - A[1], B[2] - A[2])
    a = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2]
    e = d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2]
    if a == 0.0:
        return 0.0, (_point_on_segment(P, A, d2, e) if e != 0.0 else 0.0)
    if e == 0.0:
        return _point_on_segment(A, P, d1, a), 0.0
    r = (P[0] - A[0], P[1] - A[1], P[2] - A[2])
    b = d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2]
    c = d1[0] * r[0] + d1[1] * r[1] + d1[2] * r[2]
    f = d2[0] * r[0] + d2[1] * r[1] + d2[2] * r[2]
    denom = a * e - b * b  # |d1 x d2|^2 >= 0
    if denom > _PARALLEL * a * e:
        s = min(max((b * f - c * e) / denom, 0.0), 1.0)
        t = (b * s + f) / e
        if t < 0.0:
            t, s = 0.0, min(max(-c / a, 0.0), 1.0)
        elif t > 1.0:
            t, s = 1.0, min(max((b - c) / a, 0.0), 1.0)
        return s, t
    # Parallel: an end of one segment against the other segment, the nearest of four.
    best_s, best_t = 0.0, _point_on_segment(P, A, d2, e)
    best = _gap2(P, d1, best_s, A, d2, best_t)
    t1 = _point_on_segment(Q, A, d2, e)
    g = _gap2(P, d1, 1.0, A, d2, t1)
    if g < best:
        best, best_s, best_t = g, 1.0, t1
    s0 = _point_on_segment(A, P, d1, a)
    g = _gap2(P, d1, s0, A, d2, 0.0)
    if g < best:
        best, best_s, best_t = g, s0, 0.0
    s1 = _point_on_segment(B, P, d1, a)
    g = _gap2(P, d1, s1, A, d2, 1.0)
    if g < best:
        best_s, best_t = s1, 1.0
    return best_s, best_t


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def segments_pair(P, Q, vP, vQ, A, B, vA, vB):
    """(axis_distance, v_human_directed, v_robot_directed) of a human capsule's axis PQ
    (its ends moving at vP, vQ) and a robot capsule's axis AB moving rigidly (vA, vB):
    seed Eqs. 6-8 between the two axes' nearest points (:func:`nearest_parameters`),
    x_h = P + s (Q - P) and x_r = A + t (B - A). Eq. 8's distance is |x_r - x_h|; Eq. 7's
    robot speed is that of x_r, moving at (1 - t) vA + t vB, towards x_h; Eq. 6's human
    speed towards x_r is the larger of the two ends' (vP and vQ projected on the
    direction from x_h to x_r). Coincident points take the full magnitudes (the faster
    end's), as ``separation_pair`` does; a NaN input gives NaN.

    Interpretation: the seed's body is a point; a body segment's points move at the
    ends' weighted mean where the segment is rigid, so none moves towards the robot
    faster than its faster end, and for an envelope of untracked segments
    (``cell.human_body``) that is the rule the monitor takes. A point (P = Q, vP = vQ)
    is :func:`segment_pair` of P, bit for bit."""
    if (P[0] == Q[0] and P[1] == Q[1] and P[2] == Q[2] and vP[0] == vQ[0]
            and vP[1] == vQ[1] and vP[2] == vQ[2]):
        return segment_pair(P, vP, A, B, vA, vB)
    s, t = nearest_parameters(P, Q, A, B)
    u = 1.0 - t
    x0, x1, x2 = u * A[0] + t * B[0], u * A[1] + t * B[1], u * A[2] + t * B[2]
    w0, w1, w2 = u * vA[0] + t * vB[0], u * vA[1] + t * vB[1], u * vA[2] + t * vB[2]
    y0, y1, y2 = P[0] + s * (Q[0] - P[0]), P[1] + s * (Q[1] - P[1]), P[2] + s * (Q[2] - P[2])
    dist, h_P, v_r = separation_pair((x0, x1, x2), (w0, w1, w2), (y0, y1, y2), vP)
    if vP[0] == vQ[0] and vP[1] == vQ[1] and vP[2] == vQ[2]:
        return dist, h_P, v_r  # (a rigid segment: both ends' speeds are this one)
    h_Q = separation_pair((x0, x1, x2), (w0, w1, w2), (y0, y1, y2), vQ)[1]
    return dist, (h_P if h_P >= h_Q or math.isnan(h_P) else h_Q), v_r


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def nearest_capsule_one(p_B, v_B, r_B, ends, end_velocities, radius):
    """(clearance, v_human_directed, v_robot_directed, index) of a body (radius r_B
    metres) and the capsule nearest to it among K (ends and end_velocities (K, 2, 3),
    radius (K,)): clearance = axis distance - radius - r_B metres (negative = overlap),
    the speeds of :func:`segment_pair` for that capsule, the first on ties. A NaN in any
    pair's figures (a NaN position, velocity or radius) gives (NaN, NaN, NaN, -1)."""
    best, best_h, best_r, index, faulty = np.inf, np.nan, np.nan, -1, False
    for j in range(radius.size):
        d, v_h, v_r = segment_pair(
            p_B, v_B, (ends[j, 0, 0], ends[j, 0, 1], ends[j, 0, 2]),
            (ends[j, 1, 0], ends[j, 1, 1], ends[j, 1, 2]),
            (end_velocities[j, 0, 0], end_velocities[j, 0, 1], end_velocities[j, 0, 2]),
            (end_velocities[j, 1, 0], end_velocities[j, 1, 1], end_velocities[j, 1, 2]))
        c = d - radius[j] - r_B
        if math.isnan(c) or math.isnan(v_h) or math.isnan(v_r):
            faulty = True
        elif c < best:
            best, best_h, best_r, index = c, v_h, v_r, j
    if faulty:
        best, best_h, best_r, index = np.nan, np.nan, np.nan, -1
    return best, best_h, best_r, index


@numba.njit(cache=True)
def _end_rows(arrays, q, v, tool_length, a, b, t0, t1, memo, poses, twists, p, pv, ends,
              end_velocities):
    """Points (L, P, 3) and capsule ends (L, K, 2, 3), with velocities, of rows q, v
    (L, n) of a model (``model_points.model_arrays``, work arrays ``model_work``)."""
    for row in range(q.shape[0]):
        model_points_one(arrays, tool_length, q[row], v[row], memo, poses, twists, p[row],
                         pv[row])
        capsule_ends_one(p[row], pv[row], a, b, t0, t1, ends[row], end_velocities[row])


@numba.njit(cache=True)
def _pair_rows(arrays, q, v, tool_length, a, b, t0, t1, radius, p_B, v_B, r_B, every, out,
               index, memo, poses, twists, p, pv):
    """Per row (q, v (L, n) of a model, ``model_points.model_arrays``; bodies p_B, v_B
    (L, N, 3), radii r_B (L, N)): every pair's clearance into out (L, N, K) if ``every``,
    else :func:`nearest_capsule_one`'s figures into out[:, :, :3] and index (L, N)."""
    ends, end_velocities = np.empty((a.size, 2, 3)), np.empty((a.size, 2, 3))
    for row in range(q.shape[0]):
        model_points_one(arrays, tool_length, q[row], v[row], memo, poses, twists, p, pv)
        capsule_ends_one(p, pv, a, b, t0, t1, ends, end_velocities)
        for i in range(p_B.shape[1]):
            if every:
                for j in range(a.size):
                    d = segment_pair(p_B[row, i], v_B[row, i], ends[j, 0], ends[j, 1],
                                     end_velocities[j, 0], end_velocities[j, 1])[0]
                    out[row, i, j] = d - radius[j] - r_B[row, i]
            else:
                (out[row, i, 0], out[row, i, 1], out[row, i, 2],
                 index[row, i]) = nearest_capsule_one(p_B[row, i], v_B[row, i], r_B[row, i],
                                                      ends, end_velocities, radius)


def _flat(x, lead: tuple, tail: tuple) -> np.ndarray:
    return np.ascontiguousarray(np.broadcast_to(np.asarray(x, dtype=float), lead + tail)
                                ).reshape((-1,) + tail)


def _model_of(capsules: Capsules | None, model: RobotModel | None) -> RobotModel:
    """The robot of ``capsules`` (or ``model``; neither: the UR5e), refusing a ``model``
    other than the capsules' own."""
    if capsules is None:
        return default_model() if model is None else model
    if model is not None and model is not capsules.model:
        raise ValueError(f"model {model.name}: the capsules are the {capsules.model.name}'s")
    return capsules.model


def _point_and_end_rows(q, v, tool_length: float, capsules: Capsules | None, model: RobotModel):
    """(lead shape, points (2, L, P, 3), ends (2, L, K, 2, 3)) at q, v (..., n): positions
    [0] and velocities [1] (v None: not wanted, q stands in)."""
    q = np.asarray(q, dtype=float)
    n = model.n
    if q.shape[-1:] != (n,) or (v is not None and np.shape(v)[-1:] != (n,)):
        raise ValueError(f"q has shape {q.shape}: need (..., {n}) joint positions of the "
                         f"{model.name}")
    lead = q.shape[:-1] if v is None else np.broadcast_shapes(q.shape[:-1], np.shape(v)[:-1])
    q_rows = _flat(q, lead, (n,))
    v_rows = q_rows if v is None else _flat(v, lead, (n,))
    L = q_rows.shape[0]
    c = capsules if capsules is not None else Capsules((), [], [], [], [], [], 0.0, model)
    p = np.empty((2, L, model.num_points, 3))
    ends = np.empty((2, L, c.radius.size, 2, 3))
    _end_rows(model_arrays(model), q_rows, v_rows, float(tool_length), c.a, c.b, c.t0, c.t1,
              *model_work(model), p[0], p[1], ends[0], ends[1])
    return lead, p, ends


def robot_points(q: np.ndarray, v: np.ndarray | None = None, tool_length: float = 0.0, *,
                 model: RobotModel | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """The points of ``model`` (None: the UR5e's P0 ... P7), (..., P, 3), metres, at joint
    positions q (..., n), and their velocities J(q) v (m/s) at joint velocities v (None
    when v is None)."""
    model = _model_of(None, model)
    lead, p, _ = _point_and_end_rows(q, v, tool_length, None, model)
    p = p.reshape((2,) + lead + (model.num_points, 3))
    return p[0], None if v is None else p[1]


def capsule_ends(q: np.ndarray, capsules: Capsules, v: np.ndarray | None = None, *,
                 model: RobotModel | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """Capsule ends (..., K, 2, 3), metres, at joint positions q (..., n) of the capsules'
    robot (``model``, if given, must be it), and their velocities (m/s) at joint
    velocities v (None when v is None)."""
    model = _model_of(capsules, model)
    lead, _, ends = _point_and_end_rows(q, v, capsules.tool_length, capsules, model)
    ends = ends.reshape((2,) + lead + ends.shape[2:])
    return ends[0], None if v is None else ends[1]


def _pairs(q, v, capsules, p_bodies, v_bodies, body_radii, every, model):
    model = _model_of(capsules, model)
    n = model.n
    if np.shape(q)[-1:] != (n,):
        raise ValueError(f"q has shape {np.shape(q)}: need (..., {n}) joint positions of "
                         f"the {model.name}")
    p_B, r_B = np.asarray(p_bodies, dtype=float), np.asarray(body_radii, dtype=float)
    N = p_B.shape[-2]
    leads = [np.shape(q)[:-1], p_B.shape[:-2], r_B.shape[:-1]]
    leads += [] if v is None else [np.shape(v)[:-1], np.shape(v_bodies)[:-2]]
    lead = np.broadcast_shapes(*leads)
    q_rows = _flat(q, lead, (n,))
    v_rows = np.zeros_like(q_rows) if v is None else _flat(v, lead, (n,))
    pb_rows = _flat(p_B, lead, (N, 3))
    vb_rows = np.zeros_like(pb_rows) if v is None else _flat(v_bodies, lead, (N, 3))
    K = capsules.radius.size
    out = np.empty((pb_rows.shape[0], N, K if every else 3))
    index = np.empty((pb_rows.shape[0], N), dtype=np.int64)
    _pair_rows(model_arrays(model), q_rows, v_rows, capsules.tool_length, capsules.a,
               capsules.b, capsules.t0, capsules.t1, capsules.radius, pb_rows, vb_rows,
               _flat(r_B, lead, (N,)), every, out, index, *model_work(model),
               np.empty((model.num_points, 3)), np.empty((model.num_points, 3)))
    return lead, out, index


def clearances(q: np.ndarray, capsules: Capsules, p_bodies: np.ndarray,
               body_radii: np.ndarray | float, *, model: RobotModel | None = None
               ) -> np.ndarray:
    """Clearance (metres; axis distance - capsule radius - body radius, negative =
    overlap) of every body (p_bodies (..., N, 3), radii (..., N) or scalar) to every
    capsule at joint positions q (..., n) of the capsules' robot: shape (..., N, K)."""
    lead, out, _ = _pairs(q, None, capsules, p_bodies, None, body_radii, True, model)
    return out.reshape(lead + out.shape[1:])


def nearest_capsules(q: np.ndarray, v: np.ndarray, capsules: Capsules, p_bodies: np.ndarray,
                     v_bodies: np.ndarray, body_radii: np.ndarray | float, *,
                     model: RobotModel | None = None
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`nearest_capsule_one` of every body: (clearance, v_human_directed,
    v_robot_directed, index), each (..., N), at joint positions and velocities q, v
    (..., n) of the capsules' robot, bodies at p_bodies moving at v_bodies (..., N, 3),
    radii (..., N)."""
    lead, out, index = _pairs(q, v, capsules, p_bodies, v_bodies, body_radii, False, model)
    shape = lead + out.shape[1:2]
    return (out[..., 0].reshape(shape), out[..., 1].reshape(shape),
            out[..., 2].reshape(shape), index.reshape(shape))


def min_clearance(q: np.ndarray, capsules: Capsules, p_bodies: np.ndarray,
                  body_radii: np.ndarray | float, *, model: RobotModel | None = None
                  ) -> np.ndarray:
    """The smallest clearance (metres) of each body over the capsules, (..., N); NaN if
    any of the body's pairs is NaN."""
    n = _model_of(capsules, model).n
    return nearest_capsules(q, np.zeros(n), capsules, p_bodies, np.zeros(3), body_radii,
                            model=model)[0]


@numba.njit(cache=True)
def capsule_ends_at(q, tool_length, a, b, t0, t1, out):
    """The capsule ends (K, 2, 3) at joint positions q into out (velocities unused), of
    :class:`Capsules` (a, b, t0, t1, tool_length); compiled, shared by the RobotCapsules
    system and the live runtime."""
    p, pv = np.empty((NUM_POINTS, 3)), np.empty((NUM_POINTS, 3))
    robot_points_one(q, np.zeros(6), tool_length, p, pv)
    capsule_ends_one(p, pv, a, b, t0, t1, out, np.empty_like(out))


@numba.njit(cache=True)
def model_capsule_ends_at(arrays, q, tool_length, a, b, t0, t1, memo, poses, twists, p, pv,
                          out, out_velocities):
    """:func:`capsule_ends_at` of any model (``model_points.model_arrays``, the work
    arrays ``model_work``, p and pv (P, 3)): the ends into out (K, 2, 3) at joint
    positions q (n,), their velocities at rest (zero) into out_velocities."""
    v = np.zeros(q.size)
    model_points_one(arrays, tool_length, q, v, memo, poses, twists, p, pv)
    capsule_ends_one(p, pv, a, b, t0, t1, out, out_velocities)
