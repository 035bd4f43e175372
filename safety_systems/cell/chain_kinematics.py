"""Forward kinematics of any serial chain, compiled: capsule ends, the tool frame, and their
velocities J(q) v.

The chain is plain arrays (:class:`~safety_systems.cell.robot_description.RobotDescription`
holds them): per joint k, X_parent[k] (4, 4) the joint's frame in body k's parent body,
axes[k] (3,) the unit axis in that frame, kinds[k] (0 revolute, 1 prismatic); X_tool (4, 4)
the tool frame in the last body. Body k + 1's pose is X_parent[k] then Rot(axis, q_k)
(revolute) or Trans(axis q_k) (prismatic). Velocities propagate outwards: a revolute joint
adds axis v_k to the angular velocity w, a prismatic one axis v_k to the origin's velocity;
a point p of a body moves at v_origin + w x (p - origin). Metres, radians, seconds; every
vector in the base frame.
"""

import math

import numba
import numpy as np


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def _point(poses, twists, body, local, out, out_velocity):
    """A point fixed in ``body`` at ``local`` (3,): its position and velocity into out."""
    for i in range(3):
        out[i] = (poses[body, i, 0] * local[0] + poses[body, i, 1] * local[1]
                  + poses[body, i, 2] * local[2] + poses[body, i, 3])
    r0 = out[0] - poses[body, 0, 3]
    r1 = out[1] - poses[body, 1, 3]
    r2 = out[2] - poses[body, 2, 3]
    w0, w1, w2 = twists[body, 0, 0], twists[body, 0, 1], twists[body, 0, 2]
    out_velocity[0] = twists[body, 1, 0] + w1 * r2 - w2 * r1
    out_velocity[1] = twists[body, 1, 1] + w2 * r0 - w0 * r2
    out_velocity[2] = twists[body, 1, 2] + w0 * r1 - w1 * r0


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def body_poses_one(X_parent, axes, kinds, q, v, poses, twists):
    """Every body's pose (n + 1, 3, 4) (rotation | origin, body 0 the base at identity) and
    twist (n + 1, 2, 3) (angular velocity, origin's velocity) into poses, twists, at joint
    positions q and velocities v (n,)."""
    for i in range(3):
        for j in range(4):
            poses[0, i, j] = 1.0 if i == j else 0.0
        twists[0, 0, i], twists[0, 1, i] = 0.0, 0.0
    RJ = np.empty((3, 3))
    pJ, a = np.empty(3), np.empty(3)
    for k in range(kinds.size):
        for i in range(3):  # the joint's frame J in the base frame
            for j in range(3):
                RJ[i, j] = (poses[k, i, 0] * X_parent[k, 0, j] + poses[k, i, 1]
                            * X_parent[k, 1, j] + poses[k, i, 2] * X_parent[k, 2, j])
            pJ[i] = (poses[k, i, 0] * X_parent[k, 0, 3] + poses[k, i, 1] * X_parent[k, 1, 3]
                     + poses[k, i, 2] * X_parent[k, 2, 3] + poses[k, i, 3])
        x, y, z = axes[k, 0], axes[k, 1], axes[k, 2]
        for i in range(3):
            a[i] = RJ[i, 0] * x + RJ[i, 1] * y + RJ[i, 2] * z
        if kinds[k] == 0:  # Rodrigues: Rot = I + s K + (1 - c) K^2
            c, s = math.cos(q[k]), math.sin(q[k])
            t = 1.0 - c
            rot = ((c + t * x * x, t * x * y - s * z, t * x * z + s * y),
                   (t * x * y + s * z, c + t * y * y, t * y * z - s * x),
                   (t * x * z - s * y, t * y * z + s * x, c + t * z * z))
            for i in range(3):
                for j in range(3):
                    poses[k + 1, i, j] = (RJ[i, 0] * rot[0][j] + RJ[i, 1] * rot[1][j]
                                          + RJ[i, 2] * rot[2][j])
                poses[k + 1, i, 3] = pJ[i]
        else:
            for i in range(3):
                for j in range(3):
                    poses[k + 1, i, j] = RJ[i, j]
                poses[k + 1, i, 3] = pJ[i] + a[i] * q[k]
        r0 = poses[k + 1, 0, 3] - poses[k, 0, 3]
        r1 = poses[k + 1, 1, 3] - poses[k, 1, 3]
        r2 = poses[k + 1, 2, 3] - poses[k, 2, 3]
        w0, w1, w2 = twists[k, 0, 0], twists[k, 0, 1], twists[k, 0, 2]
        twists[k + 1, 1, 0] = twists[k, 1, 0] + w1 * r2 - w2 * r1
        twists[k + 1, 1, 1] = twists[k, 1, 1] + w2 * r0 - w0 * r2
        twists[k + 1, 1, 2] = twists[k, 1, 2] + w0 * r1 - w1 * r0
        for i in range(3):
            twists[k + 1, 0, i] = twists[k, 0, i]
            if kinds[k] == 0:
                twists[k + 1, 0, i] += a[i] * v[k]
            else:
                twists[k + 1, 1, i] += a[i] * v[k]


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def chain_points_one(X_parent, axes, kinds, X_tool, bodies, local_ends, q, v, poses, twists,
                     ends, end_velocities, tool):
    """Capsule ends (K, 2, 3) and their velocities into ends, end_velocities, and the tool
    frame's origin and velocity into tool (2, 3), at joint positions q and velocities v
    (n,); capsule j's ends are local_ends[j] (2, 3) in body bodies[j]; poses (n + 1, 3, 4)
    and twists (n + 1, 2, 3) are work arrays (:func:`body_poses_one` fills them)."""
    body_poses_one(X_parent, axes, kinds, q, v, poses, twists)
    for j in range(bodies.size):
        for e in range(2):
            _point(poses, twists, bodies[j], local_ends[j, e], ends[j, e], end_velocities[j, e])
    _point(poses, twists, kinds.size, X_tool[:3, 3], tool[0], tool[1])


