import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from safety_systems.cell.operator_paths import ScriptedOperator, make_operator_path
from safety_systems.sensing.sensor_faults import UNKNOWN_ID_BASE, fault_table
from safety_systems.systems.mocap_sensor import MocapSensor
from safety_systems.systems.operator_motion import OperatorMotion

# Departs at t = 0 with a huge acceleration limit: x(t) = t (to 1e-9 m) for 0 <= t <= 1000 s,
# so a noise-free measured x tells the capture time.
RAMP = make_operator_path([-1.0, 0.0], [[0, 0, 0], [1000, 0, 0]], 1.0, 1e9)
STILL = make_operator_path([0.0], [[0.5, -1.0, 0.0]], 1.0, 1.0)
OUTPUTS = ("positions_measured", "valid", "sample_time")


def _reader(operators, **sensor_args):
    """Simulates OperatorMotion -> MocapSensor; returns read(t) -> (outputs, truth at t)."""
    builder = DiagramBuilder()
    motion = builder.AddSystem(OperatorMotion(operators=operators))
    sensor = builder.AddSystem(MocapSensor(num_bodies=motion.num_bodies, **sensor_args))
    for port in ("positions_true", "present"):
        builder.Connect(motion.GetOutputPort(port), sensor.GetInputPort(port))
    simulator = Simulator(builder.Build())
    simulator.Initialize()
    sensor_context = sensor.GetMyContextFromRoot(simulator.get_context())
    motion_context = motion.GetMyContextFromRoot(simulator.get_context())

    def read(t):
        simulator.AdvanceTo(t)
        got = [sensor.GetOutputPort(n).Eval(sensor_context).copy() for n in OUTPUTS]
        return got, motion.GetOutputPort("positions_true").Eval(motion_context).copy()

    return read


def _expected_capture(t, period, latency, drops=()):
    """Capture time of the newest frame delivered at t, or None."""
    k = math.floor((t - latency) / period + 1e-9)
    while k >= 0 and any(a <= k * period < b for a, b in drops):
        k -= 1
    return k * period if k >= 0 else None


def _probe_times(end, step=0.0131, start=0.0037):
    return np.arange(start, end, step)  # never on a capture or delivery instant


@pytest.mark.parametrize("period, latency, slots", [
    (0.05, 0.0, 1), (0.05, 0.05, 2), (0.05, 0.07, 3), (0.05, 0.1, 3), (0.01, 0.025, 4),
])
def test_frames_delivered_latency_after_capture(period, latency, slots):
    assert MocapSensor(num_bodies=1, period_sec=period, latency_sec=latency).num_slots == slots
    read = _reader([ScriptedOperator(path=RAMP, body_offsets=[[0, 0, 1]])],
                   period_sec=period, latency_sec=latency, noise_std=0.0)
    for t in _probe_times(1.0):
        (p, valid, sample_time), _ = read(t)
        c = _expected_capture(t, period, latency)
        if c is None:  # before the first delivery
            assert sample_time[0] == -math.inf
            assert valid[0] == 0.0 and np.all(np.isnan(p))
        else:
            assert sample_time[0] == pytest.approx(c, abs=1e-12), f"t={t}"
            assert valid[0] == 1.0
            np.testing.assert_allclose(p, [c, 0, 1], atol=1e-8, err_msg=f"t={t}")


def test_default_rate_is_20_hz():
    read = _reader([ScriptedOperator(path=RAMP, body_offsets=[[0, 0, 0]])], noise_std=0.0)
    stamps = {read(t)[0][2][0] for t in np.arange(0.005, 1.0, 0.01)}
    np.testing.assert_allclose(sorted(stamps), 0.05 * np.arange(20), atol=1e-12)


def test_all_invalid_before_first_delivery():
    sensor = MocapSensor(num_bodies=2, latency_sec=0.12)
    context = sensor.CreateDefaultContext()  # Drake pattern: fixed inputs, no simulation
    sensor.GetInputPort("positions_true").FixValue(context, np.arange(6.0))
    sensor.GetInputPort("present").FixValue(context, [1.0, 1.0])
    context.SetTime(0.3)
    assert sensor.GetOutputPort("sample_time").Eval(context)[0] == -math.inf
    np.testing.assert_array_equal(sensor.GetOutputPort("valid").Eval(context), [0, 0])
    assert np.all(np.isnan(sensor.GetOutputPort("positions_measured").Eval(context)))
    # The same in a simulation until capture 0 is delivered at 0.12 s.
    read = _reader([ScriptedOperator(path=STILL, body_offsets=[[0, 0, 0]])], latency_sec=0.12)
    assert read(0.119)[0][2][0] == -math.inf
    assert read(0.121)[0][2][0] == 0.0


