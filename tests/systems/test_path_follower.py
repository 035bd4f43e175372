import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from safety_systems.cell.braking import default_braking_table, stopping_time
from safety_systems.cell.joint_path import default_joint_path, joint_path_state, make_joint_path
from safety_systems.systems.path_follower import PathFollower

DT = 0.002
ACCEL = 2.0
TABLE = default_braking_table()
PATH = default_joint_path()
OUTPUTS = ("joint_positions_desired", "joint_velocities_desired", "joint_accelerations_desired")


def _follower(path=PATH, accel=ACCEL):
    return PathFollower(path=path, braking=TABLE, acceleration_limit=accel, period_sec=DT)


class _Run:
    """A PathFollower alone in a Simulator, its command fixed (changeable between ticks)."""

    def __init__(self, path=PATH, command=1.0):
        self.follower = _follower(path)
        self.simulator = Simulator(self.follower)
        self.context = self.simulator.get_mutable_context()
        self.command(command)
        self.simulator.Initialize()
        self.tick = 0

    def command(self, value):
        self.follower.GetInputPort("path_speed_commanded").FixValue(self.context, [value])

    def step(self, ticks=1):
        """Advances by whole ticks; at time k DT the updates at 0 ... (k-1) DT are done."""
        self.tick += ticks
        self.simulator.AdvanceTo(self.tick * DT)
        return self.state()

    def state(self):
        return self.follower.GetOutputPort("path_state").Eval(self.context).copy()

    def outputs(self):
        return [self.follower.GetOutputPort(n).Eval(self.context).copy() for n in OUTPUTS]


def _stop_ticks(run, limit=1000):
    """Ticks until the rate is 0 (rounding may leave ~1e-16 for one tick), and the s then."""
    ticks, moving, previous = 0, 0, run.state()[1]
    while run.state()[1] != 0.0:
        rate = run.step()[1]
        assert 0.0 <= rate < previous  # falls monotonically, never reverses
        previous, ticks, moving = rate, ticks + 1, moving + (rate > 1e-12)
        assert ticks < limit
    assert ticks <= moving + 2
    return moving + 1, run.state()[0]


def test_ramps_up_at_acceleration_limit_then_nominal_speed():
    builder = DiagramBuilder()
    follower = builder.AddSystem(_follower())
    source = builder.AddSystem(ConstantVectorSource([1.0]))
    builder.Connect(source.get_output_port(), follower.GetInputPort("path_speed_commanded"))
    simulator = Simulator(builder.Build())
    context = follower.GetMyContextFromRoot(simulator.get_context())
    simulator.Initialize()
    for k in range(1, 1001):
        simulator.AdvanceTo(k * DT)
        s, rate, finished = follower.GetOutputPort("path_state").Eval(context)
        t = k * DT
        assert rate == pytest.approx(min(ACCEL * t, 1.0), abs=1e-9), f"t={t}"
        ramp = 1.0 / ACCEL  # full speed after 0.5 s, having covered 0.25 s of path
        expected_s = ACCEL * t * t / 2 if t <= ramp else ramp / 2 + (t - ramp)
        assert s == pytest.approx(expected_s, abs=1e-9), f"t={t}"
        assert finished == 0.0
    assert rate == 1.0 and s == pytest.approx(1.75)


@pytest.mark.parametrize("stop_command", [0.0, float("nan")])
@pytest.mark.parametrize("cruise", [1.0, 0.66])
def test_stops_within_table_stopping_time(stop_command, cruise):
    run = _Run(command=cruise)
    run.step(500)
    s0, rate0, _ = run.state()
    assert rate0 == pytest.approx(cruise)
    run.command(stop_command)
    ticks, s_stop = _stop_ticks(run)
    assert abs(ticks * DT - float(stopping_time(TABLE, cruise))) <= DT + 1e-12
    # Constant deceleration: the path parameter covers sigma^2 T_1 / 2 while stopping.
    assert s_stop - s0 == pytest.approx(cruise * cruise * 0.53 / 2, abs=2 * DT)
    q = run.outputs()[0]
    run.step(100)  # at rest it stays put
    assert run.state()[0] == s_stop and run.state()[1] == 0.0
    np.testing.assert_array_equal(run.outputs()[0], q)
    np.testing.assert_array_equal(run.outputs()[1], 0.0)


