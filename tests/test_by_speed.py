"""S following the robot's speed (``safety.stopping: by_speed``): the levels' stopping
terms, the override's rule, the simulated stops by rate and S_true by rate."""

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from safety_systems.cell.stopping import TRUTH_RATES, rate_index, stops_by_rate, true_stopping
from safety_systems.config.configuration import (
    braking_table,
    contact_capsules,
    joint_path,
    level_stops,
)
from safety_systems.config.resolved_cell import resolve
from safety_systems.config.scenario import load_controller_config, load_scenario
from safety_systems.outputs.metrics import true_protective_distances
from safety_systems.runtime.safety_loop import SafetyLoop
from safety_systems.sensing import stops
from safety_systems.sensing.tracks import TRACK_LOST, TRACK_TRACKING
from safety_systems.ssm.formulas import SPEED_LEVELS, by_speed_override_command, held_level
from safety_systems.systems.speed_override import SpeedOverride

ISO = load_controller_config("models/configs/iso.yaml")
BY_SPEED = dataclasses.replace(ISO, safety=dataclasses.replace(ISO.safety, stopping="by_speed"))
TRACKING = float(TRACK_TRACKING)


def test_level_stops_keep_the_configured_margin_over_the_table_at_every_level():
    t_full, b_full = level_stops(ISO)
    assert np.all(t_full == 0.54) and np.all(b_full == 0.26)
    t, b = level_stops(BY_SPEED)
    assert t[-1] == pytest.approx(0.54) and b[-1] == pytest.approx(0.26)
    assert np.all(np.diff(t) > 0.0) and np.all(np.diff(b) > 0.0)
    # The placeholder table stops from full speed in 0.53 s at constant deceleration
    # (time proportional to speed); T_s = 0.54 s keeps its 0.01 s at every level.
    levels = np.arange(SPEED_LEVELS + 1) / SPEED_LEVELS
    assert t == pytest.approx(0.53 * levels + 0.01)
    # The table's distance at full speed is B itself (no margin to keep): its rows go
    # with the square of the speed, and between them the line is above.
    assert b[0] == 0.0 and np.all(b >= 0.26 * levels ** 2 - 1e-12)
    # A T_s below the table (which the proofs refuse) shrinks in proportion instead.
    short = dataclasses.replace(BY_SPEED, safety=dataclasses.replace(BY_SPEED.safety,
                                                                     stopping_time=0.5))
    assert level_stops(short)[0] == pytest.approx(0.5 * levels)


def _levels(n, rng):
    """S of n bodies at every level, rising with the level."""
    base = rng.uniform(0.1, 1.0, size=n)
    slope = rng.uniform(0.0, 1.5, size=n)
    return base + np.outer(np.arange(SPEED_LEVELS + 1) / SPEED_LEVELS, slope)


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**31), n=st.integers(1, 4), rate=st.floats(0.0, 1.0),
       delta_s=st.floats(1.0, 2.0), d_min=st.floats(0.0, 0.5))
def test_motion_is_permitted_only_beyond_s_at_every_speed_until_the_next_decision(
        seed, n, rate, delta_s, d_min):
    rng = np.random.default_rng(seed)
    s = _levels(n, rng)
    d = rng.uniform(0.0, 3.5, size=n)
    k, top, reason = by_speed_override_command(d, s, np.full(n, TRACKING), 0.0, rate,
                                               delta_s=delta_s, d_min=d_min)
    g_now = int(np.ceil((rate - 1e-9) * SPEED_LEVELS))
    assert k * SPEED_LEVELS == pytest.approx(round(k * SPEED_LEVELS))  # a level
    if k > 0.0:
        g = max(g_now, round(k * SPEED_LEVELS))
        assert d.min() >= s[g].max() and d.min() >= d_min and top == s[g].max()
        assert d.min() >= delta_s * s[round(k * SPEED_LEVELS)].max()
        assert reason == stops.STOP_NONE
    else:
        assert reason == stops.STOP_SEPARATION
    # Nothing faster was possible: the next level up is not beyond its own band.
    g_k = round(k * SPEED_LEVELS)
    if g_k < SPEED_LEVELS and d.min() >= s[g_now].max() and d.min() >= d_min:
        assert d.min() < delta_s * s[g_k + 1].max()


def test_a_robot_faster_than_s_allows_stops_and_a_slow_one_creeps():
    s = _levels(1, np.random.default_rng(1))
    half = SPEED_LEVELS // 2
    d = np.array([s[half, 0] + 1e-6])  # beyond S of the half-speed level, not the next
    k, _, _ = by_speed_override_command(d, s, [TRACKING], 0.0, 0.25, delta_s=1.0, d_min=0.0)
    assert k == 0.5
    k, _, reason = by_speed_override_command(d, s, [TRACKING], 0.0, 0.9, delta_s=1.0, d_min=0.0)
    assert k == 0.0 and reason == stops.STOP_SEPARATION  # S of its own speed is not met
    k, _, _ = by_speed_override_command(d, s, [TRACKING], 0.0, 0.0, delta_s=1.0, d_min=0.0)
    assert k == 0.5  # from rest it may start towards the half-speed level


@pytest.mark.parametrize("case", ["nan_d", "nan_s", "fault", "lost"])
def test_bad_inputs_stop_the_robot(case):
    s = np.full((SPEED_LEVELS + 1, 2), 0.1)
    d, status, fault = np.array([5.0, 5.0]), np.full(2, TRACKING), 0.0
    if case == "nan_d":
        d[1] = np.nan
    elif case == "nan_s":
        s[3, 0] = np.nan
    elif case == "fault":
        fault = float(stops.STOP_STALE_FRAME)
    else:
        status[0] = TRACK_LOST
    k, _, reason = by_speed_override_command(d, s, status, fault, 0.0, delta_s=1.0, d_min=0.3)
    assert k == 0.0 and reason != stops.STOP_NONE
    assert by_speed_override_command(d[:0], s[:, :0], status[:0], 0.0, 0.5)[0] == 1.0


