"""The safety properties' robustness on hand-made separations and speeds."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from verification.properties import (
    MOVING_SPEED,
    Robustness,
    separation_invariant,
    stopped_before_contact,
)

FIXED = settings(derandomize=True, deadline=None, max_examples=200)
NAN = math.nan


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


def test_separation_invariant_hand_computed():
    clearances = np.array([
        [0.20, 0.50],  # permitted; S_true = [0.40, 0.05]: body 0 inside by 0.20
        [0.01, 0.01],  # not permitted: not counted however close
        [NAN, 0.10],   # permitted; S_true = [-, 0.20]: body 1 inside by 0.10
        [1.00, 1.00],  # permitted; outside: margins 0.60, 0.95
        [0.30, 0.02],  # permitted; S_true = [0.45, 0.05]: both inside, counted once
    ])[..., None]  # one capsule: the pairs' axis (N, K) = (2, 1)
    s_true = np.array([[0.40, 0.05], [9.0, 9.0], [0.5, 0.20], [0.40, 0.05],
                       [0.45, 0.05]])[..., None]
    allowed = np.array([True, False, True, True, True])
    robustness, time = separation_invariant(clearances, s_true, allowed, 0.01)
    assert robustness == pytest.approx(-0.20, abs=1e-15)
    assert time == pytest.approx(3 * 0.01, abs=1e-15)
    # Only the fourth tick permitted: safe by the smaller margin.
    robustness, time = separation_invariant(clearances, s_true,
                                            np.array([False, False, False, True, False]), 0.01)
    assert (robustness, time) == (pytest.approx(0.60, abs=1e-15), 0.0)


def test_separation_invariant_is_inf_when_never_permitted_near_a_body():
    clearances = np.array([[[0.0]], [[NAN]]])
    s_true = np.array([[[1.0]], [[1.0]]])
    # Close only while held; permitted only while nobody is present.
    assert separation_invariant(clearances, s_true, np.array([False, True]), 0.002) == (
        math.inf, 0.0)
    assert separation_invariant(np.zeros((0, 1, 1)), np.zeros((0, 1, 1)), np.zeros(0, bool),
                                0.002) == (math.inf, 0.0)


@FIXED
@given(trace=_traces(), capsules=st.integers(1, 3), data=st.data())
def test_separation_invariant_matches_a_loop(trace, capsules, data):
    clearances, speed = trace  # (any speed above 1 mm/s stands for "permitted")
    clearances = np.repeat(clearances[..., None], capsules, axis=-1)
    if capsules > 1:
        clearances[..., 1:] += 0.1
    s_true = np.array(data.draw(st.lists(st.floats(-1.0, 3.0), min_size=clearances.size,
                                         max_size=clearances.size)),
                      dtype=float).reshape(clearances.shape)
    allowed = speed > 1e-3
    dt = 0.002
    worst, count = math.inf, 0
    for t in range(clearances.shape[0]):
        inside = False
        for i in range(clearances.shape[1]):
            for j in range(clearances.shape[2]):
                d = clearances[t, i, j]
                if allowed[t] and not math.isnan(d):
                    worst = min(worst, d - s_true[t, i, j])
                    inside = inside or d - s_true[t, i, j] < 0.0
        count += inside
    robustness, time = separation_invariant(clearances, s_true, allowed, dt)
    assert robustness == worst
    assert time == pytest.approx(count * dt, abs=1e-12)
