import numpy as np
import pytest

from safety_systems.cell.braking import default_braking_table
from safety_systems.cell.joint_path import DEFAULT_DURATIONS, DEFAULT_WAYPOINTS_DEG
from safety_systems.config.scenario import (
    BrakingConfig,
    ControllerConfig,
    PathConfig,
    RobotConfig,
    SafetyConfig,
    SensorConfig,
    TrackerConfig,
)
from safety_systems.config.configuration import (
    assumed_stopping,
    braking_table,
    frame_timeout,
    joint_path,
)

MEASURED = BrakingConfig(speed_fraction=[0.25, 0.5, 1.0], stopping_time=[0.1, 0.25, 0.4],
                         stopping_distance=[0.02, 0.08, 0.3])


def _table_rows(table):
    return [table.speed_fraction, table.stopping_time, table.stopping_distance]


@pytest.mark.parametrize("category", [0, 1])
def test_braking_table_default_is_ur5_placeholder(category):
    table = braking_table(ControllerConfig(braking=BrakingConfig(stop_category=category)))
    for got, want in zip(_table_rows(table), _table_rows(default_braking_table())):
        np.testing.assert_array_equal(got, want)
    np.testing.assert_allclose(table.stopping_time, [0.1749, 0.3498, 0.53])


def test_braking_table_from_configuration():
    table = braking_table(ControllerConfig(braking=MEASURED))
    for got, want in zip(_table_rows(table), (MEASURED.speed_fraction, MEASURED.stopping_time,
                                              MEASURED.stopping_distance)):
        np.testing.assert_array_equal(got, want)
    np.testing.assert_allclose(table.deceleration, [2.5, 2.0, 2.5])


@pytest.mark.parametrize("field, values", [
    ("stopping_time", [0.1, 0.25]),
    ("stopping_distance", [0.02, 0.0, 0.3]),
    ("speed_fraction", [0.5, 0.25, 1.0]),
])
def test_braking_table_bad_configuration_raises(field, values):
    braking = BrakingConfig(**{**MEASURED.__dict__, field: values})
    with pytest.raises(ValueError, match=field):
        braking_table(ControllerConfig(braking=braking))


def test_assumed_stopping_defaults_from_table_at_full_speed():
    assert assumed_stopping(ControllerConfig()) == pytest.approx((0.53, 0.595))
    assert assumed_stopping(ControllerConfig(braking=MEASURED)) == pytest.approx((0.4, 0.3))


@pytest.mark.parametrize("t_s, b", [(0.3, 0.2), (0.0, 0.0), (0.3, None), (None, 0.0)])
def test_assumed_stopping_configured_values_win(t_s, b):
    config = ControllerConfig(braking=MEASURED,
                              safety=SafetyConfig(stopping_time=t_s, stopping_distance=b))
    got = assumed_stopping(config)
    # A configured 0.0 is a value, not "unset" (tested with `is None`).
    assert got == (0.4 if t_s is None else t_s, 0.3 if b is None else b)
    assert all(isinstance(v, float) for v in got)


@pytest.mark.parametrize("rate, latency, processing, expected", [
    (20.0, 0.0, 0.001, 0.076),
    (100.0, 0.02, 0.002, 0.037),
    (1000.0, 0.0, 0.0005, 0.002),
])
def test_frame_timeout_default(rate, latency, processing, expected):
    config = ControllerConfig(sensor=SensorConfig(rate_hz=rate, latency=latency),
                              tracker=TrackerConfig(processing_time=processing))
    assert frame_timeout(config) == pytest.approx(expected)
    # One missed frame makes the newest frame stale: more than one period + delays.
    assert frame_timeout(config) > 1.0 / rate + latency + processing


def test_frame_timeout_configured():
    config = ControllerConfig(tracker=TrackerConfig(frame_timeout=0.3))
    assert frame_timeout(config) == 0.3
    config = ControllerConfig(sensor=SensorConfig(rate_hz=50.0, latency=0.5),
                              tracker=TrackerConfig(frame_timeout=0.25))
    assert frame_timeout(config) == 0.25


@pytest.mark.parametrize("cycles", [1, 3])
def test_joint_path_default(cycles):
    path = joint_path(RobotConfig(cycles=cycles))
    np.testing.assert_allclose(path.waypoints, np.radians(DEFAULT_WAYPOINTS_DEG))
    np.testing.assert_array_equal(path.durations, DEFAULT_DURATIONS)
    assert path.cycles == cycles
    assert path.end == pytest.approx(6.2 * cycles)


def test_joint_path_from_configuration():
    waypoints = [[0, -90, 90, -90, -90, 0], [45, -90, 90, -90, -90, 0]]
    robot = RobotConfig(cycles=2, path=PathConfig(waypoints_deg=waypoints,
                                                  segment_durations=[0.5, 1.0]))
    path = joint_path(robot)
    np.testing.assert_allclose(path.waypoints, np.radians(waypoints))
    np.testing.assert_array_equal(path.durations, [0.5, 1.0])
    assert path.cycles == 2 and path.end == pytest.approx(3.0)
    # 45 deg in 0.5 s peaks at 1.875 x 90 deg/s.
    assert np.degrees(path.peak_joint_speed) == pytest.approx(168.75)


def test_joint_path_too_fast_raises_naming_segment():
    waypoints = [[0, -90, 90, -90, -90, 0], [90, -90, 90, -90, -90, 0]]
    robot = RobotConfig(path=PathConfig(waypoints_deg=waypoints, segment_durations=[2.0, 0.5]))
    with pytest.raises(ValueError, match=r"segment_durations\[1\]=0\.5"):
        joint_path(robot)
