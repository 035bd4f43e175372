"""params.yaml: a controller configuration and the robot it was verified for, written for
deployment as a ROS 2 parameter file and read back by the project's own loader.

The file is a ROS 2 parameter file (the seed's controller ran on ROS 2): one node key,
then ``ros__parameters``, then only scalars and arrays, one parameter per dotted name::

    safety_controller:
      ros__parameters:
        schema_version: 1
        controller.type: "ssm_override"
        controller.safety.reaction_time: 0.2
        controller.tracker.exits.item0.min: [4.5, 0.8, -1.0]
        robot.path.waypoints_deg.item0: [0.0, -90.0, 90.0, -90.0, -90.0, 0.0]
        ...

Nested records become dotted names; the items of a list of records or of rows become
``item0``, ``item1``, ...; a number of a float field is always written with a decimal
point or an exponent (ROS 2 types a parameter by its spelling, and its arrays hold one
type); empty lists and unset (null) values are left out, since ROS 2 has neither.
Every value the controller reads is written, defaults too, and the robot's default path
is written out waypoint by waypoint, so the file does not depend on this version's
defaults. The blocks its type never reads (``scenario.UNUSED_BLOCKS``: an SSM
controller's ``alteration`` and ``zones``) are left out: :func:`deployed_controller`
sets them to their defaults, which is what reading the file gives them back.

Reading (:func:`load_params`) applies ``safety_systems.files.documents``' rules (a text file,
valid YAML, no duplicate keys), then the ROS 2 form (the node key, ``ros__parameters``,
scalars and arrays of one type), then every key against the schema (an unknown key is
an error naming it), then pydrake's typed load and the declared ranges, then the
configuration's and the robot's own rules; any failure is one ``InputError`` line.
Whether the file is what was certified is ``verification.deploy.certificate``'s question.

This module must not use ``from __future__ import annotations`` (the YAML loader).
"""

import dataclasses as dc
import os
import re
import typing
from pathlib import Path

import yaml

from safety_systems.files.documents import parse_typed, parse_yaml, read_text
from safety_systems.files.input_error import InputError
from safety_systems.cell.joint_path import DEFAULT_DURATIONS, DEFAULT_WAYPOINTS_DEG
from safety_systems.files.ranges import number, type_hints
from safety_systems.config.scenario import (
    UNUSED_BLOCKS,
    ControllerConfig,
    RobotConfig,
    validate_controller,
    validate_robot,
)

SCHEMA_VERSION = 1  # of params.yaml; a file of another version is refused
NODE = "safety_controller"  # the ROS 2 node the parameters are for
PARAMETERS = "ros__parameters"
ROBOT_FIELDS = ("model", "urdf", "tool_frame", "control_rate_hz", "acceleration_limit",
                "payload_radius", "tool_length", "path")
# The robot's choice (RobotConfig: a shipped model or a URDF): left out of params.yaml
# where empty (the UR5e), as a scenario leaves them out.
ROBOT_CHOICE = ("model", "urdf", "tool_frame")
_NODE_NAME = re.compile(r"/?[A-Za-z_][A-Za-z0-9_/]*|/\*\*")
_ITEM = re.compile(r"item(0|[1-9][0-9]{0,6})")


def _same_field(f: dc.Field) -> dc.Field:
    """A copy of a dataclass field (default, factory and declared range)."""
    return dc.field(default=f.default, default_factory=f.default_factory, metadata=f.metadata)


# The robot settings a certificate covers: RobotConfig's fields that describe the cell's
# robot and its program (not the simulation's mode, cycles or brake scaling), declared
# once, there.
DeployedRobot = dc.make_dataclass(
    "DeployedRobot", [(f.name, f.type, _same_field(f)) for f in dc.fields(RobotConfig)
                      if f.name in ROBOT_FIELDS])
DeployedRobot.__module__ = __name__
DeployedRobot.__doc__ = ("The robot a configuration was verified for: which robot (a "
                         "shipped model, or a URDF relative to params.yaml), control rate "
                         "(Hz), acceleration limit (1/s), the real tool (m) and the path.")


@dc.dataclass
class Params:
    """What params.yaml holds: its schema version, the controller configuration and the
    robot it was verified for."""

    schema_version: int = number(SCHEMA_VERSION, ge=1, le=1_000_000)
    controller: ControllerConfig = dc.field(default_factory=ControllerConfig)
    robot: DeployedRobot = dc.field(default_factory=DeployedRobot)


