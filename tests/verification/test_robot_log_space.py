"""A real UR RTDE log as the robot's path (issue 51): it drives the robot in the Drake
diagram and in the batched evaluator, which agree scenario by scenario; ``verify`` runs
over a space around it; its export names the log relative to params.yaml, the
certificate names it with its SHA-256 and ``check`` refuses an edited log; ``run --robot
none`` follows it."""

import csv
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from safety_systems.config.configuration import joint_path
from safety_systems.config.scenario import load_controller_config, robot_model_of
from tests.verification.conftest import run_cli
from tests.verification.search.test_evaluate_batch import _assert_agree, _three_scenarios
from verification.search.evaluate_batch import evaluate_many
from verification.search.evaluate_drake import evaluate_drake
from verification.spaces.space import load_space

ROOT = Path(__file__).parents[2]
LOG = ROOT / "tests" / "data" / "ur_rtde" / "ur3e_rad_moves.csv"
SMALL_SPACE = Path(__file__).parent / "small_space.yaml"
ISO = ROOT / "models" / "configs" / "iso.yaml"
RECORDINGS = ROOT / "models" / "recordings"


def _space(folder: Path, model: str = "") -> Path:
    """tests/verification/small_space.yaml with the real log as the robot's path (the
    log beside the space, named relative to it), approaches from farther out; the robot
    ``model`` (empty: the default, a UR5e)."""
    (folder / "robot.csv").write_bytes(LOG.read_bytes())
    space = yaml.safe_load(SMALL_SPACE.read_text())
    space["name"] = "small_logged"
    space["robot"]["path"] = {"log": {"file": "robot.csv"}}
    if model:
        space["robot"]["model"] = model
    # From as far as 4.5 m: under iso.yaml the robot runs only while every envelope of
    # the operator is beyond S (2.41 m), and a comparison needs it to run.
    space["parameters"]["start_distance"] = {"min": 0.6, "max": 4.5}
    path = folder / "space.yaml"
    path.write_text(yaml.safe_dump(space, sort_keys=False))
    return path


@pytest.mark.parametrize("model", ["", "ur3e"], ids=["ur5e", "ur3e"])
def test_the_logged_path_drives_drake_and_the_batch_alike(tmp_path, model):
    """On the default UR5e and on the UR3e, the arm that recorded the log."""
    space = load_space(_space(tmp_path, model))
    assert robot_model_of(space.robot).name == (model or "ur5e")
    path = joint_path(space.robot)
    assert path.cycles == 1 and abs(path.cycle_time - 8.96) < 1e-6
    scenarios = _three_scenarios(space, load_controller_config(ISO), 20261127)
    batch = evaluate_many(scenarios)
    assert np.isfinite(batch.robustness).any()  # the robot moved near someone
    for i, scenario in enumerate(scenarios):
        drake, _ = evaluate_drake(scenario)
        _assert_agree(drake, batch, i)


@pytest.fixture(scope="module")
def logged(tmp_path_factory) -> Path:
    """A folder holding the space around the log (space.yaml, robot.csv beside it), its
    verification under iso.yaml (verify/, budget 8) and its export (export/)."""
    folder = tmp_path_factory.mktemp("logged")
    space = _space(folder)
    code, _, err = run_cli(["verify", ISO, "--space", space, "--out", folder / "verify",
                            "--budget", "8", "--workers", "1", "--quiet"])
    assert code == 0, err
    code, _, err = run_cli(["export", ISO, "--report", folder / "verify" / "report.json",
                            "--out", folder / "export", "--quiet"])
    assert code == 0, err
    return folder


def test_verify_runs_over_a_space_around_the_log_and_names_it(logged):
    report = json.loads((logged / "verify" / "report.json").read_text())
    assert report["verdict"] == "proved"  # iso.yaml over the log's space
    inputs = json.dumps(report)
    assert "robot.csv" in inputs and _sha256(LOG) in inputs  # the log among the inputs
    # The premises name the log and take its speed: the real arm's base at 60.8 deg/s
    # (the spline's peak; 60.5 between two samples), within the placeholder's 183 deg/s.
    assert f"the robot runs its log robot.csv (SHA-256 {_sha256(LOG)})" in inputs
    assert ("the log's joints are no faster than the placeholder stopping data's full speed "
            "(60.8 deg/s (actual_q_0) <= 183 deg/s)") in inputs