def test_noise_std_matches_configuration():
    std = 0.004
    op = ScriptedOperator(path=STILL, body_offsets=[[0, 0, 1.0], [0.2, 0, 1.0], [0, 0, 1.7]])
    read = _reader([op], noise_std=std, seed=11)
    errors = []
    for k in range(300):
        (p, valid, _), truth = read(0.05 * k + 0.025)
        assert np.all(valid == 1.0)
        errors.append(p - truth)
    errors = np.array(errors)  # (300 frames, 9)
    n = errors.size
    assert np.std(errors) == pytest.approx(std, rel=0.08)  # ~6 sigma of the sample std
    assert abs(np.mean(errors)) < 5 * std / math.sqrt(n)
    for axis in range(3):  # isotropic
        assert np.std(errors[:, axis::3]) == pytest.approx(std, rel=0.15)
    # Fresh noise each frame, barely correlated from one frame to the next.
    assert not np.any(np.all(errors[1:] == errors[:-1], axis=1))
    assert abs(np.corrcoef(errors[1:].ravel(), errors[:-1].ravel())[0, 1]) < 0.1


def _frames(seed, frames=20):
    op = ScriptedOperator(path=RAMP, body_offsets=[[0, 0, 1.0], [0, 0.3, 1.0]])
    read = _reader([op], noise_std=0.01, seed=seed, latency_sec=0.03)
    return np.array([read(0.05 * k + 0.04)[0][0] for k in range(frames)])


def test_same_seed_gives_identical_frames():
    a, b, c = _frames(7), _frames(7), _frames(8)
    np.testing.assert_array_equal(a, b)
    assert np.all(np.isfinite(a))
    assert not np.any(a == c)


def test_occluded_and_absent_bodies_invalid_with_nan():
    walker = ScriptedOperator(path=RAMP, body_offsets=[[0, 0.2, 1], [0, -0.2, 1]])
    visitor = ScriptedOperator(path=STILL, body_offsets=[[0, 0, 1.7]],
                               enter_time=0.27, leave_time=0.58)
    # Body 1 occluded on [0.2, 0.4) (both ends exactly on captures), body 0 on [0.62, 0.71).
    read = _reader([walker, visitor], noise_std=0.0,
                   occlusions=[(1, 0.2, 0.4), (0, 0.62, 0.71)])
    expected = {  # capture time: valid
        0.1: [1, 1, 0], 0.15: [1, 1, 0], 0.2: [1, 0, 0], 0.25: [1, 0, 0], 0.3: [1, 0, 1],
        0.35: [1, 0, 1], 0.4: [1, 1, 1], 0.55: [1, 1, 1], 0.6: [1, 1, 0], 0.65: [0, 1, 0],
        0.7: [0, 1, 0], 0.75: [1, 1, 0],
    }
    for capture, want in expected.items():
        (p, valid, sample_time), truth = read(capture + 0.01)
        assert sample_time[0] == pytest.approx(capture)
        np.testing.assert_array_equal(valid, want, err_msg=f"capture {capture}")
        p, truth = p.reshape(3, 3), truth.reshape(3, 3)
        mask = np.asarray(want, bool)
        assert np.all(np.isnan(p[~mask]))
        # Truth moved by 0.01 m along x since the capture (ramp at 1 m/s, not the visitor).
        np.testing.assert_allclose(p[mask], truth[mask] - [[0.01 * (i < 2), 0, 0]
                                                          for i in np.flatnonzero(mask)],
                                   atol=1e-8)


def test_dropped_frames_leave_sample_time_stale():
    period, latency, drops = 0.05, 0.1, [(0.2, 0.4), (0.63, 0.66)]
    op = ScriptedOperator(path=RAMP, body_offsets=[[0, 0, 0]])
    read = _reader([op], noise_std=0.0, latency_sec=latency, dropped_frames=drops)
    # By hand: frames 0.2 ... 0.35 are lost, so frame 0.15 is still shown at 0.49 s,
    # and frame 0.4 (drop intervals are half-open) arrives at 0.5 s.
    assert read(0.49)[0][2][0] == pytest.approx(0.15)
    assert read(0.51)[0][2][0] == pytest.approx(0.4)
    read = _reader([op], noise_std=0.0, latency_sec=latency, dropped_frames=drops)
    stale = 0
    for t in _probe_times(1.2):
        (p, valid, sample_time), _ = read(t)
        c = _expected_capture(t, period, latency, drops)
        if c is None:
            assert sample_time[0] == -math.inf
            continue
        assert sample_time[0] == pytest.approx(c, abs=1e-12), f"t={t}"
        np.testing.assert_allclose(p, [c, 0, 0], atol=1e-8)
        assert valid[0] == 1.0  # a stale frame stays valid; its age tells the tracker
        stale += t - c > latency + period
    assert stale >= 10  # the drops really were exercised


