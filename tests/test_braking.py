import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from safety_systems.cell.braking import (
    BrakingTable,
    _interp_one,
    braking_deceleration,
    default_braking_table,
    path_rate_step,
    stopping_distance,
    stopping_time,
    tool_stopping_distance,
)
from safety_systems.cell.joint_path import _blend, default_joint_path, make_joint_path
from safety_systems.cell.ur5e import DH_A, DH_D

FIXED = settings(derandomize=True, deadline=None, max_examples=300)
DT = 0.002
DEFAULT = default_braking_table()
# A table whose deceleration is not constant: 0.5/0.2 = 2.5 and 1.0/0.5 = 2.0 per second.
UNEVEN = BrakingTable(np.array([0.5, 1.0]), np.array([0.2, 0.5]), np.array([0.1, 0.4]))
RATES = st.floats(-1.2, 1.2)
COMMANDS = st.floats(-1.5, 1.5) | st.just(float("nan"))


def test_default_table_from_ur5_cb3_data():
    # UR5/CB3 manual App. A: shoulder 0.70 rad in 530 ms at 100 %, over 0.85 m of reach.
    np.testing.assert_array_equal(DEFAULT.speed_fraction, [0.33, 0.66, 1.0])
    np.testing.assert_allclose(DEFAULT.stopping_time, [0.1749, 0.3498, 0.53], rtol=1e-12)
    full = 0.70 * 0.85
    assert full == pytest.approx(0.595)
    np.testing.assert_allclose(DEFAULT.stopping_distance,
                               [full * 0.33**2, full * 0.66**2, full], rtol=1e-12)
    # Constant deceleration: the same for every row.
    np.testing.assert_allclose(DEFAULT.deceleration, 1.0 / 0.53, rtol=1e-12)
    assert float(stopping_time(DEFAULT, 1.0)) == pytest.approx(0.53)
    assert float(stopping_distance(DEFAULT, 1.0)) == pytest.approx(0.595)


def test_table_rows_are_read_only():
    with pytest.raises(ValueError):
        DEFAULT.stopping_time[0] = 1.0


@pytest.mark.parametrize("rows, match", [
    (([0.5, 1.0], [0.2, 0.5], [0.1]), "stopping_distance"),
    (([0.5, 1.0], [0.2], [0.1, 0.4]), "stopping_time"),
    (([], [], []), "speed_fraction"),
    (([0.0, 1.0], [0.2, 0.5], [0.1, 0.4]), "speed_fraction"),
    (([-0.5, 1.0], [0.2, 0.5], [0.1, 0.4]), "speed_fraction"),
    (([0.5, 1.0], [0.0, 0.5], [0.1, 0.4]), "stopping_time"),
    (([0.5, 1.0], [0.2, 0.5], [0.1, -0.4]), "stopping_distance"),
    (([0.5, 1.0], [0.2, np.nan], [0.1, 0.4]), "stopping_time"),
    (([0.5, 1.0], [0.2, 0.5], [0.1, np.inf]), "stopping_distance"),
    (([1.0, 0.5], [0.2, 0.5], [0.1, 0.4]), "must increase"),
    (([0.5, 0.5], [0.2, 0.5], [0.1, 0.4]), "must increase"),
    (([[0.5, 1.0]], [[0.2, 0.5]], [[0.1, 0.4]]), "speed_fraction"),
])
def test_bad_rows_rejected(rows, match):
    with pytest.raises(ValueError, match=match):
        BrakingTable(*(np.array(r, dtype=float) for r in rows))


def test_interpolation_by_hand():
    # Deceleration: interpolated between the rows, constant beyond them, even in |speed|.
    np.testing.assert_allclose(braking_deceleration(UNEVEN, [0.0, 0.25, 0.5, 0.75, 1.0, 1.5]),
                               [2.5, 2.5, 2.5, 2.25, 2.0, 2.0])
    assert float(braking_deceleration(UNEVEN, -0.75)) == pytest.approx(2.25)
    # Stopping time and distance: from 0 at rest, linear between rows, held above the top.
    np.testing.assert_allclose(stopping_time(UNEVEN, [0.0, 0.25, 0.5, 0.75, 1.0, 2.0]),
                               [0.0, 0.1, 0.2, 0.35, 0.5, 0.5])
    np.testing.assert_allclose(stopping_distance(UNEVEN, [0.0, 0.25, 0.5, 0.75, 1.0, 2.0]),
                               [0.0, 0.05, 0.1, 0.25, 0.4, 0.4])
    assert float(stopping_time(UNEVEN, -0.75)) == pytest.approx(0.35)
    assert float(stopping_distance(UNEVEN, -0.25)) == pytest.approx(0.05)


def _step(rate, cmd, table=DEFAULT, accel=2.0):
    return float(path_rate_step(rate, cmd, DT, table=table, acceleration_limit=accel))


@FIXED
@given(rate=RATES, cmd=COMMANDS, accel=st.floats(0.1, 10.0), uneven=st.booleans())
def test_path_rate_step_properties(rate, cmd, accel, uneven):
    table = UNEVEN if uneven else DEFAULT
    new = _step(rate, cmd, table, accel)
    target = 0.0 if math.isnan(cmd) else min(max(cmd, -1.0), 1.0)  # NaN counts as 0
    if rate * target < 0.0:
        target = 0.0  # the other sign: first come to rest
    eps = 1e-12
    assert min(rate, target) - eps <= new <= max(rate, target) + eps  # towards, no overshoot
    assert new * rate >= 0.0  # never crosses zero in one tick
    assert abs(rate) - abs(new) <= float(braking_deceleration(table, rate)) * DT + eps
    assert abs(new) - abs(rate) <= accel * DT + eps
    # It moves as far as it may: reaches the target or moves by the full bound.
    bound = (float(braking_deceleration(table, rate)) if abs(target) < abs(rate) else accel) * DT
    assert new == pytest.approx(target, abs=eps) or abs(new - rate) == pytest.approx(bound)


