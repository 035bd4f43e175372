from pathlib import Path

import pytest

from safety_systems.config.scenario import (
    ScenarioError,
    dump_scenario,
    load_scenario,
    scenario_from_text,
)

SCENARIOS = sorted((Path(__file__).parents[1] / "models" / "scenarios").glob("*.yaml"))


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.name for p in SCENARIOS])
def test_shipped_scenarios_load_and_round_trip(path):
    s = load_scenario(path)
    assert scenario_from_text(dump_scenario(s)) == s


OK = """
operators:
- name: a
  bodies: [{name: l, offset: [0, 0.2, 0]}, {name: r, offset: [0, -0.2, 0]}]
  waypoints: [{time: 0, position: [2, 0, 1]}]
"""


@pytest.mark.parametrize(
    "text, field",
    [
        ("duration: foo", "duration"),
        ("durashun: 3", "durashun"),
        ("robot: {mode: fast}", "robot.mode"),
        ("robot: {cycles: 1.5}", "robot.cycles"),
        ("controller: {sensor: {rate_hz: 5}}", "controller.sensor.rate_hz"),
        ("controller: {safety: {human_speed: guess}}", "controller.safety.human_speed"),
        ("controller: {safety: {delta_s: 0.5}}", "controller.safety.delta_s"),
        ("controller: {safety: {stopping: current}}", "controller.safety.stopping"),
        (OK.replace("[0, 0.2, 0]", "[0, x, 0]"), "operators[0].bodies[0].offset[1]"),
        (OK + "  max_speed: 2.5\n", "operators[0].max_speed"),
        (OK.replace("{name: r, offset: [0, -0.2, 0]}", ""), "operators[0].bodies"),
    ],
)
def test_bad_values_name_the_field(text, field):
    with pytest.raises(ScenarioError) as e:
        scenario_from_text(text)
    assert e.value.field == field
    assert "allowed" in str(e.value) and "\n" not in str(e.value)


def test_good_minimal_scenario():
    s = scenario_from_text(OK)
    assert s.operators[0].bodies[1].offset == [0, -0.2, 0]
