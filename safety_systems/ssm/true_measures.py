"""The rules of the properties' measures on the truth, written once and compiled: when
the robot counts as moving, when the controller permits motion, and a body-capsule
pair's margin d_true - S_true (``outputs.metrics`` states the measures in full).

``outputs.metrics`` measures a Drake run with them, and the batched evaluator calls them
inside its compiled loop, so the two can differ in nothing but the arithmetic's order
(which the batch-vs-Drake tests hold to a tolerance).
"""

import math

import numba
import numpy as np

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


def permitted(command: np.ndarray) -> np.ndarray:
    """:func:`is_permitted` of every element (any shape)."""
    command = np.ascontiguousarray(command, dtype=float)
    out = np.empty(command.shape, dtype=bool)
    permitted_rows(command.reshape(-1), out.reshape(-1))
    return out
