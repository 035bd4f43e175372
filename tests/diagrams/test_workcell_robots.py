"""The whole cell on a UR10e and on the Panda: the diagram runs in both robot modes, the
dynamic plant tracks the kinematic reference within millimetres (as the UR5e's does,
``tests/test_simulation.py``), the outputs are written and the replay draws that robot."""

import base64
import csv
import dataclasses
import functools
import json
import re
from pathlib import Path

import numpy as np
import pytest

from safety_systems.cell.robot_model import robot_model
from safety_systems.cell.robot_plant import AddRobot, inverse_dynamics_torques, robot_plant
from safety_systems.config.scenario import load_scenario, robot_model_of
from safety_systems.diagrams.simulation import simulate
from safety_systems.diagrams.workcell import MakeWorkcell
from safety_systems.outputs import replay
from safety_systems.outputs.metrics import tool_state
from safety_systems.outputs.run_files import write_outputs

ROBOTS = Path(__file__).parents[2] / "models" / "scenarios" / "robots"
NAMES = ("ur10e", "panda")


@functools.cache
def runs(name: str) -> dict:
    """The first 12 s of the robot's inspection scenario (the technician walks in at
    1.8 m/s and the override stops the robot) in each mode."""
    scenario = load_scenario(ROBOTS / f"inspection_{name}.yaml")
    return {mode: simulate(dataclasses.replace(
        scenario, robot=dataclasses.replace(scenario.robot, mode=mode)), duration=12.0)
        for mode in ("kinematic", "dynamic")}


@pytest.mark.parametrize("name", NAMES)
def test_dynamic_and_kinematic_modes_agree_on_the_tool_path(name):
    kinematic, dynamic = runs(name)["kinematic"], runs(name)["dynamic"]
    n = robot_model(name).n
    assert kinematic["q"].shape[1] == dynamic["q"].shape[1] == n
    p_kin, v_kin = tool_state(kinematic)
    p_dyn, _ = tool_state(dynamic)
    assert np.linalg.norm(p_kin - p_dyn, axis=1).max() < 0.005
    assert v_kin.max() > 0.5  # the robot ran at speed
    k = dynamic["override.path_speed_commanded"][:, 0]
    assert k.max() == 1.0 and k[-1] == 0.0  # it ran, then the override stopped it


@pytest.mark.parametrize("name", NAMES)
def test_robot_capsules_are_the_models(name):
    scenario = load_scenario(ROBOTS / f"inspection_{name}.yaml")
    workcell = MakeWorkcell(scenario, logged=["q"])
    capsules = workcell.systems["robot_capsules"]
    model = robot_model_of(scenario.robot)
    assert capsules.GetInputPort("joint_positions").size() == model.n
    K = len(model.link_capsules) + 1  # and the tool
    assert capsules.GetOutputPort("capsule_ends").size() == 6 * K
    ends = runs(name)["kinematic"]["robot_capsules.capsule_ends"].reshape(-1, K, 2, 3)
    from safety_systems.cell.robot_geometry import capsule_ends
    from safety_systems.config.resolved_cell import resolve_scenario

    want = capsule_ends(runs(name)["kinematic"]["q"], resolve_scenario(scenario).capsules)[0]
    np.testing.assert_allclose(ends, want, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", NAMES)
def test_outputs_and_replay_of_the_robot(name, tmp_path):
    run = runs(name)["dynamic"]
    summary = write_outputs(run, tmp_path, html=True)
    assert {p.name for p in tmp_path.iterdir()} == {"trace.csv", "summary.json", "plot.png",
                                                    "replay.html"}
    assert summary["braking_data"] == "placeholder"
    assert f"placeholder for the {name}" in summary["braking_data_warning"]
    assert json.loads((tmp_path / "summary.json").read_text())["mode"] == "dynamic"
    with open(tmp_path / "trace.csv") as f:
        rows = list(csv.reader(f))
    assert rows[0][:4] == ["time", "k", "path_rate", "robot_speed"] and len(rows) == 1 + 6001
    html = (tmp_path / "replay.html").read_text()
    commands = b"".join(base64.b64decode(blob) for blob in
                        re.findall(r"base64,([A-Za-z0-9+/=]+)", html))
    link = {"ur10e": b"ur10e", "panda": b"panda_link7"}[name]
    assert link in commands and b"set_animation" in commands
    assert b"ur5e" not in commands


def test_add_robot_welds_the_fingers_and_actuates_the_chain():
    panda = robot_model("panda")
    plant = robot_plant(panda)
    assert plant.num_positions() == plant.num_actuators() == 7
    assert [plant.get_joint(plant.GetJointByName(j).index()).position_start()
            for j in panda.joint_names] == list(range(7))
    from pydrake.multibody.plant import MultibodyPlant

    ur10e = MultibodyPlant(0.0)
    AddRobot(ur10e, robot_model("ur10e"))
    ur10e.Finalize()
    assert ur10e.num_positions() == ur10e.num_actuators() == 6


def ur5e_torques(q, v, a):
    """The UR5e's inverse dynamics as computed before any robot (its own plant from
    ``AddUr5e``, no applied forces)."""
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import MultibodyForces

    from safety_systems.cell.ur5e import AddUr5e

    plant = MultibodyPlant(0.0)
    AddUr5e(plant)
    plant.Finalize()
    context, forces = plant.CreateDefaultContext(), MultibodyForces(plant)
    out = np.empty_like(q)
    for i in range(len(q)):
        plant.SetPositions(context, q[i])
        plant.SetVelocities(context, v[i])
        out[i] = plant.CalcInverseDynamics(context, a[i], forces)
    return out


def test_inverse_dynamics_of_the_ur5e_as_before():
    rng = np.random.default_rng(4)
    q, v, a = (rng.uniform(-2.0, 2.0, (5, 6)) for _ in range(3))
    np.testing.assert_array_equal(inverse_dynamics_torques(robot_model("ur5e"), q, v, a),
                                  ur5e_torques(q, v, a))
    tau = inverse_dynamics_torques(robot_model("panda"), rng.uniform(-1, 1, (3, 7)),
                                   np.zeros((3, 7)), np.ones((3, 7)))
    assert tau.shape == (3, 7) and np.all(np.abs(tau[:, 1]) > 0.1)  # M(q) a, joint 2


def test_replay_of_the_ur5e_still_draws_the_ur5e():
    run = runs("ur10e")["kinematic"]  # (the scenario's robot decides what is drawn)
    scenario = dataclasses.replace(run.scenario, robot=dataclasses.replace(
        run.scenario.robot, model="", path=dataclasses.replace(run.scenario.robot.path)))
    html = replay.replay_html(dataclasses.replace(run, scenario=scenario))
    commands = b"".join(base64.b64decode(blob) for blob in
                        re.findall(r"base64,([A-Za-z0-9+/=]+)", html))
    assert b"ur5e" in commands and b"ur10e" not in commands
