import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from safety_systems.kalman import initial_covariance, predict, process_noise, transition_matrix
from safety_systems.kalman import update as kf_update
from safety_systems.operator_paths import ScriptedOperator, make_operator_path
from safety_systems.systems.kalman_tracker import _P, TRACK_SLOT, _STATUS, _T_LAST, _T_SEEN, _X
from safety_systems.systems.kalman_tracker import KalmanTracker, track_estimates, track_step
from safety_systems.systems.mocap_sensor import MocapSensor
from safety_systems.systems.operator_motion import OperatorMotion
from safety_systems.systems.separation_monitor import (
    TRACK_COASTING,
    TRACK_LOST,
    TRACK_NONE,
    TRACK_TRACKING,
)

FIXED = settings(derandomize=True, deadline=None, max_examples=30)
KW = dict(measurement_std=0.01, velocity_process_noise=4.0, initial_velocity_std=2.0,
          max_coast_time=0.5, exit_radius=2.5)
NAN3 = [np.nan] * 3
# x(t) = t along the x axis (see tests/systems/test_mocap_sensor.py).
RAMP = make_operator_path([-1.0, 0.0], [[0, 0, 0], [1000, 0, 0]], 1.0, 1e9)


def _step(tracks, t, z, valid, **kw):
    return track_step(tracks, t, np.array(z, float), np.array(valid, bool), **(KW | kw))


def test_first_valid_frame_starts_tracks_at_rest():
    tracks = np.zeros((3, TRACK_SLOT))
    out = _step(tracks, 0.2, [[1, 0, 1], NAN3, [2, 2, 1]], [1, 0, 1])
    assert not np.any(tracks)  # input untouched
    np.testing.assert_array_equal(out[:, _STATUS], [TRACK_TRACKING, TRACK_NONE, TRACK_TRACKING])
    np.testing.assert_array_equal(out[0, _X], [1, 0, 1, 0, 0, 0])
    np.testing.assert_array_equal(out[2, _X], [2, 2, 1, 0, 0, 0])
    np.testing.assert_allclose(out[0, _P].reshape(6, 6), initial_covariance(0.01, 2.0))
    np.testing.assert_array_equal(out[[0, 2]][:, [_T_LAST, _T_SEEN]], 0.2)
    assert not np.any(out[1])


