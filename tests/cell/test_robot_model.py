"""The model record of every shipped robot: joints, limits, points, capsules that contain
their links, a sound reach bound, the placeholder stopping data's name; bad names and
files refused in one line."""

import math

import numpy as np
import pytest

from safety_systems.cell import ur5e, ur_family
from safety_systems.cell.capsule_fit import CHECK_RIM_CORNERS, LinkCapsules, enclosure_slack
from safety_systems.cell.chain_kinematics import body_poses_one
from safety_systems.cell.model_points import model_points
from safety_systems.cell.robot_description import load_robot_description
from safety_systems.cell.robot_geometry import model_link_capsules
from safety_systems.cell.robot_model import (
    KIND_CHAIN,
    KIND_UR,
    SHIPPED,
    default_model,
    placeholder_name,
    robot_model,
)
from safety_systems.files.input_error import InputError


@pytest.mark.parametrize("name", list(SHIPPED))
def test_each_shipped_model(name):
    model = robot_model(name)
    assert model is robot_model(name)  # made once
    assert model.name == name and model.placeholder == name
    K = len(model.link_capsules)
    assert len(model.link_names) == K and model.num_points == model.point_bodies.size + 2
    rows = np.array(model.link_capsules)
    assert np.all((rows[:, :2] >= 0) & (rows[:, :2] <= model.tool0))
    assert np.all(rows[:, 4] > 0.0)
    assert model.position_lower.shape == model.velocity_limit.shape == (model.n,)
    assert np.all(model.position_lower < model.position_upper)
    if name == "panda":
        assert model.kind == KIND_CHAIN and model.n == 7 and K == 8
        assert model.dh.size == 0 and model.tool_frame == "panda_hand"
        np.testing.assert_array_equal(rows[:, :4], [(2 * j, 2 * j + 1, 0, 1) for j in range(8)])
        np.testing.assert_allclose(model.velocity_limit, [2.175] * 4 + [2.61] * 3)
    else:
        robot = ur_family.ur_robot(name)
        assert model.kind == KIND_UR and model.n == 6 and K == 6 and model.num_points == 8
        np.testing.assert_array_equal(model.dh, [robot.dh_d[0], robot.dh_a[1], robot.dh_a[2],
                                                 robot.dh_d[3], robot.dh_d[4], robot.dh_d[5]])
        assert model.reach_bound == sum(abs(a) for a in robot.dh_a) + sum(robot.dh_d[1:])
        np.testing.assert_array_equal(model.velocity_limit, robot.velocity_limits)
        np.testing.assert_array_equal(rows[:, :2], [(k, k + 1) for k in range(6)])


