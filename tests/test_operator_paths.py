import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from safety_systems.cell.operator_paths import (
    ScriptedOperator,
    body_layout,
    make_operator_path,
    operator_position_velocity,
    operators_bodies_state,
    segment_profile,
    stack_operator_paths,
    stack_paths,
)

FIXED = settings(derandomize=True, deadline=None, max_examples=40)

# Speed limit 1.5 m/s, acceleration limit 1 m/s^2. Segment 0: 3 m along +x, trapezoidal
# (1.5 s accelerating, 0.5 s cruising, 1.5 s braking = 3.5 s). Segment 1: 1 m along +y,
# triangular (peak sqrt(1 * 1) = 1 m/s, 1 s + 1 s). Segment 2: zero length.
TIMES = [0.0, 1.0, 6.0, 9.0]
POSITIONS = [[0, 0, 0], [3, 0, 0], [3, 1, 0], [3, 1, 0]]


def _path():
    return make_operator_path(TIMES, POSITIONS, max_speed=1.5, max_acceleration=1.0)


def _random_path(seed: int):
    """A random feasible path: 2 to 5 waypoints, random limits, random slack."""
    rng = np.random.default_rng(seed)
    m = int(rng.integers(2, 6))
    v_max, a_max = rng.uniform(0.2, 2.5), rng.uniform(0.3, 4.0)
    p = rng.uniform(-2, 2, size=(m, 3))
    p[rng.uniform(size=m) < 0.2] = p[0]  # sometimes revisit the start (or stay put)
    ta, tc, _ = segment_profile(np.linalg.norm(np.diff(p, axis=0), axis=1), v_max, a_max)
    durations = 2 * ta + tc
    t = [rng.uniform(-1, 1), rng.uniform(1, 2)]
    for d in durations[:-1]:
        t.append(t[-1] + d + rng.uniform(0.0, 1.0))
    return make_operator_path(t, p, max_speed=v_max, max_acceleration=a_max)


def test_segment_profile_trapezoidal_triangular_and_zero():
    ta, tc, vp = segment_profile(np.array([3.0, 1.0, 0.0, 2.25]), 1.5, 1.0)
    np.testing.assert_allclose(vp, [1.5, 1.0, 0.0, 1.5])
    np.testing.assert_allclose(ta, [1.5, 1.0, 0.0, 1.5])
    np.testing.assert_allclose(tc, [0.5, 0.0, 0.0, 0.0], atol=1e-15)  # 2.25 m: just reaches


def test_path_profile_hand_computed():
    path = _path()
    np.testing.assert_allclose(path.peak_speeds, [1.5, 1.0, 0.0])
    np.testing.assert_allclose(path.durations, [3.5, 2.0, 0.0])
    np.testing.assert_allclose(path.departure_times, [1.0, 6.0, 9.0])
    np.testing.assert_allclose(path.directions, [[1, 0, 0], [0, 1, 0], [0, 0, 0]])
    cases = {  # t: (position, velocity)
        1.75: ([0.5 * 0.75**2, 0, 0], [0.75, 0, 0]),  # accelerating
        2.75: ([1.125 + 1.5 * 0.25, 0, 0], [1.5, 0, 0]),  # cruising at max_speed
        4.0: ([3 - 0.5 * 0.5**2, 0, 0], [0.5, 0, 0]),  # braking, 0.5 s left
        4.5: ([3, 0, 0], [0, 0, 0]),  # arrived
        5.9: ([3, 0, 0], [0, 0, 0]),  # held until the next departure
        7.0: ([3, 0.5, 0], [0, 1.0, 0]),  # triangular peak halfway
        7.5: ([3, 1 - 0.5 * 0.5**2, 0], [0, 0.5, 0]),
        8.0: ([3, 1, 0], [0, 0, 0]),
        100.0: ([3, 1, 0], [0, 0, 0]),
    }
    for t, (p, v) in cases.items():
        for got in (operator_position_velocity(path, t),
                    [a[0] for a in operator_position_velocity(path, np.array([t]))]):
            np.testing.assert_allclose(got[0], p, atol=1e-12, err_msg=f"t={t}")
            np.testing.assert_allclose(got[1], v, atol=1e-12, err_msg=f"t={t}")


