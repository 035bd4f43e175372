"""What a configuration and a scenario mean for the loop's rules: plain functions shared by
the Drake diagram, the batched verifier and the proof (never a copy in each)."""

import dataclasses

import numpy as np
from pydrake.common.yaml import yaml_dump_typed

from safety_systems.cell import human_body
from safety_systems.cell.braking import BrakingTable, default_braking_table, stopping_distance
from safety_systems.cell.braking import stopping_time as table_stopping_time
from safety_systems.cell.cartesian_path import line_path, polyline_path
from safety_systems.cell.joint_path import (
    DEFAULT_DURATIONS,
    DEFAULT_WAYPOINTS_DEG,
    JointPath,
    SplinePath,
    default_joint_path,
    make_joint_path,
)
from safety_systems.cell.operator_paths import ScriptedOperator, make_operator_path
from safety_systems.cell.recorded_operator import RecordedOperator
from safety_systems.cell.braking import PLACEHOLDER_WARNING
from safety_systems.cell.placeholder_stops import placeholder_braking_table, placeholder_warning
from safety_systems.cell.robot_geometry import Capsules, robot_capsules, tool_point
from safety_systems.cell.robot_model import RobotModel, is_ur5e, placeholder_name
from safety_systems.config.scenario import (  # noqa: F401 (robot_model_of: its callers')
    BodyConfig,
    ControllerConfig,
    RobotConfig,
    Scenario,
    actual_sensor,
    body_names,
    joint_speed_limit,
    operator_points,
    operator_posture,
    robot_log_of,
    robot_model_of,
)
from safety_systems.cell.path_speed import path_speed_bound
from safety_systems.cell.robot_log import make_log_path, window
from safety_systems.files.input_error import InputError
from safety_systems.pfl.robot_masses import effective_mass
from safety_systems.pfl.segment_regions import permitted_speeds
from safety_systems.pfl.contact_limits import pressing_speeds, segment_contact_limits
from safety_systems.pfl.speed_caps import (
    CLAMP_GAP,
    capsule_links,
    mounting_box,
    segment_caps,
    surface_boxes,
)
from safety_systems.sensing.sensor_faults import fault_table
from safety_systems.sensing.tracks import make_regions, make_rules
from safety_systems.ssm.formulas import HUMAN_SPEED_MODES, ROBOT_SPEED_TERMS, SPEED_LEVELS


def tracker_rules(config: ControllerConfig) -> np.ndarray:
    """The tracker's rules (``safety_systems.sensing.tracks.make_rules``) of a configuration."""
    s, t = config.sensor, config.tracker
    return make_rules(
        measurement_std=s.noise_std if t.measurement_std is None else t.measurement_std,
        velocity_process_noise=t.velocity_process_noise,
        initial_velocity_std=t.initial_velocity_std, period=1.0 / s.rate_hz,
        hidden_bodies=t.hidden_bodies, max_coast_time=t.max_coast_time,
        exit_radius=t.exit_radius, gate=t.gate, gate_speed=t.gate_speed,
        gate_width=t.gate_width, human_uncertainty=config.safety.human_uncertainty)


def tracker_regions(config: ControllerConfig) -> np.ndarray:
    """The cell's walls and exits (``safety_systems.sensing.tracks.make_regions``)."""
    t = config.tracker
    cell = None if t.cell is None else (t.cell.min, t.cell.max)
    return make_regions(cell, [(b.min, b.max) for b in t.exits])


def sensor_faults(scenario: Scenario) -> np.ndarray:
    """The fault table (``safety_systems.sensing.sensor_faults``) of the scenario's real sensor."""
    names = body_names(scenario)
    return fault_table([
        (f.kind, names.index(f.body) if f.body else -1,
         names.index(f.other) if f.other else -1, f.start, f.end, f.offset)
        for f in actual_sensor(scenario).faults])


def monitor_capsules(config: ControllerConfig, model: RobotModel | None = None) -> Capsules:
    """The robot (``model``; None: the UR5e) as the SeparationMonitor measures it: its
    capsules with the configured link radii (if any) and tool, or the seed's tool
    point."""
    f = config.safety
    if f.robot_geometry == "tool_point":
        return tool_point(model)
    return robot_capsules(link_radii=f.link_radii or None, payload_radius=f.payload_radius,
                          tool_length=f.tool_length, model=model)


def body_dimensions(body: BodyConfig) -> dict:
    """The monitor's body dimensions (``human_body.dimensions``) of a configuration's
    ``body`` block."""
    return human_body.dimensions({name: getattr(body, name)
                                  for name in human_body.DIMENSION_NAMES})


