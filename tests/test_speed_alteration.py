import dataclasses

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from safety_systems.cell.cartesian_path import line_path
from safety_systems.speed_alteration.ellipsoids import Ellipsoids, concatenate, spheres
from safety_systems.config.scenario import EllipsoidConfig
from safety_systems.speed_alteration.methods import (
    bimodal_speed,
    clearance,
    collision_trend,
    grid_upper,
    hwang_candidates,
    hwang_speed,
    operator_ellipsoids,
    preprogrammed_speed,
)

SETTINGS = settings(derandomize=True, max_examples=50, deadline=None)
SIZES = EllipsoidConfig()


@pytest.fixture(scope="module")
def path():
    return line_path([0.368, 0, 0.6685], [0.368, 0.12, 0.6685], speed=0.05, rpy=[np.pi, 0, 0],
                     seed=np.radians([159, -103, 74, -61, -90, -111]))


def test_preprogrammed_speed_of_a_line(path):
    # Eq. 8: 0.12 m in 2.4 s.
    assert path.cycle_time == pytest.approx(2.4)
    assert preprogrammed_speed(path) == pytest.approx(0.05, abs=1e-3)


GRID = np.linspace(-0.25, 0.25, 11)
speeds = st.lists(st.floats(-0.25, 0.25), min_size=1, max_size=20).map(np.array)


def _functions(a, c, b):
    """A convex quadratic and two monotone functions, as (pairs,) rows of speed v."""
    return lambda v: np.stack([a * (v - c) ** 2 + b, np.exp(8 * v), -np.tanh(20 * v) + 1],
                              axis=-1)


@SETTINGS
@given(st.floats(0.1, 50), st.floats(-0.3, 0.3), st.floats(0.0, 1.0), speeds)
def test_grid_upper_bounds_convex_and_monotone_functions(a, c, b, v):
    f = _functions(a, c, b)
    rows = f(GRID)
    upper = grid_upper(GRID, rows, v)
    assert upper.shape == (len(v), 3)
    assert np.all(upper >= f(v) - 1e-12)
    # Strictly between grid points it is the worse of the two around v, nothing larger.
    between = np.min(np.abs(v[:, None] - GRID), axis=1) > 1e-9
    i = np.searchsorted(GRID, v[between]) - 1
    np.testing.assert_array_equal(upper[between], np.maximum(rows[i], rows[i + 1]))


def test_grid_upper_equals_grid_values_at_grid_points():
    # (Once returned max(rows[i], rows[i+1]) there: needlessly cautious.)
    rows = _functions(3.0, 0.1, 0.0)(GRID)
    np.testing.assert_allclose(grid_upper(GRID, rows, GRID), rows)


def test_grid_upper_at_the_ends_and_outside():
    rows = np.arange(len(GRID), dtype=float)[:, None]
    assert grid_upper(GRID, rows, np.array([0.25]))[0, 0] == len(GRID) - 1
    assert grid_upper(GRID, rows, np.array([0.3]))[0, 0] == len(GRID) - 1
    assert grid_upper(GRID, rows, np.array([-0.3]))[0, 0] == 0.0  # clamped to grid[0]
    assert grid_upper(GRID, rows, np.array([-0.24]))[0, 0] == 1.0


def test_hwang_speed_minimises_eq_13():
    grid = np.array([-0.1, 0.0, 0.05, 0.1])
    danger = np.array([[0.1, 0.1], [0.2, 0.2], [0.9, 0.6], [1.5, 1.0]])
    now = np.array([0.5, 0.5])
    P = collision_trend

    def choice(d, n):  # unaltered: the previous speed was V_pre
        return hwang_speed(speeds=grid, danger=d, danger_now=n, v_pre=0.05, v_prev=0.05)

    def eq_13(d, n):
        return P(d).sum(axis=1) + (P(d) - P(n)).sum(axis=1) + np.abs(grid - 0.05) / 0.05

    # Eq. 13 of the rows: 2.29, 0.59, 1.28, 2.91 (the last also collides)  ->  0.0
    np.testing.assert_allclose(eq_13(danger, now), [2.291, 0.593, 1.281, 2.910], atol=1e-3)
    assert choice(danger, now) == 0.0
    # Without danger the pre-programmed speed wins.
    assert choice(np.zeros_like(danger), np.zeros(2)) == 0.05
    # The penalty index comes first: with rows 1-3 colliding (DI >= 1), -0.1 is the
    # only collision-free speed, though Eq. 13 prices it above V_pre (1.44 > 0.87).
    colliding = np.array([[0.0, 0.0], [1.2, 1.2], [1.0, 1.0], [1.5, 1.5]])
    high = np.array([2.0, 2.0])
    assert eq_13(colliding, high)[0] > eq_13(colliding, high)[2] + 0.5
    assert choice(colliding, high) == -0.1