def deployed_robot(robot: RobotConfig, folder: Path | None = None) -> DeployedRobot:
    """The certified part of ``robot``, its path written out: the default pick-and-place
    cycle as its waypoints, a task path's points inline (its file already read); a URDF
    robot's file and a robot log's file relative to ``folder`` (where params.yaml goes;
    None: as they are)."""
    path = dc.replace(robot.path)
    if (path.line is None and path.task_path is None and path.log is None
            and not path.waypoints_deg):
        path.waypoints_deg = [list(map(float, w)) for w in DEFAULT_WAYPOINTS_DEG]
        path.segment_durations = [float(d) for d in DEFAULT_DURATIONS]
    if path.task_path is not None and path.task_path.points:
        path.task_path = dc.replace(path.task_path, file="")
    fields = {name: getattr(robot, name) for name in ROBOT_FIELDS[:-1]}
    if folder is not None:
        if robot.urdf:
            fields["urdf"] = _relative(robot.urdf, folder)
        if path.log is not None and path.log.file:
            path.log = dc.replace(path.log, file=_relative(path.log.file, folder))
    return DeployedRobot(**fields, path=path)


def _relative(file: str, folder: Path) -> str:
    """``file`` relative to ``folder`` (params.yaml's), so that params.yaml names no
    absolute path and moves with the files it names."""
    return os.path.relpath(Path(file).resolve(), Path(folder).resolve())


def deployed_controller(config: ControllerConfig) -> ControllerConfig:
    """``config`` with the blocks its type never reads (``UNUSED_BLOCKS``) at their
    defaults: what params.yaml certifies and reads back (it leaves those blocks out)."""
    defaults = ControllerConfig()
    return dc.replace(config, **{name: getattr(defaults, name)
                                 for name in UNUSED_BLOCKS.get(config.type, ())})


def robot_config(deployed: DeployedRobot, base: RobotConfig,
                 folder: Path | None = None) -> RobotConfig:
    """``base`` (a scenario's or a space's robot) with the certified settings: the robot
    itself too (a params.yaml brings its robot), its URDF and its log resolved relative
    to ``folder`` (params.yaml's; None: as written)."""
    robot = dc.replace(base, **{name: getattr(deployed, name) for name in ROBOT_FIELDS})
    if folder is None:
        return robot
    if robot.urdf and not Path(robot.urdf).is_absolute():
        robot.urdf = str((Path(folder) / robot.urdf).resolve())
    log = robot.path.log
    if log is not None and log.file and not Path(log.file).is_absolute():
        robot.path = dc.replace(robot.path, log=dc.replace(
            log, file=str((Path(folder) / log.file).resolve())))
    return robot


# ----------------------------------------------------------------------------- writing

def _optional(hint) -> typing.Any:
    args = typing.get_args(hint)
    if typing.get_origin(hint) is typing.Union and len(args) == 2 and type(None) in args:
        return next(a for a in args if a is not type(None))
    return None


def _float_text(x: float) -> str:
    """A float spelled so that YAML 1.1 and ROS 2 both read a double (1.0e-05, not 1e-05)."""
    text = repr(float(x))
    if "e" in text and "." not in text.split("e")[0]:
        text = text.replace("e", ".0e")
    return text


def _scalar_text(value: typing.Any, hint) -> str:
    if hint is bool:
        return "true" if value else "false"
    if hint is int:
        return str(int(value))
    if hint is float:
        return _float_text(value)
    return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _flatten(obj: typing.Any, hint, key: str, default: typing.Any, out: dict) -> None:
    """Adds ``key: text`` for ``obj`` (a value of type ``hint``) and what it holds."""
    inner = _optional(hint)
    if inner is not None:
        if obj is None:
            if default is not None:
                raise InputError(key, None, "a value (ROS 2 parameters cannot be null)")
            return
        hint = inner
    if dc.is_dataclass(hint):
        hints = type_hints(hint)
        for f in dc.fields(hint):
            field_default = (f.default_factory() if f.default_factory is not dc.MISSING
                             else f.default)
            _flatten(getattr(obj, f.name), hints[f.name], f"{key}.{f.name}" if key else f.name,
                     field_default, out)
        return
    if typing.get_origin(hint) is list:
        (item,) = typing.get_args(hint)
        if not obj:
            if default:
                raise InputError(key, [], "a non-empty list (ROS 2 has no empty arrays)")
            return
        if dc.is_dataclass(item) or typing.get_origin(item) is list:
            for i, element in enumerate(obj):
                _flatten(element, item, f"{key}.item{i}", None, out)
            return
        out[key] = "[" + ", ".join(_scalar_text(x, item) for x in obj) + "]"
        return
    out[key] = _scalar_text(obj, hint)


