"""params.yaml: a ROS 2 parameter file that the project's own loader reads back exactly,
and refuses in one line when it is not one."""

import dataclasses
import re
from pathlib import Path

import pytest
import yaml

from safety_systems.files.input_error import InputError
from safety_systems.config.params_file import (
    NODE,
    Params,
    deployed_controller,
    deployed_robot,
    load_params,
    params_text,
    robot_config,
)
from safety_systems.config.scenario import (
    Box,
    RobotConfig,
    TaskPathConfig,
    load_controller_config,
    load_scenario,
)

MODELS = Path(__file__).parents[1] / "models"
CONFIGS = sorted((MODELS / "configs").glob("*.yaml"))
ROS_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*(\.[A-Za-z][A-Za-z0-9_]*)*")


def ros2_parameter_file(text: str) -> dict:
    """The parameters of a ROS 2 parameter file (as rcl_yaml_param_parser takes one):
    one node key, then ros__parameters, then names of letters, digits and '_' joined by
    '.', each holding a scalar (bool, integer, double, string) or a non-empty array of
    scalars of one type; raises AssertionError otherwise."""
    data = yaml.safe_load(text)
    assert isinstance(data, dict) and len(data) == 1, "one node key"
    (node, body), = data.items()
    assert isinstance(node, str) and re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", node)
    assert isinstance(body, dict) and list(body) == ["ros__parameters"]
    params = body["ros__parameters"]
    assert isinstance(params, dict) and params
    for name, value in params.items():
        assert isinstance(name, str) and ROS_NAME.fullmatch(name), name
        values = value if isinstance(value, list) else [value]
        assert values, f"{name}: an empty array"
        kinds = {type(v) for v in values}
        assert len(kinds) == 1 and kinds <= {bool, int, float, str}, (name, value)
    return params


def _params(config_path: Path, robot: RobotConfig | None = None) -> Params:
    config = load_controller_config(config_path)
    cell = load_scenario(MODELS / "scenarios" / "co_kitting.yaml").controller.tracker
    config = dataclasses.replace(config, tracker=dataclasses.replace(
        config.tracker, exits=cell.exits, cell=Box([-6.0, -6.0, -1.0], [6.0, 6.0, 3.0])))
    return Params(controller=config, robot=deployed_robot(robot or RobotConfig()))


@pytest.mark.parametrize("config_path", CONFIGS, ids=lambda p: p.name)
def test_every_shipped_configuration_round_trips_through_a_ros2_parameter_file(
        tmp_path, config_path):
    params = _params(config_path)
    text = params_text(params, ["a header line"])
    found = ros2_parameter_file(text)
    assert found["schema_version"] == 1 and found["controller.type"] == params.controller.type
    # Floats stay doubles even where they are whole numbers (ROS 2 types by spelling).
    assert isinstance(found["controller.safety.delta_s"], float)
    assert isinstance(found["robot.path.waypoints_deg.item0"][0], float)
    path = tmp_path / "params.yaml"
    path.write_text(text)
    assert load_params(path) == params


def test_a_controller_s_unused_blocks_are_left_out_and_read_back_as_defaults(tmp_path):
    """An SSM configuration's params.yaml has no alteration.* or zones.* parameters (the
    SSM controller never reads them), even where the configuration set them; ERGA's
    keeps its alteration block and drops zones."""
    ssm = _params(MODELS / "configs" / "iso.yaml")
    ssm.controller = dataclasses.replace(ssm.controller, alteration=dataclasses.replace(
        ssm.controller.alteration, speed_limit=0.123), zones=dataclasses.replace(
        ssm.controller.zones, red_speed=0.05))
    text = params_text(ssm)
    assert not [k for k in ros2_parameter_file(text)
                if k.startswith(("controller.alteration.", "controller.zones."))]
    path = tmp_path / "params.yaml"
    path.write_text(text)
    read = load_params(path)
    assert read.controller == deployed_controller(ssm.controller) != ssm.controller
    assert read.controller.alteration == type(ssm.controller.alteration)()
    assert read.controller.safety == ssm.controller.safety
    erga = _params(MODELS / "configs" / "erga.yaml")
    keys = ros2_parameter_file(params_text(erga))
    assert any(k.startswith("controller.alteration.") for k in keys)
    assert not any(k.startswith("controller.zones.") for k in keys)