def test_hwang_candidates_are_v_pre_and_the_limits():
    np.testing.assert_array_equal(hwang_candidates(0.05, 0.25), [-0.25, 0.05, 0.25])
    # A pre-programmed speed above the cap is capped (|V| <= 250 mm/s, Eq. 11).
    np.testing.assert_array_equal(hwang_candidates(0.4, 0.25), [-0.25, 0.25])


# Hwang's trend rule on three candidates (retreat, V_pre, advance) and one pair: the DI
# now is 0.5; the retreat takes the pair apart, V_pre and the advance bring it closer.
SPEEDS = np.array([-0.25, 0.05, 0.25])
NOW = np.array([0.5])
APART = np.array([[0.3], [0.6], [0.8]])


def test_hwang_unaltered_keeps_v_pre_while_it_is_collision_free():
    assert hwang_speed(speeds=SPEEDS, danger=APART, danger_now=NOW, v_pre=0.05,
                       v_prev=0.05) == 0.05


@pytest.mark.parametrize("v_prev", [-0.25, 0.25, 0.0])
def test_hwang_altered_keeps_to_speeds_that_reduce_the_collision_trend(v_prev):
    # Altered (the last choice was not V_pre): V_pre raises the collision-trend sum, the
    # retreat reduces it, so the retreat is taken although Eq. 13 prices it at 6.
    assert hwang_speed(speeds=SPEEDS, danger=APART, danger_now=NOW, v_pre=0.05,
                       v_prev=v_prev) == -0.25


def test_hwang_alteration_ends_when_v_pre_reduces_the_trend_too():
    # The operator leaves: every candidate reduces the sum; Eq. 13 picks V_pre.
    leaving = np.array([[0.2], [0.3], [0.4]])
    assert hwang_speed(speeds=SPEEDS, danger=leaving, danger_now=NOW, v_pre=0.05,
                       v_prev=-0.25) == 0.05


def test_hwang_alteration_ends_when_no_speed_reduces_the_trend():
    # At rest against the start of its path (the retreat goes nowhere) beside an
    # operator who stands still: no candidate reduces the sum, so Eq. 13 alone decides
    # and the robot moves on (no deadlock).
    still = np.array([[0.5], [0.6], [0.8]])
    assert hwang_speed(speeds=SPEEDS, danger=still, danger_now=NOW, v_pre=0.05,
                       v_prev=-0.25) == 0.05


def test_hwang_altered_ignores_a_reducing_speed_that_collides():
    # Two pairs. The advance would reduce the sum (it leaves pair 1) but collides with
    # pair 2; the retreat and V_pre raise it: the penalty index ranks first, then Eq. 13
    # picks V_pre among the collision-free speeds.
    now = np.array([0.5, 0.5])
    danger = np.array([[0.6, 0.6], [0.55, 0.55], [0.05, 1.0]])
    rise = (collision_trend(danger) - collision_trend(now)).sum(axis=1)
    assert rise[2] < 0.0 < min(rise[0], rise[1])
    assert hwang_speed(speeds=SPEEDS, danger=danger, danger_now=now, v_pre=0.05,
                       v_prev=0.25) == 0.05


@pytest.mark.parametrize("gap, threshold, expected", [
    (0.5, 0.1, 0.05), (0.1, 0.1, 0.0), (0.05, 0.1, 0.0), (-0.2, 0.1, 0.0),
    (1e-9, 0.0, 0.05), (0.0, 0.0, 0.0), (float("inf"), 0.0, 0.05),
])
def test_bimodal_thresholds(gap, threshold, expected):
    assert bimodal_speed(gap, v_pre=0.05, threshold=threshold) == expected


@SETTINGS
@given(st.lists(st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)),
                min_size=1, max_size=3),
       st.lists(st.floats(0.01, 0.2), min_size=3, max_size=3),
       st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)), st.floats(0.01, 0.2))
