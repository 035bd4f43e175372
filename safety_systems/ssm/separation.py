"""The SeparationMonitor's maths over the robot's capsules (seed 000, Eqs. 6-11), compiled
and shared by the SeparationMonitor system, the batched verifier and the properties.

Every tracked body is a sphere (its radius from the scenario) and the robot a set of K
capsules (``safety_systems.cell.robot_geometry``; the seed's tool point is one capsule of
length and radius 0, and then bodies count as points). For each body-capsule pair,
``robot_geometry.segment_pair`` gives Eqs. 6-8 with the robot point taken as the nearest
point of the capsule's axis, and ``ssm.body_protective_distance`` gives S (Eqs. 9-11) from the
pair's directed speeds. A body's d_i is its smallest clearance over the capsules (axis
distance - capsule radius - body radius; less the radius of its ball while hidden,
``ssm.hidden_ball_radius``) and its S_i the largest S over its pairs: Eq. 12 then
compares the closest clearance with the largest S over all pairs (S_max), as the seed
compares each d_i with S_max over its bodies. Interpretation: the seed has one robot
point; taking S_max over every pair is the conservative reading of "over all pairs".
"""

import math

import numba
import numpy as np

from safety_systems.cell.robot_geometry import segment_pair
from safety_systems.ssm.formulas import hidden_ball_radius, body_protective_distance
from safety_systems.sensing.tracks import usable



@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def capsule_axis(ends, end_velocities, j):
    """Capsule j's ends A, B and their velocities as tuples (what ``segment_pair`` takes):
    array slices passed to an inlined helper in a loop cost ~100 ns each in reference
    counting, tuples nothing (measured: 113 ns against 9 ns per pair)."""
    return ((ends[j, 0, 0], ends[j, 0, 1], ends[j, 0, 2]),
            (ends[j, 1, 0], ends[j, 1, 1], ends[j, 1, 2]),
            (end_velocities[j, 0, 0], end_velocities[j, 0, 1], end_velocities[j, 0, 2]),
            (end_velocities[j, 1, 0], end_velocities[j, 1, 1], end_velocities[j, 1, 2]))


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def pair_separation(p, w, r_B, z_d, ends, end_velocities, radius, j, monitor):
    """(clearance, S, v_human_directed, v_robot) of one body (at ``p``, moving at ``w``:
    tuples; radius r_B, Z_d ``z_d``) and capsule j: Eqs. 6-8 to the nearest point of the
    capsule's axis (``robot_geometry.segment_pair``), the clearance less the capsule's
    and the body's radii, and S by ``ssm.body_protective_distance``. ``monitor`` = (mode index,
    T_s + T_r, T_r, B + C + Z_r, v_iso, v_iso_reduced, robot speed index in
    ``ssm.ROBOT_SPEED_TERMS``): v_robot is Eq. 7's directed speed, or (``fastest_point``)
    the speed of the capsule's faster end, which no point of its axis exceeds (a rigid
    link's velocity is affine along the axis)."""
    mode, t_sr, t_r, const, iso, iso_reduced, robot_speed = monitor
    clearance, h, r = pair_speeds(p, w, r_B, ends, end_velocities, radius, j, robot_speed)
    return (clearance,
            body_protective_distance(h, r, z_d, mode, t_sr, t_r, const, iso, iso_reduced), h, r)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def pair_speeds(p, w, r_B, ends, end_velocities, radius, j, robot_speed):
    """(clearance, v_human_directed, v_robot) of one body and capsule j, as
    :func:`pair_separation` takes them (``robot_speed`` its index in
    ``ssm.ROBOT_SPEED_TERMS``)."""
    end_a, end_b, vel_a, vel_b = capsule_axis(ends, end_velocities, j)
    axis, h, r = segment_pair(p, w, end_a, end_b, vel_a, vel_b)
    if robot_speed == 1:
        r = max(math.sqrt(vel_a[0] * vel_a[0] + vel_a[1] * vel_a[1] + vel_a[2] * vel_a[2]),
                math.sqrt(vel_b[0] * vel_b[0] + vel_b[1] * vel_b[1] + vel_b[2] * vel_b[2]))
    return axis - radius[j] - r_B, h, r


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def body_levels(p_B, v_B, r_B, z_d, ends, end_velocities, radius, monitor, level_t_sr,
                level_const, out, i):
    """Body i's S at every speed level into out[:, i] (G + 1, N): the largest over the
    capsules of ``ssm.body_protective_distance`` with the level's T_s + T_r
    (``level_t_sr``) and B + C + Z_r (``level_const``), the pair's speeds by
    :func:`pair_speeds` (``monitor`` as :func:`pair_separation` takes it; its T_s and B
    are not used). A NaN anywhere gives NaN at every level."""
    mode, _, t_r, _, iso, iso_reduced, robot_speed = monitor
    p, w = (p_B[0], p_B[1], p_B[2]), (v_B[0], v_B[1], v_B[2])
    for g in range(out.shape[0]):
        out[g, i] = -np.inf
    for j in range(radius.size):
        _, h, r = pair_speeds(p, w, r_B, ends, end_velocities, radius, j, robot_speed)
        for g in range(out.shape[0]):
            s_g = body_protective_distance(h, r, z_d, mode, level_t_sr[g], t_r, level_const[g],
                                           iso, iso_reduced)
            out[g, i] = np.nan if math.isnan(s_g) or math.isnan(out[g, i]) \
                else max(out[g, i], s_g)