def tracked_points(scenario: Scenario) -> list[list[str]]:
    """The body point each tracked body slot marks, operator by operator."""
    return [operator_points(o) for o in scenario.operators]


def monitor_recipe(config: ControllerConfig, points: list[list[str]],
                   names: list[str] | None = None) -> human_body.Recipe:
    """How the monitor bounds every segment of operators whose tracked bodies mark
    ``points`` (``human_body.envelope_recipe``) under the configuration's body model; on
    the seed's tool point (Eq. 8 measures points) the segments' own radii are 0 (the
    envelopes' widths stay: they are where the segments may be)."""
    recipe = human_body.envelope_recipe(points, body_dimensions(config.body), names)
    if config.safety.robot_geometry == "tool_point":
        recipe = dataclasses.replace(recipe, radius=np.zeros_like(recipe.radius))
    return recipe


def scenario_monitor_recipe(scenario: Scenario) -> human_body.Recipe:
    """:func:`monitor_recipe` of a scenario's operators and controller."""
    return monitor_recipe(scenario.controller, tracked_points(scenario),
                          [o.name for o in scenario.operators])


def truth_recipe(scenario: Scenario) -> human_body.Recipe:
    """How the properties take every segment of the scenario's operators from their true
    points (``human_body.envelope_recipe`` with the table's dimensions; true point p of
    operator k in slot 10 k + p): a scripted operator's every point is known (its
    posture), so each segment is the capsule between its true points; a recorded
    operator's known points are those its mapping names, and a segment between unknown
    points is the envelope of the known ones (where the recording allows it to be). On
    the tool point (``contact_geometry``) the segments' radii are 0."""
    n = human_body.NUM_POINTS
    points = [list(human_body.POINTS) if not o.recording else operator_points(o)
              for o in scenario.operators]
    slots = [[n * k + human_body.point_index(p) for p in pts] for k, pts in enumerate(points)]
    recipe = human_body.envelope_recipe(points, None, [o.name for o in scenario.operators],
                                        slots)
    if scenario.contact_geometry == "tool_point":
        recipe = dataclasses.replace(recipe, radius=np.zeros_like(recipe.radius))
    return recipe


def operator_postures(scenario: Scenario) -> np.ndarray:
    """(K, 10, 3) every body point's offset from each scripted operator
    (``scenario.operator_posture``)."""
    return np.array([operator_posture(o) for o in scenario.operators], dtype=float).reshape(
        len(scenario.operators), human_body.NUM_POINTS, 3)


def contact_capsules(robot: RobotConfig, contact_geometry: str) -> Capsules:
    """The real robot for the safety properties: the capsules of the robot's model
    (``robot_model_of``) with the cell's real tool (``robot.payload_radius``,
    ``robot.tool_length``), or its tool point."""
    model = robot_model_of(robot)
    if contact_geometry == "tool_point":
        return tool_point(model)
    return robot_capsules(payload_radius=robot.payload_radius, tool_length=robot.tool_length,
                          model=model)


def placeholder_braking(config: ControllerConfig) -> bool:
    """Whether ``config`` gives no stopping data, so the robot's placeholder table is
    used."""
    return not config.braking.speed_fraction


def braking_table(config: ControllerConfig, model: RobotModel | None = None) -> BrakingTable:
    """The configured stopping data, or, when none is given, the placeholder table of the
    robot ``model`` (``placeholder_stops``; None or the UR5e: the UR5 table,
    ``braking.default_braking_table``). A robot from a URDF has no placeholder: refused
    (``InputError``), its measured data is needed."""
    b = config.braking
    if placeholder_braking(config):
        if model is None or is_ur5e(model):
            return default_braking_table()
        return placeholder_braking_table(placeholder_name(model))
    return BrakingTable(np.array(b.speed_fraction), np.array(b.stopping_time),
                        np.array(b.stopping_distance))


def braking_warning(model: RobotModel | None = None) -> str:
    """The warning printed (and written to summary.json) beside a result computed with
    the placeholder stopping data of ``model`` (None or the UR5e: the UR5's,
    ``braking.PLACEHOLDER_WARNING``): it names the robot and the figures' source."""
    if model is None or is_ur5e(model):
        return PLACEHOLDER_WARNING
    return placeholder_warning(placeholder_name(model))