def test_clearance_of_spheres(centres, radii, other, r2):
    assume(np.min(np.linalg.norm(np.array(centres) - other, axis=1)) > 1e-9)
    a = spheres(np.array(centres), np.array(radii[:len(centres)]))
    b = spheres(np.array([other]), r2)
    d = np.linalg.norm(np.array(centres) - np.array(other), axis=1)
    expected = np.min(d - np.array(radii[:len(centres)]) - r2)
    assert clearance(a, b) == pytest.approx(expected, abs=1e-12)
    assert clearance(b, a) == pytest.approx(expected, abs=1e-12)


def test_clearance_of_concentric_spheres():
    # (Once 0: the unit vector between coincident centres was 0, so the radii vanished.)
    a, b = spheres(np.zeros((1, 3)), 0.1), spheres(np.zeros((1, 3)), 0.15)
    assert clearance(a, b) == pytest.approx(-0.25)


def test_clearance_without_pairs_is_infinite():
    empty = spheres(np.zeros((0, 3)), 0.05)
    assert clearance(empty, spheres(np.zeros((1, 3)), 0.05)) == np.inf
    assert clearance(spheres(np.zeros((1, 3)), 0.05), empty) == np.inf


# Two operators: 0 has both gloves and a head tracked; 1 has one glove lost and a head.
POSITIONS = np.array([[1.0, 0.2, 1.0], [1.0, -0.2, 1.0], [1.3, 0.0, 1.6],
                      [0.0, 1.0, 1.0], [np.nan, np.nan, np.nan], [0.0, 1.3, 1.6]])
OPERATOR_OF = np.array([0, 0, 0, 1, 1, 1])
IS_HAND = np.array([True, True, False, True, True, False])
VALID = np.array([True, True, True, True, False, True])


def _by_centre(e: Ellipsoids, x) -> np.ndarray:
    i = np.flatnonzero(np.all(np.isclose(e.centres, x), axis=1))
    assert i.size == 1, (x, e.centres)
    return e.semi_axes[i[0]]


def test_operator_ellipsoids_upper_body_only_with_both_hands():
    e = operator_ellipsoids(POSITIONS, VALID, OPERATOR_OF, IS_HAND, SIZES)
    # 8 for operator 0's upper body + its head sphere + operator 1's glove and head.
    assert e.centres.shape == (11, 3)
    assert np.all(np.isfinite(e.centres))
    np.testing.assert_allclose(e.centres[:2], POSITIONS[:2])  # the upper body's hands
    np.testing.assert_allclose(_by_centre(e, POSITIONS[2]), SIZES.head_radius)
    np.testing.assert_allclose(_by_centre(e, POSITIONS[3]), SIZES.hand_radius)
    np.testing.assert_allclose(_by_centre(e, POSITIONS[5]), SIZES.head_radius)
    # An upper arm: a segment, longer along one axis than across.
    assert np.sum(np.isclose(e.semi_axes[:, 1], SIZES.upper_arm_radius)) == 2


def test_operator_ellipsoids_hands_model_is_spheres():
    sizes = dataclasses.replace(SIZES, human="hands")
    e = operator_ellipsoids(POSITIONS, VALID, OPERATOR_OF, IS_HAND, sizes)
    np.testing.assert_allclose(e.centres, POSITIONS[VALID])
    radii = np.where(IS_HAND[VALID], sizes.hand_radius, sizes.head_radius)
    np.testing.assert_allclose(e.semi_axes, np.repeat(radii[:, None], 3, axis=1))
    np.testing.assert_allclose(e.rotations, np.broadcast_to(np.eye(3), (5, 3, 3)))


@pytest.mark.parametrize("human", ["hands", "upper_body"])
def test_operator_ellipsoids_empty_when_nothing_valid(human):
    sizes = dataclasses.replace(SIZES, human=human)
    e = operator_ellipsoids(POSITIONS, np.zeros(6, bool), OPERATOR_OF, IS_HAND, sizes)
    assert e.centres.shape == (0, 3) and e.semi_axes.shape == (0, 3)
    assert e.rotations.shape == (0, 3, 3)
    # And it combines with others and yields no pairs.
    assert concatenate(e, spheres(np.zeros((1, 3)), 0.1)).centres.shape == (1, 3)


def test_operator_ellipsoids_two_full_operators():
    valid = np.ones(6, bool)
    positions = POSITIONS.copy()
    positions[4] = [0.0, 0.8, 1.0]
    e = operator_ellipsoids(positions, valid, OPERATOR_OF, IS_HAND, SIZES)
    assert e.centres.shape == (2 * 8 + 2, 3)
