import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from safety_systems.cell.joint_path import (
    DEFAULT_DURATIONS,
    DEFAULT_WAYPOINTS_DEG,
    default_joint_path,
    joint_path_state,
    make_joint_path,
)
from safety_systems.cell.ur5e import JOINT_VELOCITY_LIMIT

FIXED = settings(derandomize=True, deadline=None, max_examples=100)
PATH = default_joint_path(cycles=3)
W = np.radians(DEFAULT_WAYPOINTS_DEG)


def test_default_path_built_from_constants():
    np.testing.assert_allclose(PATH.waypoints, W)
    np.testing.assert_array_equal(PATH.durations, DEFAULT_DURATIONS)
    np.testing.assert_allclose(PATH.starts, [0.0, 0.8, 1.6, 3.1, 3.9, 4.7])
    assert PATH.cycle_time == pytest.approx(6.2)
    assert PATH.end == pytest.approx(18.6)
    np.testing.assert_allclose(PATH.deltas, np.roll(W, -1, axis=0) - W)
    with pytest.raises(ValueError):
        PATH.waypoints[0, 0] = 1.0  # read-only


@pytest.mark.parametrize("cycle", [0, 1, 2])
def test_waypoints_reached_at_rest_at_segment_boundaries(cycle):
    s = PATH.starts + cycle * PATH.cycle_time
    q, dq, ddq = joint_path_state(PATH, s)
    np.testing.assert_allclose(q, W, atol=1e-12)
    np.testing.assert_allclose(dq, 0.0, atol=1e-12)
    np.testing.assert_allclose(ddq, 0.0, atol=1e-12)
    # Each segment ends, at rest, on the next waypoint.
    ends = s + PATH.durations - 1e-12
    q_end, dq_end, _ = joint_path_state(PATH, ends)
    np.testing.assert_allclose(q_end, np.roll(W, -1, axis=0), atol=1e-9)
    np.testing.assert_allclose(dq_end, 0.0, atol=1e-9)


def test_continuous_across_cycle_wrap_and_task_end():
    for s in (PATH.cycle_time, 2 * PATH.cycle_time, PATH.end):
        q, dq, ddq = joint_path_state(PATH, [s - 1e-9, s, min(s + 1e-9, PATH.end)])
        np.testing.assert_allclose(q, np.broadcast_to(W[0], (3, 6)), atol=1e-9)
        np.testing.assert_allclose(dq, 0.0, atol=1e-6)
    # Every cycle repeats the first.
    s = np.linspace(0.0, PATH.cycle_time, 777, endpoint=False)
    q0 = joint_path_state(PATH, s)[0]
    for c in (1, 2):
        np.testing.assert_allclose(joint_path_state(PATH, s + c * PATH.cycle_time)[0], q0,
                                   atol=1e-12)


def test_continuous_everywhere_on_a_dense_grid():
    s = np.linspace(0.0, PATH.end, 200_001)
    q, dq, ddq = joint_path_state(PATH, s)
    h = s[1] - s[0]
    # Lipschitz bounds: no jumps in q or dq anywhere (segment joins included).
    assert np.max(np.abs(np.diff(q, axis=0))) <= PATH.peak_joint_speed * h * (1 + 1e-9)
    assert np.max(np.abs(np.diff(dq, axis=0))) <= np.max(np.abs(ddq)) * h * (1 + 1e-6)


@FIXED
@given(s=st.floats(1e-4, 18.6 - 1e-4) | st.sampled_from([0.8, 6.2, 10.7]))
def test_derivatives_match_finite_differences(s):
    h = 1e-6  # central differences; at joins the jerk jumps, so the error there is O(h)
    q, dq, ddq = joint_path_state(PATH, np.array([s - h, s, s + h]))
    np.testing.assert_allclose(dq[1], (q[2] - q[0]) / (2 * h), atol=1e-6)
    np.testing.assert_allclose(ddq[1], (dq[2] - dq[0]) / (2 * h), atol=1e-4)


