"""Safety zones and performance recovery (seed 001, Sections 2.5-2.6, Eq. 6)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from safety_systems.config.scenario import (
    ControllerConfig,
    ScenarioError,
    ZonesConfig,
    scenario_from_text,
    validate_controller,
)
from safety_systems.planning.zones import (
    GREEN,
    RED,
    YELLOW,
    closest_distance,
    recovery_step,
    zone_of,
    zone_speed,
)

FIXED = settings(derandomize=True, deadline=None, max_examples=200)
G, R = 1.0, 0.5  # green and red thresholds, m


@pytest.mark.parametrize("d, zone", [
    (math.inf, GREEN), (5.0, GREEN), (G, GREEN),            # green at >= green_distance
    (np.nextafter(G, 0.0), YELLOW), (0.75, YELLOW), (np.nextafter(R, 1.0), YELLOW),
    (R, RED), (np.nextafter(R, 0.0), RED), (0.0, RED),      # red at <= yellow_distance
    (math.nan, RED),                                        # no distance: fail safe
])
def test_zone_of_at_and_around_thresholds(d, zone):
    assert int(zone_of(d, green_distance=G, yellow_distance=R)) == zone


def test_zone_of_is_vectorised():
    d = np.array([[2.0, 1.0, 0.9], [0.51, 0.5, 0.1]])
    assert zone_of(d, green_distance=G, yellow_distance=R).tolist() == [[0, 0, 1], [1, 2, 2]]


@st.composite
def zones_configs(draw):
    unit = st.floats(0.0, 1.0)
    red_s, yellow_s, green_s = sorted(draw(st.lists(unit, min_size=3, max_size=3)))
    red_d = draw(st.floats(0.01, 3.0))
    green_d = red_d + draw(st.floats(0.01, 3.0))
    z = ZonesConfig(green_distance=green_d, yellow_distance=red_d, green_speed=green_s,
                    yellow_speed=yellow_s, red_speed=red_s)
    validate_controller(ControllerConfig(zones=z))  # a valid configuration
    return z


@FIXED
@given(zones_configs(), st.lists(st.floats(0.0, 10.0), min_size=2, max_size=30))
def test_zone_speed_never_higher_when_closer(z, distances):
    speeds = (z.green_speed, z.yellow_speed, z.red_speed)
    v_red, v_yellow, v_green = zone_speed(np.array([RED, YELLOW, GREEN]), speeds)
    assert v_red <= v_yellow <= v_green
    d = np.sort(np.array(distances + [z.yellow_distance, z.green_distance]))
    v = zone_speed(zone_of(d, green_distance=z.green_distance, yellow_distance=z.yellow_distance),
                   speeds)
    assert np.all(np.diff(v) >= 0.0)  # non-decreasing in the distance
    assert v[d <= z.yellow_distance].tolist() == [z.red_speed] * int(np.sum(d <= z.yellow_distance))
    assert np.all(v[d >= z.green_distance] == z.green_speed)


def test_closest_distance_ignores_unusable_bodies():
    bodies = np.array([[3.0, 4.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.0, 2.0]])
    assert closest_distance(np.zeros(3), bodies, np.array([True, False, True])) == 2.0
    assert closest_distance(np.zeros(3), bodies, np.array([True, True, True])) == pytest.approx(0.1)
    # Robot point away from the origin: |(1, 2, 2) - (3, 4, 0)| = sqrt(4 + 4 + 4).
    assert closest_distance([1.0, 2.0, 2.0], bodies, np.array([True, False, False])) == \
        pytest.approx(math.sqrt(12.0))


def test_closest_distance_is_inf_without_usable_bodies():
    bodies = np.array([[0.1, 0.0, 0.0]])
    assert closest_distance(np.zeros(3), bodies, np.array([False])) == math.inf
    assert closest_distance(np.zeros(3), np.zeros((0, 3)), np.zeros(0, bool)) == math.inf


def test_recovery_drop_is_immediate():
    kw = dict(max_acceleration=1.0, max_jerk=5.0)
    assert recovery_step(0.8, 0.6, 0.3, 0.01, **kw) == (0.3, 0.0)
    assert recovery_step(0.8, 0.6, 0.0, 0.01, **kw) == (0.0, 0.0)
    assert recovery_step(0.5, 0.2, 0.5, 0.01, **kw) == (0.5, 0.0)  # at the target: rest


@FIXED
@given(st.floats(0.0, 1.0), st.floats(0.0, 1.0), st.floats(0.0, 1.0),
       st.floats(1e-3, 0.1), st.floats(0.1, 5.0), st.floats(0.5, 50.0))
def test_recovery_single_rise_step_is_bounded(k, a_frac, target, dt, a_max, j_max):
    rate = a_frac * a_max  # any state the profile can be in: 0 <= rate <= max_acceleration
    k_new, rate_new = recovery_step(k, rate, target, dt, max_acceleration=a_max,
                                    max_jerk=j_max)
    if target <= k:
        assert (k_new, rate_new) == (target, 0.0)
        return
    assert k <= k_new <= target  # never overshoots
    assert 0.0 <= rate_new <= a_max
    assert abs(rate_new - rate) <= j_max * dt * (1 + 1e-12)
    assert k_new - k <= a_max * dt * (1 + 1e-12)


def _rise(k0, target, dt, a_max, j_max, steps=100_000):
    """The k trace of a rise, until it rests at the target (at most ``steps``)."""
    k, rate, ks = k0, 0.0, [k0]
    for _ in range(steps):
        k, rate = recovery_step(k, rate, target, dt, max_acceleration=a_max, max_jerk=j_max)
        ks.append(k)
        if k == target and rate == 0.0:
            break
    return np.array(ks)


RISES = [(0.01, 1.0, 5.0), (0.01, 0.4, 20.0), (0.001, 1.0, 5.0), (0.05, 2.0, 1.0)]


@pytest.mark.parametrize("dt, a_max, j_max", RISES)
def test_rise_from_0_to_1_is_bounded_and_finite(dt, a_max, j_max):
    ks = _rise(0.0, 1.0, dt, a_max, j_max)
    # Finite: a trapezoid in the rate takes 1/a_max + a_max/j_max s; allow twice that.
    assert ks[-1] == 1.0 and len(ks) - 1 <= 2.0 * (1.0 / a_max + a_max / j_max) / dt + 10
    assert ks.max() == 1.0  # no overshoot
    d1, d2 = np.diff(ks), np.diff(ks, 2)
    assert np.all(d1 >= 0.0)
    assert d1.max() <= a_max * dt * (1 + 1e-9)
    assert d1.max() == pytest.approx(a_max * dt) or a_max**2 / j_max > 1.0
    # Bounded jerk while k is still on its way (before the step that reaches 1).
    arrive = int(np.argmax(ks == 1.0))
    assert np.all(np.abs(d2[:arrive - 2]) <= j_max * dt**2 * (1 + 1e-9))
    # The jerk is used: the rate first grows by exactly max_jerk * dt per step.
    assert d1[0] == pytest.approx(j_max * dt**2) and d2[0] == pytest.approx(j_max * dt**2)


@pytest.mark.parametrize("dt, a_max, j_max", [(0.01, 1.0, 5.0)])
def test_rise_jerk_bounded_including_arrival(dt, a_max, j_max):
    ks = _rise(0.0, 1.0, dt, a_max, j_max)
    assert np.all(np.abs(np.diff(ks, 2)) <= j_max * dt**2 * (1 + 1e-6))


OK = """
operators:
- name: a
  bodies: [{name: l, point: hand_left, offset: [0, 0.2, 0]},
           {name: r, point: hand_right, offset: [0, -0.2, 0]}]
  waypoints: [{time: 0, position: [2, 0, 1]}]
