"""Typed scenario files: the cell, the controller configuration and the operators.

Loaded strictly with ``pydrake.common.yaml.yaml_load_typed`` (unknown keys and wrong
types are errors) and then range-checked by :func:`validate_scenario`; every problem
is raised as :class:`ScenarioError` naming the field, the value and what is allowed.
This module must not use ``from __future__ import annotations`` (it breaks the loader).
"""

import dataclasses as dc
import math
import typing
from pathlib import Path

import numpy as np
from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed

from safety_systems.joint_path import make_joint_path
from safety_systems.operator_paths import make_operator_path
from safety_systems.sensor_faults import BODY_FAULTS, FAULT_KINDS, SWAP
from safety_systems.ssm import HUMAN_SPEED_MODES
from safety_systems.tracks import HIDDEN_BODY_RULES


class ScenarioError(ValueError):
    """A bad value in a scenario or configuration file (one line: field, value, allowed)."""

    def __init__(self, field: str, value: typing.Any, allowed: str):
        self.field, self.value, self.allowed = field, value, allowed
        super().__init__(f"{field}: got {value!r}; allowed: {allowed}")


@dc.dataclass
class Interval:
    """A time interval [start, end) in seconds."""

    start: float = 0.0
    end: float = 0.0


@dc.dataclass
class Occlusion:
    """The named body is invisible to the sensor over [start, end)."""

    body: str = ""
    start: float = 0.0
    end: float = 0.0


@dc.dataclass
class SensorFault:
    """Frames captured over [start, end) carry a fault (``safety_systems.sensor_faults``):
    ``outlier`` (the body's entry displaced by ``offset``, m), ``swap`` (the body's and
    ``other``'s entries carry each other's ids), ``non_finite``, ``unknown_id`` (the
    body's entry), ``time_duplicate`` or ``time_backwards`` (the whole frame; no body)."""

    kind: str = "outlier"
    body: str = ""
    other: str = ""
    start: float = 0.0
    end: float = 0.0
    offset: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.0])


@dc.dataclass
class SensorConfig:
    """Motion-capture sensor (seed Section 4: OptiTrack streamed at 20 Hz, 0.2 mm).

    ``occlusions``, ``dropouts`` and ``faults`` describe the real sensor of a scenario
    (what happens to the frames), not the controller's assumptions."""

    rate_hz: float = 20.0
    noise_std: float = 0.0002
    latency: float = 0.0
    occlusions: list[Occlusion] = dc.field(default_factory=list)
    dropouts: list[Interval] = dc.field(default_factory=list)
    faults: list[SensorFault] = dc.field(default_factory=list)
    seed: int = 0


@dc.dataclass
class Box:
    """An axis-aligned box [min, max] in the robot base frame, m."""

    min: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.0])
    max: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.0])


@dc.dataclass
class TrackerConfig:
    """Kalman tracker (seed Eqs. 2-4).

    ``measurement_std`` None: the sensor's noise. ``processing_time``: seconds from a
    frame's delivery to the tracker's update. ``frame_timeout`` None: a frame is stale
    (protective stop) 1.5 sensor periods + latency + processing time after its capture,
    so one missing frame stops the robot. ``velocity_process_noise``: Q2 of Eq. 4, which
    the seed leaves unspecified beyond "the velocity dynamics (assumed constant)"; we
    read that literally: (0.22 m/s)^2 per step, a nearly constant velocity, which
    smooths the estimate (and makes it lag a sudden lunge).

    Hidden bodies (``safety_systems.tracks``): ``hazard`` keeps a body that is no longer
    seen as a ball growing at ``safety.occlusion_speed`` until it is seen leaving through
    one of the ``exits`` or beyond the ``cell``'s walls (None: no walls); ``expire`` is
    the previous rule, kept for comparison: a track unseen for ``max_coast_time`` s ends
    if its estimate lies beyond ``exit_radius`` m from the base, else is lost (stop).
    ``gate``: reject (and stop on) a position farther from its track than a body moving
    at ``gate_speed`` m/s (ISO 13855's 2.0 m/s hand speed) could be, plus ``gate_width``
    m (0.05 m: noise and estimate error, with room) and Z_d.
    """

    measurement_std: typing.Optional[float] = None
    velocity_process_noise: float = 0.05
    initial_velocity_std: float = 2.0
    hidden_bodies: str = "hazard"
    max_coast_time: float = 0.5
    exit_radius: float = 2.5
    exits: list[Box] = dc.field(default_factory=list)
    cell: typing.Optional[Box] = None
    gate: bool = True
    gate_speed: float = 2.0
    gate_width: float = 0.05
    processing_time: float = 0.001
    frame_timeout: typing.Optional[float] = None