@pytest.mark.parametrize("t", [-1e6, -3.0, 0.0, 0.5, 0.999999])
def test_start_held_before_first_departure(t):
    # Waypoint 0's time (0.0) only orders the list: the start is held for all t < 1.
    for p, v in (operator_position_velocity(_path(), t),
                 operator_position_velocity(_path(), np.array([t, t]))):
        np.testing.assert_array_equal(p, np.broadcast_to([0.0, 0, 0], np.shape(p)))
        np.testing.assert_array_equal(v, np.zeros(np.shape(v)))


def test_single_waypoint_is_held_forever():
    path = make_operator_path([2.0], [[1.0, 2.0, 3.0]], max_speed=1.0, max_acceleration=1.0)
    p, v = operator_position_velocity(path, np.array([-5.0, 2.0, 50.0]))
    np.testing.assert_array_equal(p, [[1.0, 2.0, 3.0]] * 3)
    np.testing.assert_array_equal(v, np.zeros((3, 3)))
    np.testing.assert_array_equal(operator_position_velocity(path, 7.0)[0], [1.0, 2.0, 3.0])


@FIXED
@given(seed=st.integers(0, 2**32 - 1))
def test_limits_respected_and_waypoints_reached(seed):
    path = _random_path(seed)
    dt = 1e-3
    t = np.arange(path.waypoint_times[0] - 0.5, path.departure_times[-1] + 6.0, dt)
    p, v = operator_position_velocity(path, t)
    speed = np.linalg.norm(v, axis=1)
    assert speed.max() <= path.max_speed * (1 + 1e-12)
    accel = np.linalg.norm(np.diff(v, axis=0), axis=1) / dt
    assert accel.max() <= path.max_acceleration * (1 + 1e-9)
    # Velocity is the derivative of position (trapezoid rule, error <= a dt / 2 per step).
    np.testing.assert_allclose(
        np.diff(p, axis=0) / dt, 0.5 * (v[1:] + v[:-1]), atol=path.max_acceleration * dt
    )
    # Each segment ends at its waypoint, at rest, no later than the next departure.
    arrive = path.departure_times + path.durations
    deadlines = np.r_[path.departure_times[1:], arrive[-1]]
    assert np.all(arrive <= deadlines + 1e-12)
    p_end, v_end = operator_position_velocity(path, np.r_[arrive, deadlines - 1e-9])
    targets = np.r_[path.waypoint_positions[1:], path.waypoint_positions[1:]]
    np.testing.assert_allclose(p_end, targets, atol=1e-8)
    np.testing.assert_allclose(v_end, 0.0, atol=1e-8)


