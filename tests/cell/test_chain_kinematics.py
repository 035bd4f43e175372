"""The compiled chain kinematics against Drake's MultibodyPlant (positions, and velocities
as the translational Jacobian times v) and against the UR5e's closed form."""

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable

from safety_systems.cell import ur5e, ur_family
from safety_systems.cell.chain_kinematics import chain_points
from safety_systems.cell.robot_description import load_robot_description

PANDA = ur_family.MODELS / "panda" / "panda.urdf"
URDFS = [ur_family.UR5E.urdf, ur_family.UR10E.urdf, ur_family.UR3E.urdf, PANDA]


def drake_points(description, bodies, local_ends, q, v):
    """(ends, end velocities, tool, tool velocity) of one q, v by Drake."""
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModels(str(description.urdf))
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(description.base_link),
                     RigidTransform())
    plant.Finalize()
    context = plant.CreateDefaultContext()
    q_all, v_all = np.zeros(plant.num_positions()), np.zeros(plant.num_velocities())
    for k, name in enumerate(description.joint_names):
        joint = plant.GetJointByName(name)
        q_all[joint.position_start()], v_all[joint.velocity_start()] = q[k], v[k]
    plant.SetPositions(context, q_all)
    plant.SetVelocities(context, v_all)
    world = plant.world_frame()

    def point(frame, p):
        x = plant.CalcPointsPositions(context, frame, p.reshape(3, 1), world)[:, 0]
        J = plant.CalcJacobianTranslationalVelocity(context, JacobianWrtVariable.kV, frame,
                                                    p.reshape(3, 1), world, world)
        return x, J @ v_all

    ends, velocities = np.empty_like(local_ends), np.empty_like(local_ends)
    for j, body in enumerate(bodies):
        frame = plant.GetFrameByName(description.link_names[body - 1])
        for e in range(2):
            ends[j, e], velocities[j, e] = point(frame, local_ends[j, e])
    tool, tool_velocity = point(plant.GetFrameByName(description.tool_frame), np.zeros(3))
    return ends, velocities, tool, tool_velocity


@pytest.mark.parametrize("urdf", URDFS, ids=lambda p: p.stem)
def test_chain_points_match_drake(urdf):
    description = load_robot_description(urdf)
    n = description.num_joints
    rng = np.random.default_rng(7)
    bodies = np.repeat(np.arange(1, n + 1), 2)
    local_ends = rng.uniform(-0.3, 0.3, (bodies.size, 2, 3))
    q = rng.uniform(-np.pi, np.pi, (12, n))
    v = rng.uniform(-3.0, 3.0, (12, n))
    got = chain_points(description, bodies, local_ends, q, v)
    for row in range(len(q)):
        want = drake_points(description, bodies, local_ends, q[row], v[row])
        for g, w in zip(got, want):
            np.testing.assert_allclose(g[row], w, rtol=0, atol=1e-12)


def test_chain_tool_is_ur5e_closed_form():
    """For the UR5e the generic chain's tool0 equals ur5e's closed form (the same frames)."""
    description = load_robot_description(ur_family.UR5E.urdf)
    rng = np.random.default_rng(3)
    q, v = rng.uniform(-2 * np.pi, 2 * np.pi, (200, 6)), rng.uniform(-3, 3, (200, 6))
    _, _, tool, tool_velocity = chain_points(description, np.zeros(0, dtype=int),
                                             np.zeros((0, 2, 3)), q, v)
    p, pv = ur5e.tool0_position_and_velocity(q, v)
    np.testing.assert_allclose(tool, p, rtol=0, atol=1e-12)
    np.testing.assert_allclose(tool_velocity, pv, rtol=0, atol=1e-12)


def test_chain_points_shapes_and_zero_velocity():
    description = load_robot_description(ur_family.UR5E.urdf)
    ends, velocities, tool, tool_velocity = chain_points(
        description, np.array([1, 6]), np.zeros((2, 2, 3)), np.zeros((4, 5, 6)))
    assert ends.shape == (4, 5, 2, 2, 3) and tool.shape == (4, 5, 3)
    assert np.all(velocities == 0.0) and np.all(tool_velocity == 0.0)
    np.testing.assert_allclose(ends[0, 0, 1, 0], ur5e.dh_frames(np.zeros(6))[5][:3, 3],
                               atol=1e-15)