@dc.dataclass
class SafetyConfig:
    """Separation monitor and speed override (seed Eqs. 9-12).

    ``stopping_time`` and ``stopping_distance`` None: taken from the braking table at
    full speed. ``human_uncertainty_sigmas`` > 0 adds that many standard deviations of
    each track's position estimate to Z_d (0 = the seed's constant Z_d).
    ``occlusion_speed`` (m/s): the radius of a hidden body's ball grows at this speed
    (0 = the seed's: a hidden body stays where it was last seen).

    ``robot_geometry``: ``capsules`` (the monitor measures every robot link:
    ``safety_systems.robot_geometry``, the UR5e model's capsules or ``link_radii`` (6 m),
    and the tool from the flange along its z axis for ``tool_length`` m with
    ``payload_radius`` m) or ``tool_point`` (the seed's Eq. 8: the tool flange as a
    point, bodies as points).
    """

    robot_geometry: str = "capsules"
    payload_radius: float = 0.05
    tool_length: float = 0.0
    link_radii: list[float] = dc.field(default_factory=list)
    human_speed: str = "estimated"
    iso_human_speed: float = 2.0
    iso_reduced_human_speed: float = 1.6
    reaction_time: float = 0.1
    stopping_time: typing.Optional[float] = None
    stopping_distance: typing.Optional[float] = None
    intrusion_distance: float = 0.0
    human_uncertainty: float = 0.0
    robot_uncertainty: float = 0.0
    human_uncertainty_sigmas: float = 0.0
    occlusion_speed: float = 0.0
    delta_s: float = 2.0
    d_min: float = 0.30


@dc.dataclass
class BrakingConfig:
    """Stopping data by speed fraction; empty lists: the defaults for the category.

    Integrators must enter the stopping data measured on their own cell.
    """

    stop_category: int = 1
    speed_fraction: list[float] = dc.field(default_factory=list)
    stopping_time: list[float] = dc.field(default_factory=list)
    stopping_distance: list[float] = dc.field(default_factory=list)


@dc.dataclass
class LineConfig:
    """A straight tool0 line (m, base frame) at a nominal speed (m/s), the tool held at
    roll-pitch-yaw ``rpy_deg``; inverse kinematics starts from ``seed_deg``."""

    start: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.0])
    goal: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.0])
    speed: float = 0.05
    rpy_deg: list[float] = dc.field(default_factory=lambda: [180.0, 0.0, 0.0])
    seed_deg: list[float] = dc.field(
        default_factory=lambda: [159.0, -103.0, 74.0, -61.0, -90.0, -111.0])


@dc.dataclass
class TaskPoints:
    """A task-space path file (``safety-systems plan`` writes one): points in m."""

    points: list[list[float]] = dc.field(default_factory=list)


@dc.dataclass
class TaskPathConfig:
    """A tool0 path through task-space points (m, base frame), run there and back
    ``robot.cycles`` times rest to rest at a mean ``speed`` (m/s), the tool held at
    roll-pitch-yaw ``rpy_deg``; inverse kinematics starts from ``seed_deg``. The points
    are ``points``, or, when that is empty, those of ``file`` (a ``TaskPoints`` YAML
    file, relative to the scenario file)."""

    points: list[list[float]] = dc.field(default_factory=list)
    file: str = ""
    speed: float = 0.1
    rpy_deg: list[float] = dc.field(default_factory=lambda: [180.0, 0.0, 0.0])
    seed_deg: list[float] = dc.field(
        default_factory=lambda: [90.0, -90.0, 90.0, -90.0, -90.0, 0.0])


@dc.dataclass
class PathConfig:
    """The robot's path: a cyclic joint-space path (empty lists: the default
    pick-and-place cycle), a one-way straight tool ``line``, or a ``task_path``."""

    waypoints_deg: list[list[float]] = dc.field(default_factory=list)
    segment_durations: list[float] = dc.field(default_factory=list)
    line: typing.Optional[LineConfig] = None
    task_path: typing.Optional[TaskPathConfig] = None


@dc.dataclass
class RobotConfig:
    """The UR5e station. ``mode``: ``kinematic`` (fast) or ``dynamic`` (plant + PD).

    ``acceleration_limit``: how fast the path speed may rise, in fractions of the
    nominal path speed per second (2.0: from rest to full speed in 0.5 s).
    ``braking_time_scale``: the real robot's stopping times as a multiple of the
    configured stopping data (1: the brakes are as the data says; > 1: weaker brakes,
    which verification uses to check what happens when the data is wrong).
    ``payload_radius`` and ``tool_length``: the real tool (m), a capsule from the
    flange along its z axis; the properties measure contact against it.
    """

    mode: str = "kinematic"
    control_rate_hz: float = 500.0
    cycles: int = 3
    acceleration_limit: float = 2.0
    braking_time_scale: float = 1.0
    payload_radius: float = 0.05
    tool_length: float = 0.0
    path: PathConfig = dc.field(default_factory=PathConfig)


