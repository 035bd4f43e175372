"""RobotCapsules: capsule ends by forward kinematics, their velocities by Eq. 5."""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from safety_systems.cell.braking import default_braking_table
from safety_systems.cell.joint_path import default_joint_path, joint_path_state
from safety_systems.cell.robot_geometry import capsule_ends, robot_capsules, tool_point
from safety_systems.systems.path_follower import PathFollower
from safety_systems.systems.robot_capsules import RobotCapsules
from safety_systems.cell.ur5e import dh_forward_kinematics, tool0_position

DT = 0.002
CAPSULES = robot_capsules(payload_radius=0.05, tool_length=0.15)


def _trajectory():
    """A smooth joint trajectory over 1 s that moves every joint (radians)."""
    rng = np.random.default_rng(5)
    times = np.linspace(0.0, 1.0, 6)
    knots = np.radians([140.0, -80.0, 100.0, -110.0, -90.0, 0.0])[:, None] + rng.uniform(
        -0.4, 0.4, (6, times.size))
    return PiecewisePolynomial.CubicWithContinuousSecondDerivatives(
        times, knots, np.zeros(6), np.zeros(6))


def _simulate(source_system, capsules=CAPSULES):
    builder = DiagramBuilder()
    source = builder.AddSystem(source_system)
    ee = builder.AddSystem(RobotCapsules(capsules=capsules, period_sec=DT))
    builder.Connect(source.get_output_port(0), ee.GetInputPort("joint_positions"))
    simulator = Simulator(builder.Build())
    simulator.Initialize()
    return simulator, ee, ee.GetMyContextFromRoot(simulator.get_context())


def _read(ee, context):
    return [ee.GetOutputPort(n).Eval(context).copy().reshape(-1, 2, 3)
            for n in ("capsule_ends", "capsule_velocities")]


def test_ends_are_the_capsules_forward_kinematics():
    ee = RobotCapsules(capsules=CAPSULES, period_sec=DT)
    point = RobotCapsules(capsules=tool_point(), period_sec=DT)
    rng = np.random.default_rng(2)
    for _ in range(20):
        q = rng.uniform(-math.pi, math.pi, 6)
        ends = []
        for system in (ee, point):
            context = system.CreateDefaultContext()
            system.GetInputPort("joint_positions").FixValue(context, q)
            ends.append(system.GetOutputPort("capsule_ends").Eval(context).reshape(-1, 2, 3))
        np.testing.assert_array_equal(ends[0], capsule_ends(q, CAPSULES)[0])
        # The seed's tool point: both ends are tool0, bit for bit.
        np.testing.assert_array_equal(ends[1], [[tool0_position(q)] * 2])
        np.testing.assert_allclose(ends[1][0, 0], dh_forward_kinematics(q)[:3, 3], atol=1e-12)


def test_velocity_nan_before_first_tick():
    ee = RobotCapsules(capsules=CAPSULES, period_sec=DT)
    context = ee.CreateDefaultContext()
    ee.GetInputPort("joint_positions").FixValue(context, np.zeros(6))
    assert np.all(np.isnan(ee.GetOutputPort("capsule_velocities").Eval(context)))
    simulator, ee, context = _simulate(ConstantVectorSource(np.ones(6)))
    assert np.all(np.isnan(_read(ee, context)[1]))  # initialised, tick at t = 0 not yet run
    simulator.AdvanceTo(DT / 2)
    np.testing.assert_array_equal(_read(ee, context)[1], 0.0)  # robot at rest


def test_velocity_is_eq5_difference_of_positions():
    traj = _trajectory()
    simulator, ee, context = _simulate(TrajectorySource(traj))

    def p(t):
        return capsule_ends(traj.value(t).ravel(), CAPSULES)[0]

    speeds = []
    for k in range(1, 400):
        t = k * DT
        simulator.AdvanceTo(t)
        position, velocity = _read(ee, context)
        np.testing.assert_allclose(position, p(t), atol=1e-12)
        eq5 = (p(t) - p(t - DT)) / DT
        np.testing.assert_allclose(velocity, eq5, atol=1e-9, err_msg=f"t={t}")
        # Eq. 5 is a central difference for J v at the middle of the tick.
        mid = t - DT / 2
        _, jv = capsule_ends(traj.value(mid).ravel(), CAPSULES,
                             traj.EvalDerivative(mid, 1).ravel())
        np.testing.assert_allclose(velocity, jv, atol=2e-4, err_msg=f"t={t}")
        speeds.append(np.linalg.norm(jv, axis=-1).max())
        # Between ticks: the current position against the one stored at the last tick.
        simulator.AdvanceTo(t + 0.4 * DT)
        np.testing.assert_allclose(_read(ee, context)[1], (p(t + 0.4 * DT) - p(t)) / DT,
                                   atol=1e-9)
    assert max(speeds) > 0.5  # the test moved the tool fast enough to mean something


def test_velocity_from_path_follower():
    path = default_joint_path()
    builder = DiagramBuilder()
    follower = builder.AddSystem(PathFollower(path=path, braking=default_braking_table(),
                                              acceleration_limit=2.0, period_sec=DT))
    command = builder.AddSystem(ConstantVectorSource([1.0]))
    ee = builder.AddSystem(RobotCapsules(capsules=CAPSULES, period_sec=DT))
    builder.Connect(command.get_output_port(), follower.GetInputPort("path_speed_commanded"))
    builder.Connect(follower.GetOutputPort("joint_positions_desired"),
                    ee.GetInputPort("joint_positions"))
    simulator = Simulator(builder.Build())
    simulator.Initialize()
    root = simulator.get_context()
    follower_context, ee_context = (s.GetMyContextFromRoot(root) for s in (follower, ee))
    previous = None
    for k in range(1, 1500):
        simulator.AdvanceTo(k * DT)
        s, rate, _ = follower.GetOutputPort("path_state").Eval(follower_context)
        q = joint_path_state(path, s)[0]
        position, velocity = _read(ee, ee_context)
        if previous is not None:
            np.testing.assert_allclose(velocity, (position - previous) / DT, atol=1e-9)
        if rate == 1.0:  # at nominal speed: J q'(s) sigma, up to O(DT) of the difference
            _, jv = capsule_ends(q, CAPSULES, joint_path_state(path, s)[1])
            np.testing.assert_allclose(velocity, jv, atol=0.01)
        previous = position
    assert rate == 1.0


@pytest.mark.parametrize("period", [0.0, -0.002, math.nan, math.inf])
def test_bad_period_rejected(period):
    with pytest.raises(ValueError, match="period_sec"):
        RobotCapsules(capsules=CAPSULES, period_sec=period)
