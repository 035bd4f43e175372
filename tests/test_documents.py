"""The rules every input file is read under (``safety_systems.files.documents``)."""

import dataclasses as dc
import hashlib
import math
from pathlib import Path

import pytest

from safety_systems.files import documents
from safety_systems.files.documents import load_document
from safety_systems.files.input_error import InputError
from safety_systems.files.ranges import Limits, field_limits, number, unranged_fields
from safety_systems.sensing.recording_mapping import RecordingMapping
from safety_systems.config.scenario import (
    MAX_DURATION,
    ControllerConfig,
    OperatorConfig,
    Scenario,
    TaskPoints,
    load_controller_config,
    load_scenario,
)
from safety_systems.config.params_file import Params
from safety_systems.planning.task_space import TaskScene, load_scene
from verification.spaces.box import ScenarioSpace
from verification.spaces.space import load_space
from verification.tune.tunable import TunableConfig, TuneFile

MODELS = Path(__file__).parents[1] / "models"
INSPECTION = MODELS / "scenarios" / "inspection_seed.yaml"


def _load(tmp_path, data, schema=Scenario, validate=None):
    path = tmp_path / "doc.yaml"
    path.write_bytes(data if isinstance(data, bytes) else data.encode())
    with pytest.raises(InputError) as e:
        load_document(path, schema, validate)
    line = str(e.value)
    assert "\n" not in line and line.startswith(f"{path}: ") and "allowed: " in line
    return e.value


@pytest.mark.parametrize("data, field, needle", [
    (b"\x00\x01\x02binary", "<file>", "binary"),
    ("duration: 3\n".encode("utf-16"), "<file>", "binary"),
    (b"duration: 3\xff\n", "<file>", "binary"),
    ("robot:\n\tmode: kinematic\n", "line 2, column 1", "tab"),
    ("robot: {mode: [kinematic}\n", "line 1, column 25", "YAML syntax"),
    ("duration: 3\n---\nduration: 4\n", "line 2, column 1", "one YAML document"),
    ("", "<document>", "none"),
    ("# a comment and nothing else\n", "<document>", "none"),
    ("- 1\n- 2\n", "<document>", "a mapping of Scenario fields"),
    ("operators: {name: a}\n", "operators", "a list"),
    ("robot: [1, 2]\n", "robot", "a mapping of RobotConfig fields"),
    ("robot:\n", "robot", "a mapping of RobotConfig fields"),
    ("operators: [[1, 2]]\n", "operators[0]", "a mapping of OperatorConfig fields"),
    ("duration: 3\nduration: 4\n", "duration", "the first is on line 1"),
    ("robot:\n  mode: kinematic\n  cycles: 2\n  mode: dynamic\n", "robot.mode",
     "the first is on line 2"),
    ("operators:\n- {name: a, name: b}\n", "operators[0].name", "each key once"),
    ("a: &a [1, *a]\n", "a[1]", "recursive"),
    ("duration: !!python/object:os.system {}\n", "line 1, column 11", "no tags"),
    ("duration: !Seconds 3\n", "line 1, column 11", "no tags"),
    ("1: 2\n", "1", "one of the fields"),
    # A typo in a nested field: the nearest field first, then every field.
    ("controller: {safety: {iso_humna_speed: 2.0}}\n", "controller.safety.iso_humna_speed",
     "allowed: did you mean iso_human_speed? (one of the fields ['clamp_margin', "),
    ("robot: {cycels: 2}\n", "robot.cycels", "did you mean cycles?"),
    ("duration: true\n", "duration", "a number"),
    ("duration: 10e400\n", "duration", "0 < duration <= 600 s"),
    ("robot: {cycles: 2.5}\n", "robot.cycles", "an integer"),
    ("name: [a]\n", "name", "a string"),
    ("duration: 1.0e12\n", "duration", f"0 < duration <= {MAX_DURATION:g} s"),
    ("duration: .nan\n", "duration", "0 < duration <= 600 s"),
    ("duration: -.inf\n", "duration", "0 < duration <= 600 s"),
    ("controller: {safety: {iso_human_speed: 1.0e300}}\n",
     "controller.safety.iso_human_speed", "<= 10 m/s"),
    ("robot: {cycles: 100000000000000000000000000}\n", "robot.cycles",
     "an integer, 1 <= cycles <= 1000"),
    ("robot: {path: {waypoints_deg: [[0, 0, 0, 0, 0, 720]]}}\n",
     "robot.path.waypoints_deg[0][5]", "-360 <= waypoints_deg <= 360 deg"),
    # The whole operator's schema: a body's former radius is no field (it marks a point
    # now), the body model's figures and posture offsets have their ranges.
    ("operators: [{bodies: [{name: hand, radius: 0.05}]}]\n", "operators[0].bodies[0].radius",
     "one of the fields"),
    ("controller: {body: {neck_lean_deg: 95}}\n", "controller.body.neck_lean_deg",
     "0 <= neck_lean_deg <= 89 deg"),
    ("controller: {body: {hand_radius: 0}}\n", "controller.body.hand_radius",
     "0 < hand_radius <= 2 m"),
    ("operators: [{posture: [{point: chest, offset: [0, 0, 3]}]}]\n",
     "operators[0].posture[0].offset[2]", "-2 <= offset <= 2 m"),
])
def test_bad_documents_give_one_line_naming_the_field(tmp_path, data, field, needle):
    error = _load(tmp_path, data)
    assert error.field == field and needle in str(error), str(error)


