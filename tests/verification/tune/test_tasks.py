"""Tune's tasks on the robot's own log (issue 51): a task scenario whose path is a real UR
RTDE log runs until the log's end, later when an operator comes close than with none,
and a small tune over such a task chooses a configuration by its task time."""

import json
import math
import shutil
from pathlib import Path

import pytest
import yaml

from safety_systems.config.scenario import load_controller_config, load_scenario
from tests.verification.conftest import MODELS, SMALL_SPACE, TUNE_BLOCK, run_cli
from verification.tune.tasks import lost_time, run_task

LOG = Path(__file__).parents[2] / "data" / "ur_rtde" / "ur3e_rad_moves.csv"
ISO = MODELS / "configs" / "iso.yaml"


def _log_task(folder: Path) -> Path:
    """inspection.yaml with the real log as the robot's path (once, robot.csv beside the
    task) and its technician's walk brought forward to the log's 9 s: in from 3 m, at
    the desk from 3 s to 8 s, gone by 14 s."""
    shutil.copy(LOG, folder / "robot.csv")
    task = yaml.safe_load((MODELS / "scenarios" / "inspection_seed.yaml").read_text())
    task["name"], task["duration"] = "logged_inspection", 15.0
    task["robot"]["cycles"] = 1
    task["robot"]["path"] = {"log": {"file": "robot.csv"}}
    technician = task["operators"][0]
    technician["leave_time"] = 20.0
    technician["waypoints"] = [
        {"time": 0.0, "position": [3.0, 0.5, 0.3]},
        {"time": 3.0, "position": [1.35, 0.0, 0.3]},
        {"time": 6.0, "position": [1.0, 0.0, 0.3]},
        {"time": 8.0, "position": [1.6, 0.3, 0.3]},
        {"time": 14.0, "position": [5.0, 1.5, 0.3]},
    ]
    path = folder / "task.yaml"
    path.write_text(yaml.safe_dump(task, sort_keys=False))
    return path


def test_a_logged_task_runs_to_the_logs_end_and_loses_time_to_an_operator(tmp_path):
    task, iso = load_scenario(_log_task(tmp_path)), load_controller_config(ISO)
    alone = run_task(task, iso, operators=False)
    # Alone, the robot runs the log's 8.96 s at its own pace, after the path rate's rise
    # from rest (at most 1 / acceleration_limit = 0.5 s, half of it lost), held only for
    # the first ticks, before the first frame (20 Hz) is tracked.
    assert 8.96 < alone.task_time < 8.96 + 0.5 and alone.stopped_time < 0.05
    run = run_task(task, iso)
    assert run.task_time is not None and run.stopped_time > 1.0
    assert lost_time(run, alone) > 1.0  # the technician at the desk held the robot


def test_tune_chooses_a_configuration_by_a_logged_tasks_time(tmp_path):
    (tmp_path / "tune.yaml").write_text(TUNE_BLOCK)
    code, _, err = run_cli(["tune", ISO, "--tune", tmp_path / "tune.yaml", "--space",
                            SMALL_SPACE, "--tasks", _log_task(tmp_path), "--out",
                            tmp_path / "tune", "--budget", "6", "--candidates", "2",
                            "--screen", "2", "--workers", "1", "--quiet"])
    assert code == 0, err
    result = json.loads((tmp_path / "tune" / "tune.json").read_text())
    assert result["chosen"]["verdict"] == "proved"
    rows = {r["configuration"]: r["tasks"]["logged_inspection"] for r in result["table"]}
    alone = run_task(load_scenario(tmp_path / "task.yaml"), load_controller_config(ISO),
                     operators=False)
    for name in ("chosen", "iso.yaml"):
        assert rows[name]["no_operator"] == pytest.approx(alone.task_time, abs=1e-9)
        assert math.isfinite(rows[name]["task_time"])
        assert rows[name]["lost_time"] > 1.0  # the technician held the robot
    assert rows["chosen"]["task_time"] <= rows["iso.yaml"]["task_time"]