@dc.dataclass
class EllipsoidConfig:
    """Ellipsoid models (seed 004, Eqs. 1-5), metres.

    Robot: one ellipsoid per link between DH frame origins (``link_radii``, 6 values;
    empty: the tool only) and a ``tool_radius`` sphere ``tool_offset`` along tool0's z
    axis from the flange. Operator: ``human``: ``hands`` (a sphere per tracked glove) or
    ``upper_body`` (hands, forearms, upper arms, head and torso, built from the gloves;
    ``safety_systems.ellipsoids.human_ellipsoids``).
    """

    link_radii: list[float] = dc.field(
        default_factory=lambda: [0.075, 0.065, 0.055, 0.05, 0.05, 0.05])
    tool_radius: float = 0.05
    tool_offset: float = 0.0
    human: str = "upper_body"
    hand_radius: float = 0.05
    forearm_radius: float = 0.05
    upper_arm_radius: float = 0.06
    head_radius: float = 0.12
    torso_semi_axes: list[float] = dc.field(default_factory=lambda: [0.12, 0.20, 0.30])


@dc.dataclass
class SpeedAlterationConfig:
    """Speed alteration controllers (seed 004): ``erga``, ``hwang``, ``bimodal``, ``none``.

    Every ``rate_hz`` they choose an end-effector speed along the path, signed (the
    robot may back away), at most ``speed_limit`` (ISO 10218-1: 0.25 m/s). ERGA: Eq. 11
    weights ``P``, ``D`` and penalty ``R`` (Eq. 12), GA settings (Section IV-A) and an
    explicit ``seed``; ``prediction``: ``constant_velocity`` (Eqs. 9-10) or ``kalman``
    (the tracker's velocity). ``hwang_candidates``: speeds tried by Eq. 13's search.
    ``bimodal_clearance``: Morato's stop/go distance between the closest ellipsoids.
    """

    rate_hz: float = 10.0
    speed_limit: float = 0.25
    P: float = 1.0
    D: float = 1.0
    R: float = 10.0
    population: int = 50
    generations: int = 100
    crossover: float = 0.8
    mutation: float = 0.1
    elites: int = 2
    seed: int = 0
    prediction: str = "constant_velocity"
    hwang_candidates: int = 101
    bimodal_clearance: float = 0.0
    ellipsoids: EllipsoidConfig = dc.field(default_factory=EllipsoidConfig)


@dc.dataclass
class ZonesConfig:
    """Safety zones (seed 001, Section 2.5, Eq. 6): green while the closest tracked body
    is at least ``green_distance`` from the tool, red within ``red_distance``, yellow in
    between; each zone has a speed (fraction of the nominal path speed). Performance
    recovery (Section 2.6): speeding up (after a zone change or a resume) follows a
    bounded-jerk profile, path acceleration at most ``max_acceleration`` (1/s) and its
    rate at most ``max_jerk`` (1/s^2); slowing down is immediate (within the brakes).
    Decisions at ``rate_hz``."""

    green_distance: float = 1.0
    red_distance: float = 0.5
    green_speed: float = 1.0
    yellow_speed: float = 0.5
    red_speed: float = 0.1
    max_acceleration: float = 1.0
    max_jerk: float = 5.0
    rate_hz: float = 100.0


ROBOT_GEOMETRIES = ("capsules", "tool_point")
CONTROLLER_TYPES = ("ssm_override", "erga", "hwang", "bimodal", "none", "zones")


@dc.dataclass
class ControllerConfig:
    """Everything the safety controller is configured with (a CONFIG file).

    ``type`` chooses the controller: ``ssm_override`` (seed 000, Eq. 12; uses
    ``safety``), a speed alteration controller of seed 004 (``erga``, ``hwang``,
    ``bimodal``; ``none`` keeps the pre-programmed speed) configured by ``alteration``,
    or seed 001's safety ``zones``.
    """

    type: str = "ssm_override"
    sensor: SensorConfig = dc.field(default_factory=SensorConfig)
    tracker: TrackerConfig = dc.field(default_factory=TrackerConfig)
    safety: SafetyConfig = dc.field(default_factory=SafetyConfig)
    braking: BrakingConfig = dc.field(default_factory=BrakingConfig)
    alteration: SpeedAlterationConfig = dc.field(default_factory=SpeedAlterationConfig)
    zones: ZonesConfig = dc.field(default_factory=ZonesConfig)


@dc.dataclass
class Body:
    """A tracked rigid body (glove, head) at a fixed offset from its operator, monitored
    as a sphere of ``radius`` m (default 0.05 m, a hand; give a head about 0.12 m)."""

    name: str = ""
    offset: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.0])
    radius: float = 0.05


@dc.dataclass
class Waypoint:
    """At ``time`` the operator sets off for ``position`` as fast as its limits allow."""

    time: float = 0.0
    position: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.0])


@dc.dataclass
class OperatorConfig:
    """A scripted operator: bodies, timed waypoints, limits and presence window."""

    name: str = ""
    max_speed: float = 1.8
    max_acceleration: float = 2.0
    enter_time: float = 0.0
    leave_time: float = math.inf
    bodies: list[Body] = dc.field(default_factory=list)
    waypoints: list[Waypoint] = dc.field(default_factory=list)


@dc.dataclass
class Gesture:
    """A gesture command (seed 001, Section 2.1) at ``time``: start, stop or resume."""

    time: float = 0.0
    command: str = "stop"


