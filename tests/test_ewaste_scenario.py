"""Seed 001's e-waste sorting cell: the planned path in the workcell, zones and gestures."""

from pathlib import Path

import numpy as np
import pytest

from safety_systems.outputs.compare import compare
from safety_systems.outputs.metrics import task_time, tool_state
from safety_systems.config.scenario import load_scenario
from safety_systems.diagrams.simulation import simulate

SCENARIO = Path(__file__).parents[1] / "models" / "scenarios" / "ewaste_sorting.yaml"


@pytest.fixture(scope="module")
def run():
    return simulate(load_scenario(SCENARIO))


def test_the_cycles_finish_within_the_duration(run):
    finished = task_time(run)
    assert finished is not None and finished < run.scenario.duration


def test_the_robot_runs_the_planned_path(run):
    points = np.array(run.scenario.robot.path.task_path.points)
    p, _ = tool_state(run)
    # It starts at the planned start and reaches the planned goal, along the planned points.
    np.testing.assert_allclose(p[0], points[0], atol=1e-6)
    assert np.min(np.linalg.norm(p - points[-1], axis=1)) < 2e-3
    nearest = np.min(np.linalg.norm(p[:, None, :] - points[None, ::10, :], axis=2), axis=0)
    assert nearest.max() < 5e-3


def test_zone_speeds_and_gestures(run):
    cfg = run.scenario.controller.zones
    k = run["zones.path_speed_commanded"][:, 0]
    zone = run["zones.zone"][:, 0]
    assert {0.0, 1.0, 2.0} <= set(np.unique(zone))  # the operator visits every zone
    assert np.all(k[zone == 2] <= cfg.red_speed + 1e-12)
    assert np.all(k[zone == 1] <= cfg.yellow_speed + 1e-12)
    stopped = (run.time > 20.02) & (run.time < 24.0)  # stop at 20 s, resume at 24 s
    assert np.all(k[stopped] == 0.0)
    _, speed = tool_state(run)
    assert np.all(speed[(run.time > 21.0) & (run.time < 24.0)] < 1e-9)
    assert k[(run.time > 25.0) & (run.time < 30.0)].max() > 0.0


def test_compare_scores_the_zones_controller():
    scenario = load_scenario(SCENARIO)
    scenario = type(scenario)(**{**scenario.__dict__, "duration": 12.0})
    rows = compare([scenario], ["zones", "none"])
    for r in rows:
        e = r["evaluation"]
        assert 0.0 <= e["overall_score"] <= 100.0
        assert e["overall_score"] == pytest.approx(0.8 * e["safety_score"]
                                                   + 0.2 * e["efficiency_score"])
    zones, none = rows
    # Slowing down near the operator costs task progress and smoothness of progress.
    assert zones["evaluation"]["task_completion"] < none["evaluation"]["task_completion"]
    assert zones["evaluation"]["efficiency_score"] < none["evaluation"]["efficiency_score"]