@numba.njit(cache=True)
def _chain_rows(X_parent, axes, kinds, X_tool, bodies, local_ends, q, v, ends, end_velocities,
                tool):
    n = kinds.size
    poses, twists = np.empty((n + 1, 3, 4)), np.empty((n + 1, 2, 3))
    for row in range(q.shape[0]):
        chain_points_one(X_parent, axes, kinds, X_tool, bodies, local_ends, q[row], v[row],
                         poses, twists, ends[row], end_velocities[row], tool[row])


def chain_points(description, bodies: np.ndarray, local_ends: np.ndarray, q: np.ndarray,
                 v: np.ndarray | None = None):
    """(ends (..., K, 2, 3), end velocities (..., K, 2, 3), tool origin (..., 3), tool
    velocity (..., 3)) of ``description``'s chain at joint positions q (..., n) and
    velocities v (zero when None), for capsules with ends ``local_ends`` (K, 2, 3) in
    bodies ``bodies`` (K,) (1 ... n)."""
    n = description.num_joints
    q = np.asarray(q, dtype=float)
    v = np.zeros_like(q) if v is None else np.asarray(v, dtype=float)
    lead = np.broadcast_shapes(q.shape[:-1], v.shape[:-1])
    q_rows = np.ascontiguousarray(np.broadcast_to(q, lead + (n,))).reshape(-1, n)
    v_rows = np.ascontiguousarray(np.broadcast_to(v, lead + (n,))).reshape(-1, n)
    bodies = np.ascontiguousarray(bodies, dtype=np.int64)
    local_ends = np.ascontiguousarray(local_ends, dtype=float).reshape(-1, 2, 3)
    L, K = q_rows.shape[0], bodies.size
    ends, end_velocities, tool = np.empty((L, K, 2, 3)), np.empty((L, K, 2, 3)), np.empty((L, 2, 3))
    _chain_rows(np.ascontiguousarray(description.X_parent), np.ascontiguousarray(description.axes),
                np.ascontiguousarray(description.kinds), np.ascontiguousarray(description.X_tool),
                bodies, local_ends, q_rows, v_rows, ends, end_velocities, tool)
    return (ends.reshape(lead + (K, 2, 3)), end_velocities.reshape(lead + (K, 2, 3)),
            tool[:, 0].reshape(lead + (3,)), tool[:, 1].reshape(lead + (3,)))