GESTURES = ("start", "stop", "resume")


@dc.dataclass
class Scenario:
    """One simulation: duration, robot, controller configuration and operators.

    ``sensor``: the cell's real sensor when it differs from the one the controller is
    configured for (``controller.sensor``), e.g. a larger latency; None: as configured.
    ``contact_geometry``: what counts as contact for the safety properties:
    ``capsules`` (a body's sphere within ``contact_distance`` m of a robot capsule; the
    real tool is ``robot.payload_radius`` and ``robot.tool_length``) or ``tool_point``
    (a body's centre within ``contact_distance`` of the tool flange, the seed's view).
    ``jerk_window``: [first, last] sample (controller periods) over which ``compare``
    reports jerk; empty: the whole run. ``gestures``: timed start/stop/resume commands
    for the ``zones`` controller.
    """

    name: str = ""
    duration: float = 30.0
    contact_geometry: str = "capsules"
    contact_distance: float = 0.0
    robot: RobotConfig = dc.field(default_factory=RobotConfig)
    controller: ControllerConfig = dc.field(default_factory=ControllerConfig)
    sensor: typing.Optional[SensorConfig] = None
    jerk_window: list[int] = dc.field(default_factory=list)
    gestures: list[Gesture] = dc.field(default_factory=list)
    operators: list[OperatorConfig] = dc.field(default_factory=list)


MAX_OPERATORS = 5
MAX_BODIES_PER_OPERATOR = 3
ISO_MAX_HUMAN_SPEED = 2.0  # ISO 13855 hand speed, m/s


def _check(ok: bool, field: str, value: typing.Any, allowed: str) -> None:
    if not ok:
        raise ScenarioError(field, value, allowed)


def _finite_nonneg(field: str, value: float) -> None:
    _check(math.isfinite(value) and value >= 0.0, field, value, "a finite number >= 0")


def _positive(field: str, value: float) -> None:
    _check(math.isfinite(value) and value > 0.0, field, value, "a finite number > 0")


def validate_sensor(s: SensorConfig, prefix: str) -> None:
    """Range checks of a sensor description; raises :class:`ScenarioError`."""
    _check(20.0 <= s.rate_hz <= 1000.0, f"{prefix}.rate_hz", s.rate_hz, "20 to 1000")
    _finite_nonneg(f"{prefix}.noise_std", s.noise_std)
    _finite_nonneg(f"{prefix}.latency", s.latency)
    _check(s.latency <= 1.0, f"{prefix}.latency", s.latency, "0 to 1.0 s")
    _check(s.seed >= 0, f"{prefix}.seed", s.seed, "an integer >= 0")
    for i, d in enumerate(s.dropouts):
        _check(0.0 <= d.start < d.end, f"{prefix}.dropouts[{i}]", [d.start, d.end],
               "0 <= start < end")
    for i, o in enumerate(s.occlusions):
        _check(0.0 <= o.start < o.end, f"{prefix}.occlusions[{i}]", [o.start, o.end],
               "0 <= start < end")
    for i, f in enumerate(s.faults):
        where = f"{prefix}.faults[{i}]"
        _check(f.kind in FAULT_KINDS, f"{where}.kind", f.kind, " | ".join(FAULT_KINDS))
        _check(0.0 <= f.start < f.end, where, [f.start, f.end], "0 <= start < end")
        _check(len(f.offset) == 3 and all(math.isfinite(x) and abs(x) <= 10.0
                                          for x in f.offset),
               f"{where}.offset", f.offset, "3 numbers in m, each within +-10")


def _box(field: str, box: Box) -> None:
    _check(len(box.min) == 3 and len(box.max) == 3 and all(
        math.isfinite(a) and math.isfinite(b) and a <= b for a, b in zip(box.min, box.max)),
        field, [box.min, box.max], "min and max: 3 finite numbers in m each, min <= max")


