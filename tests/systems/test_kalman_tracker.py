"""The KalmanTracker system: a thin wrapper over safety_systems.sensing.tracks, in the loop."""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from safety_systems.sensing import stops
from safety_systems.cell.operator_paths import ScriptedOperator, make_operator_path
from safety_systems.systems.kalman_tracker import KalmanTracker
from safety_systems.systems.mocap_sensor import MocapSensor
from safety_systems.systems.operator_motion import OperatorMotion
from safety_systems.sensing.tracks import (
    TRACK_HIDDEN,
    TRACK_NONE,
    TRACK_SLOT,
    TRACK_TRACKING,
    estimates,
    frame_update,
    make_rules,
)

KW = dict(measurement_std=0.0002, velocity_process_noise=4.0, initial_velocity_std=2.0,
          period=0.05)
NAN3 = [np.nan] * 3
# x(t) = t along the x axis (see tests/systems/test_mocap_sensor.py).
RAMP = make_operator_path([-1.0, 0.0], [[0, 0, 0], [1000, 0, 0]], 1.0, 1e9)
SENSOR_PORTS = ("positions_measured", "valid", "sample_time", "frame_number", "body_ids")


def _tracker(n=1, latency=0.0):
    return KalmanTracker(num_bodies=n, period_sec=0.05, latency_sec=latency,
                         processing_time=0.001, frame_timeout=0.076 + latency,
                         rules=make_rules(**KW))


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
    for name in SENSOR_PORTS:
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
    assert fault[0] == stops.STOP_STALE_FRAME
    assert np.all(np.isnan(p)) and np.all(np.isnan(v)) and np.all(status == TRACK_NONE)
    for t in np.arange(0.022, 1.0459, 0.0071):  # fresh frames up to 0.95 + 0.096 s
        assert read(t)[5][0] == 0.0, f"t={t}"
    for t in np.arange(1.047, 1.520, 0.0071):  # capture 1.5 processed at 1.521
        assert read(t)[5][0] == stops.STOP_STALE_FRAME, f"t={t}"
    for t in np.arange(1.522, 2.0, 0.0071):
        assert read(t)[5][0] == 0.0, f"t={t}"


def test_frames_by_number_faults_by_cause_and_the_wrapper_is_the_function():
    tracker = _tracker(2)
    simulator = Simulator(tracker)
    context = simulator.get_mutable_context()
    ports = [tracker.GetInputPort(n) for n in SENSOR_PORTS]
    names = ("positions_estimated", "track_status", "fault", "rejected_frames")

    def frame(number, t, z, valid, until, ids=(1, 2)):
        for port, value in zip(ports, (np.ravel(z), valid, [t], [number], ids)):
            port.FixValue(context, np.asarray(value, float))
        simulator.AdvanceTo(until)
        return [tracker.GetOutputPort(n).Eval(context).copy() for n in names]

    assert frame(-1, -np.inf, [NAN3] * 2, [0, 0], 0.0005)[2][0] == stops.STOP_STALE_FRAME
    rules, tracks, t_good = make_rules(**KW), np.zeros((2, TRACK_SLOT)), -np.inf
    good = [[1, 0, 1], NAN3]
    p, status, fault, counts = frame(0, 0.0, good, [1, 0], 0.01)
    assert fault[0] == 0.0 and list(status) == [TRACK_TRACKING, TRACK_NONE]
    np.testing.assert_array_equal(p[:3], [1, 0, 1])
    assert np.all(np.isnan(p[3:]))  # untracked slot
    tracks, _, _, t_good = frame_update(tracks, 0.0, np.array(good), [1, 0], rules=rules)
    # Body 1 flagged seen without a position: rejected, body 0 still used.
    p, status, fault, counts = frame(1, 0.05, [[1.05, 0, 1], [np.nan, 0, 1]], [1, 1], 0.06)
    assert fault[0] == stops.STOP_NON_FINITE and list(counts) == [1, 0, 0, 0]
    assert list(status) == [TRACK_TRACKING, TRACK_NONE]
    tracks, _, _, t_good = frame_update(tracks, 0.05, np.array([[1.05, 0, 1], NAN3]), [1, 1],
                                        rules=rules, t_good=t_good)
    np.testing.assert_allclose(p, estimates(tracks, t_good)[0].ravel())  # wrapper == function
    z = [[1.1, 0, 1], [0, 2, 1]]
    p, status, fault, _ = frame(2, 0.1, z, [1, 1], 0.11)  # a clean frame clears the fault
    assert fault[0] == 0.0 and list(status) == [TRACK_TRACKING, TRACK_TRACKING]
    tracks, _, _, t_good = frame_update(tracks, 0.1, np.array(z), [1, 1], rules=rules,
                                        t_good=t_good)
    np.testing.assert_allclose(p, estimates(tracks, t_good)[0].ravel())
    # The same frame number again: not a new frame (nothing processed, no fault yet).
    assert frame(2, 0.1, [[9, 9, 9]] * 2, [1, 1], 0.16)[2][0] == 0.0
    np.testing.assert_allclose(frame(2, 0.1, z, [1, 1], 0.165)[0],
                               estimates(tracks, t_good)[0].ravel())
    # A new frame whose time repeats or goes back, or is unknown: a bad frame.
    for number, t, until in ((3, 0.1, 0.21), (4, 0.08, 0.26), (5, np.nan, 0.31)):
        assert frame(number, t, z, [1, 1], until)[2][0] == stops.STOP_BAD_TIME
    # An unknown id, then a swap the gate catches; then clean again.
    p, status, fault, counts = frame(6, 0.35, z, [1, 1], 0.36, ids=(1, 7))
    assert fault[0] == stops.STOP_UNKNOWN_ID and list(status) == [TRACK_TRACKING, TRACK_HIDDEN]
    p, status, fault, counts = frame(7, 0.40, z, [1, 1], 0.41, ids=(2, 1))
    assert fault[0] == stops.STOP_GATE and list(counts) == [1, 3, 1, 2]
    assert frame(8, 0.45, z, [1, 1], 0.46)[2][0] == 0.0


@pytest.mark.parametrize("name, value", [
    ("period_sec", 0.0), ("processing_time", 0.0), ("frame_timeout", -1.0),
    ("latency_sec", -0.01), ("frame_timeout", math.inf),
])
def test_bad_arguments_rejected(name, value):
    args = dict(num_bodies=1, period_sec=0.05, latency_sec=0.0, processing_time=0.001,
                frame_timeout=0.076, rules=make_rules(**KW)) | {name: value}
    with pytest.raises(ValueError, match=name):
        KalmanTracker(**args)
