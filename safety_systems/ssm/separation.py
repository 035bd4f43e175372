"""The SeparationMonitor's maths over the robot's capsules and the operators' segments (seed
000, Eqs. 6-11), compiled and shared by the SeparationMonitor system, the batched verifier,
the runtime and the properties.

Every operator is a set of capsules (``safety_systems.cell.human_body``: the monitor's
envelopes of its segments, or the true segments for the properties), each given by its
axis' ends, their velocities and a radius; the robot is a set of K capsules
(``safety_systems.cell.robot_geometry``; the seed's tool point is one capsule of length
and radius 0). For each segment-capsule pair, ``robot_geometry.segments_pair`` gives
Eqs. 6-8 between the two axes' nearest points, and ``formulas.body_protective_distance``
gives S (Eqs. 9-11) from the pair's directed speeds. A segment's d_i is its smallest
clearance over the capsules (axis distance - capsule radius - segment radius) and its S_i
the largest S over its pairs: Eq. 12 then compares the closest clearance with the largest
S over all pairs (S_max), as the seed compares each d_i with S_max over its bodies.
Interpretation: the seed has one robot point and point bodies; taking S_max over every
pair is the conservative reading of "over all pairs". A hidden body's growing ball is
inside its segments' envelopes (``human_body.envelope_rows``).
"""

import math

import numba
import numpy as np

from safety_systems.cell.robot_geometry import segments_pair
from safety_systems.ssm.formulas import body_protective_distance
from safety_systems.sensing.tracks import usable


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def capsule_axis(ends, end_velocities, j):
    """Capsule j's ends A, B and their velocities as tuples (what ``segments_pair`` takes):
    array slices passed to an inlined helper in a loop cost ~100 ns each in reference
    counting, tuples nothing (measured: 113 ns against 9 ns per pair)."""
    return ((ends[j, 0, 0], ends[j, 0, 1], ends[j, 0, 2]),
            (ends[j, 1, 0], ends[j, 1, 1], ends[j, 1, 2]),
            (end_velocities[j, 0, 0], end_velocities[j, 0, 1], end_velocities[j, 0, 2]),
            (end_velocities[j, 1, 0], end_velocities[j, 1, 1], end_velocities[j, 1, 2]))


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def pair_separation(segment, r_H, z_d, ends, end_velocities, radius, j, monitor):
    """(clearance, S, v_human_directed, v_robot) of one segment (``segment`` = its axis'
    ends P, Q and their velocities vP, vQ, tuples; radius r_H, Z_d ``z_d``) and capsule
    j: Eqs. 6-8 between the two axes (``robot_geometry.segments_pair``), the clearance
    less the capsule's and the segment's radii, and S by
    ``formulas.body_protective_distance``. ``monitor`` = (mode index, T_s + T_r, T_r,
    B + C + Z_r, v_iso, v_iso_reduced, robot speed index in ``ROBOT_SPEED_TERMS``):
    v_robot is Eq. 7's directed speed, or (``fastest_point``) the speed of the capsule's
    faster end, which no point of its axis exceeds (a rigid link's velocity is affine
    along the axis)."""
    mode, t_sr, t_r, const, iso, iso_reduced, robot_speed = monitor
    clearance, h, r = pair_speeds(segment, r_H, ends, end_velocities, radius, j, robot_speed)
    return (clearance,
            body_protective_distance(h, r, z_d, mode, t_sr, t_r, const, iso, iso_reduced), h, r)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def pair_speeds(segment, r_H, ends, end_velocities, radius, j, robot_speed):
    """(clearance, v_human_directed, v_robot) of one segment and capsule j, as
    :func:`pair_separation` takes them (``robot_speed`` its index in
    ``formulas.ROBOT_SPEED_TERMS``)."""
    P, Q, vP, vQ = segment
    end_a, end_b, vel_a, vel_b = capsule_axis(ends, end_velocities, j)
    axis, h, r = segments_pair(P, Q, vP, vQ, end_a, end_b, vel_a, vel_b)
    if robot_speed == 1:
        r = max(math.sqrt(vel_a[0] * vel_a[0] + vel_a[1] * vel_a[1] + vel_a[2] * vel_a[2]),
                math.sqrt(vel_b[0] * vel_b[0] + vel_b[1] * vel_b[1] + vel_b[2] * vel_b[2]))
    return axis - radius[j] - r_H, h, r


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def segment_of(h_ends, h_velocities, i):
    """Segment i's axis ends and their velocities as tuples (:func:`pair_separation`'s
    ``segment``)."""
    return capsule_axis(h_ends, h_velocities, i)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def segment_levels(segment, r_H, z_d, ends, end_velocities, radius, monitor, level_t_sr,
                   level_const, out, i):
    """Segment i's S at every speed level into out[:, i] (G + 1, M): the largest over the
    capsules of ``formulas.body_protective_distance`` with the level's T_s + T_r
    (``level_t_sr``) and B + C + Z_r (``level_const``), the pair's speeds by
    :func:`pair_speeds` (``monitor`` as :func:`pair_separation` takes it; its T_s and B
    are not used). A NaN anywhere gives NaN at every level."""
    mode, _, t_r, _, iso, iso_reduced, robot_speed = monitor
    for g in range(out.shape[0]):
        out[g, i] = -np.inf
    for j in range(radius.size):
        _, h, r = pair_speeds(segment, r_H, ends, end_velocities, radius, j, robot_speed)
        for g in range(out.shape[0]):
            s_g = body_protective_distance(h, r, z_d, mode, level_t_sr[g], t_r, level_const[g],
                                           iso, iso_reduced)
            out[g, i] = np.nan if math.isnan(s_g) or math.isnan(out[g, i]) \
                else max(out[g, i], s_g)