def validate_controller(c: ControllerConfig, prefix: str = "controller") -> None:
    """Range checks of a controller configuration; raises :class:`ScenarioError`."""
    validate_sensor(c.sensor, f"{prefix}.sensor")
    s = c.sensor
    t = c.tracker
    if t.measurement_std is not None:
        _positive(f"{prefix}.tracker.measurement_std", t.measurement_std)
    _positive(f"{prefix}.tracker.velocity_process_noise", t.velocity_process_noise)
    _positive(f"{prefix}.tracker.initial_velocity_std", t.initial_velocity_std)
    _positive(f"{prefix}.tracker.max_coast_time", t.max_coast_time)
    _positive(f"{prefix}.tracker.exit_radius", t.exit_radius)
    _check(t.hidden_bodies in HIDDEN_BODY_RULES, f"{prefix}.tracker.hidden_bodies",
           t.hidden_bodies, " | ".join(HIDDEN_BODY_RULES))
    _check(math.isfinite(t.gate_speed) and 0.0 < t.gate_speed <= 10.0,
           f"{prefix}.tracker.gate_speed", t.gate_speed, "0 < gate_speed <= 10 m/s")
    _check(math.isfinite(t.gate_width) and 0.0 <= t.gate_width <= 2.0,
           f"{prefix}.tracker.gate_width", t.gate_width, "0 to 2 m")
    for i, box in enumerate(t.exits):
        _box(f"{prefix}.tracker.exits[{i}]", box)
    if t.cell is not None:
        _box(f"{prefix}.tracker.cell", t.cell)
    _positive(f"{prefix}.tracker.processing_time", t.processing_time)
    if t.frame_timeout is not None:
        due = 1.0 / s.rate_hz + s.latency + t.processing_time
        _check(math.isfinite(t.frame_timeout) and t.frame_timeout > due,
               f"{prefix}.tracker.frame_timeout", t.frame_timeout,
               f"more than one sensor period + latency + processing time ({due:.4g} s)")
    f = c.safety
    _check(f.robot_geometry in ROBOT_GEOMETRIES, f"{prefix}.safety.robot_geometry",
           f.robot_geometry, " | ".join(ROBOT_GEOMETRIES))
    _check(math.isfinite(f.payload_radius) and 0.0 < f.payload_radius <= 1.0,
           f"{prefix}.safety.payload_radius", f.payload_radius, "0 < payload_radius <= 1 m")
    _check(math.isfinite(f.tool_length) and 0.0 <= f.tool_length <= 1.0,
           f"{prefix}.safety.tool_length", f.tool_length, "0 to 1 m")
    _check(len(f.link_radii) in (0, 6) and all(math.isfinite(r) and 0.0 < r <= 0.5
                                               for r in f.link_radii),
           f"{prefix}.safety.link_radii", f.link_radii,
           "empty (the UR5e model's capsules) or 6 radii in m, each 0 < r <= 0.5")
    _check(f.human_speed in HUMAN_SPEED_MODES, f"{prefix}.safety.human_speed", f.human_speed,
           " | ".join(HUMAN_SPEED_MODES))
    for name in ("iso_human_speed", "iso_reduced_human_speed"):
        _positive(f"{prefix}.safety.{name}", getattr(f, name))
    for name in ("reaction_time", "intrusion_distance", "human_uncertainty",
                 "robot_uncertainty", "human_uncertainty_sigmas", "occlusion_speed", "d_min"):
        _finite_nonneg(f"{prefix}.safety.{name}", getattr(f, name))
    for name in ("stopping_time", "stopping_distance"):
        if getattr(f, name) is not None:
            _finite_nonneg(f"{prefix}.safety.{name}", getattr(f, name))
    _check(math.isfinite(f.delta_s) and f.delta_s >= 1.0, f"{prefix}.safety.delta_s",
           f.delta_s, "a finite number >= 1")
    _check(c.type in CONTROLLER_TYPES, f"{prefix}.type", c.type, " | ".join(CONTROLLER_TYPES))
    validate_alteration(c.alteration, f"{prefix}.alteration")
    z = c.zones
    _check(math.isfinite(z.green_distance) and z.green_distance > z.red_distance > 0.0,
           f"{prefix}.zones.green_distance", [z.green_distance, z.red_distance],
           "green_distance > red_distance > 0 (m)")
    _check(0.0 <= z.red_speed <= z.yellow_speed <= z.green_speed <= 1.0,
           f"{prefix}.zones.red_speed", [z.red_speed, z.yellow_speed, z.green_speed],
           "0 <= red_speed <= yellow_speed <= green_speed <= 1")
    for name in ("max_acceleration", "max_jerk"):
        _positive(f"{prefix}.zones.{name}", getattr(z, name))
    _check(1.0 <= z.rate_hz <= 1000.0, f"{prefix}.zones.rate_hz", z.rate_hz, "1 to 1000 (Hz)")
    b = c.braking
    _check(b.stop_category in (0, 1), f"{prefix}.braking.stop_category", b.stop_category,
           "0 or 1")
    n = len(b.speed_fraction)
    for name in ("speed_fraction", "stopping_time", "stopping_distance"):
        values = getattr(b, name)
        _check(len(values) == n, f"{prefix}.braking.{name}", values,
               f"a list as long as speed_fraction ({n} values)")
        _check(all(math.isfinite(v) and v > 0.0 for v in values), f"{prefix}.braking.{name}",
               values, "positive finite numbers")
    _check(all(a < b_ for a, b_ in zip(b.speed_fraction, b.speed_fraction[1:])),
           f"{prefix}.braking.speed_fraction", b.speed_fraction, "strictly increasing fractions")
    _check(n == 0 or (max(b.speed_fraction) <= 1.0 and b.speed_fraction[-1] == 1.0),
           f"{prefix}.braking.speed_fraction", b.speed_fraction,
           "fractions of nominal speed up to and including 1.0")


