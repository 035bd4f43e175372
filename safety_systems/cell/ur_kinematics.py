"""Closed-form kinematics of any Universal Robots arm, compiled, the DH constants an
argument: tool0 and the DH origins P0 ... P6 with the tool tip P7, and their velocities.

Every UR arm has standard DH alpha = (pi/2, 0, 0, pi/2, -pi/2, 0), a1 = a4 = a5 = a6 = 0
and d2 = d3 = 0 (``ur_family``), so its kinematics is six numbers,
``dh = (d1, a2, a3, d4, d5, d6)`` (:func:`ur_dh`), and joints 2-4 are parallel: in the
frame turned by q1 the tool lies at u = a2 c2 + a3 c23 + d5 s234 - d6 s5 c234
(horizontal), w = a2 s2 + a3 s23 - d5 c234 - d6 s5 s234 (vertical), n = d4 + d6 c5 (along
joint 2's axis); then p = (c1 u + s1 n, s1 u - c1 n, d1 + w). Velocities are the time
derivatives (J(q) v). ``ur5e`` and ``robot_geometry`` call these with the UR5e's constants
(a tuple, frozen into their builds); ``model_points`` with any UR's (an array).
"""

import math

import numba
import numpy as np


def ur_dh(dh_d, dh_a) -> np.ndarray:
    """(d1, a2, a3, d4, d5, d6) of a UR arm's DH d and a (6 each), as the functions here
    take them."""
    return np.array([dh_d[0], dh_a[1], dh_a[2], dh_d[3], dh_d[4], dh_d[5]], dtype=float)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def trig_one(q):
    """(c1, s1, c2, s2, c23, s23, c234, s234, c5, s5): the cosines and sines of the
    kinematics' five angles at q."""
    q1, q2, q3, q4, q5 = q[0], q[1], q[2], q[3], q[4]
    return (math.cos(q1), math.sin(q1), math.cos(q2), math.sin(q2), math.cos(q2 + q3),
            math.sin(q2 + q3), math.cos(q2 + q3 + q4), math.sin(q2 + q3 + q4), math.cos(q5),
            math.sin(q5))


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def _cos_sin(angle, memo, j):
    """cos and sin of ``angle``, reusing those in memo[3 j: 3 j + 3] (angle, cos, sin)
    when the angle is the same (not for 0: its sign would be lost)."""
    if angle != memo[3 * j] or angle == 0.0:  # a NaN memo never matches
        memo[3 * j], memo[3 * j + 1], memo[3 * j + 2] = angle, math.cos(angle), math.sin(angle)
    return memo[3 * j + 1], memo[3 * j + 2]


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def trig_reusing(q, memo):
    """:func:`trig_one`, each pair reused from ``memo`` (15,) while its angle stays the
    same (:func:`_cos_sin`)."""
    q1, q2, q3, q4, q5 = q[0], q[1], q[2], q[3], q[4]
    c1, s1 = _cos_sin(q1, memo, 0)
    c2, s2 = _cos_sin(q2, memo, 1)
    c23, s23 = _cos_sin(q2 + q3, memo, 2)
    c234, s234 = _cos_sin(q2 + q3 + q4, memo, 3)
    c5, s5 = _cos_sin(q5, memo, 4)
    return c1, s1, c2, s2, c23, s23, c234, s234, c5, s5


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def tool0_from_trig(trig, v, dh):
    """tool0's position and velocity (6 floats) from ``trig`` (:func:`trig_one`), joint
    velocities v (6,) and the DH constants ``dh`` (see the module docstring)."""
    d1, a2, a3, d4, d5, d6 = dh[0], dh[1], dh[2], dh[3], dh[4], dh[5]
    c1, s1, c2, s2, c23, s23, c234, s234, c5, s5 = trig
    u = a2 * c2 + a3 * c23 + d5 * s234 - d6 * s5 * c234
    w = a2 * s2 + a3 * s23 - d5 * c234 - d6 * s5 * s234
    n = d4 + d6 * c5
    v1, v2, v3, v4, v5 = v[0], v[1], v[2], v[3], v[4]
    v23 = v2 + v3
    v234 = v23 + v4
    du = -a2 * s2 * v2 - a3 * s23 * v23 + d5 * c234 * v234
    du -= d6 * (c5 * c234 * v5 - s5 * s234 * v234)
    dw = a2 * c2 * v2 + a3 * c23 * v23 + d5 * s234 * v234
    dw -= d6 * (c5 * s234 * v5 + s5 * c234 * v234)
    dn = -d6 * s5 * v5
    return (c1 * u + s1 * n, s1 * u - c1 * n, d1 + w,
            -s1 * v1 * u + c1 * du + c1 * v1 * n + s1 * dn,
            c1 * v1 * u + s1 * du + s1 * v1 * n - c1 * dn, dw)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def _turned(p, pv, k, c1, s1, v1, u, w, n, du, dw, dn, height):
    """Row k of p, pv from (u, w, n) (horizontal, vertical, along joint 2's axis) in the
    frame turned by q1, and their rates, as :func:`tool0_from_trig` maps them."""
    p[k, 0], p[k, 1], p[k, 2] = c1 * u + s1 * n, s1 * u - c1 * n, height + w
    pv[k, 0] = -s1 * v1 * u + c1 * du + c1 * v1 * n + s1 * dn
    pv[k, 1] = c1 * v1 * u + s1 * du + s1 * v1 * n - c1 * dn
    pv[k, 2] = dw


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def points_from_trig(trig, v, tool_length, dh, p, pv):
    """P0 ... P7 into p (8, 3) and their velocities into pv from ``trig``
    (:func:`trig_one`), joint velocities v (6,), the tool length (m) and the DH constants:
    P0 = 0, P1 = (0, 0, d1) on joint 1's axis, P2 = P1 + a2 (c2, s2), P3 = P2 + a3 (c23,
    s23), P4 = P3 + d4 along joint 2's axis, P5 = P4 + d5 z4, P6 tool0
    (:func:`tool0_from_trig`, bit for bit), P7 = P6 + tool_length z6."""
    d1, a2, a3, d4, d5 = dh[0], dh[1], dh[2], dh[3], dh[4]
    c1, s1, c2, s2, c23, s23, c234, s234, c5, s5 = trig
    v1, v2, v3, v4, v5 = v[0], v[1], v[2], v[3], v[4]
    v23 = v2 + v3
    v234 = v23 + v4
    for i in range(3):  # P0, P1 = (0, 0, d1): on joint 1's axis, at rest
        p[0, i], p[1, i], pv[0, i], pv[1, i] = 0.0, 0.0, 0.0, 0.0
    p[1, 2] = d1
    u, w, du, dw = a2 * c2, a2 * s2, -a2 * s2 * v2, a2 * c2 * v2  # P2
    _turned(p, pv, 2, c1, s1, v1, u, w, 0.0, du, dw, 0.0, d1)
    u, w, du, dw = u + a3 * c23, w + a3 * s23, du - a3 * s23 * v23, dw + a3 * c23 * v23
    _turned(p, pv, 3, c1, s1, v1, u, w, 0.0, du, dw, 0.0, d1)
    _turned(p, pv, 4, c1, s1, v1, u, w, d4, du, dw, 0.0, d1)
    u, w = u + d5 * s234, w - d5 * c234  # P5
    du, dw = du + d5 * c234 * v234, dw + d5 * s234 * v234
    _turned(p, pv, 5, c1, s1, v1, u, w, d4, du, dw, 0.0, d1)
    p[6, 0], p[6, 1], p[6, 2], pv[6, 0], pv[6, 1], pv[6, 2] = tool0_from_trig(trig, v, dh)
    _turned(p, pv, 7, c1, s1, v1, -s5 * c234, -s5 * s234, c5,  # z6 (= z5) and its rate
            s5 * s234 * v234 - c5 * c234 * v5, -c5 * s234 * v5 - s5 * c234 * v234,
            -s5 * v5, 0.0)
    for i in range(3):
        p[7, i] = p[6, i] + tool_length * p[7, i]
        pv[7, i] = pv[6, i] + tool_length * pv[7, i]