def test_the_default_path_is_written_out_and_runs_the_same(tmp_path):
    robot = RobotConfig()
    deployed = deployed_robot(robot)
    assert len(deployed.path.waypoints_deg) == 6  # not left to this version's default
    from safety_systems.config.configuration import joint_path

    a, b = joint_path(robot), joint_path(robot_config(deployed, robot))
    assert (a.waypoints == b.waypoints).all() and (a.durations == b.durations).all()


def test_a_task_path_is_written_inline(tmp_path):
    robot = RobotConfig(cycles=1, path=dataclasses.replace(
        RobotConfig().path, task_path=TaskPathConfig(
            points=[[0.4, 0.2, 0.3], [0.5, 0.1, 0.35], [0.45, -0.2, 0.3]], file="x.yaml")))
    params = _params(CONFIGS[0], robot)
    assert params.robot.path.task_path.file == ""
    path = tmp_path / "params.yaml"
    path.write_text(params_text(params))
    ros2_parameter_file(path.read_text())
    assert load_params(path) == params


BAD = [
    ("controller.safety.dmin: 0.3", "controller.safety.dmin", "unknown key"),
    ("controller.safety.d_min: 1", "controller.safety.d_min", "decimal point"),
    ("controller.safety.d_min: [0.3]", "controller.safety.d_min", "a single value"),
    ("controller.safety.d_min: 9.0", "controller.safety.d_min", "d_min <= 5"),
    ("controller.safety.link_radii: []", "controller.safety.link_radii", "non-empty array"),
    ("controller.safety: {d_min: 0.3}", "controller.safety", "scalar"),
    ("controller.tracker.exits.item5.min: [1.0, 1.0, 1.0]",
     "controller.tracker.exits.item2", "without gaps"),
    ("controller.tracker.exits.first.min: [1.0, 1.0, 1.0]", "controller.tracker.exits.first",
     "unknown key"),
    ("robot.path.waypoints_deg.item9: [1.0, 2.0]", "robot.path.waypoints_deg.item", "gaps"),
    ("schema_version: 2", "schema_version", "another"),
    ("controller.safety.human_speed: \"fast\"", "controller.safety.human_speed", "iso"),
]


@pytest.mark.parametrize("line, field, needle", BAD, ids=[b[0][:30] for b in BAD])
def test_a_bad_parameter_is_one_line_naming_it(tmp_path, line, field, needle):
    text = params_text(_params(CONFIGS[0]))
    key = line.split(":")[0]
    lines = [x for x in text.splitlines() if not x.strip().startswith(key + ":")
             and not (key == "schema_version" and "schema_version" in x)]
    lines.append(f"    {line}")
    path = tmp_path / "params.yaml"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError) as e:
        load_params(path)
    message = str(e.value)
    assert len(message.splitlines()) == 1 and message.startswith(f"{path}: ")
    assert field in message and needle in message, message


@pytest.mark.parametrize("text, needle", [
    (f"{NODE}:\n  ros__parameters:\n    schema_version: 1\nother:\n  ros__parameters: {{}}\n",
     "one node name"),
    (f"{NODE}:\n  parameters:\n    schema_version: 1\n", "ros__parameters"),
    (f"{NODE}:\n  ros__parameters:\n    a: [1, 2.0]\n", "one type"),
    (f"{NODE}:\n  ros__parameters:\n    schema_version: 1\n    schema_version: 1\n",
     "each key once"),
])
def test_a_file_that_is_not_a_ros2_parameter_file_is_refused(tmp_path, text, needle):
    path = tmp_path / "params.yaml"
    path.write_text(text)
    with pytest.raises(InputError) as e:
        load_params(path)
    assert needle in str(e.value) and len(str(e.value).splitlines()) == 1