def validate_alteration(a: SpeedAlterationConfig, prefix: str) -> None:
    """Range checks of the speed alteration settings."""
    _check(1.0 <= a.rate_hz <= 100.0, f"{prefix}.rate_hz", a.rate_hz, "1 to 100 (Hz)")
    for name in ("speed_limit", "R"):
        _positive(f"{prefix}.{name}", getattr(a, name))
    for name in ("P", "D", "bimodal_clearance"):
        _finite_nonneg(f"{prefix}.{name}", getattr(a, name))
    _check(a.population >= 2, f"{prefix}.population", a.population, "an integer >= 2")
    _check(a.generations >= 1, f"{prefix}.generations", a.generations, "an integer >= 1")
    for name in ("crossover", "mutation"):
        value = getattr(a, name)
        _check(0.0 <= value <= 1.0, f"{prefix}.{name}", value, "a probability in [0, 1]")
    _check(0 <= a.elites < a.population, f"{prefix}.elites", a.elites, "0 <= elites < population")
    _check(a.seed >= 0, f"{prefix}.seed", a.seed, "an integer >= 0")
    _check(a.prediction in ("constant_velocity", "kalman"), f"{prefix}.prediction",
           a.prediction, "constant_velocity | kalman")
    _check(a.hwang_candidates >= 3, f"{prefix}.hwang_candidates", a.hwang_candidates,
           "an integer >= 3")
    e = a.ellipsoids
    _check(len(e.link_radii) in (0, 6), f"{prefix}.ellipsoids.link_radii", e.link_radii,
           "6 radii in m, or none (the tool only)")
    _check(all(math.isfinite(r) and r > 0 for r in e.link_radii),
           f"{prefix}.ellipsoids.link_radii", e.link_radii, "positive radii in m")
    for name in ("tool_radius", "hand_radius", "forearm_radius", "upper_arm_radius",
                 "head_radius"):
        _positive(f"{prefix}.ellipsoids.{name}", getattr(e, name))
    _check(math.isfinite(e.tool_offset), f"{prefix}.ellipsoids.tool_offset", e.tool_offset,
           "a finite offset in m")
    _check(e.human in ("hands", "upper_body"), f"{prefix}.ellipsoids.human", e.human,
           "hands | upper_body")
    _check(len(e.torso_semi_axes) == 3 and all(x > 0 for x in e.torso_semi_axes),
           f"{prefix}.ellipsoids.torso_semi_axes", e.torso_semi_axes, "3 positive lengths in m")


