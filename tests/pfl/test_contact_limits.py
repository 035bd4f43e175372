"""A contact that lasts (issue 46): the transient and quasi-static compressions of Annex
A, the robot's contact detection, and the course of one contact tick by tick."""

import math

import numpy as np
import pytest

from safety_systems.cell.human_body import SEGMENT_NAMES
from safety_systems.pfl.body_regions import body_region
from safety_systems.pfl.contact_limits import (
    E_LATCHED,
    EPISODE_COLUMNS,
    contact_rows,
    contact_step,
    episode_reset,
    pressing_speeds,
    segment_contact_limits,
)

HAND = SEGMENT_NAMES.index("hand_right")
DT = 0.002


def test_the_compressions_are_force_over_stiffness_the_strictest_region_each():
    x = segment_contact_limits(175.0)
    hand, wrist = body_region("hands_fingers"), body_region("lower_arms_wrists")
    # Table A.2's 140 N and Table A.3's 75 N/mm: 1.87 mm quasi-static, twice transient
    assert x[HAND, 1] == pytest.approx(140.0 / 75e3)
    assert x[HAND, 0] == pytest.approx(2 * 140.0 / 75e3)
    assert x[HAND, 1] == min(hand.force / hand.spring_constant,
                             wrist.force / wrist.spring_constant)
    # detection: the softest region (the wrist, 40 N/mm) needs the most indentation
    assert x[HAND, 2] == pytest.approx(175.0 / 40e3)
    for name in ("head", "neck"):  # no contact permitted: no figures
        assert x[SEGMENT_NAMES.index(name)].tolist() == [0.0, 0.0, 0.0]
    assert np.all(x[2:, 0] > x[2:, 1])
    with pytest.raises(ValueError, match="contact_stop_force"):
        segment_contact_limits(0.0)


def _course(in_contact, moving, v_rel, limit=1.0, x=(0.004, 0.002, 0.003), detect=0.05,
            window=0.5):
    T = len(in_contact)
    figures, latched = np.empty((T, 1)), np.empty((T, 1), dtype=bool)
    contact_rows(np.array(in_contact, dtype=bool)[:, None], np.array(moving, dtype=bool),
                 np.array(v_rel, dtype=float)[:, None], np.zeros((T, 1), dtype=bool),
                 np.array([limit]), np.array([x]), detect, window, DT, 0.0, figures, latched)
    return figures[:, 0], latched[:, 0]


def test_a_robot_that_keeps_pressing_beyond_the_window_is_a_violation():
    # 2 s in contact, moving into the hand at 1.5 mm/s: 3 mm by the end, past the
    # quasi-static 2 mm, the detection's 10 mm never: the robot presses on past the window
    n = 1000
    figures, latched = _course([True] * n, [True] * n, [0.0015] * n, x=(0.004, 0.002, 0.01))
    assert not latched.any()
    assert figures.min() < 0.0
    first_bad = np.argmax(figures < 0.0)
    assert first_bad * DT == pytest.approx(0.002 / 0.0015, abs=2 * DT)  # past 2 mm
    assert figures[: round(0.5 / DT)].min() >= 0.0  # legal while the transient held
    assert figures.min() == pytest.approx(0.002 - 0.0015 * DT * n)


def test_a_brief_impact_the_robot_comes_off_is_permitted():
    # 0.2 s in contact at 10 mm/s towards the hand, then moving away, contact over at 0.3 s
    steps = [0.01] * 100 + [-0.01] * 50 + [0.0] * 100
    contact = [True] * 150 + [False] * 100
    figures, latched = _course(contact, [True] * 250, steps, limit=1.0, x=(0.004, 0.002, 0.01))
    assert figures.min() >= 0.0
    assert figures.min() == pytest.approx(0.004 - 0.01 * DT * 100)  # at the deepest point
    assert np.isinf(figures[150:]).all() and not latched.any()


def test_detection_stops_the_robot_after_its_time_and_holds_until_the_contact_ends():
    steps = [0.02] * 200
    figures, latched = _course([True] * 150 + [False] * 50, [True] * 200, steps,
                               x=(1.0, 1.0, 0.003), detect=0.05)
    over = int(math.ceil(0.003 / (0.02 * DT))) - 1  # the tick x reaches 3 mm
    first = np.argmax(latched)
    assert first == over + round(0.05 / DT)  # held for the detection time, then stops
    assert latched[first:150].all() and not latched[150:].any()  # released: contact over


def test_a_contact_the_robot_never_moved_in_is_not_the_robots():
    figures, latched = _course([True] * 100, [False] * 100, [0.0] * 100)
    assert np.isinf(figures).all() and not latched.any()


def test_speed_rules_and_fail_safe():
    state = np.empty(EPISODE_COLUMNS)
    episode_reset(state)
    # too fast at the impact: limit - speed
    assert contact_step(state, True, True, 1.5, False, 0.0, DT, 1.0, 1.0, 1.0, 1.0, 0.1,
                        0.5) == pytest.approx(-0.5)
    episode_reset(state)
    # clampable or forbidden: minus infinity
    assert contact_step(state, True, True, 0.1, True, 0.0, DT, 1.0, 1.0, 1.0, 1.0, 0.1,
                        0.5) == -np.inf
    episode_reset(state)
    assert contact_step(state, True, True, np.nan, False, 0.0, DT, 1.0, 1.0, 1.0, 1.0, 0.1,
                        0.5) == -np.inf
    assert state[E_LATCHED] == 0.0


def test_a_robot_creeping_into_a_hand_below_the_moving_speed_still_counts():
    # 0.9 mm/s towards the hand (below true_measures.MOVING_SPEED, 1 mm/s) for 4 s: 3.6 mm
    n = 2000
    figures, _ = _course([True] * n, [False] * n, [0.0009] * n, x=(0.004, 0.002, 0.01))
    assert figures.min() == pytest.approx(0.002 - 0.0009 * DT * n)
    assert figures.min() < 0.0


def test_what_the_pressing_speeds_leave_a_ur5e_as_docs_pfl_says():
    """docs/explanation/pfl.md: at the default force limit (175 N) and detection time
    (0.25 s) no segment may be pressed at all; at the PFL tune's lowest force (50 N,
    models/tune/ssm_pfl.yaml) the fastest is a few millimetres a second."""
    from safety_systems.config.scenario import SafetyConfig

    f = SafetyConfig()
    stop_time, period = 0.3, 0.002  # a short stop: the most room the formula can give
    speeds = pressing_speeds(segment_contact_limits(f.contact_stop_force),
                             f.contact_detection_time, stop_time, period)
    assert f.contact_stop_force == 175.0 and np.all(speeds == 0.0), speeds
    least_force = pressing_speeds(segment_contact_limits(50.0), f.contact_detection_time,
                                  stop_time, period)
    assert 0.001 < least_force.max() < 0.01, least_force