def assumed_stopping(config: ControllerConfig, model: RobotModel | None = None
                     ) -> tuple[float, float]:
    """(T_s, B) the monitor uses: the configured values, else the table's at full speed
    (:func:`braking_table` of ``model``)."""
    table = braking_table(config, model)
    t_s = config.safety.stopping_time
    b = config.safety.stopping_distance
    return (float(table_stopping_time(table, 1.0)) if t_s is None else t_s,
            float(stopping_distance(table, 1.0)) if b is None else b)


def level_stops(config: ControllerConfig, model: RobotModel | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """(T_s, B) the monitor uses at each speed level g / SPEED_LEVELS, g = 0..SPEED_LEVELS
    (``safety.stopping: by_speed``), from :func:`assumed_stopping`'s full-speed values and
    the braking table (interpolated linearly from (0, 0, 0)): the larger of

    - the table's stop from the level plus the configured margin over the table's
      full-speed stop, T_table(sigma) + (T_s - T_table(1)), and likewise for B with
      D_table; and
    - the full-speed value scaled by the table's shape, T_s T_table(sigma) / T_table(1)
      (B D_table(sigma) / D_table(1)).

    Interpretation: ISO/TS 15066 leaves how S_s follows the speed to the stopping data.
    The configured T_s and B keep their meaning at full speed; a margin they carry over
    the table (here 0.54 s against 0.53 s) stays whole at every level, since what it
    covers (a control tick's rounding, the brakes' onset) does not shrink with the speed;
    a T_s or B below the table (unsafe at full speed, and the proofs say so) shrinks in
    proportion instead of going negative. With ``full_speed`` every level has the
    full-speed values."""
    t_s, b = assumed_stopping(config, model)
    levels = np.arange(SPEED_LEVELS + 1) / SPEED_LEVELS
    if config.safety.stopping != "by_speed":
        return np.full(levels.size, float(t_s)), np.full(levels.size, float(b))
    table = braking_table(config, model)  # (of model: None, the UR5e)
    t_table = np.asarray(table_stopping_time(table, levels), dtype=float)
    d_table = np.asarray(stopping_distance(table, levels), dtype=float)
    return (np.maximum(t_s * t_table / t_table[-1], t_table + (t_s - t_table[-1])),
            np.maximum(b * d_table / d_table[-1], d_table + (b - d_table[-1])))


def level_terms(config: ControllerConfig, model: RobotModel | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """(T_s + T_r, B + C + Z_r) at each speed level (:func:`level_stops` of ``model``), as
    ``separation.level_rows`` takes them."""
    f = config.safety
    t_s, b = level_stops(config, model)
    return (np.ascontiguousarray(t_s + f.reaction_time),
            np.ascontiguousarray(b + f.intrusion_distance + f.robot_uncertainty))


def monitor_terms(config: ControllerConfig, model: RobotModel | None = None) -> tuple:
    """The SeparationMonitor's S terms as ``separation.pair_separation`` takes them:
    (human-speed mode index, T_s + T_r, T_r, B + C + Z_r, v_iso, v_iso_reduced, robot
    speed index), T_s and B by :func:`assumed_stopping` of ``model``."""
    f = config.safety
    t_s, b = assumed_stopping(config, model)
    return (HUMAN_SPEED_MODES.index(f.human_speed), float(t_s + f.reaction_time),
            float(f.reaction_time), float(b + f.intrusion_distance + f.robot_uncertainty),
            float(f.iso_human_speed), float(f.iso_reduced_human_speed),
            ROBOT_SPEED_TERMS.index(f.robot_speed))


def frame_timeout(config: ControllerConfig) -> float:
    """Age after which a frame is stale, seconds (see ``TrackerConfig``)."""
    if config.tracker.frame_timeout is not None:
        return config.tracker.frame_timeout
    return 1.5 / config.sensor.rate_hz + config.sensor.latency + config.tracker.processing_time


def joint_path(robot: RobotConfig) -> JointPath | SplinePath:
    """The robot's path from the scenario: its line, its waypoints (of its model's joints,
    within their speeds), or the default pick and place cycle (a UR arm's)."""
    p = robot.path
    if p.log is not None:
        return log_path(robot)
    if p.task_path is not None:
        t = p.task_path
        return polyline_path(np.array(t.points), speed=t.speed, rpy=np.radians(t.rpy_deg),
                             seed=np.radians(t.seed_deg), cycles=robot.cycles,
                             there_and_back=True)
    if p.line is not None:
        return line_path(np.array(p.line.start), np.array(p.line.goal), speed=p.line.speed,
                         rpy=np.radians(p.line.rpy_deg), seed=np.radians(p.line.seed_deg))
    if not p.waypoints_deg:
        model = robot_model_of(robot)
        if is_ur5e(model):
            return default_joint_path(cycles=robot.cycles)
        return make_joint_path(np.radians(DEFAULT_WAYPOINTS_DEG), DEFAULT_DURATIONS,
                               cycles=robot.cycles, joint_speed_limit=joint_speed_limit(model))
    return make_joint_path(np.radians(p.waypoints_deg), p.segment_durations,
                           cycles=robot.cycles,
                           joint_speed_limit=joint_speed_limit(robot_model_of(robot)),
                           num_joints=robot_model_of(robot).n)


def log_path(robot: RobotConfig) -> SplinePath:
    """The path of a robot's ``path.log`` (``cell.robot_log.make_log_path``): its window,
    once, or ``robot.cycles`` times when it repeats."""
    g = robot.path.log
    log = robot_log_of(robot)
    return _log_path(log.sha256, log.file, g.start, g.end, g.repeat, robot.cycles, log)


def _log_path(digest, file, start, end, repeat, cycles, log) -> SplinePath:
    key = (digest, file, start, end, repeat, cycles if repeat else 1)
    path = _LOG_PATHS.get(key)
    if path is None:
        if len(_LOG_PATHS) > 16:
            _LOG_PATHS.clear()
        s, q = window(log, start, end)
        path = _LOG_PATHS[key] = make_log_path(s, q, repeat=repeat, cycles=cycles)
    return path


_LOG_PATHS: dict = {}  # the paths of robot logs, by the log's bytes and window


def scripted_operators(scenario: Scenario) -> list[ScriptedOperator]:
    """The scenario's operators as scripted paths with rigid body offsets."""
    return [
        ScriptedOperator(
            path=make_operator_path([w.time for w in o.waypoints],
                                    [w.position for w in o.waypoints],
                                    o.max_speed, o.max_acceleration),
            body_offsets=np.array([b.offset for b in o.bodies]),
            enter_time=o.enter_time, leave_time=o.leave_time,
            point_offsets=operator_posture(o),
        )
        for o in scenario.operators
    ]


def with_controller(scenario: Scenario, config: ControllerConfig) -> Scenario:
    """``scenario`` run under another controller configuration: ``config``'s settings
    in the scenario's cell. What belongs to the cell stays the scenario's: its real sensor
    (``actual_sensor``: the configuration states what the controller is configured for,
    not what the cell's sensor does) and, when ``config`` declares none, its exits and
    walls (``tracker.exits``, ``tracker.cell``: where operators come and go)."""
    tracker = config.tracker
    if not tracker.exits and tracker.cell is None:
        cell = scenario.controller.tracker
        tracker = dataclasses.replace(tracker, exits=list(cell.exits), cell=cell.cell)
    return dataclasses.replace(scenario, sensor=actual_sensor(scenario),
                               controller=dataclasses.replace(config, tracker=tracker))


def is_recorded(scenario: Scenario) -> bool:
    """Whether the scenario's operators are played from recordings (they are all
    recorded or all scripted)."""
    return any(o.recording for o in scenario.operators)


def recorded_operators(scenario: Scenario) -> list[RecordedOperator]:
    """The scenario's recorded operators (``safety_systems.sensing.recording_mapping``)."""
    from safety_systems.sensing.recording_mapping import load_recorded_operator

    return [RecordedOperator(bodies=load_recorded_operator(o.recording, o.mapping, o.name),
                             start=o.start, time_scale=o.time_scale, shift=tuple(o.shift),
                             enter_time=o.enter_time, leave_time=o.leave_time,
                             yaw_deg=o.yaw_deg)
            for o in scenario.operators]


@dataclasses.dataclass(frozen=True)
class PflTerms:
    """What power and force limiting (``safety.mode``, ``safety_systems.pfl.speed_caps``)
    means for a scenario's loop and its properties."""

    caps: np.ndarray  # (12,) each segment's path-rate cap (0: pure SSM); all 0 under ssm
    limits: np.ndarray  # (12,) each segment's permissible relative speed, m/s (0: none)
    boxes: np.ndarray  # (S, 2, 3) the robot's mounting surface, then the declared ones
    reach: float  # m: a segment's envelope this close to a surface loses its cap
    speed_bound: float  # V_R, m/s: no monitor capsule axis point is faster at rate 1
    effective_mass: float  # m_R, kg (ISO/TS 15066 Eq. A.4, with the configured payload)
    # (12, 3) each segment's transient, quasi-static and detection compressions, m
    # (``pfl.contact_limits.segment_contact_limits``)
    compressions: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 3)))
    detection_time: float = 0.0  # s: the robot's contact detection holds this long
    window: float = 0.5  # s: the transient window after an impact
    monitor_links: np.ndarray = dataclasses.field(  # each monitor capsule's link
        default_factory=lambda: np.zeros(0, dtype=np.int64))

    @property
    def capped(self) -> bool:
        """Whether some segment may hold the robot above rest (the override's caps)."""
        return bool(np.any(self.caps > 0.0))