def test_restarts_after_a_stop():
    run = _Run()
    run.step(300)
    run.command(0.0)
    _stop_ticks(run)
    run.command(0.5)
    rates = [run.step()[1] for _ in range(200)]
    assert rates[0] == pytest.approx(ACCEL * DT)
    assert rates[-1] == pytest.approx(0.5)


def test_outputs_are_path_reference_at_state():
    run = _Run()
    checked = 0
    for phase_ticks, command, rate_dot in ((100, 1.0, ACCEL), (400, 1.0, None),
                                           (200, 0.0, -1.0 / 0.53)):
        run.command(command)
        for _ in range(phase_ticks):
            s, rate, _ = run.step()
            q, dq, ddq = joint_path_state(PATH, s)
            got_q, got_v, got_a = run.outputs()
            np.testing.assert_allclose(got_q, q, atol=1e-12)
            np.testing.assert_allclose(got_v, dq * rate, atol=1e-12)
            if rate_dot is not None and 0.0 < rate < 1.0:
                np.testing.assert_allclose(got_a, ddq * rate**2 + dq * rate_dot, atol=1e-9)
                checked += 1
    assert checked > 250
    # Joint velocity never exceeds the path's peak at nominal speed.
    assert np.max(np.abs(got_v)) <= PATH.peak_joint_speed


def test_finishes_at_path_end():
    w = np.zeros((2, 6))
    w[1, 0] = 0.5
    path = make_joint_path(w, [0.5, 0.5])  # end = 1.0 s of path
    run = _Run(path)
    finished_at = None
    for _ in range(1000):
        s, rate, finished = run.step()
        assert s <= path.end
        if finished:
            finished_at = finished_at or run.tick
            assert s == path.end and rate == 0.0
    # Ramp covers 0.25 s of path in 0.5 s, the remaining 0.75 s at full speed.
    assert finished_at * DT == pytest.approx(1.25, abs=DT)
    assert list(run.state()) == [path.end, 0.0, 1.0]
    q, v, a = run.outputs()
    np.testing.assert_allclose(q, w[0], atol=1e-12)
    np.testing.assert_allclose(v, 0.0, atol=1e-12)
    np.testing.assert_allclose(a, 0.0, atol=1e-9)


def test_never_runs_below_path_start():
    run = _Run(command=-1.0)
    for _ in range(50):
        assert list(run.step()) == [0.0, 0.0, 0.0]
    run.command(1.0)
    run.step(100)
    run.command(-1.0)  # brakes, then backs up to the start and rests there
    for _ in range(1000):
        s, rate, _ = run.step()
        assert s >= 0.0
    assert list(run.state()) == [0.0, 0.0, 0.0]


@pytest.mark.parametrize("kwargs, match", [
    (dict(acceleration_limit=0.0), "acceleration_limit"),
    (dict(acceleration_limit=-1.0), "acceleration_limit"),
    (dict(acceleration_limit=math.nan), "acceleration_limit"),
    (dict(acceleration_limit=math.inf), "acceleration_limit"),
    (dict(period_sec=0.0), "period_sec"),
    (dict(period_sec=-0.002), "period_sec"),
    (dict(period_sec=math.nan), "period_sec"),
])
def test_bad_arguments_rejected(kwargs, match):
    args = dict(path=PATH, braking=TABLE, acceleration_limit=ACCEL, period_sec=DT) | kwargs
    with pytest.raises(ValueError, match=match):
        PathFollower(**args)
