"""A path's stopping data from the published per-joint stops (cell/path_stops.py)."""

import math

import numpy as np
import pytest

from safety_systems.cell import braking
from safety_systems.cell.braking import path_rate_step
from safety_systems.cell.joint_path import joint_path_state, make_joint_path
from safety_systems.cell.ur5e import tool0_position
from safety_systems.cell.path_stops import (
    PUBLISHED_STOPS,
    joint_decelerations,
    path_stop_time,
    path_stops,
    peak_speeds_of,
)
from safety_systems.config.configuration import joint_path
from safety_systems.config.scenario import load_scenario

W = math.radians(183.0)


@pytest.mark.parametrize("robot", sorted(PUBLISHED_STOPS))
def test_a_stop_at_the_derived_rate_is_no_shorter_and_turns_no_less_than_published(robot):
    for (theta, t), a in zip(PUBLISHED_STOPS[robot].stops, PUBLISHED_STOPS[robot].decelerations):
        assert W / a >= t - 1e-12  # its time
        assert W * W / (2.0 * a) >= theta - 1e-12  # its angle
        assert W / a == pytest.approx(t) or W * W / (2.0 * a) == pytest.approx(theta)


def test_the_wrists_brake_no_harder_than_the_slowest_published_joint():
    a = joint_decelerations("ur5e", 6)
    assert np.all(a[3:] == a[:3].min())
    assert a[1] == pytest.approx(W / 0.530)  # the UR5's shoulder: its time binds


def test_a_path_at_the_test_speed_on_the_shoulder_stops_as_the_placeholder_does():
    peaks = np.array([0.0, W, 0.0, 0.0, 0.0, 0.0])
    assert path_stop_time(peaks) == pytest.approx(braking.UR5_SHOULDER_STOP_TIME)
    assert path_stop_time(0.5 * peaks) == pytest.approx(0.5 * braking.UR5_SHOULDER_STOP_TIME)


def test_the_main_jobs_path_stops_by_its_slowest_joint_to_speed_ratio():
    path = joint_path(load_scenario("models/scenarios/inspection_seed.yaml").robot)
    peaks = peak_speeds_of(path)
    a = joint_decelerations("ur5e", 6)
    # (independently: each joint's peak from its waypoints, the quintic blend's 1.875)
    by_hand = np.max(1.875 * np.abs(path.deltas) / path.durations[:, None], axis=0)
    assert peaks == pytest.approx(by_hand)
    assert path_stop_time(peaks) == pytest.approx(np.max(by_hand / a))
    assert path_stop_time(peaks) < braking.UR5_SHOULDER_STOP_TIME


def test_the_braking_model_stops_the_path_in_the_derived_time_and_distance():
    path = make_joint_path(np.radians([[140.0, -80.0, 100.0, -110.0, -90.0, 0.0],
                                       [220.0, -65.0, 110.0, -135.0, -90.0, 0.0]]),
                           np.array([1.2, 1.2]), cycles=3)
    table = path_stops(path, peak_speeds_of(path))
    assert table.stopping_time == pytest.approx(table.stopping_time[-1]
                                                * table.speed_fraction)
    for rate, t_stop in zip(table.speed_fraction, table.stopping_time):
        sigma, t, h = np.array([rate]), 0.0, 0.002
        while sigma[0] > 0.0:
            sigma = path_rate_step(sigma, 0.0, h, table=table, acceleration_limit=1.0)
            t += h
        assert t == pytest.approx(t_stop, abs=2 * h)
    # the distance row is the worst tool travel of that stop, so a slower start travels less,
    # and about what the path's fastest tool speed over the stop's mean rate gives (its worst
    # start is at that speed, which a stop this short, against 1.2 s blends, barely leaves)
    assert np.all(np.diff(table.stopping_distance) > 0.0)
    s = np.linspace(0.0, path.cycle_time, 20001)
    p = tool0_position(joint_path_state(path, s)[0])
    v_max = np.max(np.linalg.norm(np.diff(p, axis=0), axis=1) / np.diff(s))
    for rate, t_stop, d in zip(table.speed_fraction, table.stopping_time,
                               table.stopping_distance):
        assert 0.9 * v_max * rate * t_stop / 2.0 <= d <= 1.01 * v_max * rate * t_stop / 2.0


def test_a_robot_with_no_published_joint_stops_is_refused():
    with pytest.raises(ValueError, match="ur5e, ur3e"):
        path_stop_time(np.ones(6), "panda")
