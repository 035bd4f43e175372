"""Builders: ``AddSafetyController`` and ``MakeWorkcell`` (the whole cell from a scenario).

The diagram (seed Sections 4-6, Fig. 5's loop)::

    OperatorMotion -> MocapSensor -> KalmanTracker -> SeparationMonitor -> SpeedOverride
                                                             ^                   |
         UR5e (kinematic, or plant + inverse dynamics) -> RobotCapsules          |
                    ^                                                            |
                    +------------------ PathFollower (braking) <-----------------+

Every signal is logged at the control period.
"""

import dataclasses
import math
from collections.abc import Iterable

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.controllers import InverseDynamicsController
from pydrake.systems.framework import Diagram, DiagramBuilder, OutputPort
from pydrake.systems.primitives import Demultiplexer, Multiplexer, VectorLogSink

from safety_systems.config.configuration import (
    contact_capsules,
    truth_recipe,
    is_recorded,
    joint_path,
    tracked_points,
    recorded_operators,
    scripted_operators,
    sensor_faults,
)
from safety_systems.cell.joint_path import JointPath
from safety_systems.config.resolved_cell import ResolvedCell, scenario_cell
from safety_systems.config.scenario import (
    RobotConfig,
    Scenario,
    actual_sensor,
    body_names,
    body_point,
)
from safety_systems.pfl.speed_caps import CLAMP_GAP, capsule_links
from safety_systems.systems.bimodal_speed_controller import BimodalSpeedController
from safety_systems.systems.contact_stop import ContactStop
from safety_systems.systems.erga_speed_controller import ErgaSpeedController
from safety_systems.systems.gesture_source import GestureSource
from safety_systems.systems.hwang_speed_controller import HwangSpeedController
from safety_systems.systems.kalman_tracker import KalmanTracker
from safety_systems.systems.mocap_sensor import MocapSensor
from safety_systems.systems.operator_motion import OperatorMotion
from safety_systems.systems.path_follower import PathFollower
from safety_systems.systems.recorded_motion import RecordedMotion
from safety_systems.systems.preprogrammed_speed_controller import PreprogrammedSpeedController
from safety_systems.systems.robot_capsules import RobotCapsules
from safety_systems.systems.operator_envelopes import OperatorEnvelopes
from safety_systems.systems.separation_monitor import SeparationMonitor
from safety_systems.systems.speed_override import SpeedOverride
from safety_systems.systems.zones_controller import ZonesController
from safety_systems.ssm.formulas import SPEED_LEVELS
from safety_systems.cell.robot_model import RobotModel
from safety_systems.cell.robot_plant import AddRobot

# Joint-space gains of the dynamic mode's inverse-dynamics controller: critically
# damped, natural frequency 30 rad/s (own choice).
DYNAMIC_KP = 900.0
DYNAMIC_KD = 60.0


def AddOperators(builder: DiagramBuilder, scenario: Scenario):
    """Adds the operators' ground truth, named ``operators``: ``OperatorMotion`` of the
    scripted operators, or ``RecordedMotion`` of the recorded ones (the same ports);
    returns (the system, the occlusions the recordings imply: (body slot, start, end)
    over each recording's gaps)."""
    if not is_recorded(scenario):
        return builder.AddNamedSystem(
            "operators", OperatorMotion(operators=scripted_operators(scenario))), []
    operators = recorded_operators(scenario)
    hidden, first = [], 0
    for op in operators:
        hidden += [(first + i, a, b) for i, a, b in op.hidden_intervals()]
        first += op.num_bodies
    return builder.AddNamedSystem("operators", RecordedMotion(operators=operators)), hidden


@dataclasses.dataclass
class SafetyController:
    """What ``AddSafetyController`` added: the tracker, the controller's systems by name
    and the port carrying the commanded path speed (a fraction of nominal, signed)."""

    tracker: KalmanTracker
    systems: dict
    command: OutputPort


SPEED_CONTROLLERS = {"erga": ErgaSpeedController, "hwang": HwangSpeedController,
                     "bimodal": BimodalSpeedController, "none": PreprogrammedSpeedController}


def body_roles(scenario: Scenario) -> tuple[np.ndarray, np.ndarray]:
    """(operator index, is-a-hand) of every body slot: a body marking a hand point is a
    hand (``scenario.body_point``); seed 004's controllers take the others as heads."""
    operator_of = [k for k, o in enumerate(scenario.operators) for _ in o.bodies]
    is_hand = [body_point(b).startswith("hand") for o in scenario.operators for b in o.bodies]
    return np.array(operator_of), np.array(is_hand)


