"""Typed scenario files: the cell, the controller configuration and the operators.

Read under the rules of ``safety_systems.files.documents`` (strict typed YAML, no duplicate
keys; every number within the range declared on its field with ``ranges.number``,
units beside it) and then checked field against field by :func:`validate_scenario`;
every problem is raised as :class:`ScenarioError` (``InputError``) naming the file,
the field, the value and what is allowed. Upper bounds are physical: ``MAX_DURATION``
for any time, ``MAX_CELL`` for any position, 360 deg for any angle, ``SEED_MAX`` for
seeds, and the ones given on the fields.
This module must not use ``from __future__ import annotations`` (it breaks the loader).
"""

import dataclasses as dc
import math
import typing
from pathlib import Path

import numpy as np
from pydrake.common.yaml import yaml_dump_typed

from safety_systems.files.documents import load_document, read_input
from safety_systems.files.documents import parse_typed as _parse_typed
from safety_systems.files.input_error import InputError
from safety_systems.cell import human_body
from safety_systems.cell.joint_path import make_joint_path
from safety_systems.cell.operator_paths import make_operator_path
from safety_systems.cell.operators import MAX_BODIES_PER_OPERATOR, MAX_OPERATORS, NAME
from safety_systems.cell.robot_model import SHIPPED, KIND_UR, RobotModel, is_ur5e, robot_model
from safety_systems.files.ranges import SEED_MAX, check_limits, number
from safety_systems.sensing.sensor_faults import BODY_FAULTS, FAULT_KINDS, SWAP
from safety_systems.ssm.formulas import HUMAN_SPEED_MODES, ROBOT_SPEED_TERMS, STOPPING_MODES
from safety_systems.sensing.tracks import HIDDEN_BODY_RULES
from safety_systems.pfl.speed_caps import SAFETY_MODES

ScenarioError = InputError  # the name this module's callers know

MAX_DURATION = 600.0  # s: a scenario's longest run (ten minutes of cell time, 300,000
#                       logged control ticks at 500 Hz), and so the latest of any time
MAX_CELL = 20.0  # m: the largest coordinate of anything in a cell (base frame)
MAX_HUMAN_SPEED = 10.0  # m/s: above any human motion (a sprint; ISO 13855 uses 2.0)
# m/s: the fastest scripted operator. The shipped spaces keep ISO 13855's hand speed,
# 2.0 m/s; real hands reach 2.5-2.7 m/s in a handover and 2.7-3.4 m/s in jumps and
# walks (issue 32's recordings), so a space may state more, with a configuration whose
# human speed covers it
MAX_SCRIPTED_SPEED = 4.0
MAX_ROBOT_SPEED = 3.0  # m/s: above the UR5e's fastest tool speed (180 deg/s at 0.85 m)
MAX_STOPPING_TIME = 10.0  # s
MAX_STOPPING_DISTANCE = 5.0  # m


def _time(default: float = 0.0) -> typing.Any:
    return number(default, ge=0.0, le=MAX_DURATION, unit="s")


def _position(default: typing.Any) -> typing.Any:
    return number(default, ge=-MAX_CELL, le=MAX_CELL, unit="m")


def _angles(default: typing.Any) -> typing.Any:
    return number(default, ge=-360.0, le=360.0, unit="deg")


def _seed() -> typing.Any:
    return number(0, ge=0, le=SEED_MAX)


@dc.dataclass
class Interval:
    """A time interval [start, end) in seconds."""

    start: float = _time()
    end: float = _time()


@dc.dataclass
class Occlusion:
    """The named body is invisible to the sensor over [start, end)."""

    body: str = ""
    start: float = _time()
    end: float = _time()


@dc.dataclass
class SensorFault:
    """Frames captured over [start, end) carry a fault (``safety_systems.sensing.sensor_faults``):
    ``outlier`` (the body's entry displaced by ``offset``, m), ``swap`` (the body's and
    ``other``'s entries carry each other's ids), ``non_finite``, ``unknown_id`` (the
    body's entry), ``time_duplicate`` or ``time_backwards`` (the whole frame; no body)."""

    kind: str = "outlier"
    body: str = ""
    other: str = ""
    start: float = _time()
    end: float = _time()
    offset: list[float] = number([0.0, 0.0, 0.0], ge=-10.0, le=10.0, unit="m")


@dc.dataclass
class SensorConfig:
    """Motion-capture sensor (seed Section 4: OptiTrack streamed at 20 Hz, 0.2 mm).

    ``occlusions``, ``dropouts`` and ``faults`` describe the real sensor of a scenario
    (what happens to the frames), not the controller's assumptions."""

    rate_hz: float = number(20.0, ge=20.0, le=1000.0, unit="Hz")
    noise_std: float = number(0.0002, ge=0.0, le=0.05, unit="m")
    latency: float = number(0.0, ge=0.0, le=1.0, unit="s")
    occlusions: list[Occlusion] = dc.field(default_factory=list)
    dropouts: list[Interval] = dc.field(default_factory=list)
    faults: list[SensorFault] = dc.field(default_factory=list)
    seed: int = _seed()


