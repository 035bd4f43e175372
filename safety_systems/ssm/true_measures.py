"""The rules of the properties' measures on the truth, written once and compiled: the
operators' true segments, when the robot counts as moving, when the controller permits
motion, and a segment-capsule pair's margin d_true - S_true (``outputs.metrics`` states
the measures in full).

``outputs.metrics`` measures a Drake run with them, and the batched evaluator calls them
inside its compiled loop, so the two can differ in nothing but the arithmetic's order
(which the batch-vs-Drake tests hold to a tolerance).
"""

import math

import numba
import numpy as np

from safety_systems.cell.human_body import NUM_POINTS as NUM_BODY_POINTS
from safety_systems.cell.human_body import envelope_rows
from safety_systems.sensing.tracks import TRACK_NONE, TRACK_TRACKING
from safety_systems.ssm.formulas import body_protective_distance

MOVING_SPEED = 1e-3  # m/s: the robot moves when its fastest capsule end is faster


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def is_moving(speed):
    """Whether a robot at this speed (its fastest capsule end, m/s) is moving."""
    return speed > MOVING_SPEED


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def is_permitted(command):
    """Whether the controller permits motion: a command other than 0 (a NaN counts as 0,
    as the PathFollower takes it)."""
    return math.isfinite(command) and command != 0.0


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def is_ssm_permitted(command, cap):
    """Whether the controller permits motion *by speed and separation monitoring* near a
    segment whose power and force limiting cap in force is ``cap`` (a path rate,
    ``pfl.speed_caps``; 0 under ``safety.mode: ssm``): a command above the cap (at or
    below it the robot may run by the cap alone, where contact is permitted). With cap
    0 this is :func:`is_permitted`."""
    return is_permitted(command) and command > cap


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def true_margin(clearance, v_h, v_r, mode, t_stop, t_r, b_stop, iso, iso_reduced):
    """d_true - S_true of one pair: its clearance less Eqs. 9-11 on its true directed
    speeds (mode index, the robot's own stopping time ``t_stop`` and distance ``b_stop``
    with T_r and C folded in as ``body_protective_distance`` takes them), Z_d = 0."""
    return clearance - body_protective_distance(v_h, v_r, 0.0, mode, t_stop, t_r, b_stop, iso,
                                                iso_reduced)


@numba.njit(cache=True)
def moving_rows(speed, out):
    """:func:`is_moving` of every element of ``speed`` into ``out`` (bool)."""
    for i in range(speed.size):
        out[i] = is_moving(speed[i])


@numba.njit(cache=True)
def permitted_rows(command, out):
    """:func:`is_permitted` of every element of ``command`` into ``out`` (bool)."""
    for i in range(command.size):
        out[i] = is_permitted(command[i])


def moving(speed: np.ndarray) -> np.ndarray:
    """:func:`is_moving` of every element (any shape)."""
    speed = np.ascontiguousarray(speed, dtype=float)
    out = np.empty(speed.shape, dtype=bool)
    moving_rows(speed.reshape(-1), out.reshape(-1))
    return out


@numba.njit(cache=True)
def _ssm_permitted_rows(command, caps, out):
    for t in range(caps.shape[0]):
        for i in range(caps.shape[1]):
            out[t, i] = is_ssm_permitted(command[t], caps[t, i])


def ssm_permitted(command: np.ndarray, caps: np.ndarray) -> np.ndarray:
    """(T, M) :func:`is_ssm_permitted` of each tick's command (T,) against each segment's
    cap in force (T, M)."""
    caps = np.ascontiguousarray(caps, dtype=float)
    out = np.empty(caps.shape, dtype=bool)
    _ssm_permitted_rows(np.ascontiguousarray(command, dtype=float), caps, out)
    return out


def permitted(command: np.ndarray) -> np.ndarray:
    """:func:`is_permitted` of every element (any shape)."""
    command = np.ascontiguousarray(command, dtype=float)
    out = np.empty(command.shape, dtype=bool)
    permitted_rows(command.reshape(-1), out.reshape(-1))
    return out


@numba.njit(cache=True)
def true_segment_rows(regions, candidates, radius, operator, slots, points, velocities,
                      operator_present, ends, end_velocities, out_radius, present):
    """The operators' true segments at T instants: for each row of true body points
    (T, 10 K, 3; operator k's point p in slot 10 k + p, NaN where unknown) and their
    velocities, and operator presence (T, K), every segment's capsule (ends and their
    velocities (T, M, 2, 3), radius (T, M)) and whether its operator is present
    (T, M); compiled. A segment is ``human_body.envelope_rows`` of the recipe
    ``configuration.truth_recipe`` on the true points, with no allowance: the capsule
    between its true points where both are known, else the envelope of the known ones."""
    P, M = points.shape[1], radius.size
    status, zeros, std = np.empty(P), np.zeros(P), np.empty(M)
    seg_status = np.empty(M)
    for row in range(points.shape[0]):
        for i in range(P):
            status[i] = TRACK_TRACKING if operator_present[row, i // NUM_BODY_POINTS] > 0.5 \
                else TRACK_NONE
        envelope_rows(regions, candidates, radius, operator, slots, points[row],
                      velocities[row], status, zeros, zeros, 0.0, 0.0, ends[row],
                      end_velocities[row], out_radius[row], seg_status, std)
        for m in range(M):
            present[row, m] = seg_status[m] == TRACK_TRACKING


def true_segments(recipe, points: np.ndarray, velocities: np.ndarray,
                  operator_present: np.ndarray) -> tuple[np.ndarray, ...]:
    """:func:`true_segment_rows` of rows of points (T, 30 K) or (T, 10 K, 3): (ends,
    end_velocities (T, M, 2, 3), radius (T, M), present (T, M) bool)."""
    T = points.shape[0]
    points = np.ascontiguousarray(points, dtype=float).reshape(T, -1, 3)
    velocities = np.ascontiguousarray(velocities, dtype=float).reshape(T, -1, 3)
    M = recipe.radius.size
    out = (np.empty((T, M, 2, 3)), np.empty((T, M, 2, 3)), np.empty((T, M)),
           np.empty((T, M), dtype=np.bool_))
    true_segment_rows(recipe.regions, recipe.candidates, recipe.radius, recipe.operator,
                      recipe.slots, points, velocities,
                      np.ascontiguousarray(operator_present, dtype=float).reshape(T, -1), *out)
    return out