def AddSafetyController(builder: DiagramBuilder, *, cell: ResolvedCell, num_bodies: int,
                        control_period: float, path=None, operator_of=None,
                        is_hand=None, points=None, operator_names=None) -> SafetyController:
    """Adds the tracker and the controller that the resolved cell's configuration
    (``cell.config.type``) names, for the cell's robot.

    ``ssm_override`` (seed 000): RobotCapsules (the robot as the monitor measures it,
    ``cell.capsules``), OperatorEnvelopes (every operator's segments from its tracked
    bodies, which mark the body points ``points``, per operator in slot order, named
    ``operator_names``: ``cell.recipe_for``), SeparationMonitor and
    SpeedOverride; left to connect: the RobotCapsules' ``joint_positions``. The
    seed-004 controllers (``erga``, ``hwang``, ``bimodal``, ``none``) need ``path`` and
    the body roles (``body_roles``); left to connect: their ``path_state``. ``zones``
    (seed 001) needs ``path``; left to connect: its ``path_state`` and ``gesture``.
    Always left to connect: the tracker's ``positions_measured``, ``valid``,
    ``sample_time``, ``frame_number`` and ``body_ids``. Under ``safety.mode: ssm_pfl``
    the SpeedOverride takes power and force limiting's caps and fixed surfaces
    (``cell.pfl``).
    """
    config = cell.config
    s, t, f = config.sensor, config.tracker, config.safety
    tracker = builder.AddNamedSystem("tracker", KalmanTracker(
        num_bodies=num_bodies, period_sec=1.0 / s.rate_hz, latency_sec=s.latency,
        processing_time=t.processing_time, frame_timeout=cell.frame_timeout,
        rules=cell.tracker_rules, regions=cell.tracker_regions))
    if config.type == "zones":
        zones = builder.AddNamedSystem("zones", ZonesController(
            path=path, config=config.zones, num_bodies=num_bodies))
        for name in ("positions_estimated", "track_status", "fault"):
            builder.Connect(tracker.GetOutputPort(name), zones.GetInputPort(name))
        return SafetyController(tracker, {"zones": zones},
                                zones.GetOutputPort("path_speed_commanded"))
    if config.type != "ssm_override":
        # Decide one control tick after the tracker has processed the newest frame.
        offset = s.latency + t.processing_time + control_period
        speed = builder.AddNamedSystem("speed", SPEED_CONTROLLERS[config.type](
            path=path, config=config.alteration, operator_of=operator_of, is_hand=is_hand,
            offset_sec=offset))
        for name in ("positions_estimated", "velocities_estimated", "track_status", "fault"):
            builder.Connect(tracker.GetOutputPort(name), speed.GetInputPort(name))
        return SafetyController(tracker, {"speed": speed},
                                speed.GetOutputPort("path_speed_commanded"))
    t_s, b = cell.stopping
    by_speed = f.stopping == "by_speed"
    capsules = cell.capsules
    robot = builder.AddNamedSystem("robot_capsules", RobotCapsules(
        capsules=capsules, period_sec=control_period))
    if points is None:
        raise ValueError("points: the body point of every tracked body, per operator "
                         "(the SSM monitor bounds the operators' segments from them)")
    recipe = cell.recipe_for(points, operator_names)
    envelopes = builder.AddNamedSystem("envelopes", OperatorEnvelopes(
        num_bodies=num_bodies, recipe=recipe, tracking_allowance=config.body.tracking_allowance,
        occlusion_speed=f.occlusion_speed))
    m = envelopes.num_segments
    monitor = builder.AddNamedSystem("monitor", SeparationMonitor(
        num_segments=m, capsule_radii=capsules.radius,
        human_speed=f.human_speed, reaction_time=f.reaction_time,
        stopping_time=t_s, stopping_distance=b, intrusion_distance=f.intrusion_distance,
        human_uncertainty=f.human_uncertainty, robot_uncertainty=f.robot_uncertainty,
        human_uncertainty_sigmas=f.human_uncertainty_sigmas, iso_speed=f.iso_human_speed,
        iso_reduced_speed=f.iso_reduced_human_speed, robot_speed=f.robot_speed,
        level_terms=cell.level_terms if by_speed else None))
    pfl = cell.pfl if f.mode == "ssm_pfl" else None
    capped = pfl is not None
    override = builder.AddNamedSystem("override", SpeedOverride(
        num_bodies=m, delta_s=f.delta_s, d_min=f.d_min,
        levels=SPEED_LEVELS if by_speed else None,
        caps=np.tile(pfl.caps, m // pfl.caps.size) if capped else None,
        surfaces=pfl.boxes if capped else None, clamp_reach=pfl.reach if capped else 0.0,
        capsule_radii=capsules.radius if capped else None,
        capsule_links=pfl.monitor_links if capped else None))
    if capped:
        for name in ("segment_ends", "segment_radii"):
            builder.Connect(envelopes.GetOutputPort(name), override.GetInputPort(name))
        builder.Connect(robot.GetOutputPort("capsule_ends"),
                        override.GetInputPort("capsule_ends"))
    for name in ("positions_estimated", "velocities_estimated", "track_status", "position_std",
                 "unseen_time"):
        builder.Connect(tracker.GetOutputPort(name), envelopes.GetInputPort(name))
    for name in ("segment_ends", "segment_velocities", "segment_radii", "segment_status",
                 "segment_std"):
        builder.Connect(envelopes.GetOutputPort(name), monitor.GetInputPort(name))
    for name in ("capsule_ends", "capsule_velocities"):
        builder.Connect(robot.GetOutputPort(name), monitor.GetInputPort(name))
    builder.Connect(monitor.GetOutputPort("distances"), override.GetInputPort("distances"))
    name = "level_protective_distances" if by_speed else "protective_distances"
    builder.Connect(monitor.GetOutputPort(name), override.GetInputPort(name))
    builder.Connect(envelopes.GetOutputPort("segment_status"),
                    override.GetInputPort("track_status"))
    builder.Connect(tracker.GetOutputPort("fault"), override.GetInputPort("fault"))
    return SafetyController(tracker, {"robot_capsules": robot, "envelopes": envelopes,
                                      "monitor": monitor, "override": override},
                            override.GetOutputPort("path_speed_commanded"))


@dataclasses.dataclass
class Workcell:
    """A built workcell: the diagram, its named systems, and the one logger of every
    logged signal with each signal's columns in it (``"system.port"``, ``"q"``, ``"v"``)."""

    diagram: Diagram
    scenario: Scenario
    path: JointPath
    body_names: list[str]
    systems: dict
    logger: VectorLogSink | None
    columns: dict[str, slice]
    cell: ResolvedCell  # what the scenario's configuration means: every system's terms
    plant: MultibodyPlant | None = None


def _sensor_intervals(scenario: Scenario) -> tuple[list, list]:
    names = body_names(scenario)
    s = actual_sensor(scenario)
    occlusions = [(names.index(o.body), o.start, o.end) for o in s.occlusions]
    return occlusions, [(d.start, d.end) for d in s.dropouts]


def AddRobotWithInverseDynamics(builder: DiagramBuilder, dt: float,
                                model: RobotModel | None = None
                                ) -> tuple[MultibodyPlant, InverseDynamicsController]:
    """Adds the dynamic mode's plant of ``model`` (None: the UR5e; time step ``dt``,
    ``cell.robot_plant.AddRobot``) and its inverse-dynamics controller (gains
    ``DYNAMIC_KP``, ``DYNAMIC_KD`` on every joint), the plant's state fed back and the
    controller driving the actuators; left to connect: the controller's desired state and
    desired acceleration."""
    from safety_systems.cell.robot_model import default_model

    model = default_model() if model is None else model
    plant = builder.AddNamedSystem("plant", MultibodyPlant(time_step=dt))
    AddRobot(plant, model)
    plant.Finalize()
    reference = MultibodyPlant(time_step=dt)
    AddRobot(reference, model)
    reference.Finalize()
    n = model.n
    controller = builder.AddNamedSystem("inverse_dynamics", InverseDynamicsController(
        reference, kp=np.full(n, DYNAMIC_KP), ki=np.zeros(n), kd=np.full(n, DYNAMIC_KD),
        has_reference_acceleration=True))
    builder.Connect(plant.get_state_output_port(), controller.get_input_port_estimated_state())
    builder.Connect(controller.get_output_port_control(), plant.get_actuation_input_port())
    return plant, controller


def AddUr5eWithInverseDynamics(builder: DiagramBuilder, dt: float
                               ) -> tuple[MultibodyPlant, InverseDynamicsController]:
    """:func:`AddRobotWithInverseDynamics` of the UR5e."""
    return AddRobotWithInverseDynamics(builder, dt)


def _add_robot(builder: DiagramBuilder, robot: RobotConfig, model: RobotModel,
               follower: PathFollower, dt: float
               ) -> tuple[OutputPort, OutputPort, MultibodyPlant | None]:
    """Adds the robot (its model ``model``) in its mode; returns its joint position and
    velocity ports."""
    if robot.mode == "kinematic":
        return (follower.GetOutputPort("joint_positions_desired"),
                follower.GetOutputPort("joint_velocities_desired"), None)
    n = model.n
    plant, controller = AddRobotWithInverseDynamics(builder, dt, model)
    desired = builder.AddNamedSystem("desired_state", Multiplexer([n, n]))
    builder.Connect(follower.GetOutputPort("joint_positions_desired"), desired.get_input_port(0))
    builder.Connect(follower.GetOutputPort("joint_velocities_desired"), desired.get_input_port(1))
    builder.Connect(desired.get_output_port(), controller.get_input_port_desired_state())
    builder.Connect(follower.GetOutputPort("joint_accelerations_desired"),
                    controller.get_input_port_desired_acceleration())
    split = builder.AddNamedSystem("joint_state", Demultiplexer([n, n]))
    builder.Connect(plant.get_state_output_port(), split.get_input_port())
    return split.get_output_port(0), split.get_output_port(1), plant


def MakeWorkcell(scenario: Scenario, *, logged: Iterable[str] | None = None,
                 cell: ResolvedCell | None = None) -> Workcell:
    """Builds the whole cell of a (validated) scenario, every system from the resolved
    ``cell`` of its configuration (None: ``resolve_scenario(scenario)``, here once;
    given, it must be of the scenario's configuration).

    Every output port is logged at the control period unless ``logged`` names the
    signals to keep (``"q"``, ``"v"`` and ``"system.port"`` keys).
    """
    robot = scenario.robot
    cell = scenario_cell(scenario, cell, "MakeWorkcell")
    dt = 1.0 / robot.control_rate_hz
    path = joint_path(robot)
    names = body_names(scenario)
    builder = DiagramBuilder()
    motion, recorded_gaps = AddOperators(builder, scenario)
    sensor = _add_sensor(builder, scenario, motion, recorded_gaps)
    operator_of, is_hand = body_roles(scenario)
    safety = AddSafetyController(builder, cell=cell, num_bodies=len(names),
                                 control_period=dt, path=path, operator_of=operator_of,
                                 is_hand=is_hand, points=tracked_points(scenario),
                                 operator_names=[o.name for o in scenario.operators])
    for name in ("positions_measured", "valid", "sample_time", "frame_number", "body_ids"):
        builder.Connect(sensor.GetOutputPort(name), safety.tracker.GetInputPort(name))
    speed = safety.systems.get("speed")
    zones = safety.systems.get("zones")
    follower = _add_follower(builder, scenario, cell, path, safety, speed)
    q_port, v_port, plant = _add_robot(builder, robot, cell.model, follower, dt)
    systems = dict(operators=motion, mocap=sensor, tracker=safety.tracker, **safety.systems,
                   follower=follower)
    if "robot_capsules" in safety.systems:
        builder.Connect(q_port, safety.systems["robot_capsules"].GetInputPort("joint_positions"))
    override = safety.systems.get("override")
    if override is not None and override.HasInputPort("contact_stop"):  # ssm_pfl
        systems["contact_stop"] = AddContactStop(builder, scenario, cell, motion, q_port,
                                                 v_port, override)
    if override is not None and override.HasInputPort("path_state"):  # by_speed
        builder.Connect(follower.GetOutputPort("path_state"), override.GetInputPort("path_state"))
    for controller in (speed, zones):
        if controller is not None:
            builder.Connect(follower.GetOutputPort("path_state"),
                            controller.GetInputPort("path_state"))
    if zones is not None:
        gestures = builder.AddNamedSystem("gestures", GestureSource(
            events=[(g.time, g.command) for g in scenario.gestures]))
        builder.Connect(gestures.get_output_port(), zones.GetInputPort("gesture"))
        systems["gestures"] = gestures
    logger, columns = _log_signals(builder, systems, q_port, v_port, logged, dt)
    diagram = builder.Build()
    diagram.set_name("workcell")
    return Workcell(diagram, scenario, path, names, systems, logger, columns, cell, plant)


def AddContactStop(builder: DiagramBuilder, scenario: Scenario, cell: ResolvedCell, motion,
                   q_port: OutputPort, v_port: OutputPort, override) -> ContactStop:
    """Adds the robot's own contact detection under ``safety.mode: ssm_pfl``, named
    ``contact_stop`` (``ContactStop``, on the operators' truth ``motion`` and the real
    robot's joints, with the resolved ``cell``'s force limits and clamping surfaces),
    into the SpeedOverride's ``contact_stop``."""
    robot, f = scenario.robot, scenario.controller.safety
    pfl = cell.pfl
    capsules = contact_capsules(robot, scenario.contact_geometry)
    recipe = truth_recipe(scenario)
    per = recipe.radius.size // pfl.limits.size
    stop = builder.AddNamedSystem("contact_stop", ContactStop(
        capsules=capsules, links=capsule_links(capsules), recipe=recipe,
        limits=np.tile(pfl.limits, per), compressions=np.tile(pfl.compressions, (per, 1)),
        boxes=pfl.boxes, contact_distance=scenario.contact_distance, clamp_gap=CLAMP_GAP,
        detection_time=f.contact_detection_time, window=f.transient_window,
        period_sec=1.0 / robot.control_rate_hz))
    builder.Connect(q_port, stop.GetInputPort("joint_positions"))
    builder.Connect(v_port, stop.GetInputPort("joint_velocities"))
    for name in ("points_true", "point_velocities_true", "operators_present"):
        builder.Connect(motion.GetOutputPort(name), stop.GetInputPort(name))
    builder.Connect(stop.GetOutputPort("contact_stop"), override.GetInputPort("contact_stop"))
    return stop


def _add_sensor(builder: DiagramBuilder, scenario: Scenario, motion, recorded_gaps: list):
    """The cell's real motion-capture sensor (``actual_sensor``), named ``mocap``, fed by
    the operators' truth; the recordings' gaps are occlusions."""
    occlusions, dropouts = _sensor_intervals(scenario)
    occlusions += recorded_gaps
    real = actual_sensor(scenario)
    sensor = builder.AddNamedSystem("mocap", MocapSensor(
        num_bodies=len(body_names(scenario)), period_sec=1.0 / real.rate_hz,
        noise_std=real.noise_std, latency_sec=real.latency, occlusions=occlusions,
        dropped_frames=dropouts, faults=sensor_faults(scenario), seed=real.seed,
        pivots=[b.pivot for o in scenario.operators for b in o.bodies]))
    builder.Connect(motion.GetOutputPort("positions_true"),
                    sensor.GetInputPort("positions_true"))
    builder.Connect(motion.GetOutputPort("present"), sensor.GetInputPort("present"))
    return sensor


def _add_follower(builder: DiagramBuilder, scenario: Scenario, cell: ResolvedCell, path,
                  safety: SafetyController, speed) -> PathFollower:
    """The PathFollower, named ``follower``, driven by the safety controller's command,
    braking by the resolved ``cell``'s stopping data."""
    robot, config = scenario.robot, scenario.controller
    follower = builder.AddNamedSystem("follower", PathFollower(
        path=path, braking=cell.braking,
        acceleration_limit=robot.acceleration_limit,
        braking_time_scale=robot.braking_time_scale, period_sec=1.0 / robot.control_rate_hz,
        max_rate=1.0 if speed is None else config.alteration.speed_limit
        / speed.preprogrammed_speed))
    builder.Connect(safety.command, follower.GetInputPort("path_speed_commanded"))
    return follower


def _log_signals(builder: DiagramBuilder, systems: dict, q_port: OutputPort,
                 v_port: OutputPort, logged: Iterable[str] | None, dt: float):
    """(the logger, each signal's columns in it): every output port of ``systems`` (and
    q, v), or those ``logged`` names, through one multiplexer into one sink (one publish
    event per tick instead of one per signal), split by column when read."""
    ports = {"q": q_port, "v": v_port}
    for system_name, system in systems.items():
        for i in range(system.num_output_ports()):
            port = system.get_output_port(i)
            ports[f"{system_name}.{port.get_name()}"] = port
    if logged is not None:
        logged = set(logged)
        unknown = logged - set(ports)
        if unknown:
            raise ValueError(f"logged: unknown signals {sorted(unknown)}; allowed: {sorted(ports)}")
    keys = [key for key in ports if (logged is None or key in logged) and ports[key].size()]
    sizes = [ports[key].size() for key in keys]
    columns, start = {}, 0
    for key, size in zip(keys, sizes):
        columns[key] = slice(start, start + size)
        start += size
    logger = None
    if keys:
        mux = builder.AddNamedSystem("log signals", Multiplexer(sizes))
        for i, key in enumerate(keys):
            builder.Connect(ports[key], mux.get_input_port(i))
        logger = builder.AddNamedSystem("log", VectorLogSink(start, dt))
        builder.Connect(mux.get_output_port(), logger.get_input_port())
    for key in ports:  # empty signals (no bodies) log no columns
        if (logged is None or key in logged) and key not in columns:
            columns[key] = slice(start, start)
    return logger, columns


def control_ticks(duration: float, period: float) -> int:
    """Number of control ticks in [0, duration]."""
    return int(math.floor(duration / period + 1e-9)) + 1