@FIXED
@given(seed=st.integers(0, 2**32 - 1), data=st.data())
def test_scalar_fast_path_equals_vectorised(seed, data):
    path = _random_path(seed)
    t_min, t_max = path.waypoint_times[0] - 1, path.departure_times[-1] + 5
    times = data.draw(st.lists(st.floats(t_min, t_max), min_size=1, max_size=20))
    # Also the phase boundaries exactly, where the branch choice matters.
    d, ta, tc = path.departure_times, path.accel_durations, path.cruise_durations
    end = d + 2 * ta + tc
    times = np.r_[times, d, d + ta, d + ta + tc, end, end + 1e-6, d - 1e-6]
    p_vec, v_vec = operator_position_velocity(path, times)
    for i, t in enumerate(times):
        p, v = operator_position_velocity(path, float(t))
        assert p.shape == v.shape == (3,)
        np.testing.assert_allclose(p, p_vec[i], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(v, v_vec[i], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize(
    "times, positions, v_max, a_max, match",
    [
        ([0, 1, 1], POSITIONS[:3], 1.5, 1.0, "strictly increasing"),
        ([0, 2, 1, 3], POSITIONS, 1.5, 1.0, "strictly increasing"),
        ([], np.zeros((0, 3)), 1.5, 1.0, "times"),
        ([0, float("nan")], POSITIONS[:2], 1.5, 1.0, "times"),
        ([0, 1], POSITIONS[:3], 1.5, 1.0, r"positions has shape \(3, 3\)"),
        ([0, 1], [[0, 0], [1, 1]], 1.5, 1.0, "positions"),
        ([0, 1], [[0, 0, 0], [0, float("inf"), 0]], 1.5, 1.0, "positions"),
        # 3.5 s needed for the 3 m segment, 3.0 s given before waypoint 2 departs.
        ([0, 1, 4, 9], POSITIONS, 1.5, 1.0, r"waypoint 1: .*3\.5000 s.*3\.0000 s.*waypoint 2"),
        ([0, 1, 4.6, 6.0], POSITIONS, 1.5, 1.0, r"waypoint 2: .*2\.0000 s.*1\.4000 s"),
        (TIMES, POSITIONS, 0.0, 1.0, "max_speed=0.0"),
        (TIMES, POSITIONS, -1.0, 1.0, "max_speed"),
        (TIMES, POSITIONS, math.inf, 1.0, "max_speed"),
        (TIMES, POSITIONS, 1.5, 0.0, "max_acceleration=0.0"),
        (TIMES, POSITIONS, 1.5, float("nan"), "max_acceleration"),
    ],
)
def test_make_operator_path_rejects_bad_input(times, positions, v_max, a_max, match):
    with pytest.raises(ValueError, match=match):
        make_operator_path(times, positions, max_speed=v_max, max_acceleration=a_max)


def test_segment_that_just_fits_is_accepted():
    path = make_operator_path([0, 1, 4.5, 9], POSITIONS, max_speed=1.5, max_acceleration=1.0)
    np.testing.assert_allclose(operator_position_velocity(path, 4.5)[0], [3, 0, 0])


def _operators():
    path_a = _path()
    path_b = make_operator_path([0, 0.5], [[1, 1, 0], [1, 2, 0]], 1.0, 2.0)
    return [
        ScriptedOperator(path=path_a, body_offsets=[[0.1, 0, 1.0], [-0.1, 0, 1.0]],
                         enter_time=2.0, leave_time=5.0),
        ScriptedOperator(path=path_b, body_offsets=[[0, 0, 1.7]]),  # from 0.0, never leaves
    ]


def test_bodies_state_offsets_and_velocities():
    ops = _operators()
    for t in (0.2, 2.75, 7.25):
        p, v, _ = operators_bodies_state(ops, t)
        assert p.shape == v.shape == (9,)
        ref = [operator_position_velocity(op.path, t) for op in ops]
        np.testing.assert_allclose(p.reshape(3, 3), [ref[0][0] + [0.1, 0, 1.0],
                                                     ref[0][0] + [-0.1, 0, 1.0],
                                                     ref[1][0] + [0, 0, 1.7]])
        np.testing.assert_allclose(v.reshape(3, 3), [ref[0][1], ref[0][1], ref[1][1]])
    p, _, _ = operators_bodies_state(ops, 2.75)
    np.testing.assert_allclose(p[:3], [1.125 + 1.5 * 0.25 + 0.1, 0, 1.0])


@pytest.mark.parametrize(
    "t, present",
    [(-1.0, [0, 0, 0]), (0.0, [0, 0, 1]), (1.999999, [0, 0, 1]), (2.0, [1, 1, 1]),
     (4.999999, [1, 1, 1]), (5.0, [0, 0, 1]), (1e9, [0, 0, 1])],
)
def test_presence_window_is_half_open(t, present):
    ops = _operators()
    _, _, got = operators_bodies_state(ops, t)
    np.testing.assert_array_equal(got, present)
    _, _, got_vec = operators_bodies_state(ops, np.array([t]))
    np.testing.assert_array_equal(got_vec, [present])


def test_bodies_state_vectorised_matches_scalar_and_layout():
    ops = _operators()
    times = np.linspace(-1.0, 10.0, 45)
    layout = body_layout(ops)
    np.testing.assert_array_equal(layout.operator_index, [0, 0, 1])
    p, v, present = operators_bodies_state(ops, times, layout)
    assert p.shape == v.shape == (45, 9) and present.shape == (45, 3)
    for i, t in enumerate(times):
        for got, want in zip(operators_bodies_state(ops, t), (p[i], v[i], present[i])):
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    assert 0 < present[:, 0].sum() < 45  # the window is actually exercised


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(body_offsets=np.zeros((0, 3))), "body_offsets"),
        # up to ten bodies, one per body point (it was three: gloves and head)
        (dict(body_offsets=np.zeros((11, 3))), "body_offsets"),
        (dict(body_offsets=np.zeros((2, 2))), "body_offsets"),
        (dict(body_offsets=[[0, 0, float("nan")]]), "body_offsets"),
        (dict(body_offsets=[[0, 0, 0]], enter_time=float("nan")), "enter_time"),
        (dict(body_offsets=[[0, 0, 0]], enter_time=math.inf), "enter_time"),
        (dict(body_offsets=[[0, 0, 0]], enter_time=3.0, leave_time=3.0), "leave_time"),
        (dict(body_offsets=[[0, 0, 0]], point_offsets=np.zeros((9, 3))), "point_offsets"),
    ],
)
def test_scripted_operator_rejects_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        ScriptedOperator(path=_path(), **kwargs)