def flat_parameters(params: Params) -> dict[str, str]:
    """Every parameter of params.yaml by its dotted name, spelled as written (none of the
    blocks the controller's type never reads)."""
    flat: dict[str, str] = {}
    _flatten(params, Params, "", None, flat)
    unused = tuple(f"controller.{name}." for name in UNUSED_BLOCKS.get(
        params.controller.type, ()))
    empty = {f"robot.{name}" for name in ROBOT_CHOICE if not getattr(params.robot, name)}
    return {key: text for key, text in flat.items()
            if not key.startswith(unused) and key not in empty}


def params_text(params: Params, header: list[str] = ()) -> str:
    """params.yaml's text: ``header`` lines as comments, then the ROS 2 form."""
    flat = flat_parameters(params)
    lines = [f"# {line}".rstrip() for line in header]
    lines += [f"{NODE}:", f"  {PARAMETERS}:"]
    lines += [f"    {key}: {text}" for key, text in flat.items()]
    return "\n".join(lines) + "\n"


# ----------------------------------------------------------------------------- reading

def is_params_document(raw: typing.Any) -> bool:
    """Whether plain YAML data has a params file's shape (one node key holding
    ``ros__parameters``)."""
    return (isinstance(raw, dict) and len(raw) == 1
            and isinstance(next(iter(raw.values())), dict)
            and PARAMETERS in next(iter(raw.values())))


def _kind(value: typing.Any) -> type | None:
    """The ROS 2 type of a scalar (bool, int, float or str), None for anything else."""
    for kind in (bool, int, float, str):
        if isinstance(value, kind):
            return kind
    return None


def _ros_parameters(raw: typing.Any, file: Path) -> dict:
    """The ``ros__parameters`` mapping of a ROS 2 parameter file, its form checked."""
    allowed = f"one node name as the only top-level key, e.g. {NODE}: (a ROS 2 parameter file)"
    if not isinstance(raw, dict) or len(raw) != 1:
        keys = sorted(map(str, raw)) if isinstance(raw, dict) else raw
        raise InputError("<document>", keys, allowed, file=file)
    node, body = next(iter(raw.items()))
    if not isinstance(node, str) or not _NODE_NAME.fullmatch(node):
        raise InputError("<document>", node, allowed, file=file)
    if not isinstance(body, dict) or list(body) != [PARAMETERS]:
        raise InputError(str(node), sorted(map(str, body)) if isinstance(body, dict) else body,
                         f"{PARAMETERS} as the node's only key", file=file)
    params = body[PARAMETERS]
    if not isinstance(params, dict):
        raise InputError(f"{node}.{PARAMETERS}", params, "a mapping of parameter names to "
                         "values", file=file)
    for key, value in params.items():
        if not isinstance(key, str):
            raise InputError(f"{node}.{PARAMETERS}", key, "parameter names (strings)",
                             file=file)
        kinds = {_kind(x) for x in value} if isinstance(value, list) else {_kind(value)}
        if None in kinds or len(kinds) != 1:
            raise InputError(key, value, "a scalar, or a non-empty array of scalars of one "
                             "type (ROS 2 parameters)", file=file)
    return params


def _leaf(hint) -> tuple[type, bool]:
    """(the scalar type a parameter of ``hint`` holds, whether it is an array)."""
    hint = _optional(hint) or hint
    if typing.get_origin(hint) is list:
        return typing.get_args(hint)[0], True
    return hint, False