def test_the_speed_override_system_reads_the_rate_and_the_levels():
    o = SpeedOverride(num_bodies=1, delta_s=1.0, d_min=0.0, levels=SPEED_LEVELS)
    c = o.CreateDefaultContext()
    s = _levels(1, np.random.default_rng(1))
    o.GetInputPort("distances").FixValue(c, [s[SPEED_LEVELS // 2, 0] + 1e-6])
    o.GetInputPort("level_protective_distances").FixValue(c, s.reshape(-1))
    o.GetInputPort("track_status").FixValue(c, [TRACKING])
    o.GetInputPort("fault").FixValue(c, [0.0])
    for rate, k in ((0.25, 0.5), (0.9, 0.0)):
        o.GetInputPort("path_state").FixValue(c, [0.0, rate, 0.0])
        assert o.GetOutputPort("path_speed_commanded").Eval(c)[0] == k


def test_stops_by_rate_grow_with_the_rate_and_end_at_the_full_speed_stop():
    sc = load_scenario("models/scenarios/inspection_seed.yaml")
    args = (joint_path(sc.robot), contact_capsules(sc.robot, "capsules"),
            braking_table(sc.controller), 1.3, 0.002)
    by_rate = stops_by_rate(*args)
    full = true_stopping(*args)
    assert by_rate.time[-1] == full.time and by_rate.distance[-1] == full.distance
    assert by_rate.time[0] == 0.0 and np.all(np.diff(by_rate.time) >= 0.0)
    assert np.all(np.diff(by_rate.distance) >= 0.0) and by_rate.distance[1] > 0.0
    assert by_rate.at(0.5) == (by_rate.time[TRUTH_RATES // 2],
                               by_rate.distance[TRUTH_RATES // 2])
    assert rate_index(0.5 + 1e-6) == TRUTH_RATES // 2 + 1 and rate_index(np.nan) == TRUTH_RATES


def test_s_true_by_speed_takes_the_stop_from_the_rate_now():
    sc = dataclasses.replace(load_scenario("models/scenarios/inspection_seed.yaml"),
                             controller=BY_SPEED)
    full = dataclasses.replace(sc, controller=ISO)
    v_h, v_r = np.full((3, 2), 0.5), np.full((3, 2), 0.2)
    rate = np.array([1.0, 0.5, 0.0])
    by_speed = true_protective_distances(sc, v_h, v_r, rate)
    at_full = true_protective_distances(full, v_h, v_r)
    assert by_speed[0] == pytest.approx(at_full[0])
    assert np.all(by_speed[1] < at_full[1]) and np.all(by_speed[2] < by_speed[1])
    # at rest: only the reaction and the robot's speed terms and C are left
    f = BY_SPEED.safety
    assert by_speed[2] == pytest.approx(2.0 * f.reaction_time + 0.2 * f.reaction_time
                                        + f.intrusion_distance)
    with pytest.raises(ValueError):
        true_protective_distances(sc, v_h, v_r)


def test_the_runtime_takes_s_from_the_rate_bound_and_a_missing_one_as_full_speed():
    # One operator tracked by a right glove alone: the monitor bounds its whole body from
    # the glove (the other hand's envelope, a ball about the glove as wide as both arms and
    # the shoulders, is the nearest), so the glove stands at 4.0 m where it stood at 1.7 m
    # as a lone 0.05 m ball; the nearest segment's d lies between S's levels again.
    loop = SafetyLoop(resolve(BY_SPEED), [["hand_right"]])
    q = np.array([0.0, -1.57, 1.57, -1.57, -1.57, 0.0])
    loop.robot(q, 0.0)
    loop.robot(q, 0.002)  # at rest
    for t in (0.0, 0.05, 0.1):
        loop.frame(t, np.array([[4.0, 0.0, 0.3]]), np.ones(1), np.ones(1))
    loop.decide(0.1, 0.0)
    assert loop.out.shape == (4, 12) and loop.level_out.shape == (SPEED_LEVELS + 1, 12)
    i = np.nanargmin(loop.out[0])  # the nearest segment
    d, s = loop.out[0, i], loop.level_out[:, i]
    assert np.all(np.diff(s) > 0.0) and s[1] < d < s[-1]  # some levels met, not all
    k_slow, _, _ = loop.decide(0.1, 0.0)
    assert 0.0 < k_slow < 1.0  # from rest: the fastest level whose S is met
    k_fast, _, reason = loop.decide(0.1, 1.0)
    assert k_fast == 0.0 and reason == stops.STOP_SEPARATION  # at full speed: S not met
    assert loop.decide(0.1, np.nan)[0] == 0.0  # no bound: full speed


@pytest.mark.parametrize("rate, k, expected", [
    (0.5, 0.0, 8), (0.5, 0.75, 12), (0.25, 0.5, 8), (1.0, 0.0, 16),
    (math.nan, 0.0, 16), (math.inf, 0.0, 16), (-math.inf, 0.0, 16),  # fails to full speed
    (0.5, math.nan, 8), (0.0, math.inf, 0), (0.0, 2.0, 16), (0.0, -1.0, 0)])
def test_the_held_level_is_the_larger_of_the_rate_and_the_command_and_fails_to_full_speed(
        rate, k, expected):
    assert held_level(rate, k, 16) == expected
