"""The UR family: each URDF written from its record (the UR5e's byte for byte as before),
each URDF's kinematics the DH product of its constants (Drake's FK at random q)."""

import dataclasses
import importlib.util
import math

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant

from safety_systems.cell import ur5e, ur_family
from safety_systems.cell.ur_family import UR_ROBOTS, UrRobot, dh_frames, ur_robot

GENERATOR = ur_family.MODELS / "generate_urdf.py"


def _generator():
    spec = importlib.util.spec_from_file_location("generate_urdf", GENERATOR)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("name", list(UR_ROBOTS))
def test_each_urdf_is_its_records_output(name):
    robot = ur_robot(name)
    assert robot.urdf.read_text() == _generator().make_urdf(robot)


def test_ur5e_urdf_unchanged_by_the_family_generator():
    """The family generator writes the UR5e's URDF byte for byte as the UR5e-only one did
    (its text at the commit before the family: the file in git's first version)."""
    import subprocess

    before = subprocess.run(["git", "show", "74650dc:models/ur5e/ur5e.urdf"],
                            cwd=ur_family.MODELS.parent, capture_output=True, check=False)
    if before.returncode != 0:
        pytest.skip("no git history here")
    assert _generator().make_urdf(ur_family.UR5E).encode() == before.stdout


def test_ur5e_record_is_ur5e_module():
    r = ur_family.UR5E
    assert r.dh_d == ur5e.DH_D and r.dh_a == ur5e.DH_A and r.dh_alpha == ur5e.DH_ALPHA
    assert r.link_masses == ur5e.LINK_MASSES and r.link_coms == ur5e.LINK_COMS
    np.testing.assert_array_equal(r.position_upper, ur5e.JOINT_POSITION_UPPER)
    np.testing.assert_array_equal(r.effort_limits, ur5e.JOINT_EFFORT_LIMITS)
    np.testing.assert_array_equal(dh_frames(r, np.full(6, 0.3)), ur5e.dh_frames(np.full(6, 0.3)))


def _plant(robot: UrRobot):
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModels(str(robot.urdf))
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("base_link"), RigidTransform())
    plant.Finalize()
    return plant


@pytest.mark.parametrize("name", list(UR_ROBOTS))
def test_urdf_kinematics_match_dh_constants(name):
    """Drake's pose of every link frame (DH frame {i} turned by q_{i+1}... so tool0 and each
    joint origin) equals the DH product of the record's constants at random q."""
    robot = ur_robot(name)
    plant = _plant(robot)
    context = plant.CreateDefaultContext()
    rng = np.random.default_rng(35)
    for q in rng.uniform(-2 * np.pi, 2 * np.pi, (20, 6)):
        plant.SetPositions(context, q)
        frames = dh_frames(robot, q)
        X = plant.CalcRelativeTransform(context, plant.world_frame(),
                                        plant.GetFrameByName("tool0")).GetAsMatrix4()
        np.testing.assert_allclose(X, frames[6], rtol=0, atol=1e-12)
        for k, link in enumerate(ur_family.LINK_NAMES[1:], start=1):  # DH origin P_k
            p = plant.CalcRelativeTransform(context, plant.world_frame(),
                                            plant.GetFrameByName(link)).translation()
            np.testing.assert_allclose(p, frames[k][:3, 3], rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", list(UR_ROBOTS))
def test_urdf_limits_and_masses_are_the_records(name):
    robot = ur_robot(name)
    plant = _plant(robot)
    np.testing.assert_array_equal(plant.GetPositionUpperLimits(), robot.position_upper)
    np.testing.assert_array_equal(plant.GetVelocityUpperLimits(), robot.velocity_limits)
    np.testing.assert_array_equal(plant.GetEffortUpperLimits(), robot.effort_limits)
    masses = [plant.GetBodyByName(link).default_mass() for link in ur_family.LINK_NAMES]
    assert masses == list(robot.link_masses)


def test_record_refuses_bad_figures():
    fields = dataclasses.asdict(ur_family.UR3E)
    UrRobot(**fields)
    with pytest.raises(ValueError, match="velocity_limits"):
        UrRobot(**{**fields, "velocity_limits": (1.0,) * 5})
    with pytest.raises(ValueError, match="link_masses"):
        UrRobot(**{**fields, "link_masses": (1.0, -1.0, 1.0, 1.0, 1.0, 1.0)})
    with pytest.raises(ValueError, match="reach"):
        UrRobot(**{**fields, "reach": math.nan})
    with pytest.raises(ValueError, match="allowed: ur3e"):
        ur_robot("ur5")