"""


@pytest.mark.parametrize("zones, field", [
    ("{red_speed: 0.6, yellow_speed: 0.5}", "controller.zones.red_speed"),
    ("{yellow_speed: 0.9, green_speed: 0.8}", "controller.zones.red_speed"),
    ("{green_speed: 1.2}", "controller.zones.green_speed"),
    ("{green_distance: 0.5, yellow_distance: 0.5}", "controller.zones.green_distance"),
    ("{green_distance: 0.4, yellow_distance: 0.5}", "controller.zones.green_distance"),
    ("{yellow_distance: 0.0}", "controller.zones.yellow_distance"),
    ("{max_jerk: 0.0}", "controller.zones.max_jerk"),
])
def test_bad_zones_config_names_the_field(zones, field):
    with pytest.raises(ScenarioError) as e:
        scenario_from_text(OK + f"controller: {{zones: {zones}}}\n")
    assert e.value.field == field
    assert "allowed" in str(e.value)


def test_good_zones_config_loads():
    text = OK + ("controller: {type: zones, zones: {green_distance: 1.2, yellow_distance: 0.4, "
                 "red_speed: 0.5, yellow_speed: 0.5, green_speed: 0.5}}\n")
    z = scenario_from_text(text).controller.zones
    assert (z.green_distance, z.yellow_distance, z.red_speed, z.green_speed) == (1.2, 0.4, 0.5, 0.5)
