"""Every model's compiled points: a UR's closed form with its DH constants as arguments
equals the UR5e's old closed form bit for bit and Drake's forward kinematics (and J v) on
every UR; a chain's equals Drake's on the Panda."""

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable

from safety_systems.cell import ur5e
from safety_systems.cell.model_points import (
    model_arrays,
    model_points,
    model_points_one,
    model_tool0_one,
    model_work,
)
from safety_systems.cell.robot_geometry import robot_points, robot_points_one_memo
from safety_systems.cell.robot_model import KIND_UR, SHIPPED, robot_model


def test_ur5e_points_bit_for_bit_the_closed_form():
    """model_points of the UR5e (its constants an array) against robot_points (the UR5e's
    constants frozen into the build, as before models existed), and tool0 against
    ur5e.tool0_position_and_velocity, at 5000 random (q, v)."""
    rng = np.random.default_rng(35)
    q, v = rng.uniform(-7.0, 7.0, (5000, 6)), rng.uniform(-4.0, 4.0, (5000, 6))
    q[::7, 3] = 0.0  # (angles of 0 are not reused from the memo)
    model = robot_model("ur5e")
    p, pv = model_points(model, q, v, 0.137)
    p_old, pv_old = robot_points(q, v, 0.137)
    assert np.array_equal(p, p_old) and np.array_equal(pv, pv_old)
    tool, tool_v = ur5e.tool0_position_and_velocity(q, v)
    assert np.array_equal(p[:, 6], tool) and np.array_equal(pv[:, 6], tool_v)


def test_model_points_one_reuses_its_memo_as_the_old_memo_did():
    model = robot_model("ur5e")
    rng = np.random.default_rng(3)
    memo, poses, twists = model_work(model)
    old_memo = np.full(15, np.nan)
    p, pv, p_old, pv_old = (np.empty((8, 3)) for _ in range(4))
    q = rng.uniform(-3.0, 3.0, 6)
    for _ in range(50):  # some joints still, some moving
        q[rng.integers(0, 6)] += rng.normal()
        v = rng.normal(size=6)
        model_points_one(model_arrays(model), 0.1, q, v, memo, poses, twists, p, pv)
        _old(q, v, 0.1, old_memo, p_old, pv_old)
        assert np.array_equal(p, p_old) and np.array_equal(pv, pv_old)
        assert np.array_equal(memo, old_memo, equal_nan=True)


def _old(q, v, tool_length, memo, p, pv):
    import numba

    @numba.njit
    def call(q, v, tool_length, memo, p, pv):
        robot_points_one_memo(q, v, tool_length, memo, p, pv)

    call(q, v, tool_length, memo, p, pv)


def _drake(model):
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModels(str(model.urdf))
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(model.base_link),
                     RigidTransform())
    plant.Finalize()
    bodies = [model.base_link] + [plant.get_joint(plant.GetJointByName(j).index()).child_body()
                                  .name() for j in model.joint_names]
    return plant, bodies


def _drake_points(model, plant, bodies, q, v, tool_length):
    """Every point of the model and its velocity by Drake, at one q, v."""
    context = plant.CreateDefaultContext()
    q_all, v_all = np.zeros(plant.num_positions()), np.zeros(plant.num_velocities())
    for k, name in enumerate(model.joint_names):
        joint = plant.GetJointByName(name)
        q_all[joint.position_start()], v_all[joint.velocity_start()] = q[k], v[k]
    plant.SetPositions(context, q_all)
    plant.SetVelocities(context, v_all)
    world = plant.world_frame()
    tool = plant.GetFrameByName(model.tool_frame)
    frames = [plant.GetFrameByName(bodies[b]) for b in model.point_bodies]
    frames += [tool, tool]
    local = np.r_[model.point_local, [[0.0, 0.0, 0.0], [0.0, 0.0, tool_length]]]
    p, pv = np.empty((model.num_points, 3)), np.empty((model.num_points, 3))
    for i, (frame, x) in enumerate(zip(frames, local)):
        p[i] = plant.CalcPointsPositions(context, frame, x.reshape(3, 1), world)[:, 0]
        J = plant.CalcJacobianTranslationalVelocity(context, JacobianWrtVariable.kV, frame,
                                                    x.reshape(3, 1), world, world)
        pv[i] = J @ v_all
    return p, pv


@pytest.mark.parametrize("name", list(SHIPPED))
def test_points_match_drake(name):
    """Each model's points (a UR's by its closed form, the Panda's by its chain) and their
    velocities equal Drake's forward kinematics and translational Jacobian times v, to
    1e-12 m and m/s, at random (q, v) within the joint limits."""
    model = robot_model(name)
    plant, bodies = _drake(model)
    rng = np.random.default_rng(11)
    lower = np.maximum(model.position_lower, -np.pi)
    upper = np.minimum(model.position_upper, np.pi)
    q = rng.uniform(lower, upper, (15, model.n))
    v = rng.uniform(-3.0, 3.0, (15, model.n))
    p, pv = model_points(model, q, v, 0.21)
    for row in range(len(q)):
        want, want_v = _drake_points(model, plant, bodies, q[row], v[row], 0.21)
        np.testing.assert_allclose(p[row], want, rtol=0, atol=1e-12)
        np.testing.assert_allclose(pv[row], want_v, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", [n for n in SHIPPED if n != "panda"])
def test_ur_closed_form_equals_its_chain(name):
    """A UR's closed form and its own chain arrays (the URDF's joints) give the same points."""
    model = robot_model(name)
    assert model.kind == KIND_UR
    rng = np.random.default_rng(5)
    q, v = rng.uniform(-7.0, 7.0, (500, 6)), rng.uniform(-4.0, 4.0, (500, 6))
    p, pv = model_points(model, q, v, 0.3)
    p_chain, pv_chain = model_points(model, q, v, 0.3, chain=True)
    np.testing.assert_allclose(p_chain, p, rtol=0, atol=1e-12)
    np.testing.assert_allclose(pv_chain, pv, rtol=0, atol=1e-12)


def test_wrong_joint_count_refused():
    with pytest.raises(ValueError, match=r"\(\.\.\., 7\) joint positions of the panda"):
        model_points(robot_model("panda"), np.zeros(6))


@pytest.mark.parametrize("name", ["ur5e", "ur20", "panda"])
def test_tool0_alone_is_the_points_tool0(name):
    """model_tool0_one: tool0 without the other points, bit for bit a UR's P6 (the UR5e's
    ur5e.tool0_reusing_trig), a chain's to round-off."""
    import numba

    model = robot_model(name)
    arrays, (memo, poses, twists) = model_arrays(model), model_work(model)

    @numba.njit
    def tool0_rows(arrays, q, v, memo, poses, twists, out):
        for row in range(q.shape[0]):
            out[row] = model_tool0_one(arrays, q[row], v[row], memo, poses, twists)

    rng = np.random.default_rng(8)
    q, v = rng.uniform(-3.0, 3.0, (300, model.n)), rng.uniform(-2.0, 2.0, (300, model.n))
    out = np.empty((300, 6))
    tool0_rows(arrays, q, v, memo, poses, twists, out)
    p, pv = model_points(model, q, v)
    want = np.concatenate([p[:, model.tool0], pv[:, model.tool0]], axis=1)
    if name == "panda":
        np.testing.assert_allclose(out, want, rtol=0, atol=1e-15)
    else:
        assert np.array_equal(out, want)
    if name == "ur5e":
        t, tv = ur5e.tool0_position_and_velocity(q, v)
        assert np.array_equal(out, np.concatenate([t, tv], axis=1))
