"""compare on seed 000's co-kitting cell: seed 001's metric with its contact gate."""

import dataclasses
from pathlib import Path

from safety_systems.outputs.compare import compare
from safety_systems.config.scenario import load_scenario

SCENARIOS = Path(__file__).parents[1] / "models" / "scenarios"


def test_a_colliding_run_scores_lower_on_safety_in_the_co_kitting_cell():
    # Without speed and separation monitoring the robot's ellipsoids meet the operator's
    # (danger index >= 1, at about 31 s); with it they do not. The run cut at 35 s.
    scenario = dataclasses.replace(load_scenario(SCENARIOS / "co_kitting.yaml"), duration=35.0)
    ssm, none = compare([scenario], ["ssm_override", "none"])
    assert none["max_danger_index"] >= 1.0 and none["contact"]
    assert ssm["max_danger_index"] < 1.0 and not ssm["contact"]
    assert none["evaluation"]["contact_free"] == 0.0
    assert none["evaluation"]["safety_score"] < ssm["evaluation"]["safety_score"]
    assert none["evaluation"]["overall_score"] < ssm["evaluation"]["overall_score"]
