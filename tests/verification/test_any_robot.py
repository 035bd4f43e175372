"""Any robot (issue 35): on a UR10e (the UR family) and on the Franka Panda (a chain from
its URDF), ``verify`` proves over a space on that robot's path, ``tune`` chooses a
configuration it proves and times that robot's task, ``export`` certifies it with the
robot named and its URDF's SHA-256, ``check`` accepts it and refuses an edited robot
description, and ``simulate`` runs the certified parameters on that robot."""

import hashlib
import json
import shutil
from pathlib import Path

import pytest
import yaml

from tests.verification.conftest import TUNE_BLOCK, _shared, run_cli

ROOT = Path(__file__).parents[2]
MODELS = ROOT / "models"
SMALL_SPACE = Path(__file__).parent / "small_space.yaml"
ROBOTS = {
    "ur10e": {"robot": {"model": "ur10e"}, "config": "iso_ur10e.yaml",
              "task": "inspection_ur10e.yaml", "space": "default_ur10e.yaml"},
    "panda": {"robot": {"urdf": str(MODELS / "panda" / "panda.urdf")},
              "config": "iso_panda.yaml", "task": "inspection_panda.yaml",
              "space": "default_panda.yaml", "tool": {"payload_radius": 0.07,
                                                      "tool_length": 0.12}},
}


def _small_space(robot: str, folder: Path) -> Path:
    """tests/verification/small_space.yaml on ``robot`` and its path (the robot block of
    its shipped default space)."""
    space = yaml.safe_load(SMALL_SPACE.read_text())
    shipped = yaml.safe_load((MODELS / "spaces" / "robots" / ROBOTS[robot]["space"])
                             .read_text())
    space["robot"] = dict(shipped["robot"], **ROBOTS[robot]["robot"])
    space["name"] = f"small_{robot}"
    path = folder / f"small_{robot}.yaml"
    path.write_text(yaml.safe_dump(space, sort_keys=False))
    return path


def _task(robot: str, folder: Path) -> Path:
    """The robot's inspection task, cut to 3 cycles and 25 s."""
    task = yaml.safe_load((MODELS / "scenarios" / "robots" / ROBOTS[robot]["task"])
                          .read_text())
    task["duration"], task["robot"]["cycles"] = 25.0, 3
    task["robot"].update(ROBOTS[robot]["robot"])
    path = folder / "task.yaml"
    path.write_text(yaml.safe_dump(task, sort_keys=False))
    return path


def _tune_and_export(robot: str):
    def build(root: Path) -> None:
        space, task = _small_space(robot, root), _task(robot, root)
        (root / "tune.yaml").write_text(TUNE_BLOCK)
        config = MODELS / "configs" / "robots" / ROBOTS[robot]["config"]
        code, _, err = run_cli(["verify", config, "--space", space, "--out", root / "verify",
                                "--budget", "16", "--workers", "1", "--quiet"])
        assert code == 0, err
        code, _, err = run_cli(["tune", config, "--tune", root / "tune.yaml", "--space", space,
                                "--tasks", task, "--out", root / "tune", "--budget", "16",
                                "--candidates", "2", "--screen", "2", "--workers", "1",
                                "--quiet"])
        assert code == 0, err
        chosen = json.loads((root / "tune" / "tune.json").read_text())["chosen"]
        code, _, err = run_cli(["export", chosen["config"], "--report", chosen["report"],
                                "--out", root / "export", "--quiet"])
        assert code == 0, err
    return build


@pytest.fixture(scope="module", params=list(ROBOTS))
def robot_run(request, tmp_path_factory, worker_id) -> tuple[str, Path]:
    robot = request.param
    return robot, _shared(tmp_path_factory, worker_id, f"any_robot_{robot}",
                          _tune_and_export(robot))


def test_verify_proves_both_properties_on_the_robot_s_path(robot_run):
    robot, root = robot_run
    report = json.loads((root / "verify" / "report.json").read_text())
    assert report["verdict"] == "proved"
    assert all(p["proof"]["proved"] for p in report["properties"].values())
    assert report["robot"]["model"] == robot
    premises = [x["statement"] for p in report["properties"].values()
                for x in p["proof"]["premises"]]
    assert any(f"the {robot} model's capsules contain the real arm" in x for x in premises)
    assert any(f"PLACEHOLDER FOR THE {robot.upper()}" in x for x in premises)
    markdown = (root / "verify" / "report.md").read_text()
    assert f"- robot: {robot} (" in markdown and f"placeholder for the {robot}" in markdown
    # (the words the verification's resolved cell gave, kept in the report)
    assert f"placeholder for the {robot}" in report["braking_data_warning"]


def test_tune_chooses_a_proved_configuration_timed_on_the_robot_s_task(robot_run):
    robot, root = robot_run
    result = json.loads((root / "tune" / "tune.json").read_text())
    assert result["chosen"]["verdict"] == "proved"
    rows = {r["configuration"]: r for r in result["table"]}
    assert rows["chosen"]["total_task_time"] is not None  # the task on that robot ran
    task = yaml.safe_load((root / "task.yaml").read_text())
    assert set(rows["chosen"]["tasks"]) == {task["name"]}


def test_export_names_the_robot_and_check_refuses_another_robot_description(robot_run,
                                                                           tmp_path):
    robot, root = robot_run
    export = root / "export"
    cert = json.loads((export / "certificate.json").read_text())
    assert cert["robot"]["model"] == robot
    code, out, err = run_cli(["check", export / "params.yaml"])
    assert code == 0, err
    params = (export / "params.yaml").read_text()
    if robot == "ur10e":
        assert 'robot.model: "ur10e"' in params and "robot.urdf" not in params
        return
    # The Panda's URDF is named relative to params.yaml; a copy of the export beside an
    # edited copy of the URDF is refused in one line naming the file.
    (line,) = [x for x in params.splitlines() if "robot.urdf:" in x]
    written = line.split(":", 1)[1].strip().strip('"')
    assert not Path(written).is_absolute()
    assert (export / written).resolve() == (MODELS / "panda" / "panda.urdf").resolve()
    assert cert["robot"]["urdf_sha256"] == hashlib.sha256(
        (MODELS / "panda" / "panda.urdf").read_bytes()).hexdigest()
    copy = tmp_path / "a" / "b" / "export"
    shutil.copytree(export, copy)
    urdf = (copy / written).resolve()
    urdf.parent.mkdir(parents=True, exist_ok=True)
    shutil.copytree(MODELS / "panda", urdf.parent, dirs_exist_ok=True)
    code, _, err = run_cli(["check", copy / "params.yaml"])
    assert code == 0, err
    urdf.write_text(urdf.read_text().replace('velocity="2.175"', 'velocity="2.300"', 1))
    code, _, err = run_cli(["check", copy / "params.yaml"])
    assert code == 1 and err.count("\n") == 1 and "urdf_sha256" in err and "panda" in err


def test_simulate_runs_the_certified_parameters_on_that_robot(robot_run, tmp_path):
    robot, root = robot_run
    code, out, err = run_cli(["simulate", root / "task.yaml", "--config",
                              root / "export" / "params.yaml", "--out", tmp_path / "sim",
                              "--duration", "6", "--quiet"])
    assert code == 0, err
    summary = json.loads((tmp_path / "sim" / "summary.json").read_text())
    assert summary["braking_data"] == "placeholder"
    assert not summary["contact_while_moving"]