def _place(schema: type, node: dict, tokens: list[str], value: typing.Any, key: str,
           file: Path) -> None:
    """Puts the parameter ``key`` (the rest of its name: ``tokens``) into the nested
    ``node`` of ``schema``'s plain data; items of lists go into {index: item} maps."""
    fields = {f.name for f in dc.fields(schema)}
    name = tokens[0]
    if name not in fields:
        raise InputError(key, value, f"a known parameter (unknown key: {name!r} is not one "
                         f"of {sorted(fields)})", file=file)
    hint = type_hints(schema)[name]
    hint = _optional(hint) or hint
    item = typing.get_args(hint)[0] if typing.get_origin(hint) is list else None
    nested = dc.is_dataclass(hint) or (item is not None and (
        dc.is_dataclass(item) or typing.get_origin(item) is list))
    if len(tokens) == 1:
        if nested:
            raise InputError(key, value, f"the names under {key} (a record: "
                             f"{key}.<field> or {key}.item0...)", file=file)
        if name in node:
            raise InputError(key, value, "each parameter once", file=file)
        _check_kind(hint, value, key, file)
        node[name] = value
        return
    if dc.is_dataclass(hint):
        _place(hint, node.setdefault(name, {}), tokens[1:], value, key, file)
        return
    match = _ITEM.fullmatch(tokens[1]) if nested and not dc.is_dataclass(hint) else None
    if match is None:
        raise InputError(key, value, f"a known parameter (unknown key: nothing is named "
                         f"{'.'.join(tokens[1:])!r} under {name!r})", file=file)
    items = node.setdefault(name, {})
    index = int(match.group(1))
    if dc.is_dataclass(item):
        if len(tokens) < 3:
            raise InputError(key, value, f"the names under {key} ({key}.<field>)", file=file)
        _place(item, items.setdefault(index, {}), tokens[2:], value, key, file)
        return
    if len(tokens) != 2 or index in items:
        raise InputError(key, value, "each row once, as <name>.item<N>: [values]", file=file)
    _check_kind(item, value, key, file)
    items[index] = value


def _check_kind(hint, value: typing.Any, key: str, file: Path) -> None:
    """ROS 2 types a parameter by its spelling: a float field's values are doubles."""
    leaf, array = _leaf(hint)
    values = value if isinstance(value, list) else [value]
    if array != isinstance(value, list):
        raise InputError(key, value, "an array [..]" if array else "a single value",
                         file=file)
    if leaf is float and not all(isinstance(x, float) for x in values):
        raise InputError(key, value, "doubles, written with a decimal point (1.0, not 1: "
                         "ROS 2 types a parameter by its spelling)", file=file)


def _lists(schema: type, node: dict, prefix: str, file: Path) -> None:
    """Turns the {index: item} maps of ``node`` into lists, items numbered without gaps."""
    hints = type_hints(schema)
    for name, value in node.items():
        hint = _optional(hints[name]) or hints[name]
        key = f"{prefix}.{name}" if prefix else name
        if dc.is_dataclass(hint):
            _lists(hint, value, key, file)
        elif isinstance(value, dict):
            missing = next((i for i in range(len(value)) if i not in value), None)
            if missing is not None:
                raise InputError(f"{key}.item{missing}", "missing",
                                 f"items numbered from item0 without gaps ({len(value)} "
                                 "items)", file=file)
            (item,) = typing.get_args(hint)
            node[name] = [value[i] for i in range(len(value))]
            if dc.is_dataclass(item):
                for i, element in enumerate(node[name]):
                    _lists(item, element, f"{key}.item{i}", file)


def params_from_text(text: str, file: str | Path) -> Params:
    """Every rule of the module docstring on a params file's text."""
    file = Path(file)
    flat = _ros_parameters(parse_yaml(text, file), file)
    data: dict = {}
    for key, value in flat.items():
        _place(Params, data, key.split("."), value, key, file)
    _lists(Params, data, "", file)
    params = parse_typed(Params, yaml.safe_dump(data, sort_keys=False), file)
    try:
        if params.schema_version != SCHEMA_VERSION:
            raise InputError("schema_version", params.schema_version,
                             f"{SCHEMA_VERSION} (this safety-systems reads params schema "
                             f"{SCHEMA_VERSION}; the file was written for another)")
        validate_controller(params.controller, "controller")
        task = params.robot.path.task_path
        if task is not None and task.file:
            raise InputError("robot.path.task_path.file", task.file,
                             "empty: a params file holds its path's points inline")
        validate_robot(robot_config(params.robot, RobotConfig(), file.parent), "robot")
    except InputError as e:
        raise e.in_file(file) from None
    return params


def load_params(path: str | Path) -> Params:
    """Reads a params file (see the module docstring); raises InputError (one line)."""
    return params_from_text(read_text(path), path)


def looks_like_params(path: str | Path) -> bool:
    """Whether the YAML file ``path`` has a params file's shape (False when it cannot be
    read: its own loader then says why)."""
    try:
        return is_params_document(parse_yaml(read_text(path), path))
    except InputError:
        return False

