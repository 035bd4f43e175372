import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from safety_systems.pfl.body_regions import REGIONS, body_region
from safety_systems.pfl.contact_speed import (
    permissible_speed,
    reduced_mass,
    robot_effective_mass,
    speed_from_force,
    speed_from_pressure,
    transient_speed,
)

FIXED = settings(derandomize=True, deadline=None, max_examples=200)
masses = st.floats(0.1, 500.0)
PERMITTED = [r for r in REGIONS if r.transient_contact]


def test_the_hand_by_hand():
    # A hand (0.6 kg, 75 N/mm) struck by a robot of m_R = 10 kg, transient force 2 x 140 N:
    # mu = 0.6 * 10 / 10.6 = 0.566 kg; v = 280 / sqrt(0.566 * 75000) = 1.359 m/s.
    mu = 0.6 * 10.0 / 10.6
    assert reduced_mass(0.6, 10.0) == pytest.approx(mu)
    expected = 280.0 / math.sqrt(mu * 75_000.0)
    assert expected == pytest.approx(1.3590, abs=1e-4)
    assert transient_speed(body_region("hands_fingers"), 10.0) == pytest.approx(expected)


def test_effective_mass_eq_a4():
    assert robot_effective_mass(17.7, 2.0) == pytest.approx(10.85)
    np.testing.assert_allclose(robot_effective_mass([20.0, 30.0], 1.0), [11.0, 16.0])
    with pytest.raises(ValueError, match="payload"):
        robot_effective_mass(17.7, -1.0)
    with pytest.raises(ValueError, match="moving_mass"):
        robot_effective_mass(math.inf, 0.0)


@FIXED
@given(m_H=masses, m_R=masses)
def test_reduced_mass_eq_a3(m_H, m_R):
    mu = reduced_mass(m_H, m_R)
    assert mu == pytest.approx(1.0 / (1.0 / m_H + 1.0 / m_R))
    assert mu <= min(m_H, m_R) * (1 + 1e-12)
    assert mu == pytest.approx(reduced_mass(m_R, m_H))


@FIXED
@given(force=st.floats(1.0, 1000.0), mu=masses, k=st.floats(1e3, 2e5))
def test_the_speed_brings_exactly_the_energy_the_force_allows(force, mu, k):
    # mu v^2 / 2 = F^2 / (2 k): the energy the contact may transfer.
    v = speed_from_force(force, mu, k)
    assert 0.5 * mu * v**2 == pytest.approx(force**2 / (2 * k))


def test_the_lesser_of_force_and_pressure():
    hand, mu = body_region("hands_fingers"), reduced_mass(0.6, 10.0)
    k, F, p = hand.spring_constant, hand.transient_force, hand.transient_pressure
    by_force = speed_from_force(F, mu, k)
    small, large = 0.5e-4, 4e-4  # 0.5 cm^2: p A = 190 N < 280 N; 4 cm^2: 1520 N
    assert speed_from_pressure(p, small, mu, k) == pytest.approx(190.0 / math.sqrt(mu * k))
    assert permissible_speed(F, mu, k, pressure=p, area=small) < by_force
    assert permissible_speed(F, mu, k, pressure=p, area=large) == pytest.approx(by_force)
    assert permissible_speed(F, mu, k) == pytest.approx(by_force)
    assert transient_speed(hand, 10.0, contact_area=small) == pytest.approx(
        190.0 / math.sqrt(mu * k))


@FIXED
@given(light=masses, extra=st.floats(0.01, 500.0), area=st.one_of(st.none(),
                                                                  st.floats(1e-5, 1e-3)))
def test_a_heavier_robot_may_strike_only_slower(light, extra, area):
    for region in PERMITTED:
        v_light = transient_speed(region, light, contact_area=area)
        v_heavy = transient_speed(region, light + extra, contact_area=area)
        assert 0.0 < v_heavy < v_light


def test_a_forbidden_region_permits_no_speed():
    for name in ("skull_forehead", "face", "neck"):
        np.testing.assert_array_equal(
            transient_speed(body_region(name), np.array([0.5, 10.0, 100.0])), 0.0)
        assert transient_speed(body_region(name), 10.0, contact_area=1e-4) == 0.0


def test_vectorised_over_the_robots_mass():
    hand = body_region("hands_fingers")
    m_R = np.array([5.0, 10.0, 20.0])
    np.testing.assert_allclose(transient_speed(hand, m_R),
                               [transient_speed(hand, m) for m in m_R])
