"""What ``safety-systems tune`` may change: the tunable parameters and their bounds.

An integrator declares them in a ``tune:`` block, in the configuration file itself or
in a file of their own (``--tune FILE``, whose one key is ``tune:``)::

    tune:
    - {name: safety.intrusion_distance, min: 0.0, max: 0.15}
    - {name: safety.human_speed, choices: [iso, estimated_with_floor]}
    - {name: tracker.gate, choices: ["true", "false"]}

``name`` is a field of the controller configuration (``safety_systems.config.scenario
.ControllerConfig``) by its dotted path; numbers get ``min`` and ``max`` (inside the
field's declared range; whole numbers for integer fields), strings and flags get
``choices``. Measured properties are refused (:data:`MEASURED`): the stopping data,
the sensor's rate, latency and noise, the tracker's processing time; so are the cell's
layout (exits and walls) and the controller's type. The reaction time T_r may be tuned,
but never below the loop's own reaction time (the frame timeout and a control tick):
S cannot claim a faster reaction than the loop has. The frame timeout is a setting (how
old the newest frame may be before the tracker stops the robot), tunable above one
sensor period + latency + processing time: a shorter one stops sooner on a late frame,
and lets T_r and the separation allowance shrink.

This module must not use ``from __future__ import annotations`` (the YAML loader).
"""

import dataclasses as dc
import typing
from pathlib import Path

import numpy as np

from safety_systems.files.documents import load_document
from safety_systems.files.input_error import InputError
from safety_systems.files.ranges import field_limits, type_hints
from safety_systems.config.scenario import ControllerConfig, validate_controller
from safety_systems.config.resolved_cell import resolve
from verification.tune.levers import Lever, check_levers

# Names (and what is under them) that tune refuses, with why.
MEASURED = {
    "sensor": "the sensor's rate, latency and noise are measured properties of the cell's "
              "sensor",
    "braking": "the stopping data is measured on the robot",
    "body": "the operators' body model (sizes, lean limits, tracking allowance) is a premise "
            "about the people in the cell and the tracker, not a setting",
    "safety.stopping_time": "the stopping time T_s is measured on the robot",
    "safety.stopping_distance": "the stopping distance S_s (B) is measured on the robot",
    "tracker.processing_time": "the tracker's processing time is measured on its computer",
    "safety.contact_detection_time": "the robot's contact detection time is its "
                                     "manufacturer's figure, a property of the robot",
    "safety.transient_window": "the transient contact's window is ISO/TS 15066's, a premise "
                               "of the standard",
    "tracker.exits": "the exits are the cell's layout, not a setting",
    "tracker.cell": "the cell's walls are its layout, not a setting",
    "type": "the controller type is not a parameter: tune one controller's parameters",
}
REACTION_TIME = "safety.reaction_time"


@dc.dataclass
class TunedParameter:
    """One tunable parameter: ``name`` (a dotted field of the configuration) searched
    over [``min``, ``max``] (numbers) or over ``choices`` (strings; flags as "true" and
    "false")."""

    limits_checked_by = "check_block"  # min and max: the named field's declared range
    name: str = ""
    min: typing.Optional[float] = None
    max: typing.Optional[float] = None
    choices: list[str] = dc.field(default_factory=list)


@dc.dataclass
class TuneFile:
    """A file of tunable parameters (``--tune``), and the sensing ``levers`` whose price
    the chosen configuration is given in (``verification.tune.levers``)."""

    tune: list[TunedParameter] = dc.field(default_factory=list)
    levers: list[Lever] = dc.field(default_factory=list)


@dc.dataclass
class TunableConfig(ControllerConfig):
    """A controller configuration that may carry its own ``tune:`` block."""

    tune: list[TunedParameter] = dc.field(default_factory=list)


def _field(name: str) -> tuple[type, typing.Any, str]:
    """(the dataclass holding the field, the field's type, its last name) of a dotted
    name; raises KeyError naming the first part that is not a field of a record."""
    schema = ControllerConfig
    parts = name.split(".")
    for i, part in enumerate(parts):
        hints = type_hints(schema)
        if part not in hints:
            raise KeyError(".".join(parts[:i + 1]))
        if i == len(parts) - 1:
            return schema, hints[part], part
        if not dc.is_dataclass(hints[part]):
            raise KeyError(".".join(parts[:i + 2]))
        schema = hints[part]
    raise KeyError(name)


def _leaf(hint) -> type | None:
    """float, int, str or bool for a scalar field (Optional allowed), None otherwise."""
    args = [a for a in typing.get_args(hint) if a is not type(None)]
    if typing.get_origin(hint) is typing.Union and len(args) == 1:
        hint = args[0]
    return hint if hint in (float, int, str, bool) else None


