"""The safety properties' robustness on hand-made separations and speeds."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from verification.properties import (
    MOVING_SPEED,
    Robustness,
    protective_intrusion,
    stopped_before_contact,
)

FIXED = settings(derandomize=True, deadline=None, max_examples=200)
NAN = math.nan
# S = v_H (T_s + T_r) + v_R T_r + B + C ("estimated" mode: v_H is the directed speed).
S_ARGS = dict(reaction_time=0.1, stopping_time=0.2, stopping_distance=0.05)


def test_moving_speed_is_one_millimetre_per_second():
    assert MOVING_SPEED == 1e-3


def test_stopped_before_contact_hand_made():
    separations = np.array([
        [0.50, NAN],   # moving: 0.50
        [0.30, 0.01],  # at rest: ignored however close
        [NAN, 0.25],   # moving: 0.25 (the absent body does not count)
        [0.02, 0.60],  # exactly MOVING_SPEED: not moving, ignored
        [0.40, 0.70],  # moving: 0.40
    ])
    speed = np.array([0.01, 0.0, 0.002, 1e-3, 1.0])
    assert stopped_before_contact(separations, speed, 0.10) == pytest.approx(0.15, abs=1e-15)
    assert stopped_before_contact(separations, speed, 0.30) == pytest.approx(-0.05, abs=1e-15)
    # Just above the threshold the instant at 0.02 m counts.
    speed[3] = 1e-3 + 1e-9
    assert stopped_before_contact(separations, speed, 0.10) == pytest.approx(-0.08, abs=1e-15)


def test_stopped_before_contact_is_inf_when_never_moving_near_a_body():
    separations = np.array([[NAN, NAN], [0.01, 0.02], [NAN, NAN]])
    # Moving only while no body is present; at rest while bodies are close.
    assert stopped_before_contact(separations, np.array([1.0, 0.0, 0.5]), 0.1) == math.inf
    # Never moving at all.
    assert stopped_before_contact(separations, np.zeros(3), 0.1) == math.inf
    # No instants.
    assert stopped_before_contact(np.zeros((0, 2)), np.zeros(0), 0.1) == math.inf


def test_contact_while_moving_is_negative_and_touching_the_limit_is_zero():
    separations = np.array([[0.1, 2.0]])
    assert stopped_before_contact(separations, np.array([0.5]), 0.1) == 0.0
    assert Robustness(0.0, 0.1, 0.0, 0.0).safe  # a robustness of exactly 0 is safe
    assert not Robustness(-1e-12, 0.1, 0.0, 0.0).safe
    assert stopped_before_contact(separations, np.array([0.5]), 0.1 + 1e-9) < 0.0


@st.composite
def _traces(draw):
    t = draw(st.integers(0, 8))
    n = draw(st.integers(1, 3))
    seps = draw(st.lists(st.one_of(st.just(NAN), st.floats(0.0, 3.0)),
                         min_size=t * n, max_size=t * n))
    speeds = draw(st.lists(st.sampled_from([0.0, 5e-4, 1e-3, 1.1e-3, 0.3, 2.0]),
                           min_size=t, max_size=t))
    return np.array(seps, dtype=float).reshape(t, n), np.array(speeds, dtype=float)


@FIXED
@given(trace=_traces(), contact=st.floats(0.0, 0.5))
def test_stopped_before_contact_matches_a_loop(trace, contact):
    separations, speed = trace
    closest = math.inf
    for row, v in zip(separations, speed):
        if v > 1e-3:
            for d in row:
                if not math.isnan(d):
                    closest = min(closest, d)
    value = stopped_before_contact(separations, speed, contact)
    assert value == closest - contact
    touched = any(v > 1e-3 and np.any(row < contact) for row, v in zip(separations, speed))
    assert (value < 0.0) == touched


def test_protective_intrusion_hand_computed():
    separations = np.array([
        [0.20, 0.50],  # moving; S = [0.40, 0.05]: body 0 inside by 0.20
        [0.01, 0.01],  # at rest: not counted
        [NAN, 0.10],   # moving; S = [-, 0.20]: body 1 inside by 0.10
        [1.00, 1.00],  # moving; S = [0.40, 0.05]: outside
        [0.30, 0.02],  # moving; S = [0.45, 0.05]: both inside, counted once; 0.15, 0.03
    ])
    speed = np.array([0.5, 0.0, 0.5, 0.5, 0.5])
    v_h = np.array([[1.0, 0.0], [9.0, 9.0], [5.0, 0.5], [1.0, 0.0], [1.0, 0.0]])
    v_r = np.array([[0.5, 0.0], [9.0, 9.0], [0.0, 0.0], [0.5, 0.0], [1.0, 0.0]])
    # One capsule: the pairs' axis (N, K) = (2, 1).
    time, deepest = protective_intrusion(separations[..., None], speed, v_h[..., None],
                                         v_r[..., None], 0.01, **S_ARGS)
    assert time == pytest.approx(3 * 0.01, abs=1e-15)
    assert deepest == pytest.approx(0.20, abs=1e-12)


def test_protective_intrusion_margins_enter_s():
    separations = np.array([[[0.30]], [[0.30]]])
    speed = np.array([0.5, 0.5])
    v = np.zeros((2, 1, 1))
    # S = B = 0.05: outside; + C 0.2 + Z_d 0.1 = 0.35: inside by 0.05 at both instants.
    assert protective_intrusion(separations, speed, v, v, 0.002, **S_ARGS) == (0.0, 0.0)
    time, deepest = protective_intrusion(separations, speed, v, v, 0.002, **S_ARGS,
                                         intrusion_distance=0.2, human_uncertainty=0.1)
    assert time == pytest.approx(0.004, abs=1e-15)
    assert deepest == pytest.approx(0.05, abs=1e-12)


def test_protective_intrusion_is_zero_when_none():
    separations = np.array([[2.0, NAN], [NAN, NAN], [0.0, 0.0]])[..., None]
    speed = np.array([1.0, 1.0, 0.0])  # close only while at rest
    v = np.ones((3, 2, 1))
    time, deepest = protective_intrusion(separations, speed, v, v, 0.002, **S_ARGS)
    assert (time, deepest) == (0.0, 0.0)
    # A body moving away lowers S ("estimated" mode): no intrusion at 0.06 m.
    time, deepest = protective_intrusion(np.array([[[0.06]]]), np.array([1.0]),
                                         np.array([[[-0.1]]]), np.array([[[0.0]]]), 0.002,
                                         **S_ARGS)
    assert (time, deepest) == (0.0, 0.0)


@FIXED
@given(trace=_traces(), capsules=st.integers(1, 3), data=st.data())
def test_protective_intrusion_matches_a_loop(trace, capsules, data):
    separations, speed = trace
    # Every body-capsule pair: the same clearances, each pair its own speeds.
    separations = np.repeat(separations[..., None], capsules, axis=-1)
    if capsules > 1:
        separations[..., 1:] += 0.1
    shape = separations.shape
    floats = st.floats(-1.0, 2.0)
    v_h = np.array(data.draw(st.lists(floats, min_size=separations.size,
                                      max_size=separations.size)), dtype=float).reshape(shape)
    v_r = np.array(data.draw(st.lists(floats, min_size=separations.size,
                                      max_size=separations.size)), dtype=float).reshape(shape)
    dt = 0.002
    count, deepest = 0, 0.0
    for t in range(shape[0]):
        inside = False
        for i in range(shape[1]):
            for j in range(shape[2]):
                d = separations[t, i, j]
                s = v_h[t, i, j] * (0.2 + 0.1) + v_r[t, i, j] * 0.1 + 0.05  # Eq. 1, same order
                if speed[t] > 1e-3 and not math.isnan(d) and s - d > 0.0:
                    inside = True
                    deepest = max(deepest, s - d)
        count += inside
    time, worst = protective_intrusion(separations, speed, v_h, v_r, dt, **S_ARGS)
    assert time == pytest.approx(count * dt, abs=1e-12)
    assert worst == pytest.approx(deepest, abs=1e-12)
    assert worst >= 0.0