_SPEED_BOUNDS: dict = {}  # V_R by the robot station and the monitor's capsules


def _speed_bound(robot: RobotConfig, config: ControllerConfig) -> float:
    f = config.safety
    key = (yaml_dump_typed(robot), f.robot_geometry, tuple(f.link_radii), f.payload_radius,
           f.tool_length)
    if key not in _SPEED_BOUNDS:
        if len(_SPEED_BOUNDS) > 64:
            _SPEED_BOUNDS.clear()
        _SPEED_BOUNDS[key] = path_speed_bound(joint_path(robot), monitor_capsules(
            config, robot_model_of(robot)))
    return _SPEED_BOUNDS[key]


def monitor_speed_bound(robot: RobotConfig, config: ControllerConfig) -> float:
    """V_R, m/s: a bound on the speed of any point of the monitor's capsules' axes
    (:func:`monitor_capsules` of the robot's model) on the robot station's path at path
    rate 1 (``cell.path_speed.path_speed_bound``); at rate sigma no such point is faster
    than sigma V_R. Kept per robot station and capsules, as ssm_pfl's caps take it."""
    return _speed_bound(robot, config)


def _stop_time(config: ControllerConfig, model: RobotModel) -> float:
    """The longer of the configured T_s and the braking table's own stop from full
    speed (s): how long the robot may take to stop once its contact detection acts."""
    return max(assumed_stopping(config, model)[0],
               float(table_stopping_time(braking_table(config, model), 1.0)))