def check_block(block: list[TunedParameter], config: ControllerConfig, *,
                control_period: float) -> None:
    """Raises InputError (naming ``tune[i]``) unless every parameter names a tunable
    scalar field once, with bounds inside its declared range or choices the
    configuration accepts."""
    if not block:
        raise InputError("tune", [], "one or more tunable parameters, in a tune: block of "
                         "the configuration or in --tune FILE")
    seen = set()
    for i, p in enumerate(block):
        where = f"tune[{i}]"
        for measured, why in MEASURED.items():
            if p.name == measured or p.name.startswith(measured + "."):
                raise InputError(f"{where}.name", p.name, f"a parameter that is not measured "
                                 f"({why}; tune refuses it)")
        try:
            schema, hint, last = _field(p.name)
        except KeyError as e:
            raise InputError(f"{where}.name", p.name, f"a field of the configuration by its "
                             f"dotted name, e.g. safety.intrusion_distance ({e.args[0]!r} is "
                             "not one)") from None
        leaf = _leaf(hint)
        if leaf is None:
            raise InputError(f"{where}.name", p.name, "a single number, string or flag "
                             "(lists and records are not tunable)")
        if p.name in seen:
            raise InputError(f"{where}.name", p.name, "each parameter once")
        seen.add(p.name)
        if leaf in (float, int):
            _check_bounds(p, where, leaf, field_limits(schema, last))
            for bound in ("min", "max"):  # the configuration's own rules at each end
                _accepted(config, p.name, getattr(p, bound), f"{where}.{bound}")
            if p.name == REACTION_TIME:
                floor = reaction_floor(config, block, control_period)
                if p.min < floor - 1e-12:
                    raise InputError(f"{where}.min", p.min, f"min >= {floor:.4g} s, the "
                                     "loop's own reaction time (frame timeout + a control "
                                     "tick, with the least frame timeout the block "
                                     "allows): T_r cannot claim a faster reaction")
        else:
            if p.min is not None or p.max is not None or not p.choices:
                raise InputError(where, p.name, "choices: [...] (a string or flag has no "
                                 "min or max)")
            for choice in p.choices:
                _accepted(config, p.name, choice, f"{where}.choices")


def _accepted(config: ControllerConfig, name: str, value, where: str) -> None:
    """Raises InputError (naming ``where``) unless the configuration's rules accept
    ``config`` with ``name`` set to ``value``."""
    try:
        validate_controller(with_values(config, {name: value}))
    except InputError as e:
        raise InputError(where, value, f"a value the configuration accepts ({e.allowed})"
                         ) from None


FRAME_TIMEOUT = "tracker.frame_timeout"


def reaction_floor(config: ControllerConfig, block: list[TunedParameter],
                   control_period: float) -> float:
    """The least T_r any candidate of ``block`` may have: the loop's own reaction time,
    the frame timeout (the least the block allows, if it tunes it) plus a control
    tick. Each candidate is held to its own frame timeout's (``Tuner.build``)."""
    timeouts = [p.min for p in block if p.name == FRAME_TIMEOUT and p.min is not None]
    if timeouts:
        config = with_values(config, {FRAME_TIMEOUT: min(timeouts)})
    # (the frame timeout is the configuration's alone: any station resolves it)
    return resolve(config).frame_timeout + control_period


def _check_bounds(p: TunedParameter, where: str, leaf: type, limits) -> None:
    if p.choices or p.min is None or p.max is None:
        raise InputError(where, p.name, "min: and max: (a number has no choices)")
    for bound in ("min", "max"):
        value = getattr(p, bound)
        if not limits.holds(value):
            raise InputError(f"{where}.{bound}", value, limits.describe(p.name, leaf is int))
        if leaf is int and value != round(value):
            raise InputError(f"{where}.{bound}", value, "a whole number (an integer field)")
    if not p.min <= p.max:
        raise InputError(f"{where}.max", p.max, f"max >= min ({p.min:g})")


def _value(p: TunedParameter, leaf: type, u: float) -> typing.Any:
    """The value at ``u`` in [0, 1] of the parameter's bounds or choices."""
    if p.choices:
        choice = p.choices[min(int(u * len(p.choices)), len(p.choices) - 1)]
        return choice == "true" if leaf is bool else choice
    value = p.min + u * (p.max - p.min)
    if leaf is int:
        return int(round(value))
    # Four significant digits (a setting a person can read and type), within the bounds.
    return float(min(max(float(f"{value:.4g}"), p.min), p.max))


def values_at(block: list[TunedParameter], unit: np.ndarray) -> dict[str, typing.Any]:
    """The parameters' values at a point of the unit cube (one axis per parameter)."""
    return {p.name: _value(p, _leaf(_field(p.name)[1]), float(u))
            for p, u in zip(block, unit)}


def with_values(config: ControllerConfig, values: dict[str, typing.Any]) -> ControllerConfig:
    """``config`` with the named fields set (``values`` by dotted name; flags may be
    given as "true" and "false")."""
    for name, value in values.items():
        _, hint, _ = _field(name)
        if _leaf(hint) is bool and isinstance(value, str):
            value = value == "true"
        config = _replace(config, name.split("."), value)
    return config


def _replace(obj, parts: list[str], value):
    if len(parts) == 1:
        return dc.replace(obj, **{parts[0]: value})
    return dc.replace(obj, **{parts[0]: _replace(getattr(obj, parts[0]), parts[1:], value)})


def plain_config(config: TunableConfig) -> ControllerConfig:
    """The ControllerConfig of a TunableConfig (its tune block dropped)."""
    return ControllerConfig(**{f.name: getattr(config, f.name)
                               for f in dc.fields(ControllerConfig)})


def load_tunable(path: str | Path, tune_path: str | Path | None = None
                 ) -> tuple[ControllerConfig, list[TunedParameter]]:
    """The configuration of ``path`` and its tunable parameters: those of ``tune_path``
    if given, else the configuration's own ``tune:`` block (checked by
    :func:`check_block` later, when the space gives the control period)."""
    loaded = load_document(path, TunableConfig,
                           lambda c: validate_controller(plain_config(c), prefix="config"))
    block = loaded.tune
    if tune_path is not None:
        block = load_document(tune_path, TuneFile).tune
    return plain_config(loaded), block


def load_levers(tune_path: str | Path | None) -> list[Lever]:
    """The ``levers:`` of a tune file (none without one), their sensor sets checked."""
    if tune_path is None:
        return []
    return load_document(tune_path, TuneFile, lambda f: check_levers(f.levers)).levers