def validate_scenario(s: Scenario) -> None:
    """Range checks of a whole scenario; raises :class:`ScenarioError`."""
    _positive("duration", s.duration)
    _check(s.contact_geometry in ROBOT_GEOMETRIES, "contact_geometry", s.contact_geometry,
           " | ".join(ROBOT_GEOMETRIES))
    _check(math.isfinite(s.contact_distance) and 0.0 <= s.contact_distance <= 1.0,
           "contact_distance", s.contact_distance, "0 to 1 m")
    last = -math.inf
    for i, g in enumerate(s.gestures):
        _check(g.command in GESTURES, f"gestures[{i}].command", g.command, " | ".join(GESTURES))
        _check(math.isfinite(g.time) and g.time >= 0.0 and g.time > last,
               f"gestures[{i}].time", g.time, "finite, >= 0 and after the previous gesture")
        last = g.time
    _check(not s.jerk_window or (len(s.jerk_window) == 2
                                 and 2 <= s.jerk_window[0] < s.jerk_window[1]),
           "jerk_window", s.jerk_window, "empty, or [first, last] samples with 2 <= first < last")
    r = s.robot
    _check(r.mode in ("kinematic", "dynamic"), "robot.mode", r.mode, "kinematic | dynamic")
    _check(100.0 <= r.control_rate_hz <= 2000.0, "robot.control_rate_hz", r.control_rate_hz,
           "100 to 2000")
    _check(r.cycles >= 1, "robot.cycles", r.cycles, "an integer >= 1")
    _positive("robot.acceleration_limit", r.acceleration_limit)
    _check(math.isfinite(r.payload_radius) and 0.0 < r.payload_radius <= 1.0,
           "robot.payload_radius", r.payload_radius, "0 < payload_radius <= 1 m")
    _check(math.isfinite(r.tool_length) and 0.0 <= r.tool_length <= 1.0,
           "robot.tool_length", r.tool_length, "0 to 1 m")
    p = r.path
    if p.line is not None:
        _check(not p.waypoints_deg and not p.segment_durations, "robot.path.line", "line",
               "either a line or waypoints, not both")
        _check(r.cycles == 1, "robot.cycles", r.cycles, "1 for a one-way line path")
        for name in ("start", "goal", "rpy_deg"):
            _check(len(getattr(p.line, name)) == 3, f"robot.path.line.{name}",
                   getattr(p.line, name), "3 numbers")
        _check(len(p.line.seed_deg) == 6, "robot.path.line.seed_deg", p.line.seed_deg,
               "6 joint angles in deg")
        _positive("robot.path.line.speed", p.line.speed)
        _check(p.line.start != p.line.goal, "robot.path.line.goal", p.line.goal,
               "a point other than start")
    if p.task_path is not None:
        t = p.task_path
        _check(p.line is None and not p.waypoints_deg, "robot.path.task_path", "task_path",
               "one kind of path: task_path, line or waypoints")
        _check(bool(t.points) or bool(t.file), "robot.path.task_path.points", t.points,
               "2 or more [x, y, z] points in m, or a file")
        _check(not t.points or (len(t.points) >= 2 and all(len(q) == 3 for q in t.points)),
               "robot.path.task_path.points", t.points, "2 or more [x, y, z] points in m")
        _positive("robot.path.task_path.speed", t.speed)
        _check(len(t.rpy_deg) == 3, "robot.path.task_path.rpy_deg", t.rpy_deg, "3 angles in deg")
        _check(len(t.seed_deg) == 6, "robot.path.task_path.seed_deg", t.seed_deg,
               "6 joint angles in deg")
    if p.waypoints_deg or p.segment_durations:
        _check(len(p.waypoints_deg) >= 2, "robot.path.waypoints_deg", p.waypoints_deg,
               "at least 2 waypoints of 6 joint angles")
        for i, w in enumerate(p.waypoints_deg):
            _check(len(w) == 6, f"robot.path.waypoints_deg[{i}]", w, "6 joint angles in deg")
        _check(len(p.segment_durations) == len(p.waypoints_deg),
               "robot.path.segment_durations", p.segment_durations,
               f"{len(p.waypoints_deg)} durations (one per segment, the last closes the cycle)")
        for i, d in enumerate(p.segment_durations):
            _positive(f"robot.path.segment_durations[{i}]", d)
        try:
            make_joint_path(np.radians(p.waypoints_deg), p.segment_durations, cycles=r.cycles)
        except ValueError as e:
            raise ScenarioError("robot.path.segment_durations", p.segment_durations,
                                str(e)) from None
    validate_controller(s.controller)
    if s.sensor is not None:
        validate_sensor(s.sensor, "sensor")
    _check(math.isfinite(r.braking_time_scale) and r.braking_time_scale > 0.0,
           "robot.braking_time_scale", r.braking_time_scale, "a finite number > 0")
    _check(1 <= len(s.operators) <= MAX_OPERATORS, "operators", len(s.operators),
           f"1 to {MAX_OPERATORS} operators")
    names = set()
    for i, o in enumerate(s.operators):
        f = f"operators[{i}]"
        _check(bool(o.name) and o.name not in names, f"{f}.name", o.name, "a unique non-empty name")
        names.add(o.name)
        _check(0.0 < o.max_speed <= ISO_MAX_HUMAN_SPEED, f"{f}.max_speed", o.max_speed,
               f"0 < max_speed <= {ISO_MAX_HUMAN_SPEED} m/s")
        _positive(f"{f}.max_acceleration", o.max_acceleration)
        _finite_nonneg(f"{f}.enter_time", o.enter_time)
        _check(o.leave_time > o.enter_time, f"{f}.leave_time", o.leave_time,
               f"later than enter_time ({o.enter_time})")
        _check(2 <= len(o.bodies) <= MAX_BODIES_PER_OPERATOR, f"{f}.bodies", len(o.bodies),
               f"2 to {MAX_BODIES_PER_OPERATOR} bodies (both gloves, optionally the head)")
        for j, b in enumerate(o.bodies):
            _check(len(b.offset) == 3, f"{f}.bodies[{j}].offset", b.offset, "3 numbers in m")
            _check(math.isfinite(b.radius) and 0.0 <= b.radius <= 0.5,
                   f"{f}.bodies[{j}].radius", b.radius, "0 to 0.5 m")
        _check(len(o.waypoints) >= 1, f"{f}.waypoints", o.waypoints, "at least one waypoint")
        last = -math.inf
        for j, w in enumerate(o.waypoints):
            _check(len(w.position) == 3, f"{f}.waypoints[{j}].position", w.position,
                   "3 numbers in m")
            _check(math.isfinite(w.time) and w.time > last, f"{f}.waypoints[{j}].time", w.time,
                   f"finite and later than the previous waypoint's ({last})")
            last = w.time
        try:
            make_operator_path([w.time for w in o.waypoints], [w.position for w in o.waypoints],
                               o.max_speed, o.max_acceleration)
        except ValueError as e:
            raise ScenarioError(f"{f}.waypoints", [w.time for w in o.waypoints],
                                f"times the operator's limits can keep ({e})") from None
    bodies = [f"{o.name}/{b.name}" for o in s.operators for b in o.bodies]
    _check(len(set(bodies)) == len(bodies), "operators[].bodies[].name", bodies,
           "unique body names within each operator")
    sensor, where = actual_sensor(s), "sensor" if s.sensor is not None else "controller.sensor"
    for i, oc in enumerate(sensor.occlusions):
        _check(oc.body in bodies, f"{where}.occlusions[{i}].body", oc.body, f"one of {bodies}")
    for i, fault in enumerate(sensor.faults):
        if fault.kind in BODY_FAULTS:
            _check(fault.body in bodies, f"{where}.faults[{i}].body", fault.body,
                   f"one of {bodies}")
        else:
            _check(not fault.body, f"{where}.faults[{i}].body", fault.body,
                   f"empty: {fault.kind} acts on the whole frame")
        if fault.kind == FAULT_KINDS[SWAP]:
            _check(fault.other in bodies and fault.other != fault.body,
                   f"{where}.faults[{i}].other", fault.other, f"another of {bodies}")