def test_frame_numbers_ids_and_injected_faults():
    walker = ScriptedOperator(path=RAMP, body_offsets=[[0, 0.2, 1], [0, -0.2, 1], [0, 0, 1.6]])
    faults = fault_table([
        ("outlier", 0, -1, 0.2, 0.3, (0.0, 1.0, 0.0)),
        ("swap", 1, 2, 0.3, 0.4, (0, 0, 0)),
        ("non_finite", 2, -1, 0.4, 0.45, (0, 0, 0)),
        ("unknown_id", 0, -1, 0.45, 0.5, (0, 0, 0)),
        ("time_duplicate", -1, -1, 0.5, 0.55, (0, 0, 0)),
        ("time_backwards", -1, -1, 0.55, 0.6, (0, 0, 0)),
    ])
    read = _reader([walker], noise_std=0.0, faults=faults)

    def frame(capture):
        (p, valid, sample_time), truth = read(capture + 0.01)
        return p.reshape(3, 3), valid, sample_time[0], truth.reshape(3, 3) - [0.01, 0, 0]

    clean = frame(0.15)
    np.testing.assert_allclose(clean[0], clean[3], atol=1e-8)
    p, valid, t, truth = frame(0.2)  # outlier: body 0 displaced 1 m along y
    np.testing.assert_allclose(p, truth + [[0, 1, 0], [0, 0, 0], [0, 0, 0]], atol=1e-8)
    p, valid, t, truth = frame(0.4)  # non-finite, still flagged seen
    assert np.isnan(p[2, 0]) and valid[2] == 1.0 and t == pytest.approx(0.4)
    assert frame(0.5)[2] == pytest.approx(0.45)  # the previous capture's time
    assert frame(0.55)[2] == pytest.approx(0.45)  # the capture before the previous one
    assert frame(0.6)[2] == pytest.approx(0.6)


def test_frame_number_and_body_ids_outputs():
    faults = fault_table([("swap", 1, 2, 0.3, 0.4, (0, 0, 0)),
                          ("unknown_id", 0, -1, 0.45, 0.5, (0, 0, 0))])
    sensor = MocapSensor(num_bodies=3, noise_std=0.0, latency_sec=0.05, faults=faults)
    context = sensor.CreateDefaultContext()
    sensor.GetInputPort("positions_true").FixValue(context, np.arange(9.0))
    sensor.GetInputPort("present").FixValue(context, np.ones(3))
    simulator = Simulator(sensor, context)
    assert sensor.GetOutputPort("frame_number").Eval(context)[0] == -1.0
    for capture, ids in ((0.25, [1, 2, 3]), (0.3, [1, 3, 2]), (0.45, [UNKNOWN_ID_BASE, 2, 3])):
        simulator.AdvanceTo(capture + 0.05 + 0.001)  # delivered one latency later
        assert sensor.GetOutputPort("frame_number").Eval(context)[0] == round(capture / 0.05)
        np.testing.assert_array_equal(sensor.GetOutputPort("body_ids").Eval(context), ids)


@pytest.mark.parametrize("kwargs, match", [
    (dict(faults=np.zeros((1, 5))), "faults"),
    (dict(faults=fault_table([("swap", 0, 3, 0.0, 1.0, (0, 0, 0))])), "faults"),
    (dict(num_bodies=0), "num_bodies=0"),
    # 50 slots: five operators of ten bodies, one per body point (it was 15, three
    # bodies each, before the operator became a whole body)
    (dict(num_bodies=51), "num_bodies=51"),
    (dict(num_bodies=2.0), "num_bodies"),
    (dict(period_sec=0.0005), "period_sec=0.0005"),
    (dict(period_sec=0.06), "period_sec"),
    (dict(period_sec=float("nan")), "period_sec"),
    (dict(noise_std=-0.001), "noise_std"),
    (dict(noise_std=float("inf")), "noise_std"),
    (dict(latency_sec=-0.01), "latency_sec"),
    (dict(latency_sec=float("nan")), "latency_sec"),
    (dict(seed=-1), "seed"),
    (dict(seed=1.5), "seed"),
    (dict(occlusions=[(3, 0.0, 1.0)]), "body_index must be in 0..2"),
    (dict(occlusions=[(-1, 0.0, 1.0)]), "occlusions"),
    (dict(occlusions=[(0.5, 0.0, 1.0)]), "occlusions"),
    (dict(occlusions=[(0, 2.0, 1.0)]), "t_start <= t_end"),
    (dict(dropped_frames=[(1.0, 0.5)]), "dropped_frames"),
    (dict(dropped_frames=[(float("nan"), 0.5)]), "dropped_frames"),
])
def test_bad_arguments_rejected(kwargs, match):
    args = dict(num_bodies=3) | kwargs
    with pytest.raises(ValueError, match=match):
        MocapSensor(**args)


def test_boundary_arguments_accepted():
    for period in (0.001, 0.05):
        MocapSensor(num_bodies=50, period_sec=period, noise_std=0.0,
                    latency_sec=0.0, occlusions=[(49, 1.0, 1.0)],
                    dropped_frames=[(0.0, math.inf)], seed=0)