@dc.dataclass
class Box:
    """An axis-aligned box [min, max] in the robot base frame, m."""

    min: list[float] = _position([0.0, 0.0, 0.0])
    max: list[float] = _position([0.0, 0.0, 0.0])


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

    Hidden bodies (``safety_systems.sensing.tracks``): ``hazard`` keeps a body that is no longer
    seen as a ball growing at ``safety.occlusion_speed`` until it is seen leaving through
    one of the ``exits`` or beyond the ``cell``'s walls (None: no walls); ``expire`` is
    the previous rule, kept for comparison: a track unseen for ``max_coast_time`` s ends
    if its estimate lies beyond ``exit_radius`` m from the base, else is lost (stop).
    ``gate``: reject (and stop on) a position farther from its track than a body moving
    at ``gate_speed`` m/s (ISO 13855's 2.0 m/s hand speed) could be, plus ``gate_width``
    m (0.05 m: noise and estimate error, with room) and Z_d.
    """

    measurement_std: typing.Optional[float] = number(None, gt=0.0, le=1.0, unit="m")
    velocity_process_noise: float = number(0.05, gt=0.0, le=100.0, unit="(m/s)^2")
    initial_velocity_std: float = number(2.0, gt=0.0, le=MAX_HUMAN_SPEED, unit="m/s")
    hidden_bodies: str = "hazard"
    max_coast_time: float = number(0.5, gt=0.0, le=60.0, unit="s")
    exit_radius: float = number(2.5, gt=0.0, le=MAX_CELL, unit="m")
    exits: list[Box] = dc.field(default_factory=list)
    cell: typing.Optional[Box] = None
    gate: bool = True
    gate_speed: float = number(2.0, gt=0.0, le=MAX_HUMAN_SPEED, unit="m/s")
    gate_width: float = number(0.05, ge=0.0, le=2.0, unit="m")
    processing_time: float = number(0.001, gt=0.0, le=1.0, unit="s")
    frame_timeout: typing.Optional[float] = number(None, gt=0.0, le=10.0, unit="s")


@dc.dataclass
class SafetyConfig:
    """Separation monitor and speed override (seed Eqs. 9-12).

    ``stopping_time`` and ``stopping_distance`` None: taken from the braking table at
    full speed. ``human_uncertainty_sigmas`` > 0 adds that many standard deviations of
    each track's position estimate to Z_d (0 = the seed's constant Z_d).
    ``occlusion_speed`` (m/s): the radius of a hidden body's ball grows at this speed
    (0 = the seed's: a hidden body stays where it was last seen).

    ``robot_geometry``: ``capsules`` (the monitor measures every robot link:
    ``safety_systems.cell.robot_geometry``, the UR5e model's capsules or ``link_radii`` (6 m),
    and the tool from the flange along its z axis for ``tool_length`` m with
    ``payload_radius`` m) or ``tool_point`` (the seed's Eq. 8: the tool flange as a
    point, bodies as points).

    ``stopping``: the robot's stop in S (T_s and B): ``full_speed`` (the seed's: the
    stop from full speed, ``stopping_time`` and ``stopping_distance``, at every speed)
    or ``by_speed`` (ISO/TS 15066's S_s from the robot's current speed: the stop from
    the fastest the robot may run until the next decision, the full-speed values scaled
    by the braking table's shape; the commanded speed is then one of
    ``ssm.SPEED_LEVELS`` + 1 levels: ``ssm.formulas.by_speed_command``).

    ``mode``: ``ssm`` (speed and separation monitoring: no contact while the robot
    moves) or ``ssm_pfl`` (power and force limiting near the body regions ISO/TS 15066
    permits transient contact with: ``safety_systems.pfl.speed_caps``). Under ``ssm_pfl``
    each operator segment lets the robot keep a path rate at which no point of it moves
    faster than the segment's permissible relative speed (Annex A, for the robot's
    effective mass with ``payload_mass`` kg of tooling and workpiece), or than
    ``pfl_speed`` m/s where lower (None: the segment's own); the head, face and neck keep
    pure SSM, and so does a segment within ``pfl.speed_caps.CLAMP_GAP`` +
    ``clamp_margin`` m of what it could be pressed against: the robot's mounting surface
    (``robot.mounting_size``), a ``fixed_surfaces`` box (tables, walls, fixtures, robot
    base frame) or two links of the robot. A contact that lasts is bounded too
    (``safety_systems.pfl.contact_limits``): the robot's own contact detection stops it
    once its force reaches ``contact_stop_force`` N (its configured force limit plus that
    limit's tolerance) held for ``contact_detection_time`` s, and the robot's indentation
    must stay within the transient compression until ``transient_window`` s after the
    impact and within the quasi-static one after (premises trusted from this file, as the
    stopping data are).

    ``robot_speed``: the robot's speed in S (Eq. 11's S_R = v_R T_r): ``directed`` (the
    seed's and ISO/TS 15066's v_R^d, Eq. 7: the speed of the capsule's point nearest
    the body towards it, negative when it moves away) or ``fastest_point`` (the speed of
    the capsule's fastest point, whatever its direction: never credits a robot moving
    away, so S does not hang on where the body is thought to be, and the separation
    invariant's proof needs far less Z_d + Z_r; ``verification.proof``).
    """

    robot_geometry: str = "capsules"
    robot_speed: str = "directed"
    stopping: str = "full_speed"
    payload_radius: float = number(0.05, gt=0.0, le=1.0, unit="m")
    tool_length: float = number(0.0, ge=0.0, le=1.0, unit="m")
    link_radii: list[float] = number([], gt=0.0, le=0.5, unit="m")
    human_speed: str = "estimated"
    iso_human_speed: float = number(2.0, gt=0.0, le=MAX_HUMAN_SPEED, unit="m/s")
    iso_reduced_human_speed: float = number(1.6, gt=0.0, le=MAX_HUMAN_SPEED, unit="m/s")
    reaction_time: float = number(0.1, ge=0.0, le=5.0, unit="s")
    stopping_time: typing.Optional[float] = number(None, ge=0.0, le=MAX_STOPPING_TIME,
                                                   unit="s")
    stopping_distance: typing.Optional[float] = number(None, ge=0.0,
                                                       le=MAX_STOPPING_DISTANCE, unit="m")
    intrusion_distance: float = number(0.0, ge=0.0, le=2.0, unit="m")
    human_uncertainty: float = number(0.0, ge=0.0, le=1.0, unit="m")
    robot_uncertainty: float = number(0.0, ge=0.0, le=1.0, unit="m")
    human_uncertainty_sigmas: float = number(0.0, ge=0.0, le=10.0)
    occlusion_speed: float = number(0.0, ge=0.0, le=MAX_HUMAN_SPEED, unit="m/s")
    delta_s: float = number(2.0, ge=1.0, le=10.0)
    d_min: float = number(0.30, ge=0.0, le=5.0, unit="m")
    mode: str = "ssm"
    pfl_speed: typing.Optional[float] = number(None, gt=0.0, le=MAX_HUMAN_SPEED, unit="m/s")
    payload_mass: float = number(0.0, ge=0.0, le=100.0, unit="kg")
    fixed_surfaces: list[Box] = dc.field(default_factory=list)
    clamp_margin: float = number(0.3, ge=0.0, le=2.0, unit="m")
    contact_stop_force: float = number(175.0, gt=0.0, le=1000.0, unit="N")
    contact_detection_time: float = number(0.25, ge=0.0, le=2.0, unit="s")
    transient_window: float = number(0.5, gt=0.0, le=2.0, unit="s")


def _dimension(name: str) -> typing.Any:
    default = human_body.DEFAULT_DIMENSIONS[name]
    if name.endswith("_deg"):
        return number(default, ge=0.0, le=89.0, unit="deg")
    return number(default, gt=0.0, le=2.0, unit="m")


@dc.dataclass
class BodyConfig:
    """The SeparationMonitor's model of an operator (``safety_systems.cell.human_body``):
    the largest segment lengths and radii of the people in the cell and their posture
    limits (defaults: the 95th percentiles of adult men, ``human_body`` says whence),
    and ``tracking_allowance``, how far a tracked point's estimate may be from the point
    (the proof checks it covers the tracker's error). Premises about people: ``tune``
    does not change them."""

    neck: float = _dimension("neck")
    upper_trunk: float = _dimension("upper_trunk")
    lower_trunk: float = _dimension("lower_trunk")
    shoulder: float = _dimension("shoulder")
    upper_arm: float = _dimension("upper_arm")
    forearm: float = _dimension("forearm")
    head_shoulder: float = _dimension("head_shoulder")
    head_radius: float = _dimension("head_radius")
    neck_radius: float = _dimension("neck_radius")
    trunk_radius: float = _dimension("trunk_radius")
    shoulder_radius: float = _dimension("shoulder_radius")
    upper_arm_radius: float = _dimension("upper_arm_radius")
    forearm_radius: float = _dimension("forearm_radius")
    hand_radius: float = _dimension("hand_radius")
    trunk_lean_deg: float = _dimension("trunk_lean_deg")
    neck_lean_deg: float = _dimension("neck_lean_deg")
    tracking_allowance: float = number(0.01, ge=0.0, le=0.5, unit="m")


@dc.dataclass
class BrakingConfig:
    """Stopping data by speed fraction; empty lists: the defaults for the category.

    Integrators must enter the stopping data measured on their own cell.
    """

    stop_category: int = number(1, ge=0, le=1)
    speed_fraction: list[float] = number([], gt=0.0, le=1.0)
    stopping_time: list[float] = number([], gt=0.0, le=MAX_STOPPING_TIME, unit="s")
    stopping_distance: list[float] = number([], gt=0.0, le=MAX_STOPPING_DISTANCE, unit="m")


@dc.dataclass
class LineConfig:
    """A straight tool0 line (m, base frame) at a nominal speed (m/s), the tool held at
    roll-pitch-yaw ``rpy_deg``; inverse kinematics starts from ``seed_deg``."""

    start: list[float] = _position([0.0, 0.0, 0.0])
    goal: list[float] = _position([0.0, 0.0, 0.0])
    speed: float = number(0.05, gt=0.0, le=MAX_ROBOT_SPEED, unit="m/s")
    rpy_deg: list[float] = _angles([180.0, 0.0, 0.0])
    seed_deg: list[float] = _angles([159.0, -103.0, 74.0, -61.0, -90.0, -111.0])


@dc.dataclass
class TaskPoints:
    """A task-space path file (``safety-systems plan`` writes one): points in m."""

    points: list[list[float]] = _position([])


@dc.dataclass
class TaskPathConfig:
    """A tool0 path through task-space points (m, base frame), run there and back
    ``robot.cycles`` times rest to rest at a mean ``speed`` (m/s), the tool held at
    roll-pitch-yaw ``rpy_deg``; inverse kinematics starts from ``seed_deg``. The points
    are ``points``, or, when that is empty, those of ``file`` (a ``TaskPoints`` YAML
    file, relative to the scenario file)."""

    points: list[list[float]] = _position([])
    file: str = ""
    speed: float = number(0.1, gt=0.0, le=MAX_ROBOT_SPEED, unit="m/s")
    rpy_deg: list[float] = _angles([180.0, 0.0, 0.0])
    seed_deg: list[float] = _angles([90.0, -90.0, 90.0, -90.0, -90.0, 0.0])


@dc.dataclass
class RobotLogConfig:
    """The robot's path as its own log recorded it (``safety_systems.cell.robot_log``):
    ``file`` (relative to the file that names it) a UR RTDE CSV (``timestamp``,
    ``actual_q_0`` ...) or a ROS bag (a rosbag2 folder, .mcap, .db3 or .bag) whose
    ``sensor_msgs/msg/JointState`` ``topic`` (empty: its only one) gives the joints by
    name; the samples from log time ``start`` to ``end`` (s after its first sample; None:
    its last) run at the log's own pace at path rate 1. ``repeat``: run it
    ``robot.cycles`` times (it must end where it starts), else once (``robot.cycles`` is
    then not used). ``max_gap``: the longest spacing of two samples accepted (a longer
    one is samples lost)."""

    file: str = ""
    topic: str = ""
    start: float = number(0.0, ge=0.0, le=100_000.0, unit="s")
    end: typing.Optional[float] = number(None, gt=0.0, le=100_000.0, unit="s")
    repeat: bool = False
    max_gap: float = number(0.05, gt=0.0, le=1.0, unit="s")


@dc.dataclass
class PathConfig:
    """The robot's path: a cyclic joint-space path (empty lists: the default
    pick-and-place cycle), a one-way straight tool ``line``, a ``task_path``, or the
    robot's own ``log``."""

    waypoints_deg: list[list[float]] = _angles([])
    segment_durations: list[float] = number([], gt=0.0, le=MAX_DURATION, unit="s")
    line: typing.Optional[LineConfig] = None
    task_path: typing.Optional[TaskPathConfig] = None
    log: typing.Optional[RobotLogConfig] = None


@dc.dataclass
class RobotConfig:
    """The robot station. ``model``: a shipped robot (``cell.robot_model.SHIPPED``: the
    UR family ``ur3e``, ``ur5e``, ``ur10e``, ``ur16e``, ``ur20``, ``ur30``, and
    ``panda``), empty for the UR5e; or ``urdf``: any serial arm's URDF file (relative to
    the file that names it), its tool frame ``tool_frame`` (empty: tool0 on a UR, else the
    chain's last link, ``cell.robot_description``). The path's joints are the robot's;
    the default pick-and-place path is a UR arm's only.
    ``mode``: ``kinematic`` (fast) or ``dynamic`` (plant + PD).

    ``acceleration_limit``: how fast the path speed may rise, in fractions of the
    nominal path speed per second (2.0: from rest to full speed in 0.5 s).
    ``braking_time_scale``: the real robot's stopping times as a multiple of the
    configured stopping data (1: the brakes are as the data says; > 1: weaker brakes,
    which verification uses to check what happens when the data is wrong).
    ``payload_radius`` and ``tool_length``: the real tool (m), a capsule from the
    flange along its z axis; the properties measure contact against it.
    ``mounting_size``: [x, y] (m) of the table or floor the robot stands on, centred on
    its base, whose top is the base frame's z = 0 plane; empty (the default): a square
    over the robot's reach. A body region can be clamped against it
    (``safety_systems.pfl.speed_caps``: power and force limiting keeps pure SSM there).
    """

    model: str = ""
    urdf: str = ""
    tool_frame: str = ""
    mode: str = "kinematic"
    control_rate_hz: float = number(500.0, ge=100.0, le=2000.0, unit="Hz")
    cycles: int = number(3, ge=1, le=1000)
    acceleration_limit: float = number(2.0, gt=0.0, le=100.0, unit="1/s")
    braking_time_scale: float = number(1.0, gt=0.0, le=10.0)
    payload_radius: float = number(0.05, gt=0.0, le=1.0, unit="m")
    tool_length: float = number(0.0, ge=0.0, le=1.0, unit="m")
    mounting_size: list[float] = number([], gt=0.0, le=40.0, unit="m")
    path: PathConfig = dc.field(default_factory=PathConfig)


@dc.dataclass
class EllipsoidConfig:
    """Ellipsoid models (seed 004, Eqs. 1-5), metres.

    Robot: one ellipsoid per link between DH frame origins (``link_radii``, 6 values;
    empty: the tool only) and a ``tool_radius`` sphere ``tool_offset`` along tool0's z
    axis from the flange. Operator: ``human``: ``hands`` (a sphere per tracked glove) or
    ``upper_body`` (hands, forearms, upper arms, head and torso, built from the gloves;
    ``safety_systems.speed_alteration.ellipsoids.human_ellipsoids``).
    """

    link_radii: list[float] = number([0.075, 0.065, 0.055, 0.05, 0.05, 0.05], gt=0.0, le=0.5,
                                     unit="m")
    tool_radius: float = number(0.05, gt=0.0, le=1.0, unit="m")
    tool_offset: float = number(0.0, ge=-1.0, le=1.0, unit="m")
    human: str = "upper_body"
    hand_radius: float = number(0.05, gt=0.0, le=0.5, unit="m")
    forearm_radius: float = number(0.05, gt=0.0, le=0.5, unit="m")
    upper_arm_radius: float = number(0.06, gt=0.0, le=0.5, unit="m")
    head_radius: float = number(0.12, gt=0.0, le=0.5, unit="m")
    torso_semi_axes: list[float] = number([0.12, 0.20, 0.30], gt=0.0, le=1.0, unit="m")


@dc.dataclass
class SpeedAlterationConfig:
    """Speed alteration controllers (seed 004): ``erga``, ``hwang``, ``bimodal``, ``none``.

    Every ``rate_hz`` they choose an end-effector speed along the path, signed (the
    robot may back away), at most ``speed_limit`` (ISO 10218-1: 0.25 m/s). ERGA: Eq. 11
    weights ``P``, ``D`` and penalty ``R`` (Eq. 12), GA settings (Section IV-A) and an
    explicit ``seed``; ``prediction``: ``constant_velocity`` (Eqs. 9-10) or ``kalman``
    (the tracker's velocity). Hwang's method chooses among the pre-programmed speed and
    +-``speed_limit``. ``bimodal_clearance``: Morato's stop/go distance between the
    closest ellipsoids.
    """

    rate_hz: float = number(10.0, ge=1.0, le=100.0, unit="Hz")
    speed_limit: float = number(0.25, gt=0.0, le=MAX_ROBOT_SPEED, unit="m/s")
    P: float = number(1.0, ge=0.0, le=1e6)
    D: float = number(1.0, ge=0.0, le=1e6)
    R: float = number(10.0, gt=0.0, le=1e6)
    population: int = number(50, ge=2, le=10_000)
    generations: int = number(100, ge=1, le=10_000)
    crossover: float = number(0.8, ge=0.0, le=1.0)
    mutation: float = number(0.1, ge=0.0, le=1.0)
    elites: int = number(2, ge=0, le=10_000)
    seed: int = _seed()
    prediction: str = "constant_velocity"
    bimodal_clearance: float = number(0.0, ge=0.0, le=5.0, unit="m")
    ellipsoids: EllipsoidConfig = dc.field(default_factory=EllipsoidConfig)


@dc.dataclass
class ZonesConfig:
    """Safety zones (seed 001, Section 2.5, Eq. 6): green while the closest tracked body
    is at least ``green_distance`` (d_green) from the tool, red within ``yellow_distance``
    (the seed's d_yellow, the inner threshold of Eq. 6c), yellow in
    between; each zone has a speed (fraction of the nominal path speed). Performance
    recovery (Section 2.6): speeding up (after a zone change or a resume) follows a
    bounded-jerk profile, path acceleration at most ``max_acceleration`` (1/s) and its
    rate at most ``max_jerk`` (1/s^2); slowing down is immediate (within the brakes).
    Decisions at ``rate_hz``."""

    green_distance: float = number(1.0, gt=0.0, le=MAX_CELL, unit="m")
    yellow_distance: float = number(0.5, gt=0.0, le=MAX_CELL, unit="m")
    green_speed: float = number(1.0, ge=0.0, le=1.0)
    yellow_speed: float = number(0.5, ge=0.0, le=1.0)
    red_speed: float = number(0.1, ge=0.0, le=1.0)
    max_acceleration: float = number(1.0, gt=0.0, le=100.0, unit="1/s")
    max_jerk: float = number(5.0, gt=0.0, le=10_000.0, unit="1/s^2")
    rate_hz: float = number(100.0, ge=1.0, le=1000.0, unit="Hz")


ROBOT_GEOMETRIES = ("capsules", "tool_point")
CONTROLLER_TYPES = ("ssm_override", "erga", "hwang", "bimodal", "none", "zones")
# The blocks of a ControllerConfig a controller type never reads: the speed alteration
# controllers' (seed 004) ``alteration`` and the safety zones' (seed 001) ``zones``.
UNUSED_BLOCKS = {"ssm_override": ("alteration", "zones"), "zones": ("alteration",),
                 **{t: ("zones",) for t in ("erga", "hwang", "bimodal", "none")}}


@dc.dataclass
class ControllerConfig:
    """Everything the safety controller is configured with (a CONFIG file).

    ``type`` chooses the controller: ``ssm_override`` (seed 000, Eq. 12; uses
    ``safety`` and ``body``, its model of an operator), a speed alteration controller of seed 004 (``erga``, ``hwang``,
    ``bimodal``; ``none`` keeps the pre-programmed speed) configured by ``alteration``,
    or seed 001's safety ``zones``.
    """

    type: str = "ssm_override"
    sensor: SensorConfig = dc.field(default_factory=SensorConfig)
    tracker: TrackerConfig = dc.field(default_factory=TrackerConfig)
    safety: SafetyConfig = dc.field(default_factory=SafetyConfig)
    body: BodyConfig = dc.field(default_factory=BodyConfig)
    braking: BrakingConfig = dc.field(default_factory=BrakingConfig)
    alteration: SpeedAlterationConfig = dc.field(default_factory=SpeedAlterationConfig)
    zones: ZonesConfig = dc.field(default_factory=ZonesConfig)


@dc.dataclass
class Body:
    """A tracked rigid body (a glove, a helmet, a band on the elbow, a vest's chest plate)
    at a fixed offset from its operator: ``point`` is the body point it marks
    (``safety_systems.cell.human_body.POINTS``: head, neck, chest, pelvis,
    shoulder_left|right, elbow_left|right, hand_left|right; empty: by its name, ``head``,
    ``hand`` (hand_right), ``other_hand`` (hand_left), ``right_glove``, ``left_glove``).
    ``pivot``: where the sensor reports the body from the point it marks (m, cell frame:
    a scripted body does not turn; a Motive rigid body's pivot left at its markers'
    centroid, ``safety_systems.sensing.pivots``): the sensor sees point + pivot, the
    properties the point."""

    name: str = ""
    point: str = ""
    offset: list[float] = number([0.0, 0.0, 0.0], ge=-2.0, le=2.0, unit="m")
    pivot: list[float] = number([0.0, 0.0, 0.0], ge=-0.5, le=0.5, unit="m")


@dc.dataclass
class PosturePoint:
    """Where an untracked body point of a scripted operator is, at a fixed offset from the
    operator (the truth the properties measure; the sensor does not see it)."""

    point: str = ""
    offset: list[float] = number([0.0, 0.0, 0.0], ge=-2.0, le=2.0, unit="m")


@dc.dataclass
class Waypoint:
    """At ``time`` the operator sets off for ``position`` as fast as its limits allow."""

    time: float = _time()
    position: list[float] = _position([0.0, 0.0, 0.0])


@dc.dataclass
class OperatorConfig:
    """A scripted operator: bodies, timed waypoints, limits and presence window.

    The operator is a whole body (``safety_systems.cell.human_body``): its tracked
    ``bodies`` mark some body points, ``posture`` places others, and the rest stand
    upright about the head, facing the robot base (``human_body.complete_posture``;
    an elbow bends down between its shoulder and a given hand). The whole posture moves
    rigidly along the waypoints.

    Or a recorded one (``recording`` given): the mapping file ``mapping``'s operator
    ``name`` (empty: the mapping's only one, whose name it takes) played from the
    recording (a Motive CSV export or a C3D file; both files relative to the scenario
    file, ``safety_systems.sensing.recording_mapping``): recording time ``start`` plays at
    t = 0, ``time_scale`` recording seconds per second (1.3: 30 % faster than recorded),
    every body turned by ``yaw_deg`` about the cell's z axis (through the robot base) and
    then moved by ``shift`` (m, cell frame). Its ``bodies`` come from the mapping (leave
    them empty, or give the mapping's in its order to set other radii; no
    ``waypoints``); ``max_speed`` and ``max_acceleration`` are unused. A scenario's
    operators are all scripted or all recorded; ``start``, ``time_scale``, ``yaw_deg``
    and ``shift`` are a recorded operator's only.
    """

    name: str = ""
    max_speed: float = number(1.8, gt=0.0, le=MAX_SCRIPTED_SPEED, unit="m/s")
    max_acceleration: float = number(2.0, gt=0.0, le=100.0, unit="m/s^2")
    enter_time: float = _time()
    leave_time: float = number(math.inf, gt=0.0, le=MAX_DURATION, unit="s", infinite=True)
    bodies: list[Body] = dc.field(default_factory=list)
    posture: list[PosturePoint] = dc.field(default_factory=list)
    waypoints: list[Waypoint] = dc.field(default_factory=list)
    recording: str = ""
    mapping: str = ""
    start: float = number(0.0, ge=0.0, le=100_000.0, unit="s")
    time_scale: float = number(1.0, ge=0.1, le=10.0)
    shift: list[float] = _position([0.0, 0.0, 0.0])
    yaw_deg: float = number(0.0, ge=-360.0, le=360.0, unit="deg")


@dc.dataclass
class Gesture:
    """A gesture command (seed 001, Section 2.1) at ``time``: start, stop or resume."""

    time: float = _time()
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
    duration: float = number(30.0, gt=0.0, le=MAX_DURATION, unit="s")
    contact_geometry: str = "capsules"
    contact_distance: float = number(0.0, ge=0.0, le=1.0, unit="m")
    robot: RobotConfig = dc.field(default_factory=RobotConfig)
    controller: ControllerConfig = dc.field(default_factory=ControllerConfig)
    sensor: typing.Optional[SensorConfig] = None
    jerk_window: list[int] = number([], ge=2, le=10_000_000)
    gestures: list[Gesture] = dc.field(default_factory=list)
    operators: list[OperatorConfig] = dc.field(default_factory=list)


def _check(ok: bool, field: str, value: typing.Any, allowed: str) -> None:
    if not ok:
        raise ScenarioError(field, value, allowed)


def _interval(field: str, start: float, end: float) -> None:
    _check(start < end, field, [start, end], "start < end")


def validate_sensor(s: SensorConfig, prefix: str) -> None:
    """Checks between a sensor description's fields; raises :class:`ScenarioError`."""
    for i, d in enumerate(s.dropouts):
        _interval(f"{prefix}.dropouts[{i}]", d.start, d.end)
    for i, o in enumerate(s.occlusions):
        _interval(f"{prefix}.occlusions[{i}]", o.start, o.end)
    for i, f in enumerate(s.faults):
        where = f"{prefix}.faults[{i}]"
        _check(f.kind in FAULT_KINDS, f"{where}.kind", f.kind, " | ".join(FAULT_KINDS))
        _interval(where, f.start, f.end)
        _check(len(f.offset) == 3, f"{where}.offset", f.offset, "3 numbers in m")


def _box(field: str, box: Box) -> None:
    _check(len(box.min) == 3 and len(box.max) == 3 and all(
        a <= b for a, b in zip(box.min, box.max)),
        field, [box.min, box.max], "min and max: 3 numbers in m each, min <= max")


def validate_controller(c: ControllerConfig, prefix: str = "controller") -> None:
    """Ranges (``check_limits``) and checks between a controller configuration's
    fields; raises :class:`ScenarioError`."""
    check_limits(c, prefix)
    _controller_rules(c, prefix)


def _controller_rules(c: ControllerConfig, prefix: str, model: RobotModel | None = None
                      ) -> None:
    validate_sensor(c.sensor, f"{prefix}.sensor")
    s = c.sensor
    t = c.tracker
    _check(t.hidden_bodies in HIDDEN_BODY_RULES, f"{prefix}.tracker.hidden_bodies",
           t.hidden_bodies, " | ".join(HIDDEN_BODY_RULES))
    for i, box in enumerate(t.exits):
        _box(f"{prefix}.tracker.exits[{i}]", box)
    if t.cell is not None:
        _box(f"{prefix}.tracker.cell", t.cell)
    if t.frame_timeout is not None:
        due = 1.0 / s.rate_hz + s.latency + t.processing_time
        _check(t.frame_timeout > due, f"{prefix}.tracker.frame_timeout", t.frame_timeout,
               f"more than one sensor period + latency + processing time ({due:.4g} s)")
    f = c.safety
    _check(f.robot_geometry in ROBOT_GEOMETRIES, f"{prefix}.safety.robot_geometry",
           f.robot_geometry, " | ".join(ROBOT_GEOMETRIES))
    if model is None or is_ur5e(model):
        _check(len(f.link_radii) in (0, 6), f"{prefix}.safety.link_radii", f.link_radii,
               "empty (the UR5e model's capsules) or 6 radii in m, each 0 < r <= 0.5")
    else:
        K = len(model.link_capsules)
        _check(len(f.link_radii) in (0, K), f"{prefix}.safety.link_radii", f.link_radii,
               f"empty (the {model.name} model's capsules) or {K} radii in m "
               f"({', '.join(model.link_names)}), each 0 < r <= 0.5")
    _check(f.human_speed in HUMAN_SPEED_MODES, f"{prefix}.safety.human_speed", f.human_speed,
           " | ".join(HUMAN_SPEED_MODES))
    _check(f.robot_speed in ROBOT_SPEED_TERMS, f"{prefix}.safety.robot_speed", f.robot_speed,
           " | ".join(ROBOT_SPEED_TERMS))
    _check(f.stopping in STOPPING_MODES, f"{prefix}.safety.stopping", f.stopping,
           " | ".join(STOPPING_MODES))
    _check(f.mode in SAFETY_MODES, f"{prefix}.safety.mode", f.mode, " | ".join(SAFETY_MODES))
    for i, box in enumerate(f.fixed_surfaces):
        _box(f"{prefix}.safety.fixed_surfaces[{i}]", box)
    if f.mode == "ssm_pfl":
        _check(f.robot_geometry == "capsules", f"{prefix}.safety.robot_geometry",
               f.robot_geometry, "capsules under safety.mode: ssm_pfl (a contact's body "
               "region needs the operator's segments against the robot's links)")
    _check(c.type in CONTROLLER_TYPES, f"{prefix}.type", c.type, " | ".join(CONTROLLER_TYPES))
    validate_alteration(c.alteration, f"{prefix}.alteration")
    z = c.zones
    _check(z.green_distance > z.yellow_distance, f"{prefix}.zones.green_distance",
           [z.green_distance, z.yellow_distance], "green_distance > yellow_distance > 0 (m)")
    _check(z.red_speed <= z.yellow_speed <= z.green_speed, f"{prefix}.zones.red_speed",
           [z.red_speed, z.yellow_speed, z.green_speed],
           "0 <= red_speed <= yellow_speed <= green_speed <= 1")
    b = c.braking
    n = len(b.speed_fraction)
    for name in ("speed_fraction", "stopping_time", "stopping_distance"):
        values = getattr(b, name)
        _check(len(values) == n, f"{prefix}.braking.{name}", values,
               f"a list as long as speed_fraction ({n} values)")
    _check(all(a < b_ for a, b_ in zip(b.speed_fraction, b.speed_fraction[1:])),
           f"{prefix}.braking.speed_fraction", b.speed_fraction, "strictly increasing fractions")
    _check(n == 0 or b.speed_fraction[-1] == 1.0, f"{prefix}.braking.speed_fraction",
           b.speed_fraction, "fractions of nominal speed up to and including 1.0")


def validate_alteration(a: SpeedAlterationConfig, prefix: str) -> None:
    """Checks between the speed alteration settings' fields."""
    _check(a.elites < a.population, f"{prefix}.elites", a.elites, "0 <= elites < population")
    _check(a.prediction in ("constant_velocity", "kalman"), f"{prefix}.prediction",
           a.prediction, "constant_velocity | kalman")
    e = a.ellipsoids
    _check(len(e.link_radii) in (0, 6), f"{prefix}.ellipsoids.link_radii", e.link_radii,
           "6 radii in m, or none (the tool only)")
    _check(e.human in ("hands", "upper_body"), f"{prefix}.ellipsoids.human", e.human,
           "hands | upper_body")
    _check(len(e.torso_semi_axes) == 3, f"{prefix}.ellipsoids.torso_semi_axes",
           e.torso_semi_axes, "3 positive lengths in m")


def _points(field: str, points: list, n: int, allowed: str) -> None:
    _check(len(points) == n, field, points, allowed)


def validate_scenario(s: Scenario) -> None:
    """Ranges (``check_limits``) and checks between a scenario's fields; raises
    :class:`ScenarioError` (the first problem, in the order below)."""
    check_limits(s)
    _check(s.contact_geometry in ROBOT_GEOMETRIES, "contact_geometry", s.contact_geometry,
           " | ".join(ROBOT_GEOMETRIES))
    _validate_gestures(s.gestures)
    _check(not s.jerk_window or (len(s.jerk_window) == 2
                                 and s.jerk_window[0] < s.jerk_window[1]),
           "jerk_window", s.jerk_window, "empty, or [first, last] samples with 2 <= first < last")
    validate_robot(s.robot)
    validate_robot_controller(s.robot, s.controller)
    if s.sensor is not None:
        validate_sensor(s.sensor, "sensor")
    _validate_operators(s.operators)
    _validate_sensor_bodies(s)


def _validate_gestures(gestures: list) -> None:
    last = -math.inf
    for i, g in enumerate(gestures):
        _check(g.command in GESTURES, f"gestures[{i}].command", g.command, " | ".join(GESTURES))
        _check(g.time > last, f"gestures[{i}].time", g.time,
               "0 <= time <= 600 s and after the previous gesture")
        last = g.time


def _validate_operators(operators: list) -> None:
    """The operators: their count, one kind (scripted or recorded), unique names, then
    each operator's own fields (:func:`_validate_operator`)."""
    _check(1 <= len(operators) <= MAX_OPERATORS, "operators", len(operators),
           f"1 to {MAX_OPERATORS} operators")
    recorded = [bool(o.recording) for o in operators]
    _check(all(recorded) or not any(recorded), "operators", "scripted and recorded",
           "operators all scripted or all recorded")
    names = set()
    for i, o in enumerate(operators):
        f = f"operators[{i}]"
        _check(NAME.fullmatch(o.name) is not None and o.name not in names, f"{f}.name", o.name,
               "a unique name of 1 to 64 letters, digits, '_', '-' or '.'")
        names.add(o.name)
        _validate_operator(o, f)


def _validate_operator(o: OperatorConfig, f: str) -> None:
    """One operator (field path ``f``): its window, bodies and shift, then a recorded
    operator's mapping or a scripted one's waypoints (:func:`_validate_waypoints`)."""
    _check(o.leave_time > o.enter_time, f"{f}.leave_time", o.leave_time,
           f"later than enter_time ({o.enter_time})")
    _check(1 <= len(o.bodies) <= MAX_BODIES_PER_OPERATOR, f"{f}.bodies", len(o.bodies),
           f"1 to {MAX_BODIES_PER_OPERATOR} bodies (one per body point)")
    marked = set()
    for j, b in enumerate(o.bodies):
        _check(NAME.fullmatch(b.name) is not None, f"{f}.bodies[{j}].name", b.name,
               "a name of 1 to 64 letters, digits, '_', '-' or '.'")
        point = body_point(b)
        _check(point in human_body.POINTS and point not in marked, f"{f}.bodies[{j}].point",
               b.point, "a body point no other body of the operator marks: "
               + " | ".join(human_body.POINTS) + " (empty only for the names "
               + ", ".join(human_body.LEGACY_POINTS) + ")")
        marked.add(point)
        _points(f"{f}.bodies[{j}].offset", b.offset, 3, "3 numbers in m")
        _points(f"{f}.bodies[{j}].pivot", b.pivot, 3, "3 numbers in m")
    for j, q in enumerate(o.posture):
        _check(q.point in human_body.POINTS and q.point not in marked,
               f"{f}.posture[{j}].point", q.point, "a body point no body of the operator "
               "marks and the posture places once: " + " | ".join(human_body.POINTS))
        marked.add(q.point)
        _points(f"{f}.posture[{j}].offset", q.offset, 3, "3 numbers in m")
    _points(f"{f}.shift", o.shift, 3, "3 numbers in m")
    if o.recording:
        _check(not o.waypoints, f"{f}.waypoints", o.waypoints,
               "none for a recorded operator (it moves as recorded)")
        _check(bool(o.mapping), f"{f}.mapping", o.mapping,
               "the recording's mapping file (a recorded operator needs one)")
        _check(not o.posture, f"{f}.posture", len(o.posture),
               "none for a recorded operator (its mapping names its points)")
        return
    _check(not o.mapping, f"{f}.mapping", o.mapping, "empty without a recording")
    for name, unset in (("start", 0.0), ("time_scale", 1.0), ("yaw_deg", 0.0),
                        ("shift", [0.0, 0.0, 0.0])):
        _check(getattr(o, name) == unset, f"{f}.{name}", getattr(o, name),
               f"{unset} for a scripted operator (it moves along its waypoints)")
    _validate_waypoints(o, f)
    try:
        operator_posture(o)
    except ValueError as e:
        raise ScenarioError(f"{f}.bodies", [b.offset for b in o.bodies],
                            f"a posture the operator can take ({e}; give its posture)") \
            from None


def body_point(body: Body) -> str:
    """The body point a tracked body marks: its ``point``, or its legacy name's."""
    return body.point or human_body.LEGACY_POINTS.get(body.name, "")


def operator_points(o: OperatorConfig) -> list[str]:
    """The body point of each of the operator's tracked bodies, in their order."""
    return [body_point(b) for b in o.bodies]


def operator_posture(o: OperatorConfig) -> np.ndarray:
    """(10, 3) every body point's offset from a scripted operator (``human_body.POINTS``
    order): its bodies', its posture's, the rest completed facing the robot base from
    its first waypoint (``human_body.complete_posture``); raises ValueError when a given
    hand is out of its completed shoulder's reach."""
    given = {body_point(b): np.array(b.offset, dtype=float) for b in o.bodies}
    given.update({q.point: np.array(q.offset, dtype=float) for q in o.posture})
    start = np.array(o.waypoints[0].position, dtype=float) if o.waypoints else np.zeros(3)
    offsets = list(given.values())  # their mean (as np.mean: summed in order, divided)
    total = offsets[0].copy()
    for offset in offsets[1:]:
        total += offset
    anchor = start + total / len(offsets)
    points = human_body.complete_posture(given, -anchor)
    return np.array([points[k] for k in human_body.POINTS])


def _validate_waypoints(o: OperatorConfig, f: str) -> None:
    """A scripted operator's waypoints: at least one, times increasing, a path its speed
    and acceleration limits can keep."""
    _check(len(o.waypoints) >= 1, f"{f}.waypoints", o.waypoints, "at least one waypoint")
    last = -math.inf
    for j, w in enumerate(o.waypoints):
        _points(f"{f}.waypoints[{j}].position", w.position, 3, "3 numbers in m")
        _check(w.time > last, f"{f}.waypoints[{j}].time", w.time,
               f"later than the previous waypoint's ({last})")
        last = w.time
    try:
        make_operator_path([w.time for w in o.waypoints], [w.position for w in o.waypoints],
                           o.max_speed, o.max_acceleration)
    except ValueError as e:
        raise ScenarioError(f"{f}.waypoints", [w.time for w in o.waypoints],
                            f"times the operator's limits can keep ({e})") from None


def _validate_sensor_bodies(s: Scenario) -> None:
    """Body names unique, and every body the sensor's occlusions and faults name exists."""
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


def robot_model_of(r: RobotConfig, prefix: str = "robot") -> RobotModel:
    """The model of the robot ``r`` names (``cell.robot_model.robot_model``: ``model`` or
    ``urdf``, made once per process); raises :class:`ScenarioError` naming ``prefix``'s
    field (a bad URDF: its file and its own field)."""
    _check(not (r.model and r.urdf), f"{prefix}.urdf", r.urdf,
           "empty when robot.model names a shipped robot (one of the two)")
    try:
        return robot_model(r.model, urdf=r.urdf, tool_frame=r.tool_frame)
    except InputError as e:
        if e.file is None and e.field.startswith("robot."):
            e.field = prefix + e.field[len("robot"):]
            e.args = (e._line(),)
        raise


def validate_robot(r: RobotConfig, prefix: str = "robot") -> None:
    """Checks between a robot's fields (its model, its mode, its path: the model's joint
    count, within its joint limits and speeds); raises :class:`ScenarioError` naming
    ``prefix``'s fields."""
    model = robot_model_of(r, prefix)
    n, name = model.n, model.name
    _check(r.mode in ("kinematic", "dynamic"), f"{prefix}.mode", r.mode, "kinematic | dynamic")
    _check(len(r.mounting_size) in (0, 2), f"{prefix}.mounting_size", r.mounting_size,
           "empty (a square over the robot's reach) or [x, y] in m, each 0 < x <= 40")
    p = r.path
    if p.log is not None:
        _check(p.line is None and p.task_path is None and not p.waypoints_deg
               and not p.segment_durations, f"{prefix}.path.log", p.log.file,
               "one kind of path: log, task_path, line or waypoints")
        validate_robot_log(r, model, prefix)
        return
    if p.line is not None or p.task_path is not None:
        _check(is_ur5e(model), f"{prefix}.path." + ("line" if p.line is not None else
                                                   "task_path"), name,
               "a line or task path on the ur5e only (its inverse kinematics); give "
               "waypoints_deg on another robot")
    if p.line is not None:
        _check(not p.waypoints_deg and not p.segment_durations, f"{prefix}.path.line", "line",
               "either a line or waypoints, not both")
        _check(r.cycles == 1, f"{prefix}.cycles", r.cycles, "1 for a one-way line path")
        for name in ("start", "goal", "rpy_deg"):
            _points(f"{prefix}.path.line.{name}", getattr(p.line, name), 3, "3 numbers")
        _points(f"{prefix}.path.line.seed_deg", p.line.seed_deg, 6, "6 joint angles in deg")
        _check(p.line.start != p.line.goal, f"{prefix}.path.line.goal", p.line.goal,
               "a point other than start")
    if p.task_path is not None:
        t = p.task_path
        _check(p.line is None and not p.waypoints_deg, f"{prefix}.path.task_path", "task_path",
               "one kind of path: task_path, line or waypoints")
        _check(bool(t.points) or bool(t.file), f"{prefix}.path.task_path.points", t.points,
               "2 or more [x, y, z] points in m, or a file")
        _check(not t.points or (len(t.points) >= 2 and all(len(q) == 3 for q in t.points)),
               f"{prefix}.path.task_path.points", t.points, "2 or more [x, y, z] points in m")
        _points(f"{prefix}.path.task_path.rpy_deg", t.rpy_deg, 3, "3 angles in deg")
        _points(f"{prefix}.path.task_path.seed_deg", t.seed_deg, 6, "6 joint angles in deg")
    if p.line is None and p.task_path is None and not p.waypoints_deg:
        _check(model.kind == KIND_UR, f"{prefix}.path.waypoints_deg", p.waypoints_deg,
               f"waypoints of the {model.name}'s {n} joints (the default pick-and-place "
               "path is a UR arm's)")
    if p.waypoints_deg or p.segment_durations:
        _check(len(p.waypoints_deg) >= 2, f"{prefix}.path.waypoints_deg", p.waypoints_deg,
               f"at least 2 waypoints of {n} joint angles (the {model.name}'s joints)")
        for i, w in enumerate(p.waypoints_deg):
            _points(f"{prefix}.path.waypoints_deg[{i}]", w, n,
                    f"{n} joint angles in deg (the {model.name}'s joints)")
            inside = (np.radians(w) >= model.position_lower - 1e-12) & (
                np.radians(w) <= model.position_upper + 1e-12)
            _check(bool(np.all(inside)), f"{prefix}.path.waypoints_deg[{i}]", w,
                   f"angles within the {model.name}'s joint limits: " + ", ".join(
                       f"{math.degrees(a):.1f} ... {math.degrees(b):.1f}"
                       for a, b in zip(model.position_lower, model.position_upper)) + " deg")
        _check(len(p.segment_durations) == len(p.waypoints_deg),
               f"{prefix}.path.segment_durations", p.segment_durations,
               f"{len(p.waypoints_deg)} durations (one per segment, the last closes the cycle)")
        try:
            make_joint_path(np.radians(p.waypoints_deg), p.segment_durations, cycles=r.cycles,
                            joint_speed_limit=joint_speed_limit(model), num_joints=n)
        except ValueError as e:
            raise ScenarioError(f"{prefix}.path.segment_durations", p.segment_durations,
                                str(e)) from None


def validate_robot_log(r: RobotConfig, model: RobotModel, prefix: str = "robot") -> None:
    """A robot log path (``path.log``, its file already resolved by
    :func:`read_robot_log`): its window, and the log's samples under
    ``cell.robot_log.check_joint_log`` against the model's joint limits and speeds; a
    repeated log's step back to its start too; and the path the robot runs through the
    window's samples within the joint speed limits (``check_path_speeds``). Raises
    :class:`ScenarioError` (a bad log: its file, row, field and value)."""
    from safety_systems.cell.robot_log import (
        check_joint_log,
        check_path_speeds,
        closing_step,
        make_log_path,
        window_index,
    )

    g = r.path.log
    _check(bool(g.file), f"{prefix}.path.log.file", g.file, "an RTDE CSV or a ROS bag")
    _check(g.end is None or g.end > g.start, f"{prefix}.path.log.end", g.end,
           f"later than start ({g.start} s), or none (the log's last sample)")
    log = robot_log_of(r, prefix)
    check_joint_log(log, lower=model.position_lower, upper=model.position_upper,
                    speed_limit=model.velocity_limit, robot=model.name, max_gap=g.max_gap)
    keep = window_index(log, g.start, g.end)
    s, q = log.times[keep] - log.times[keep][0], log.q[keep]
    if g.repeat:
        h, speed = closing_step(s, q)
        j = int(np.argmax(speed / model.velocity_limit))
        _check(bool(np.all(speed <= model.velocity_limit)), f"{prefix}.path.log.repeat", True,
               f"a log that ends where it starts (its last sample's {log.fields[j]} is "
               f"{math.degrees(abs(q[-1, j] - q[0, j])):.3g} deg from its first: "
               f"{math.degrees(speed[j]):.0f} deg/s over one spacing, {h:.4g} s; the "
               f"{model.name}'s limit is {math.degrees(model.velocity_limit[j]):.0f}); or "
               "false (run it once)")
    path = make_log_path(s, q, repeat=g.repeat, cycles=r.cycles)
    check_path_speeds(log, path, keep, speed_limit=model.velocity_limit, robot=model.name)


def robot_log_of(r: RobotConfig, prefix: str = "robot"):
    """The ``cell.robot_log.JointLog`` of a robot's ``path.log`` (the model's joints)."""
    from safety_systems.cell.robot_log import read_joint_log

    g = r.path.log
    model = robot_model_of(r, prefix)
    try:
        return read_joint_log(g.file, tuple(model.joint_names), g.topic)
    except InputError as e:
        if e.file is None:
            e.in_file(g.file)
        raise


def read_robot_log(robot: RobotConfig, folder: Path, prefix: str = "robot") -> None:
    """Resolves a robot log's ``file`` relative to ``folder`` (the file that names it),
    in place; the log itself is read when the robot is checked (and its bytes, with their
    SHA-256, named among the inputs)."""
    g = robot.path.log
    if g is None or not g.file:
        return
    file = (folder / g.file).resolve()
    _check(file.exists(), f"{prefix}.path.log.file", g.file, f"an existing RTDE CSV or ROS "
           f"bag ({file})")
    g.file = str(file)


def joint_speed_limit(model: RobotModel) -> float | np.ndarray:
    """The joint speed limit a path of ``model`` keeps: one number where every joint has
    the same (the UR5e's 180 deg/s), else one per joint (rad/s)."""
    limits = model.velocity_limit
    return float(limits[0]) if np.all(limits == limits[0]) else limits


def validate_robot_controller(r: RobotConfig, c: ControllerConfig,
                              prefix: str = "controller") -> None:
    """Checks between a robot and the controller configuration run on it (a scenario's, or
    one given with ``--config``): the seed-004 controllers and the zones model the UR5e
    only; ``safety.link_radii`` gives one radius per link of the robot."""
    model = robot_model_of(r)
    _controller_rules(c, prefix, model)
    _check(c.type == "ssm_override" or is_ur5e(model), f"{prefix}.type", c.type,
           f"ssm_override on the {model.name} (the seed-004 controllers and the zones model "
           "the ur5e only)")
    _check(bool(c.braking.speed_fraction) or model.placeholder is not None,
           f"{prefix}.braking.speed_fraction", c.braking.speed_fraction,
           f"the stopping data measured on the {model.name} (a robot from a URDF has no "
           "built-in placeholder)")


def actual_sensor(s: Scenario) -> SensorConfig:
    """The cell's real sensor: ``s.sensor`` if given, else the one configured."""
    return s.controller.sensor if s.sensor is None else s.sensor


def body_names(s: Scenario) -> list[str]:
    """The registered body slots, operator by operator: ``operator/body``."""
    return [f"{o.name}/{b.name}" for o in s.operators for b in o.bodies]


def load_typed(schema: type, path: str | Path) -> typing.Any:
    """Loads a YAML file strictly into the dataclass ``schema`` (the rules of
    ``safety_systems.files.documents``, declared ranges included; no other checks)."""
    return load_document(path, schema)


def load_scenario(path: str | Path) -> Scenario:
    """Load and validate a scenario file; raises :class:`ScenarioError`. A task path's
    ``file`` and recorded operators' files are read here, relative to the scenario
    file."""
    def validate(scenario: Scenario) -> None:
        read_robot_file(scenario.robot, Path(path).parent)
        read_task_path(scenario.robot, Path(path).parent)
        read_robot_log(scenario.robot, Path(path).parent)
        read_recordings(scenario, Path(path).parent)
        validate_scenario(scenario)

    return load_document(path, Scenario, validate)


def read_recordings(scenario: Scenario, folder: Path) -> None:
    """Reads every recorded operator's recording and mapping (relative to ``folder``;
    the paths are replaced by the files' full paths) and fills in its bodies (names and
    points from the mapping) and, if empty, its name (the mapping's operator's); an
    error in either file is reported at the field that names it, with the file's own
    error."""
    from safety_systems.sensing.recording_mapping import load_recorded_operator

    for i, o in enumerate(scenario.operators):
        if not o.recording:
            continue
        where = f"operators[{i}]"
        _check(bool(o.mapping), f"{where}.mapping", o.mapping,
               "the recording's mapping file (a recorded operator needs one)")
        o.recording, o.mapping = (str((folder / x).resolve()) for x in (o.recording, o.mapping))
        try:
            recorded = load_recorded_operator(o.recording, o.mapping, o.name)
        except ScenarioError as e:
            if e.file is not None:  # the recording's or the mapping's own line, as
                raise  # `check mapping` gives it
            raise ScenarioError(f"{where}.recording", o.recording,
                                f"a recording its mapping fits ({e})") from None
        if not o.name:
            from safety_systems.sensing.recording_mapping import load_mapping

            o.name = load_mapping(o.mapping).operators[0].name
        if not o.bodies:
            o.bodies = [Body(name, point, [0.0, 0.0, 0.0])
                        for name, point in zip(recorded.names, recorded.points_marked)]
        _check([b.name for b in o.bodies] == list(recorded.names)
               and [body_point(b) for b in o.bodies] == list(recorded.points_marked)
               and all(b.offset == [0.0, 0.0, 0.0] and b.pivot == [0.0, 0.0, 0.0]
                       for b in o.bodies), f"{where}.bodies",
               [b.name for b in o.bodies], f"none (they come from the mapping), or the "
               f"mapping's {list(recorded.names)} in its order, with its points, without "
               "offsets or pivots (a recorded body's pivot is its mapping's)")


def read_robot_file(robot: RobotConfig, folder: Path, prefix: str = "robot") -> None:
    """Resolves a robot's ``urdf`` relative to ``folder`` (the file that names it), in
    place, and records the robot's URDF among the inputs read (its SHA-256 in
    ``provenance``; a shipped robot's when ``model`` names one)."""
    if robot.urdf:
        file = (folder / robot.urdf).resolve()
        _check(file.is_file(), f"{prefix}.urdf", robot.urdf, f"an existing URDF file ({file})")
        robot.urdf = str(file)
        read_input(file)
    elif robot.model in SHIPPED:
        read_input(SHIPPED[robot.model])


def read_task_path(robot: RobotConfig, folder: Path, prefix: str = "robot") -> None:
    """Fills a task path's points from its ``file`` (relative to ``folder``); an error
    in that file is reported at the field that names it, with the file's own error."""
    task = robot.path.task_path
    if task is None or task.points or not task.file:
        return
    field = f"{prefix}.path.task_path.file"
    try:
        task.points = load_typed(TaskPoints, folder / task.file).points
    except ScenarioError as e:
        raise ScenarioError(field, task.file, f"a YAML file of points ({e})") from None
    _check(len(task.points) >= 2, field, task.file,
           f"a file with 2 or more points ({folder / task.file})")


def load_controller_config(path: str | Path) -> ControllerConfig:
    """Load and validate a controller configuration file."""
    return load_document(path, ControllerConfig,
                         lambda config: validate_controller(config, prefix="config"))


def scenario_from_text(text: str) -> Scenario:
    """Load and validate a scenario from YAML text."""
    scenario = _parse_typed(Scenario, text, "<text>")
    try:
        validate_scenario(scenario)
    except ScenarioError as e:
        raise e.in_file("<text>") from None
    return scenario


_DEFAULT_ROBOT_CHOICE = "robot:\n  model: ''\n  urdf: ''\n  tool_frame: ''\n"


def dump_scenario(scenario: Scenario) -> str:
    """YAML text that :func:`scenario_from_text` loads back to an equal scenario. The
    robot's choice (``model``, ``urdf``, ``tool_frame``) is left out when it is the
    default's (all empty: the UR5e), so a UR5e scenario is written as before robots could
    be chosen."""
    text = yaml_dump_typed(scenario)
    r = scenario.robot
    if not (r.model or r.urdf or r.tool_frame) and text.count(_DEFAULT_ROBOT_CHOICE) == 1:
        text = text.replace(_DEFAULT_ROBOT_CHOICE, "robot:\n")
    return text