@FIXED
@given(seed=st.integers(0, 2**32 - 1))
def test_agrees_with_reference_filter_for_one_body(seed):
    rng = np.random.default_rng(seed)
    times = np.cumsum(rng.uniform(0.01, 0.1, 30))
    seen = rng.uniform(size=30) < 0.7
    seen[0] = True
    z = rng.normal(size=(30, 3)) + times[:, None] * [1.0, -0.5, 0.0]
    tracks = np.zeros((1, TRACK_SLOT))
    x = P = None
    for t, zk, ok in zip(times, z, seen):
        tracks = _step(tracks, t, [zk], [ok], max_coast_time=10.0)
        if x is None:
            x, P, last = np.r_[zk, 0, 0, 0], initial_covariance(0.01, 2.0), t
        else:
            x, P = predict(x, P, transition_matrix(t - last), process_noise(t - last, 4.0))
            x, P = kf_update(x, P, zk if ok else None, np.eye(3) * 1e-4)
            last = t
        np.testing.assert_allclose(tracks[0, _X], x, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(tracks[0, _P].reshape(6, 6), P, rtol=1e-9, atol=1e-12)
        assert tracks[0, _STATUS] == (TRACK_TRACKING if ok else TRACK_COASTING)


def test_update_moves_towards_measurement():
    tracks = _step(np.zeros((1, TRACK_SLOT)), 0.0, [[0, 0, 1]], [1])
    out = _step(tracks, 0.05, [[0.1, 0, 1]], [1])
    assert 0.0 < out[0, 0] < 0.1 and out[0, 3] > 0.0  # towards z, moving +x
    np.testing.assert_allclose(out[0, [1, 2, 4, 5]], [0, 1, 0, 0], atol=1e-12)
    assert out[0, _T_SEEN] == out[0, _T_LAST] == 0.05
    assert out[0, _P][0] < 0.01**2  # surer of the position than the measurement alone


@pytest.mark.parametrize("z, valid", [([NAN3], [0]), ([[5, 5, 5]], [0]), ([NAN3], [1])])
def test_coasts_when_not_seen(z, valid):
    tracks = _step(np.zeros((1, TRACK_SLOT)), 0.0, [[0, 0, 1]], [1])
    tracks[0, 3:6] = [1.0, 0.0, 0.0]  # moving at 1 m/s along x
    out = _step(tracks, 0.1, z, valid)
    assert out[0, _STATUS] == TRACK_COASTING
    x, P = predict(tracks[0, _X], tracks[0, _P].reshape(6, 6), transition_matrix(0.1),
                   process_noise(0.1, 4.0))
    np.testing.assert_allclose(out[0, _X], x)
    np.testing.assert_allclose(out[0, _P].reshape(6, 6), P)
    assert out[0, _T_LAST] == 0.1 and out[0, _T_SEEN] == 0.0


def test_unseen_time_and_per_row_frame_times():
    tracks = _step(np.zeros((2, TRACK_SLOT)), 0.0, [[1, 0, 1], [0, 1, 1]], [1, 1])
    tracks = _step(tracks, np.array([0.05, 0.05]), [[1, 0, 1], NAN3], [1, 0])
    tracks = _step(tracks, np.array([0.10, 0.15]), [[1, 0, 1], NAN3], [1, 0])
    x, status, std, unseen = track_estimates(tracks)
    np.testing.assert_array_equal(status, [TRACK_TRACKING, TRACK_COASTING])
    np.testing.assert_allclose(unseen, [0.0, 0.15])  # body 1 last measured at t = 0
    np.testing.assert_allclose(tracks[:, _T_LAST], [0.10, 0.15])
    assert np.all(std > 0.0) and not np.any(np.isnan(x))
    assert track_estimates(np.zeros((1, TRACK_SLOT)))[3][0] == 0.0  # untracked


def test_expiry_none_outside_exit_radius_lost_inside():
    # Bodies at 3 m (outside 2.5 m), 1 m (inside) and at 2.4 m walking out at 1 m/s.
    tracks = _step(np.zeros((3, TRACK_SLOT)), 0.0, [[3, 0, 1], [0, 1, 1], [2.4, 0, 1]], [1, 1, 1])
    tracks[2, 3] = 1.0
    unseen = [NAN3] * 3
    at_limit = _step(tracks, 0.5, unseen, [0, 0, 0])  # not seen for exactly max_coast_time
    np.testing.assert_array_equal(at_limit[:, _STATUS], TRACK_COASTING)
    out = _step(at_limit, 0.55, unseen, [0, 0, 0])
    np.testing.assert_array_equal(out[:, _STATUS], [TRACK_NONE, TRACK_LOST, TRACK_NONE])
    assert out[2, 0] == pytest.approx(2.95)  # judged on its last estimate, now outside
    later = _step(out, 2.0, unseen, [0, 0, 0])  # ended and lost tracks stay as they are
    np.testing.assert_array_equal(later, out)
    # A larger exit radius keeps the walking body lost rather than gone.
    assert _step(at_limit, 0.55, unseen, [0, 0, 0], exit_radius=3.5)[2, _STATUS] == TRACK_LOST


@pytest.mark.parametrize("lost_status", [TRACK_LOST, TRACK_NONE])
def test_track_restarts_when_seen_again(lost_status):
    tracks = _step(np.zeros((1, TRACK_SLOT)), 0.0, [[0, 1, 1]], [1])
    tracks[0, 3:6] = [0.3, 0.2, 0.1]
    # Expires at 1 s with its estimate 1.24 m from the base: lost, or gone if beyond.
    tracks = _step(tracks, 1.0, [NAN3], [0], exit_radius=1.2 if lost_status == 0 else 1.3)
    assert tracks[0, _STATUS] == lost_status
    out = _step(tracks, 1.2, [[1, 1, 1]], [1])
    assert out[0, _STATUS] == TRACK_TRACKING
    np.testing.assert_array_equal(out[0, _X], [1, 1, 1, 0, 0, 0])
    np.testing.assert_allclose(out[0, _P].reshape(6, 6), initial_covariance(0.01, 2.0))
    assert out[0, _T_LAST] == out[0, _T_SEEN] == 1.2


def _tracker(n=1, latency=0.0):
    return KalmanTracker(num_bodies=n, period_sec=0.05, latency_sec=latency,
                         processing_time=0.001, frame_timeout=0.076 + latency,
                         **(KW | dict(measurement_std=0.0002)))


def _cell(drops=()):
    """OperatorMotion -> MocapSensor -> KalmanTracker as MakeWorkcell wires them."""
    builder = DiagramBuilder()
    motion = builder.AddSystem(OperatorMotion(operators=[
        ScriptedOperator(path=RAMP, body_offsets=[[0, 0.5, 1], [0, -0.5, 1]])]))
    sensor = builder.AddSystem(MocapSensor(
        num_bodies=2, period_sec=0.05, noise_std=0.0002, latency_sec=0.02, seed=3,
        occlusions=[(1, 0.0, 100.0)], dropped_frames=drops))
    tracker = builder.AddSystem(_tracker(2, latency=0.02))
    for name in ("positions_true", "present"):
        builder.Connect(motion.GetOutputPort(name), sensor.GetInputPort(name))
    for name in ("positions_measured", "valid", "sample_time"):
        builder.Connect(sensor.GetOutputPort(name), tracker.GetInputPort(name))
    simulator = Simulator(builder.Build())
    simulator.Initialize()
    context = tracker.GetMyContextFromRoot(simulator.get_context())
    names = ("positions_estimated", "velocities_estimated", "track_status", "position_std",
             "unseen_time", "fault")

    def read(t):
        simulator.AdvanceTo(t)
        return [tracker.GetOutputPort(n).Eval(context).copy() for n in names]

    return read


def test_estimates_constant_velocity_body_in_cell():
    read = _cell()
    for t in np.arange(0.5, 2.0, 0.0173):
        p, v, status, std, _, fault = read(t)
        capture = math.floor((t - 0.021) / 0.05 + 1e-9) * 0.05  # estimate at capture time
        np.testing.assert_allclose(p[:3], [capture, 0.5, 1.0], atol=2e-3, err_msg=f"t={t}")
        np.testing.assert_allclose(v[:3], [1.0, 0.0, 0.0], atol=0.03, err_msg=f"t={t}")
        # Body 1 is never seen: untracked, NaN estimates.
        assert np.all(np.isnan(p[3:])) and np.all(np.isnan(v[3:]))
        np.testing.assert_array_equal(status, [TRACK_TRACKING, TRACK_NONE])
        assert 0.0 < std[0] < 0.001 and fault[0] == 0.0


def test_fault_before_first_frame_and_when_frames_stop():
    read = _cell(drops=[(1.0, 1.5)])
    p, v, status, _, _, fault = read(0.0205)  # frame 0 delivered at 0.02, processed at 0.021
    assert fault[0] == 1.0
    assert np.all(np.isnan(p)) and np.all(np.isnan(v)) and np.all(status == TRACK_NONE)
    for t in np.arange(0.022, 1.0459, 0.0071):  # fresh frames up to 0.95 + 0.096 s
        assert read(t)[5][0] == 0.0, f"t={t}"
    for t in np.arange(1.047, 1.520, 0.0071):  # capture 1.5 processed at 1.521
        assert read(t)[5][0] == 1.0, f"t={t}"
    for t in np.arange(1.522, 2.0, 0.0071):
        assert read(t)[5][0] == 0.0, f"t={t}"


def test_bad_frames_raise_fault_and_are_not_used():
    tracker = _tracker(2)
    simulator = Simulator(tracker)
    context = simulator.get_mutable_context()
    ports = [tracker.GetInputPort(n) for n in ("positions_measured", "valid", "sample_time")]

    def frame(t, z, valid, until):
        for port, value in zip(ports, (np.ravel(z), valid, [t])):
            port.FixValue(context, np.asarray(value, float))
        simulator.AdvanceTo(until)
        return [tracker.GetOutputPort(n).Eval(context).copy()
                for n in ("positions_estimated", "track_status", "fault")]

    assert frame(-np.inf, [NAN3] * 2, [0, 0], 0.0005)[2][0] == 1.0  # nothing yet
    good = [[1, 0, 1], NAN3]
    p, status, fault = frame(0.0, good, [1, 0], 0.01)
    assert fault[0] == 0.0 and list(status) == [TRACK_TRACKING, TRACK_NONE]
    np.testing.assert_array_equal(p[:3], [1, 0, 1])
    assert np.all(np.isnan(p[3:]))  # untracked slot
    expected = track_step(np.zeros((2, TRACK_SLOT)), 0.0, np.array(good, float),
                          np.array([1, 0], bool), **(KW | dict(measurement_std=0.0002)))
    # Slot 1 flagged valid without a position: a bad frame.
    p, status, fault = frame(0.05, [[1.05, 0, 1], [np.nan, 0, 1]], [1, 1], 0.06)
    assert fault[0] == 1.0
    np.testing.assert_array_equal(p[:3], [1, 0, 1])  # frame not used, no coasting
    assert list(status) == [TRACK_TRACKING, TRACK_NONE]
    z = [[1.1, 0, 1], [0, 2, 1]]
    p, status, fault = frame(0.1, z, [1, 1], 0.11)  # a good frame clears the fault
    assert fault[0] == 0.0 and list(status) == [TRACK_TRACKING, TRACK_TRACKING]
    expected = track_step(expected, 0.1, np.array(z, float), np.ones(2, bool),
                          **(KW | dict(measurement_std=0.0002)))
    np.testing.assert_allclose(p, expected[:, :3].ravel())  # wrapper == function
    assert frame(0.1, [[9, 9, 9]] * 2, [1, 1], 0.16)[2][0] == 0.0  # repeat: ignored
    np.testing.assert_allclose(frame(0.1, z, [1, 1], 0.165)[0], expected[:, :3].ravel())
    assert frame(0.08, z, [1, 1], 0.21)[2][0] == 1.0  # capture time going backwards
    assert frame(np.nan, z, [1, 1], 0.26)[2][0] == 1.0
    assert frame(0.3, z, [1, 1], 0.31)[2][0] == 0.0


@pytest.mark.parametrize("name, value", [
    ("period_sec", 0.0), ("processing_time", 0.0), ("frame_timeout", -1.0),
    ("velocity_process_noise", math.nan), ("initial_velocity_std", 0.0),
    ("max_coast_time", math.inf), ("exit_radius", -2.0), ("latency_sec", -0.01),
])
def test_bad_arguments_rejected(name, value):
    args = dict(num_bodies=1, period_sec=0.05, latency_sec=0.0, processing_time=0.001,
                frame_timeout=0.076, **KW) | {name: value}
    with pytest.raises(ValueError, match=name):
        KalmanTracker(**args)