def test_the_export_names_the_log_and_check_refuses_it_edited(logged, tmp_path):
    export = logged / "export"
    values = [x for x in (export / "params.yaml").read_text().splitlines()
              if not x.startswith("#")]  # (the header's comments name the space verified)
    # params.yaml names the log relative to itself, as it does a URDF: no absolute path.
    assert '    robot.path.log.file: "../robot.csv"' in values
    assert not any(str(logged) in x or '"/' in x for x in values)
    certificate = json.loads((export / "certificate.json").read_text())
    assert certificate["robot"]["log"] == {"file": "../robot.csv", "sha256": _sha256(LOG)}
    assert "the robot&#x27;s own log ../robot.csv" in (export / "report.html").read_text()
    assert run_cli(["check", export / "params.yaml"])[0] == 0
    # The export and its log moved together stay certified.
    moved = tmp_path / "moved"
    shutil.copytree(export, moved / "export")
    shutil.copy(logged / "robot.csv", moved / "robot.csv")
    params = moved / "export" / "params.yaml"
    code, out, err = run_cli(["check", params])
    assert code == 0 and ("certified proved" in out or "certified passed" in out), err
    # One sample's wrist 1 0.1 mrad off (still a good log: the checks pass it) voids the
    # certificate; check names the log, its digest and the certified one, in one line.
    rows = list(csv.reader((moved / "robot.csv").read_text().splitlines()))
    column = rows[0].index("actual_q_3")
    rows[100][column] = repr(float(rows[100][column]) + 1e-4)
    (moved / "robot.csv").write_text("\n".join(",".join(r) for r in rows) + "\n")
    code, _, err = run_cli(["check", params])
    line = err.strip()
    assert code == 1 and "\n" not in line
    assert line.startswith(f"safety-systems: {moved / 'robot.csv'}: sha256: got ")
    assert f"allowed: the certified {_sha256(LOG)[:12]}... (the robot's log is not the one " \
        "verified)" in line
    # A missing log is a file that cannot be read: exit 2, one line naming it.
    (moved / "robot.csv").unlink()
    code, _, err = run_cli(["check", params])
    assert code == 2 and "\n" not in err.strip() and "robot.csv" in err


def test_run_with_robot_none_follows_the_certified_log(logged, tmp_path):
    from safety_systems.cli import main
    from safety_systems.runtime.params import load_certified_params
    from safety_systems.config.resolved_cell import resolve
    from safety_systems.runtime.robot_link import ModelRobot

    params = logged / "export" / "params.yaml"
    # The operator 10 m off the recorded approach: the robot may run its log.
    mapping = (RECORDINGS / "approach_mapping.yaml").read_text()
    assert "translation: [0.6, -0.8, 0.0]" in mapping
    (tmp_path / "far.yaml").write_text(mapping.replace("translation: [0.6, -0.8, 0.0]",
                                                       "translation: [10.6, -0.8, 0.0]"))
    code = main(["run", str(params), "--mocap",
                 f"replay://{RECORDINGS / 'approach.csv'}?duration=1.5", "--robot", "none",
                 "--mapping", str(tmp_path / "far.yaml"), "--log", str(tmp_path / "run"),
                 "--quiet"])
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert code == 0 and summary["certified"] is True and summary["end"] == "duration"
    from safety_systems.sensing.run_log import read_run_log

    speeds = read_run_log(tmp_path / "run" / "log-0000.mcap").column("robot_speed")
    assert np.nanmax(speeds) > 0.1  # m/s: the model robot ran the log (the arm starts in a move)
    # The model robot of the certified parameters is the log's path: at the log's first
    # sample before it moves, then along the log as its path rate takes it.
    certified = load_certified_params(params)
    robot = ModelRobot(resolve(certified.controller, certified.robot))
    assert robot.path.cycle_time == pytest.approx(8.96) and robot.path.cycles == 1
    first = np.array([float(x) for x in LOG.read_text().splitlines()[1].split(",")[7:13]])
    assert np.abs(robot.read()[0] - first).max() < 1e-12
    robot.command(1.0)
    robot.advance_to(2.0)
    q, _ = robot.read()
    assert robot.s > 1.0 and np.abs(q - joint_path(certified.robot).spline(robot.s)).max() < 1e-12


def _sha256(path: Path) -> str:
    import hashlib

    return hashlib.sha256(path.read_bytes()).hexdigest()