def pfl_terms(robot: RobotConfig, config: ControllerConfig) -> PflTerms:
    """:class:`PflTerms` of the robot station ``robot`` under ``config``: the segments'
    permissible speeds for the robot's effective mass with the configured payload (Annex
    A: ``pfl.segment_regions``; trusted from the configuration, as the stopping data
    are), the caps (``pfl.speed_caps.segment_caps`` of the lesser of those speeds and
    the speed at which the robot's contact detection still keeps a lasting contact within
    the quasi-static compression, ``pfl.contact_limits.pressing_speeds`` with the longer
    of the configured and the table's stop; under ``ssm`` all 0), V_R of the
    monitor's capsules on the robot's path (computed only under ``ssm_pfl``; NaN
    otherwise), the clamping terms (the robot's mounting surface, ``robot.mounting_size``,
    and the declared fixed surfaces; the monitor's capsules' links) and what a contact
    that lasts may do (``pfl.contact_limits``: the compressions and the robot's contact
    detection)."""
    f = config.safety
    model = robot_model_of(robot)
    m_r = effective_mass(model, f.payload_mass)
    limits = permitted_speeds(m_r)
    compressions = segment_contact_limits(f.contact_stop_force)
    caps, bound = np.zeros(limits.shape), float("nan")
    if f.mode == "ssm_pfl":
        if not m_r > 0.0:  # no inertials and no payload: Annex A's speeds are unbounded
            raise InputError("controller.safety.mode", f.mode, "ssm only for a robot whose "
                             f"description gives no link masses ({model.name}: its moving "
                             "mass is 0 kg, and no payload_mass): ssm_pfl needs the robot's "
                             "effective mass (ISO/TS 15066 Eq. A.4)")
        bound = _speed_bound(robot, config)
        caps = segment_caps(np.minimum(limits, pressing_speeds(
            compressions, f.contact_detection_time, _stop_time(config, model),
            1.0 / robot.control_rate_hz)), f.pfl_speed, bound)
    for x in (caps, limits):
        x.setflags(write=False)
    tool = max(robot.tool_length, f.tool_length) + max(robot.payload_radius,
                                                         f.payload_radius)
    boxes = np.concatenate([mounting_box(robot.mounting_size, model.base_reach + tool),
                            surface_boxes(f.fixed_surfaces)])
    boxes.setflags(write=False)
    return PflTerms(caps, limits, boxes, CLAMP_GAP + f.clamp_margin, bound, float(m_r),
                    compressions, float(f.contact_detection_time), float(f.transient_window),
                    capsule_links(monitor_capsules(config, model)))