def test_a_name_near_no_field_gets_no_guess(tmp_path):
    error = _load(tmp_path, "controller: {safety: {xyz: 1}}\n")
    assert "did you mean" not in str(error) and "one of the fields" in str(error)


def test_values_are_shortened(tmp_path):
    error = _load(tmp_path, "name: " + "x" * 10_000 + "\nrobot: {mode: [" + "1, " * 5000 + "1]}\n")
    assert len(str(error)) < 400 and "..." in str(error)


def test_a_merge_key_may_be_overridden_and_private_templates_are_dropped(tmp_path):
    path = tmp_path / "doc.yaml"
    path.write_text("_fast: &fast {mode: dynamic, cycles: 2}\n"
                    "robot:\n  <<: *fast\n  mode: kinematic\n")
    robot = load_document(path, Scenario).robot
    assert (robot.mode, robot.cycles) == ("kinematic", 2)


def test_aliases_cannot_blow_up(tmp_path):
    lines = ["_a0: &a0 [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]",
             "_a1: &a1 [" + ", ".join(["*a0"] * 200_000) + "]",
             "robot: {path: {waypoints_deg: *a1}}"]
    error = _load(tmp_path, "\n".join(lines) + "\n")
    assert "at most 1000000 values" in str(error)


def test_a_file_too_large_is_refused_before_parsing(tmp_path, monkeypatch):
    monkeypatch.setattr(documents, "MAX_BYTES", 100)
    error = _load(tmp_path, "name: " + "x" * 200 + "\n")
    assert error.field == "<file>" and "at most 100 bytes" in str(error)


def test_a_missing_file_names_it(tmp_path):
    with pytest.raises(InputError) as e:
        load_document(tmp_path / "none.yaml", Scenario)
    assert "none.yaml" in str(e.value) and "readable file" in str(e.value)


def test_validation_errors_name_the_file(tmp_path):
    error = _load(tmp_path, "controller: {zones: {green_distance: 0.4, yellow_distance: 0.5}}\n",
                  ControllerConfig, None)
    assert error.field == "controller"  # ControllerConfig has no field 'controller'
    path = tmp_path / "config.yaml"
    path.write_text("zones: {green_distance: 0.4, yellow_distance: 0.5}\n")
    with pytest.raises(InputError) as e:
        load_controller_config(path)
    assert str(e.value).startswith(f"{path}: config.zones.green_distance: got [0.4, 0.5]")


@pytest.mark.parametrize("schema", [Scenario, ControllerConfig, ScenarioSpace, TaskScene,
                                    TaskPoints, RecordingMapping, Params, TunableConfig,
                                    TuneFile])
def test_every_number_of_every_schema_declares_its_range(schema):
    assert unranged_fields(schema) == []


def test_unranged_fields_finds_a_number_without_a_range():
    @dc.dataclass
    class Inner:
        ok: float = number(1.0, gt=0.0, le=2.0)
        bare: list[int] = dc.field(default_factory=list)

    @dc.dataclass
    class Outer:
        inner: Inner = dc.field(default_factory=Inner)
        also: float = 0.0

    assert unranged_fields(Outer) == ["Inner.bare", "Outer.also"]


def test_limits_are_open_or_closed_and_infinity_only_where_declared():
    limits = Limits(0.0, 1.0, low_open=True)
    assert [limits.holds(x) for x in (0.0, 1e-300, 1.0, 1.0 + 1e-12, math.inf, math.nan)] == [
        False, True, True, False, False, False]
    never = field_limits(OperatorConfig, "leave_time")
    assert never.holds(math.inf) and not never.holds(-math.inf) and not never.holds(math.nan)


def test_shipped_files_load_and_their_hashes_are_remembered():
    documents.forget_inputs()
    for path in sorted((MODELS / "scenarios").glob("*.yaml")):
        load_scenario(path)
    for path in sorted((MODELS / "configs").glob("*.yaml")):
        load_controller_config(path)
    for path in sorted((MODELS / "spaces").glob("*.yaml")):
        load_space(path)
    load_scene(MODELS / "scenes" / "paper.yaml")
    read = documents.inputs_read()
    assert read[str(INSPECTION)] == hashlib.sha256(INSPECTION.read_bytes()).hexdigest()
    # The task path that ewaste_sorting.yaml names is read, and so hashed, too.
    assert any(p.endswith("paper_task_path.yaml") for p in read)
    documents.forget_inputs()
    assert documents.inputs_read() == {}


@pytest.mark.parametrize("name", ["a\\0b", "/", "x" * 300, "../none.yaml"])
def test_a_task_path_file_that_cannot_be_read_is_named(tmp_path, name):
    path = tmp_path / "scenario.yaml"
    path.write_text(f'robot: {{path: {{task_path: {{file: "{name}"}}}}}}\n')
    with pytest.raises(InputError) as e:
        load_scenario(path)
    assert e.value.field == "robot.path.task_path.file" and "\n" not in str(e.value)
    assert str(e.value).startswith(f"{path}: ")
