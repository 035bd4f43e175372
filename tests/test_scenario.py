from pathlib import Path

import numpy as np
import pytest

from safety_systems.cell.human_body import POINTS
from safety_systems.config.scenario import (
    ScenarioError,
    dump_scenario,
    load_scenario,
    operator_points,
    operator_posture,
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
  bodies: [{name: l, point: hand_left, offset: [0, 0.2, 0]},
           {name: r, point: hand_right, offset: [0, -0.2, 0]}]
  waypoints: [{time: 0, position: [2, 0, 1]}]
"""
# A helmet and a glove under legacy names (no point: head and hand_right), the operator at
# x = 2 m facing the robot base (-x; its right is +y), the glove 0.9 m before the helmet.
REACH = """
operators:
- name: a
  bodies: [{name: head}, {name: hand, offset: [-0.9, 0, -0.2]}]
  waypoints: [{time: 0, position: [2, 0, 1.6]}]
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
        (OK + "  max_speed: 4.5\n", "operators[0].max_speed"),
        # One body is now enough (a helmet alone: the monitor bounds the rest of the
        # operator, human_body); none is not.
        (OK.replace("""{name: l, point: hand_left, offset: [0, 0.2, 0]},
           {name: r, point: hand_right, offset: [0, -0.2, 0]}""", ""), "operators[0].bodies"),
        (OK.replace("point: hand_left", "point: knee"), "operators[0].bodies[0].point"),
        (OK + "  posture: [{point: chest, offset: [0, 0]}]\n", "operators[0].posture[0].offset"),
        (OK + "  posture: [{point: elbow}]\n", "operators[0].posture[0].point"),
        ("controller: {body: {upper_arm: 3}}", "controller.body.upper_arm"),
        ("controller: {body: {trunk_lean_deg: 90}}", "controller.body.trunk_lean_deg"),
        ("controller: {body: {tracking_allowance: -0.01}}", "controller.body.tracking_allowance"),
        ("controller: {body: {knee: 0.5}}", "controller.body.knee"),
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
    assert operator_points(s.operators[0]) == ["hand_left", "hand_right"]


def test_one_body_is_an_operator():
    s = scenario_from_text(OK.replace("""
           {name: r, point: hand_right, offset: [0, -0.2, 0]}""", ""))
    assert operator_points(s.operators[0]) == ["hand_left"]


def _error(text):
    with pytest.raises(ScenarioError) as e:
        scenario_from_text(text)
    assert "allowed" in str(e.value) and "\n" not in str(e.value)
    return e.value


def test_a_body_needs_a_point_unless_its_name_is_a_legacy_one():
    # l is not a legacy name: without point it marks nothing, and the error names the
    # field and every allowed point.
    e = _error(OK.replace("point: hand_left, ", ""))
    assert e.field == "operators[0].bodies[0].point"
    assert all(p in str(e) for p in POINTS)
    # The three-ball operator's names mark their points without point:.
    s = scenario_from_text(OK.replace("name: l, point: hand_left", "name: left_glove")
                           .replace("name: r, point: hand_right", "name: right_glove"))
    assert operator_points(s.operators[0]) == ["hand_left", "hand_right"]
    s = scenario_from_text(REACH.replace("offset: [-0.9, 0, -0.2]", "offset: [-0.3, 0, -0.4]")
                           .replace("{name: head}", "{name: head}, {name: other_hand, "
                                                    "offset: [-0.3, -0.3, -0.4]}"))
    assert operator_points(s.operators[0]) == ["head", "hand_left", "hand_right"]
    # A point given to a legacy name is the point it marks.
    s = scenario_from_text(REACH.replace("{name: hand,", "{name: hand, point: elbow_right,"))
    assert operator_points(s.operators[0]) == ["head", "elbow_right"]


def test_two_bodies_cannot_mark_one_point():
    e = _error(OK.replace("point: hand_right", "point: hand_left"))
    assert e.field == "operators[0].bodies[1].point"
    # a legacy name's point counts as marked too
    e = _error(REACH.replace("{name: head}", "{name: helmet, point: hand_right}"))
    assert e.field == "operators[0].bodies[1].point"


def test_posture_places_untracked_points():
    s = scenario_from_text(OK + "  posture: [{point: chest, offset: [0.3, 0.05, 0.1]},\n"
                                "            {point: head, offset: [0.3, 0, 0.5]}]\n")
    o = s.operators[0]
    assert [q.point for q in o.posture] == ["chest", "head"]
    assert operator_points(o) == ["hand_left", "hand_right"]  # the posture is not tracked
    posture = operator_posture(o)
    assert posture.shape == (len(POINTS), 3)
    for name, offset in (("hand_left", [0, 0.2, 0]), ("hand_right", [0, -0.2, 0]),
                         ("chest", [0.3, 0.05, 0.1]), ("head", [0.3, 0, 0.5])):
        np.testing.assert_array_equal(posture[POINTS.index(name)], offset)
    # the rest stands upright under the given head: the pelvis straight below it
    pelvis = posture[POINTS.index("pelvis")]
    np.testing.assert_allclose(pelvis[:2], [0.3, 0.0])
    assert pelvis[2] < 0.0
    assert scenario_from_text(dump_scenario(s)) == s
    # A posture point a body marks, or one the posture places twice, is refused.
    e = _error(OK + "  posture: [{point: hand_right, offset: [0, 0, 0]}]\n")
    assert e.field == "operators[0].posture[0].point"
    e = _error(OK + "  posture: [{point: chest}, {point: chest}]\n")
    assert e.field == "operators[0].posture[1].point"


def test_a_hand_out_of_its_shoulders_reach_is_refused_in_one_line():
    # The right shoulder stands 0.92 m from the glove, beyond the 0.73 m arm the posture
    # bends: refused at the bodies, naming the hand, its distance and the reach.
    e = _error(REACH)
    assert e.field == "operators[0].bodies"
    assert "hand_right" in str(e) and "0.920 m" in str(e) and "0.73 m" in str(e)
    # Giving the posture (the shoulder within reach) makes it one the operator can take.
    s = scenario_from_text(REACH + "  posture: [{point: shoulder_right, "
                                   "offset: [-0.22, 0.15, -0.15]}]\n")
    np.testing.assert_array_equal(operator_posture(s.operators[0])[POINTS.index(
        "shoulder_right")], [-0.22, 0.15, -0.15])


def test_a_recorded_operator_has_no_posture():
    # Its mapping names the points its bodies mark; the rest the monitor and the truth
    # take from the recording alone.
    text = OK.replace("waypoints: [{time: 0, position: [2, 0, 1]}]",
                      "recording: a.csv\n  mapping: a.yaml\n"
                      "  posture: [{point: chest, offset: [0, 0, 0]}]")
    e = _error(text)
    assert e.field == "operators[0].posture"