def actual_sensor(s: Scenario) -> SensorConfig:
    """The cell's real sensor: ``s.sensor`` if given, else the one configured."""
    return s.controller.sensor if s.sensor is None else s.sensor


def body_names(s: Scenario) -> list[str]:
    """The registered body slots, operator by operator: ``operator/body``."""
    return [f"{o.name}/{b.name}" for o in s.operators for b in o.bodies]


def _load_typed(schema: type, text: str, source: str) -> typing.Any:
    try:
        return yaml_load_typed(schema=schema, data=text)
    except (RuntimeError, ValueError, TypeError) as e:
        raise ScenarioError(*_describe_load_error(schema, text, e, source)) from None


def _describe_load_error(schema, text, error, source):
    """Find the field behind a loader error (its messages do not always name one)."""
    from pydrake.common.yaml import yaml_load

    message = str(error).splitlines()[0]
    try:
        raw = yaml_load(data=text)
    except Exception:  # noqa: BLE001 - report the parser's own message
        return source, "<unparsable YAML>", message
    found = _walk(schema, raw, "")
    if found is not None:
        return found
    return source, "<file>", message


def _walk(schema, raw, path):
    """Return (field, value, allowed) for the first value that does not fit the schema."""
    if dc.is_dataclass(schema):
        if not isinstance(raw, dict):
            return path or "<root>", raw, f"a mapping of {schema.__name__} fields"
        fields = {f.name: f for f in dc.fields(schema)}
        hints = typing.get_type_hints(schema)
        for key, value in raw.items():
            name = f"{path}.{key}" if path else key
            if key not in fields:
                return name, value, f"one of the fields {sorted(fields)}"
            found = _walk(hints[key], value, name)
            if found is not None:
                return found
        return None
    origin = typing.get_origin(schema)
    if origin is typing.Union:
        if raw is None:
            return None
        return _walk([a for a in typing.get_args(schema) if a is not type(None)][0], raw, path)
    if origin is list:
        if not isinstance(raw, list):
            return path, raw, "a list"
        for i, item in enumerate(raw):
            found = _walk(typing.get_args(schema)[0], item, f"{path}[{i}]")
            if found is not None:
                return found
        return None
    if schema is float and not (isinstance(raw, (int, float)) and not isinstance(raw, bool)):
        return path, raw, "a number"
    if schema is int and not (isinstance(raw, int) and not isinstance(raw, bool)):
        return path, raw, "an integer"
    if schema is str and not isinstance(raw, str):
        return path, raw, "a string"
    return None


def load_typed(schema: type, path: str | Path) -> typing.Any:
    """Loads a YAML file strictly into the dataclass ``schema`` (no range checks)."""
    return _load_typed(schema, _read(path), str(path))


def load_scenario(path: str | Path) -> Scenario:
    """Load and validate a scenario file; raises :class:`ScenarioError`. A task path's
    ``file`` is read here, relative to the scenario file."""
    text = _read(path)
    scenario = _load_typed(Scenario, text, str(path))
    read_task_path(scenario.robot, Path(path).parent)
    validate_scenario(scenario)
    return scenario


def read_task_path(robot: RobotConfig, folder: Path, prefix: str = "robot") -> None:
    """Fills a task path's points from its ``file`` (relative to ``folder``)."""
    task = robot.path.task_path
    if task is None or task.points or not task.file:
        return
    field = f"{prefix}.path.task_path.file"
    try:
        task.points = load_typed(TaskPoints, folder / task.file).points
    except ScenarioError as e:
        raise ScenarioError(field, task.file, f"a YAML file of points: {e}") from None
    _check(len(task.points) >= 2, field, task.file,
           f"a file with 2 or more points ({folder / task.file})")


def load_controller_config(path: str | Path) -> ControllerConfig:
    """Load and validate a controller configuration file."""
    config = _load_typed(ControllerConfig, _read(path), str(path))
    validate_controller(config, prefix="config")
    return config


def scenario_from_text(text: str) -> Scenario:
    """Load and validate a scenario from YAML text."""
    scenario = _load_typed(Scenario, text, "<text>")
    validate_scenario(scenario)
    return scenario


def dump_scenario(scenario: Scenario) -> str:
    """YAML text that :func:`scenario_from_text` loads back to an equal scenario."""
    return yaml_dump_typed(scenario)


def _read(path: str | Path) -> str:
    try:
        return Path(path).read_text()
    except OSError as e:
        raise ScenarioError("path", str(path), f"a readable file ({e.strerror})") from None
