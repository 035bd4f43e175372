"""The robot chosen in a scenario (``robot.model`` or ``robot.urdf``): its model, its path,
its placeholder stopping data and warning; bad choices refused by ``simulate`` with exit 2
and one line naming the file, the field, the value and what is allowed."""

from pathlib import Path

import numpy as np
import pytest

from safety_systems.cell.braking import PLACEHOLDER_WARNING, default_braking_table
from safety_systems.cell.placeholder_stops import placeholder_braking_table
from safety_systems.cell.robot_model import KIND_CHAIN, KIND_UR, SHIPPED, robot_model
from safety_systems.cli import main
from safety_systems.config.configuration import (
    braking_table,
    braking_warning,
    contact_capsules,
    joint_path,
    monitor_capsules,
)
from safety_systems.config.scenario import load_scenario, robot_model_of
from safety_systems.files.input_error import InputError

MODELS = Path(__file__).parents[2] / "models"
ROBOTS = MODELS / "scenarios" / "robots"
INSPECTION = MODELS / "scenarios" / "inspection_seed.yaml"


def test_shipped_robot_scenarios_load_with_their_models():
    ur10e = load_scenario(ROBOTS / "inspection_ur10e.yaml")
    panda = load_scenario(ROBOTS / "inspection_panda.yaml")
    assert robot_model_of(ur10e.robot) is robot_model("ur10e")
    model = robot_model_of(panda.robot)
    assert model.kind == KIND_CHAIN and model.name == "panda" and model.n == 7
    assert Path(panda.robot.urdf) == SHIPPED["panda"].resolve()  # resolved beside the file
    assert robot_model_of(load_scenario(INSPECTION).robot) is robot_model("ur5e")
    for scenario, n in ((ur10e, 6), (panda, 7)):
        path = joint_path(scenario.robot)
        assert path.num_joints == n and path.waypoints.shape == (6, n)
        caps = contact_capsules(scenario.robot, scenario.contact_geometry)
        assert caps.model is robot_model_of(scenario.robot)
        assert monitor_capsules(scenario.controller, caps.model).names == caps.names


def test_default_path_serves_every_ur():
    scenario = load_scenario(ROBOTS / "inspection_ur10e.yaml")
    scenario.robot.path.waypoints_deg, scenario.robot.path.segment_durations = [], []
    from safety_systems.config.scenario import validate_robot

    validate_robot(scenario.robot)
    assert joint_path(scenario.robot).num_joints == 6


def test_placeholder_table_and_warning_are_the_robots():
    ur5e, panda = robot_model("ur5e"), robot_model("panda")
    config = load_scenario(INSPECTION).controller
    for model, table in ((None, default_braking_table()), (ur5e, default_braking_table()),
                         (panda, placeholder_braking_table("panda")),
                         (robot_model("ur10e"), placeholder_braking_table("ur10e"))):
        got = braking_table(config, model)
        for field in ("speed_fraction", "stopping_time", "stopping_distance"):
            np.testing.assert_array_equal(getattr(got, field), getattr(table, field))
    assert braking_warning(ur5e) == braking_warning() == PLACEHOLDER_WARNING
    assert "for the panda" in braking_warning(panda)
    assert "for the ur10e" in braking_warning(robot_model("ur10e"))
    assert not np.array_equal(placeholder_braking_table("panda").stopping_distance,
                              default_braking_table().stopping_distance)


def _edited(tmp_path: Path, source: Path, *edits: tuple[str, str]) -> Path:
    text = source.read_text()
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / source.name
    path.write_text(text.replace("../../panda/panda.urdf", str(SHIPPED["panda"])))
    return path


