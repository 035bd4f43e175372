import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable

from safety_systems.cell.ur5e import (
    JOINT_EFFORT_LIMITS,
    JOINT_NAMES,
    JOINT_POSITION_UPPER,
    JOINT_VELOCITY_LIMIT,
    TOTAL_MASS,
    UR5E_URDF,
    AddUr5e,
    dh_forward_kinematics,
    tool0_position,
    tool0_position_and_velocity,
)


@pytest.fixture(scope="module")
def plant_and_context():
    plant = MultibodyPlant(0.0)
    AddUr5e(plant)
    plant.Finalize()
    return plant, plant.CreateDefaultContext()


def test_urdf_exists_beside_package():
    assert UR5E_URDF.is_file()


def test_total_mass(plant_and_context):
    plant, context = plant_and_context
    assert plant.CalcTotalMass(context) == pytest.approx(18.5 - 0.8, abs=1e-9)
    assert TOTAL_MASS == pytest.approx(17.7)


def test_joints_limits_and_actuators(plant_and_context):
    plant, _ = plant_and_context
    assert plant.num_positions() == 6 and plant.num_actuators() == 6
    np.testing.assert_allclose(plant.GetPositionUpperLimits(), JOINT_POSITION_UPPER)
    np.testing.assert_allclose(plant.GetVelocityUpperLimits(), JOINT_VELOCITY_LIMIT)
    np.testing.assert_allclose(plant.GetEffortUpperLimits(), JOINT_EFFORT_LIMITS)
    for i, name in enumerate(JOINT_NAMES):
        assert plant.GetJointByName(name).velocity_start() == i


def test_drake_fk_matches_dh(plant_and_context):
    plant, context = plant_and_context
    tool0 = plant.GetFrameByName("tool0")
    rng = np.random.default_rng(0)
    for _ in range(20):
        q = rng.uniform(-np.pi, np.pi, 6)
        plant.SetPositions(context, q)
        X_WT = tool0.CalcPoseInWorld(context).GetAsMatrix4()
        np.testing.assert_allclose(X_WT, dh_forward_kinematics(q), atol=1e-9)


def test_zero_pose_is_published_home():
    # UR5e at q = 0: tool at (a2 + a3, -(d4 + d6), d1 - d5).
    np.testing.assert_allclose(tool0_position(np.zeros(6)), [-0.8172, -0.2329, 0.0628])


def test_closed_form_velocity_matches_drake_jacobian(plant_and_context):
    plant, context = plant_and_context
    tool0 = plant.GetFrameByName("tool0")
    rng = np.random.default_rng(1)
    for _ in range(20):
        q, v = rng.uniform(-np.pi, np.pi, 6), rng.uniform(-3, 3, 6)
        plant.SetPositions(context, q)
        J = plant.CalcJacobianTranslationalVelocity(
            context, JacobianWrtVariable.kV, tool0, np.zeros(3),
            plant.world_frame(), plant.world_frame(),
        )  # fmt: skip
        p, pdot = tool0_position_and_velocity(q, v)
        np.testing.assert_allclose(pdot, J @ v, atol=1e-9)
        np.testing.assert_allclose(p, dh_forward_kinematics(q)[:3, 3], atol=1e-12)


angles = arrays(np.float64, (5, 6), elements=st.floats(-7, 7))


@settings(max_examples=30, deadline=None)
@given(q=angles, v=angles)
def test_batch_equals_single(q, v):
    p, pdot = tool0_position_and_velocity(q, v)
    assert p.shape == (5, 3) and pdot.shape == (5, 3)
    for k in range(5):
        pk, pdk = tool0_position_and_velocity(q[k], v[k])
        np.testing.assert_allclose(p[k], pk, atol=1e-12)
        np.testing.assert_allclose(pdot[k], pdk, atol=1e-12)
    np.testing.assert_allclose(p, dh_forward_kinematics(q)[:, :3, 3], atol=1e-12)
    # reach: the tool never leaves the sphere of the link lengths
    assert np.all(np.linalg.norm(p, axis=-1) < 1.2)