def test_ten_bodies_are_an_operator_and_its_points_move_with_it():
    # A whole suit: ten tracked bodies; the layout by points has ten slots per operator
    # (operator k's point p in slot 10 k + p) and every point moves with the path.
    rng = np.random.default_rng(7)
    points = rng.uniform(-0.5, 0.5, (10, 3))
    ops = [ScriptedOperator(path=_path(), body_offsets=points, point_offsets=points),
           ScriptedOperator(path=_path(), body_offsets=[[0, 0, 1.7]],
                            point_offsets=points[::-1])]
    assert ops[0].num_bodies == 10
    np.testing.assert_array_equal(
        ScriptedOperator(path=_path(), body_offsets=[[0, 0, 0]]).point_offsets,
        np.full((10, 3), np.nan))  # not given
    layout = body_layout(ops, points=True)
    np.testing.assert_array_equal(layout.operator_index, [0] * 10 + [1] * 10)
    p, v, present = operators_bodies_state(ops, 2.75, layout)
    ref, ref_v = operator_position_velocity(ops[0].path, 2.75)
    np.testing.assert_allclose(p.reshape(20, 3), np.concatenate([points, points[::-1]]) + ref)
    np.testing.assert_allclose(v.reshape(20, 3), np.broadcast_to(ref_v, (20, 3)))
    np.testing.assert_array_equal(present, np.ones(20))


@pytest.mark.parametrize("waypoints", [1, 2, 4, 6])
def test_paths_stacked_at_once_equal_the_stacked_paths(waypoints):
    rng = np.random.default_rng(waypoints)
    P = 40
    t = np.cumsum(rng.uniform(6.0, 7.0, (P, waypoints)), axis=1)
    p = rng.normal(size=(P, waypoints, 3)) * 0.5
    p[::7, 1:2] = p[::7, 0:1]  # zero-length segments
    v, a = rng.uniform(0.5, 2.0, P), rng.uniform(1.0, 5.0, P)
    at_once = stack_operator_paths(t, p, v, a)
    one_by_one = stack_paths([make_operator_path(t[i], p[i], v[i], a[i]) for i in range(P)])
    for field in dataclasses.fields(one_by_one):
        np.testing.assert_array_equal(getattr(at_once, field.name),
                                      getattr(one_by_one, field.name))
    # The same checks: a segment that cannot finish before the next departure.
    if waypoints > 2:
        t[3, 2:] -= t[3, 2] - t[3, 1] - 0.01  # 0.01 s from waypoint 1 to waypoint 2
        with pytest.raises(ValueError, match=r"waypoint 1 \(path 3\): reaching it needs"):
            stack_operator_paths(t, p, v, a)


def test_paths_stacked_at_once_are_checked_as_one_path_is():
    t = np.tile([0.0, 1.0, 6.0, 9.0], (3, 1))
    p = np.tile(np.array(POSITIONS, dtype=float), (3, 1, 1))
    v, a = np.full(3, 1.5), np.full(3, 1.0)
    stack_operator_paths(t, p, v, a)  # three copies of the good path
    bad = t.copy()
    bad[2, 2] = bad[2, 1]
    with pytest.raises(ValueError, match=r"times \(path 2\)=.*strictly increasing"):
        stack_operator_paths(bad, p, v, a)
    with pytest.raises(ValueError, match=r"max_acceleration \(path 1\)=0.0"):
        stack_operator_paths(t, p, v, np.array([1.0, 0.0, 1.0]))