def test_peak_joint_speed_at_nominal_rate():
    s = np.linspace(0.0, PATH.cycle_time, 124_001)
    dq = joint_path_state(PATH, s)[1]
    assert np.max(np.abs(dq)) == pytest.approx(PATH.peak_joint_speed, rel=1e-6)
    # By hand: the fastest segments move a joint 80 deg in 0.8 s, 1.875 x 100 deg/s.
    assert PATH.peak_joint_speed == pytest.approx(math.radians(1.875 * 80 / 1.5), rel=1e-12)
    assert math.degrees(PATH.peak_joint_speed) <= 180.0
    # Peak of each segment at its midpoint, 1.875 delta / duration.
    mid = joint_path_state(PATH, PATH.starts + PATH.durations / 2)[1]
    np.testing.assert_allclose(mid, 1.875 * PATH.deltas / PATH.durations[:, None], rtol=1e-12)


def test_too_short_duration_names_segment():
    w = np.zeros((3, 6))
    w[1, 1] = 1.0  # segments 0 and 1 move joint 1 by 1 rad, segment 2 stays
    shortest = 1.875 / JOINT_VELOCITY_LIMIT
    make_joint_path(w, [shortest, shortest, 0.01])  # exactly at the limit: allowed
    with pytest.raises(ValueError, match=r"segment_durations\[1\]=0\.5.*180 deg/s.*0\.5968"):
        make_joint_path(w, [1.0, 0.5, 0.01])
    with pytest.raises(ValueError, match=r"segment_durations\[0\]"):
        make_joint_path(w, [shortest * 0.99, 1.0, 1.0])
    with pytest.raises(ValueError, match=r"segment_durations\[1\].*90 deg/s"):
        make_joint_path(w, [2.0, 1.0, 1.0], joint_speed_limit=math.pi / 2)
    # The default path at twice the speed breaks the UR5e's 180 deg/s.
    with pytest.raises(ValueError, match=r"segment_durations\[2\]"):
        make_joint_path(W, np.array(DEFAULT_DURATIONS) / 2)


@pytest.mark.parametrize("waypoints, durations, kwargs, match", [
    (np.zeros((1, 6)), [1.0], {}, "waypoints has shape"),
    (np.zeros((3, 5)), [1.0] * 3, {}, "waypoints has shape"),
    (np.zeros(6), [1.0], {}, "waypoints has shape"),
    (np.full((2, 6), np.nan), [1.0, 1.0], {}, "waypoints"),
    (np.zeros((2, 6)), [1.0], {}, "durations"),
    (np.zeros((2, 6)), [1.0, 0.0], {}, "durations"),
    (np.zeros((2, 6)), [1.0, -1.0], {}, "durations"),
    (np.zeros((2, 6)), [1.0, np.inf], {}, "durations"),
    (np.zeros((2, 6)), [1.0, 1.0], dict(cycles=0), "cycles=0"),
    (np.zeros((2, 6)), [1.0, 1.0], dict(cycles=2.0), "cycles=2.0"),
])
def test_bad_input_rejected(waypoints, durations, kwargs, match):
    with pytest.raises(ValueError, match=match):
        make_joint_path(waypoints, durations, **kwargs)


def test_s_clipped_to_task():
    q, dq, ddq = joint_path_state(PATH, [-5.0, -1e-9, PATH.end + 1e-9, 1e6])
    np.testing.assert_allclose(q, np.broadcast_to(W[0], (4, 6)), atol=1e-12)
    np.testing.assert_array_equal(dq, 0.0)
    np.testing.assert_array_equal(ddq, 0.0)
    # Beyond the end of a one-cycle task too (no wrap into a second cycle).
    one = default_joint_path(cycles=1)
    late = joint_path_state(one, one.cycle_time + 0.5 * DEFAULT_DURATIONS[0])
    np.testing.assert_allclose(late[0], W[0], atol=1e-12)
    np.testing.assert_array_equal(late[1], 0.0)


def test_vectorised_equals_scalar():
    # A float s (the PathFollower's tick) gives what the same s in an array gives, to the bit.
    rng = np.random.default_rng(3)
    s = rng.uniform(-1.0, PATH.end + 1.0, (40, 5))
    s[0] = [0.0, PATH.end, PATH.cycle_time, PATH.starts[1], np.nextafter(PATH.starts[2], 0.0)]
    q, dq, ddq = joint_path_state(PATH, s)
    assert q.shape == dq.shape == ddq.shape == (40, 5, 6)
    for idx in np.ndindex(40, 5):
        one = joint_path_state(PATH, float(s[idx]))
        assert one[0].shape == (6,)
        for got, want in zip(one, (q[idx], dq[idx], ddq[idx])):
            np.testing.assert_array_equal(got, want)