@FIXED
@given(rate=RATES, accel=st.floats(0.1, 10.0))
def test_non_finite_command_counts_as_zero(rate, accel):
    zero = _step(rate, 0.0, DEFAULT, accel)
    for bad in (float("nan"), float("inf"), -float("inf")):
        assert _step(rate, bad, DEFAULT, accel) == zero


def test_path_rate_step_vectorised_and_examples():
    rates = np.array([0.0, 0.5, 0.5, 1.0, -0.001, 0.002])
    cmds = np.array([1.0, 0.7, 0.0, 2.0, 1.0, -1.0])
    got = path_rate_step(rates, cmds, DT, table=DEFAULT, acceleration_limit=2.0)
    decel = DT / 0.53
    np.testing.assert_allclose(got, [0.004, 0.504, 0.5 - decel, 1.0, 0.0, 0.0])
    np.testing.assert_array_equal(got, [_step(r, c) for r, c in zip(rates, cmds)])


@pytest.mark.parametrize("start", [1.0, 0.66, 0.33])
def test_full_stop_takes_table_stopping_time(start):
    rate, ticks, moving = start, 0, 0
    while rate != 0.0:
        previous = rate
        rate = _step(rate, 0.0)
        assert 0.0 <= rate < previous
        ticks += 1
        moving += rate > 1e-12  # rounding may leave ~1e-16 for one more tick
        assert ticks < 10_000
    expected = float(stopping_time(DEFAULT, start))
    assert abs((moving + 1) * DT - expected) <= DT + 1e-12
    assert ticks <= moving + 2


def test_full_stop_uneven_table_between_row_times():
    rate, ticks = 1.0, 0
    while rate != 0.0:
        rate, ticks = _step(rate, 0.0, UNEVEN), ticks + 1
    # Deceleration 2.0 at full speed rising to 2.5 below 0.5: between 0.4 s and 0.5 s.
    assert 0.4 < ticks * DT < 0.5


def _one_joint_path(delta=1.0, duration=1.0):
    """Base joint turns by delta and back, other joints at 0: tool0 on a horizontal circle."""
    w = np.zeros((2, 6))
    w[1, 0] = delta
    return make_joint_path(w, [duration, duration])


def test_tool_stopping_distance_on_a_circle_by_hand():
    delta, duration = 1.0, 1.0
    # At q2..q6 = 0: u = a2 + a3, n = d4 + d6 (ur5e._tool0_rows), radius hypot(u, n).
    radius = math.hypot(DH_A[1] + DH_A[2], DH_D[3] + DH_D[5])
    for rate in (1.0, 0.5):
        # Constant deceleration 1/0.53: the stop covers rate^2 * 0.53 / 2 s of path
        # parameter; the worst window is centred on the blend's fastest point.
        half = rate * rate * 0.53 / 2.0 / duration / 2.0
        h = _blend(np.array([0.5 - half, 0.5 + half]))[0]
        expected = radius * delta * (h[1] - h[0])
        got = tool_stopping_distance(_one_joint_path(delta, duration), DEFAULT, rate=rate)
        assert got == pytest.approx(expected, rel=2e-3)


def test_tool_stopping_distance_positive_and_grows_with_rate():
    path = default_joint_path()
    got = [tool_stopping_distance(path, DEFAULT, rate=r, starts=100) for r in (0.2, 0.5, 1.0)]
    assert 0.0 < got[0] < got[1] < got[2]
    # Plausible for a UR5e: less than the table's 0.595 m from a 0.85 m arm, more than 5 cm.
    assert 0.05 < got[2] < 0.595
    assert tool_stopping_distance(path, DEFAULT, rate=0.0, starts=10) == 0.0


@FIXED
@given(rate=st.one_of(RATES, st.just(float("nan"))), cmd=COMMANDS,
       accel=st.floats(0.1, 10.0), scale=st.floats(0.5, 3.0), max_rate=st.floats(0.5, 2.0),
       uneven=st.booleans())
def test_one_robot_path_equals_the_vectorised_one(rate, cmd, accel, scale, max_rate, uneven):
    # Python floats (the PathFollower's tick) give a float, arrays an array: the same rules.
    args = {"table": UNEVEN if uneven else DEFAULT, "acceleration_limit": accel,
            "time_scale": scale, "max_rate": max_rate}
    one = path_rate_step(float(rate), float(cmd), DT, **args)
    batched = path_rate_step(np.array([rate]), np.array([cmd]), DT, **args)[0]
    assert isinstance(one, float)
    np.testing.assert_array_equal(one, batched)


@pytest.mark.parametrize("table", [DEFAULT, UNEVEN])
def test_one_value_interpolation_is_numpys(table):
    # The compiled rate step reads the braking table by _interp_one: np.interp's values,
    # bit for bit, at the rows, between them, beyond both ends and for non-finite speeds.
    rng = np.random.default_rng(2)
    x = np.r_[rng.uniform(-0.5, 1.5, 2000), table.speed_fraction, 0.0,
              np.nextafter(table.speed_fraction, 2.0), np.nan, np.inf, -np.inf]
    want = np.interp(x, table.speed_fraction, table.deceleration)
    got = np.array([_interp_one(v, table.speed_fraction, table.deceleration) for v in x])
    np.testing.assert_array_equal(got, want)