@numba.njit(cache=True)
def level_rows(ends, end_velocities, radius, h_ends, h_velocities, h_radius, status, std,
               z_d_terms, monitor, level_t_sr, level_const, out):
    """:func:`segment_levels` of every segment with a usable status into out (G + 1, M);
    NaN for the others (Z_d as :func:`separation_rows` takes it)."""
    base, sigmas = z_d_terms
    for i in range(h_radius.size):
        if usable(status[i]):
            segment_levels(segment_of(h_ends, h_velocities, i), h_radius[i],
                           base + sigmas * std[i], ends, end_velocities, radius, monitor,
                           level_t_sr, level_const, out, i)
        else:
            for g in range(out.shape[0]):
                out[g, i] = np.nan


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def segment_separation(segment, r_H, z_d, ends, end_velocities, radius, monitor):
    """(d_i, S_i, v_human_directed, v_robot, nearest capsule) of one segment (axis ends
    and velocities ``segment``, radius r_H, Z_d ``z_d``) against K capsules (ends and
    end_velocities (K, 2, 3), radius (K,)) by :func:`pair_separation` (``monitor`` as it
    takes it). The speeds and index are the nearest pair's. A NaN in any pair gives NaN
    d_i and S_i (the override stops), index -1."""
    d, s, v_h, v_r, nearest, faulty = np.inf, -np.inf, np.nan, np.nan, -1, False
    for j in range(radius.size):
        c, s_j, h, r = pair_separation(segment, r_H, z_d, ends, end_velocities, radius, j,
                                       monitor)
        if math.isnan(c) or math.isnan(s_j):
            faulty = True
        else:
            if c < d:
                d, v_h, v_r, nearest = c, h, r, j
            s = max(s, s_j)
    if faulty:
        d, s, v_h, v_r, nearest = np.nan, np.nan, np.nan, np.nan, -1
    return d, s, v_h, v_r, nearest


@numba.njit(cache=True)
def separation_rows(ends, end_velocities, radius, h_ends, h_velocities, h_radius, status, std,
                    z_d_terms, monitor, out, nearest):
    """:func:`segment_separation` of every segment with a usable status
    (``tracks.usable``: its operator is tracked or hidden, ``human_body.envelope_rows``)
    into out (4, M): d, S, v_human_directed, v_robot_directed, and the nearest capsule's
    index into nearest (M,); NaN and -1 for the others. Segments: axis ends and their
    velocities (M, 2, 3), radii (M,); ``z_d_terms`` = (Z_d base, sigmas): Z_d = base +
    sigmas std_i (``ssm.human_uncertainty``)."""
    base, sigmas = z_d_terms
    for i in range(h_radius.size):
        if usable(status[i]):
            (out[0, i], out[1, i], out[2, i], out[3, i], nearest[i]) = segment_separation(
                segment_of(h_ends, h_velocities, i), h_radius[i], base + sigmas * std[i],
                ends, end_velocities, radius, monitor)
        else:
            out[0, i], out[1, i], out[2, i], out[3, i], nearest[i] = (np.nan, np.nan, np.nan,
                                                                      np.nan, -1)


@numba.njit(cache=True)
def _pair_rows(ends, end_velocities, radius, h_ends, h_velocities, h_radius, out):
    """Every pair's (clearance, v_human_directed, v_robot_directed) into out (3, L, M, K)
    from rows of robot capsules (L, K, 2, 3) and segments (L, M, 2, 3), radii (L, M)."""
    for row in range(h_ends.shape[0]):
        for i in range(h_ends.shape[1]):
            P, Q, vP, vQ = capsule_axis(h_ends[row], h_velocities[row], i)
            for j in range(radius.size):
                end_a, end_b, vel_a, vel_b = capsule_axis(ends[row], end_velocities[row], j)
                axis, h, r = segments_pair(P, Q, vP, vQ, end_a, end_b, vel_a, vel_b)
                out[0, row, i, j] = axis - radius[j] - h_radius[row, i]
                out[1, row, i, j], out[2, row, i, j] = h, r


def pair_figures(ends: np.ndarray, end_velocities: np.ndarray, radius: np.ndarray,
                 h_ends: np.ndarray, h_velocities: np.ndarray, h_radii: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(clearance, v_human_directed, v_robot_directed) of every segment-capsule pair, each
    (..., M, K): robot capsule ends and velocities (..., K, 2, 3), radii (K,); segments'
    axis ends and velocities (..., M, 2, 3), radii (..., M) (or broadcastable), any leading
    axes. A point body is a segment whose ends coincide."""
    ends, end_velocities = np.asarray(ends, float), np.asarray(end_velocities, float)
    h_ends, h_velocities = np.asarray(h_ends, float), np.asarray(h_velocities, float)
    K, M = ends.shape[-3], h_ends.shape[-3]
    lead = np.broadcast_shapes(ends.shape[:-3], end_velocities.shape[:-3], h_ends.shape[:-3],
                               h_velocities.shape[:-3], np.shape(h_radii)[:-1])

    def rows(x, tail):
        return np.ascontiguousarray(np.broadcast_to(x, lead + tail)).reshape((-1,) + tail)

    out = np.empty((3, math.prod(lead), M, K))
    _pair_rows(rows(ends, (K, 2, 3)), rows(end_velocities, (K, 2, 3)),
               np.ascontiguousarray(radius, dtype=float), rows(h_ends, (M, 2, 3)),
               rows(h_velocities, (M, 2, 3)), rows(np.asarray(h_radii, float), (M,)), out)
    shape = lead + (M, K)
    return out[0].reshape(shape), out[1].reshape(shape), out[2].reshape(shape)