@numba.njit(cache=True)
def level_rows(ends, end_velocities, radius, p_B, v_B, r_B, status, std, z_d_terms, monitor,
               level_t_sr, level_const, out):
    """:func:`body_levels` of every body with a usable track into out (G + 1, N); NaN for
    the others (Z_d as :func:`separation_rows` takes it)."""
    base, sigmas, _ = z_d_terms
    for i in range(p_B.shape[0]):
        if usable(status[i]):
            body_levels(p_B[i], v_B[i], r_B[i], base + sigmas * std[i], ends, end_velocities,
                        radius, monitor, level_t_sr, level_const, out, i)
        else:
            for g in range(out.shape[0]):
                out[g, i] = np.nan


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def body_separation(p_B, v_B, r_B, z_d, ball, ends, end_velocities, radius, monitor):
    """(d_i, S_i, v_human_directed, v_robot, nearest capsule) of one body (at p_B, moving
    at v_B, radius r_B; Z_d ``z_d``, hidden-ball radius ``ball``, m) against K capsules
    (ends and end_velocities (K, 2, 3), radius (K,)) by :func:`pair_separation`
    (``monitor`` as it takes it). The speeds and index are the nearest pair's. A NaN in
    any pair gives NaN d_i and S_i (the override stops), index -1."""
    d, s, v_h, v_r, nearest, faulty = np.inf, -np.inf, np.nan, np.nan, -1, False
    p, w = (p_B[0], p_B[1], p_B[2]), (v_B[0], v_B[1], v_B[2])
    for j in range(radius.size):
        c, s_j, h, r = pair_separation(p, w, r_B, z_d, ends, end_velocities, radius, j,
                                       monitor)
        if math.isnan(c) or math.isnan(s_j):
            faulty = True
        else:
            if c < d:
                d, v_h, v_r, nearest = c, h, r, j
            s = max(s, s_j)
    if faulty:
        d, s, v_h, v_r, nearest = np.nan, np.nan, np.nan, np.nan, -1
    return d - ball, s, v_h, v_r, nearest


@numba.njit(cache=True)
def separation_rows(ends, end_velocities, radius, p_B, v_B, r_B, status, std, unseen,
                    z_d_terms, monitor, out, nearest):
    """:func:`body_separation` of every body of one robot with a usable track
    (``tracks.usable``) into out (4, N): d, S, v_human_directed, v_robot_directed, and the
    nearest capsule's index into nearest (N,); NaN and -1 for the others. ``z_d_terms`` =
    (Z_d base, sigmas, occlusion speed): Z_d = base + sigmas std_i (``ssm.
    human_uncertainty``) and the ball's radius occlusion speed times unseen_i."""
    base, sigmas, occlusion_speed = z_d_terms
    for i in range(p_B.shape[0]):
        if usable(status[i]):
            (out[0, i], out[1, i], out[2, i], out[3, i], nearest[i]) = body_separation(
                p_B[i], v_B[i], r_B[i], base + sigmas * std[i],
                hidden_ball_radius(unseen[i], occlusion_speed), ends, end_velocities, radius,
                monitor)
        else:
            out[0, i], out[1, i], out[2, i], out[3, i], nearest[i] = (np.nan, np.nan, np.nan,
                                                                      np.nan, -1)


@numba.njit(cache=True)
def _pair_rows(ends, end_velocities, radius, p_B, v_B, r_B, out):
    """Every pair's (clearance, v_human_directed, v_robot_directed) into out (3, L, N, K)
    from rows of ends (L, K, 2, 3) and bodies (L, N, 3), radii (L, N)."""
    for row in range(p_B.shape[0]):
        for i in range(p_B.shape[1]):
            p = (p_B[row, i, 0], p_B[row, i, 1], p_B[row, i, 2])
            w = (v_B[row, i, 0], v_B[row, i, 1], v_B[row, i, 2])
            for j in range(radius.size):
                end_a, end_b, vel_a, vel_b = capsule_axis(ends[row], end_velocities[row], j)
                axis, h, r = segment_pair(p, w, end_a, end_b, vel_a, vel_b)
                out[0, row, i, j] = axis - radius[j] - r_B[row, i]
                out[1, row, i, j], out[2, row, i, j] = h, r


def pair_figures(ends: np.ndarray, end_velocities: np.ndarray, radius: np.ndarray,
                 p_bodies: np.ndarray, v_bodies: np.ndarray, body_radii: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(clearance, v_human_directed, v_robot_directed) of every body-capsule pair, each
    (..., N, K): capsule ends and velocities (..., K, 2, 3), radii (K,), bodies
    (..., N, 3) with radii (N,) (or broadcastable), any leading axes."""
    ends, end_velocities = np.asarray(ends, float), np.asarray(end_velocities, float)
    p_B, v_B = np.asarray(p_bodies, float), np.asarray(v_bodies, float)
    K, N = ends.shape[-3], p_B.shape[-2]
    lead = np.broadcast_shapes(ends.shape[:-3], end_velocities.shape[:-3], p_B.shape[:-2],
                               v_B.shape[:-2], np.shape(body_radii)[:-1])

    def rows(x, tail):
        return np.ascontiguousarray(np.broadcast_to(x, lead + tail)).reshape((-1,) + tail)

    out = np.empty((3, math.prod(lead), N, K))
    _pair_rows(rows(ends, (K, 2, 3)), rows(end_velocities, (K, 2, 3)),
               np.ascontiguousarray(radius, dtype=float), rows(p_B, (N, 3)), rows(v_B, (N, 3)),
               rows(np.asarray(body_radii, float), (N,)), out)
    shape = lead + (N, K)
    return out[0].reshape(shape), out[1].reshape(shape), out[2].reshape(shape)