PANDA_PATH = "    - [-40.0, -10.0, 0.0, -120.0, 0.0, 110.0, 45.0]\n    - [-40.0, 15.0,"
BAD = {
    "wrong joint count": (ROBOTS / "inspection_panda.yaml",
                          [(PANDA_PATH, ("    - [-40.0, -10.0, 0.0, -120.0, 0.0, 110.0]\n"
                                        "    - [-40.0, 15.0,"))],
                          "robot.path.waypoints_deg[0]", "7 joint angles in deg"),
    "unknown model": (ROBOTS / "inspection_ur10e.yaml", [("model: ur10e", "model: ur11e")],
                      "robot.model: got 'ur11e'", "one of ur3e, ur5e, ur10e"),
    "missing URDF": (ROBOTS / "inspection_panda.yaml",
                     [("urdf: ../../panda/panda.urdf", "urdf: no/such.urdf")],
                     "robot.urdf: got 'no/such.urdf'", "an existing URDF file"),
    "model and URDF": (ROBOTS / "inspection_panda.yaml",
                       [("  urdf: ../../panda/panda.urdf", ("  model: ur10e\n"
                                                           "  urdf: ../../panda/panda.urdf"))],
                       "robot.urdf", "one of the two"),
    "seed-004 controller on the Panda": (ROBOTS / "inspection_panda.yaml",
                                         [("controller:\n", "controller:\n  type: erga\n")],
                                         "controller.type: got 'erga'", ("ssm_override on the "
                                         "panda")),
    "zones on the UR10e": (ROBOTS / "inspection_ur10e.yaml",
                           [("controller:\n", "controller:\n  type: zones\n")],
                           "controller.type: got 'zones'", "ssm_override on the ur10e"),
    "no path on the Panda": (ROBOTS / "inspection_panda.yaml",
                             [("  path:\n", "  unused_path:\n")], "",
                             ""),
    "outside the joint limits": (ROBOTS / "inspection_panda.yaml",
                                 [("[-40.0, 15.0, 0.0, -105.0", "[-40.0, 15.0, 0.0, 5.0")],
                                 "robot.path.waypoints_deg[1]", ("within the panda's joint "
                                 "limits")),
    "too fast for the UR10e": (ROBOTS / "inspection_ur10e.yaml",
                               [("[0.8, 0.8, 1.5, 0.8, 0.8, 1.5]",
                                 "[0.8, 0.8, 0.8, 0.8, 0.8, 1.5]")],
                               "robot.path.segment_durations", ("its joint's speed limit "
                               "(120, 120, 180")),
    "link radii of the UR5e on the Panda": (ROBOTS / "inspection_panda.yaml",
                                            [("    robot_geometry: capsules\n",
                                              ("    robot_geometry: capsules\n    link_radii: "
                                              "[0.1, 0.1, 0.1, 0.1, 0.1, 0.1]\n"))],
                                            "controller.safety.link_radii", "8 radii in m"),
    "a line on the UR10e": (ROBOTS / "inspection_ur10e.yaml",
                            [("  path:\n    # Above", ("  path:\n    line: {start: [0.5, 0, 0.3],"
                              " goal: [0.6, 0, 0.3]}\n    # Above"))],
                            "robot.path.line: got 'ur10e'", "on the ur5e only"),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_robot_choice_exits_2_with_one_line(case, tmp_path, capsys):
    source, edits, field, allowed = BAD[case]
    if case == "no path on the Panda":  # the whole path block left out
        text = source.read_text()
        start, end = text.index("  path:\n"), text.index("controller:\n")
        path = tmp_path / source.name
        path.write_text((text[:start] + text[end:]).replace("../../panda/panda.urdf",
                                                            str(SHIPPED["panda"])))
        field, allowed = "robot.path.waypoints_deg", "waypoints of the panda's 7 joints"
    else:
        path = _edited(tmp_path, source, *edits)
    assert main(["simulate", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert str(path) in err[0] and field in err[0] and allowed in err[0], err[0]
    assert not (tmp_path / "out").exists()


def test_a_urdf_robot_without_stopping_data_is_refused(tmp_path, capsys):
    """A robot from its own URDF has no placeholder: simulate needs the measured data."""
    arm = tmp_path / "arm.urdf"
    text = SHIPPED["panda"].read_text().replace('<robot name="panda">', '<robot name="arm">')
    arm.write_text(text.replace('filename="meshes/', f'filename="{SHIPPED["panda"].parent}/'
                                                     'meshes/'))
    path = _edited(tmp_path, ROBOTS / "inspection_panda.yaml",
                   ("urdf: ../../panda/panda.urdf", "urdf: arm.urdf"))
    assert main(["simulate", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "controller.braking.speed_fraction" in err[0], err
    assert "measured on the arm" in err[0]
    measured = _edited(tmp_path, path, ("controller:\n", ("controller:\n  braking:\n"
                                        "    speed_fraction: [1.0]\n    stopping_time: [0.5]\n"
                                        "    stopping_distance: [0.3]\n")))
    scenario = load_scenario(measured)
    assert robot_model_of(scenario.robot).placeholder is None
    assert braking_table(scenario.controller, robot_model_of(scenario.robot)).stopping_time[0] \
        == 0.5


def test_robot_model_of_names_the_prefix():
    from safety_systems.config.scenario import RobotConfig

    with pytest.raises(InputError, match=r"^robot\.model: got 'nope'"):
        robot_model_of(RobotConfig(model="nope"))
    with pytest.raises(InputError, match=r"^space\.robot\.model: got 'nope'"):
        robot_model_of(RobotConfig(model="nope"), "space.robot")
    assert robot_model_of(RobotConfig()).kind == KIND_UR


def test_a_configuration_given_with_config_is_checked_on_the_robot(tmp_path, capsys):
    panda = str(ROBOTS / "inspection_panda.yaml")
    code = main(["simulate", panda, "--config", str(MODELS / "configs" / "erga.yaml"),
                 "--out", str(tmp_path / "out"), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert "erga.yaml: config.type: got 'erga'" in err[0] and "on the panda" in err[0]
    assert main(["simulate", panda, "--config", str(MODELS / "configs" / "iso.yaml"),
                 "--duration", "1.0", "--out", str(tmp_path / "iso"), "--quiet"]) == 0
    assert "placeholder for the panda" in capsys.readouterr().err