def test_ur5e_model_is_the_project_robot():
    model = default_model()
    assert model is robot_model("ur5e") is robot_model("")
    assert model.link_capsules == model_link_capsules()  # exactly robot_geometry's fit
    np.testing.assert_allclose(np.array(model.link_capsules)[:, 4],
                               [0.060, 0.085, 0.075, 0.040, 0.040, 0.040], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(model.velocity_limit, np.full(6, math.pi))
    assert model.reach_bound == sum(abs(a) for a in ur5e.DH_A) + sum(ur5e.DH_D[1:])


def _link_capsules(model):
    """The model's link capsules as ``capsule_fit.LinkCapsules`` in their bodies' frames."""
    description = load_robot_description(model.urdf, tool_frame=model.tool_frame)
    bodies, ends = [], []
    for a, b, t0, t1, _ in model.link_capsules:
        body = int(model.point_bodies[a]) if model.kind == KIND_CHAIN else a + 1
        if model.kind == KIND_UR:  # P_a is body a + 1's origin, P_b at (a_k, 0, d_k) in it
            end = description.X_parent[a + 1][:3, 3] if a + 1 < 6 else description.X_tool[:3, 3]
            ends.append([t0 * end, t1 * end])
        else:
            ends.append([model.point_local[a], model.point_local[b]])
        bodies.append(body)
    return description, LinkCapsules(description.collision_links, bodies, ends,
                                     np.array(model.link_capsules)[:, 4])


@pytest.mark.parametrize("name", list(SHIPPED))
def test_capsules_contain_their_links(name):
    """``capsule_fit``'s independent check. A UR's radii are fitted to the rims themselves
    (``ur_capsules``: a radius within 1 nm of a step counts as on it), and the check bounds
    each rim by a circumscribed 4096-gon, r (sec(pi / 4096) - 1) outside it (at most 45 nm
    on these arms): a UR capsule may fall short of the check by that much, no more."""
    model = robot_model(name)
    description, capsules = _link_capsules(model)
    slack = enclosure_slack(description, capsules)
    allowed = 0.0
    if model.kind == KIND_UR:
        rims = max(s.size[0] for shapes in description.collision_shapes for s in shapes)
        allowed = -(rims * (1.0 / math.cos(math.pi / CHECK_RIM_CORNERS) - 1.0) + 1e-9)
    assert allowed > -5e-8
    assert np.all(slack >= allowed), dict(zip(capsules.names, slack))


def test_enclosure_check_fails_on_a_thinner_capsule():
    description, capsules = _link_capsules(robot_model("ur10e"))
    thin = LinkCapsules(capsules.names, capsules.bodies, capsules.ends,
                        capsules.radius - np.r_[0.0, 0.002, 0.0, 0.0, 0.0, 0.0])
    assert enclosure_slack(description, thin)[1] < 0.0


@pytest.mark.parametrize("name", list(SHIPPED))
def test_reach_bounds_hold(name):
    """At random q, every point's distance from every joint axis that moves it is within
    its ``point_reach`` (tool0's the ``reach_bound``); the tip's within it plus the tool."""
    model = robot_model(name)
    rng = np.random.default_rng(2)
    n = model.n
    poses, twists = np.empty((n + 1, 3, 4)), np.empty((n + 1, 2, 3))
    worst = np.zeros(model.num_points)
    for q in rng.uniform(np.maximum(model.position_lower, -np.pi),
                         np.minimum(model.position_upper, np.pi), (200, n)):
        body_poses_one(model.X_parent, model.axes, model.kinds, q, np.zeros(n), poses, twists)
        p = model_points(model, q, None, 0.2)[0]
        bodies = np.r_[model.point_bodies, n, n]
        for j in range(n):
            R, o = poses[j][:, :3] @ model.X_parent[j][:3, :3], poses[j] @ np.r_[
                model.X_parent[j][:3, 3], 1.0]
            axis = R @ model.axes[j]
            for i in np.flatnonzero(bodies > j):
                r = p[i] - o
                worst[i] = max(worst[i], np.linalg.norm(r - (r @ axis) * axis))
    assert np.all(worst[:-1] <= model.point_reach + 1e-12)
    assert worst[model.tool0] <= model.reach_bound + 1e-12
    assert worst[model.tip] <= model.reach_bound + 0.2 + 1e-12
    assert worst[model.tool0] > 0.6 * model.reach_bound  # not a loose bound
    far = np.linalg.norm(model_points(model, rng.uniform(
        np.maximum(model.position_lower, -np.pi), np.minimum(model.position_upper, np.pi),
        (2000, n)))[0][:, :-1], axis=-1)
    assert far.max() <= model.base_reach + 1e-12 and far.max() > 0.6 * model.base_reach
    if model.kind == KIND_UR:  # as the proofs bound it (REACH_BOUND + d1)
        assert model.base_reach == model.reach_bound + model.dh[0]


def test_unknown_name_missing_file_and_bad_tool_frame_refused(tmp_path):
    for call, words in ((lambda: robot_model("ur7"), "robot.model: got 'ur7'"),
                        (lambda: robot_model(urdf=tmp_path / "none.urdf"), "robot.urdf"),
                        (lambda: robot_model("ur10e", tool_frame="wrist_3_link"),
                         "robot.tool_frame")):
        with pytest.raises(InputError) as error:
            call()
        assert words in str(error.value) and "\n" not in str(error.value)


def test_a_urdf_robot_has_no_placeholder_but_the_shipped_file_does(tmp_path):
    panda = robot_model(urdf=SHIPPED["panda"])
    assert panda.name == "panda" and panda.placeholder == "panda"
    copy = tmp_path / "arm.urdf"
    text = SHIPPED["panda"].read_text().replace('<robot name="panda">', '<robot name="arm">')
    copy.write_text(text.replace('filename="meshes/', f'filename="{SHIPPED["panda"].parent}/meshes/'))
    arm = robot_model(urdf=copy)
    assert arm.name == "arm" and arm.placeholder is None and arm.n == 7
    with pytest.raises(InputError, match="the stopping data measured on the arm"):
        placeholder_name(arm)
    assert placeholder_name(panda) == "panda"
