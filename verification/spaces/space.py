"""Scenario spaces: boxes of worst-case operator approaches, and their assumptions.

A space file (typed YAML, loaded strictly) gives a [min, max] range for each parameter
of an approach; a range with min == max fixes it. A point of the space (one value per
parameter) becomes a full :class:`safety_systems.config.scenario.Scenario`:

- The robot runs its path from t = 0. Every operator stands still at its start point
  until the onset, ``settle_time + onset_phase * cycle_time`` (the robot is then at that
  fraction of its cycle), so the tracker has settled.
- The operator's *lead* point (the hand, or the elbow, the shoulder, the head, as its
  posture says) heads for the *target*: a point of the robot at ``target_phase`` of its
  cycle, on the link ``target_link`` (an index into the robot's capsules,
  :func:`target_capsules`: on a UR the shoulder, upper arm, forearm, the three wrist
  links, the tool) at the fraction
  ``target_along`` from the link's inner joint to its outer one (for the tool: from the
  flange to the tool tip). The start point lies ``start_distance`` from the target in
  the direction (``azimuth_deg``, ``elevation_deg``); extra operators come from azimuths
  turned by 360 / n degrees.
- At the onset the lead point either goes straight for the target or, when
  ``retreat_distance`` > 0, first walks that far away and then reverses, with peak
  speed ``peak_speed`` and acceleration ``acceleration``. It reaches on through the
  target by ``overshoot`` along the same line and stays there.
- Each operator is a whole body (``safety_systems.cell.human_body``) in the posture
  ``posture`` (:data:`POSTURES`: 0 a reach with the right hand, 1 a reach over and past
  the target (the forearm's middle leads: the hand beyond, the forearm across), 2 an
  elbow-first push, 3 a shoulder-first push, 4 the trunk leaning in 40 degrees (the head
  leads), 5 both arms reaching (between the hands leads)), facing along the approach,
  moving rigidly with its lead point; every posture is one the body model's table
  allows. Each operator wears two tracked gloves (``hand``, ``other_hand``: the right
  and the left hand) and, with ``heads`` = 1, a tracked helmet (``head``), or is tracked
  at the space's ``tracked`` points (a body named after its point for the others); the
  sensor sees those only.
- Sensor conditions: noise, latency, and from the onset a run of dropped frames
  (``dropout``, s) and an occlusion (``occlusion``, s) of ``occluded_bodies`` bodies of
  every operator: 1 the right hand, 2 both hands, 3 both hands and the head, more the
  other tracked bodies in the order the space tracks them (:func:`hidden_bodies`).
- Outlier frames (marker swaps): ``outlier_frames`` consecutive frames in which every
  body of every operator is reported ``outlier_offset`` m farther back along its
  approach line (the operator's markers taken for another set's, farther out), starting
  ``outlier_delay`` s after the later of the occlusion's and the dropout's ends (so every
  body has been seen again before them). A displaced hand beside its correctly seen
  glove and head would change nothing: the monitor still sees the operator there.
- ``braking_time_scale`` > 1 makes the real brakes slower than the stopping data says.

Or, with a ``recording:`` block instead of ``parameters``, a box around a recording of
real operators (``verification.spaces.recorded`` explains its parameters and how a point
becomes a scenario). The functions below serve both kinds; the space file's types are
``verification.spaces.box``.
"""

import dataclasses as dc
import itertools
import math
from pathlib import Path

import numpy as np

from safety_systems.cell import human_body
from safety_systems.cell.joint_path import joint_path_state
from safety_systems.cell.operator_paths import segment_profile
from safety_systems.cell.robot_geometry import LINK_SEGMENTS, robot_points
from safety_systems.cell.robot_model import RobotModel
from safety_systems.config.configuration import joint_path
from safety_systems.config.resolved_cell import ResolvedCell, resolve
from safety_systems.config.scenario import (
    ROBOT_GEOMETRIES,
    Body,
    ControllerConfig,
    Interval,
    Occlusion,
    OperatorConfig,
    Scenario,
    ScenarioError,
    SensorFault,
    PosturePoint,
    Waypoint,
    read_robot_file,
    read_robot_log,
    read_task_path,
    robot_model_of,
    validate_robot,
    validate_scenario,
)
from safety_systems.files.documents import load_document
from safety_systems.files.ranges import check_limits
from verification.spaces.box import (
    LIMITS,
    MIN_GAP,
    WHOLE,
    Range,
    ScenarioSpace,
    check_ranges,
    how_many,
    span,
)
from verification.spaces.recorded import (
    read_recording_block,
    recorded_scenario,
    recorded_speed,
    recording_assumptions,
    validate_recording,
)
from verification.spaces.recorded import operators as recorded_operators

# The postures (``posture``), each: its name, the point (or the middle of two) that leads,
# and every body point relative to the head in the facing frame (x towards the target,
# y left, z up), m. Each edge is shorter than the table's length and each lean within
# its limit (``human_body.posture_violations``; tests/verification/spaces test it).
_TRUNK = {"head": (0.0, 0.0, 0.0), "neck": (0.0, 0.0, -0.18), "chest": (0.0, 0.0, -0.40),
          "pelvis": (0.0, 0.0, -0.75), "shoulder_left": (0.0, 0.19, -0.20),
          "shoulder_right": (0.0, -0.19, -0.20)}
_LEFT_DOWN = {"elbow_left": (0.05, 0.23, -0.50), "hand_left": (0.33, 0.22, -0.55)}
_RIGHT_REACH = {"elbow_right": (0.30, -0.21, -0.32), "hand_right": (0.66, -0.20, -0.36)}
_LEAN = 40.0  # deg, the trunk's lean of the leaning posture
_s, _c = math.sin(math.radians(_LEAN)), math.cos(math.radians(_LEAN))
POSTURES = (
    ("reach", ("hand_right",), _TRUNK | _LEFT_DOWN | _RIGHT_REACH),
    ("reach_past", ("elbow_right", "hand_right"), _TRUNK | _LEFT_DOWN | _RIGHT_REACH),
    ("elbow_first", ("elbow_right",), _TRUNK | _LEFT_DOWN | {
        "elbow_right": (0.25, -0.35, -0.35), "hand_right": (-0.05, -0.20, -0.55)}),
    ("shoulder_first", ("shoulder_right",), _TRUNK | _LEFT_DOWN | {
        "elbow_right": (0.0, -0.22, -0.50), "hand_right": (0.10, -0.22, -0.85)}),
    ("lean_in", ("head",), {  # the trunk 40 deg forward from the pelvis, the head bowed
        "pelvis": (-0.43 * _s - 0.14, 0.0, -0.43 * _c - 0.12),
        "chest": (-0.20 * _s - 0.14, 0.0, -0.20 * _c - 0.12),
        "neck": (-0.14, 0.0, -0.12),
        "shoulder_left": (-0.16, 0.19, -0.14), "shoulder_right": (-0.16, -0.19, -0.14),
        "elbow_left": (0.05, 0.24, -0.40), "hand_left": (0.35, 0.22, -0.52),
        "elbow_right": (0.05, -0.24, -0.40), "hand_right": (0.35, -0.22, -0.52),
        "head": (0.0, 0.0, 0.0)}),
    ("both_arms", ("hand_left", "hand_right"), _TRUNK | {
        "elbow_left": (0.28, 0.22, -0.33), "hand_left": (0.62, 0.12, -0.38),
        "elbow_right": (0.28, -0.22, -0.33), "hand_right": (0.62, -0.12, -0.38)}),
)
POSTURE_NAMES = tuple(name for name, _, _ in POSTURES)
# The tracked bodies of a space's operator: (name, the body point it marks).
TRACKED = (("hand", "hand_right"), ("other_hand", "hand_left"), ("head", "head"))
TARGET_SEGMENTS = LINK_SEGMENTS + ((6, 7),)  # the UR5e's capsules' points, the tool's last


def target_capsules(model: RobotModel) -> tuple[tuple[str, ...], tuple[tuple[int, int], ...]]:
    """(names, (a, b) point pairs) of the capsules a space's approaches may aim at on
    ``model``: each link's capsule (between its two points), then the tool (tool0 to the
    tip); ``target_link`` indexes them (the UR family's: ``TARGET_SEGMENTS``)."""
    names = tuple(model.link_names) + ("tool",)
    pairs = tuple((int(a), int(b)) for a, b, *_ in model.link_capsules)
    return names, pairs + ((model.tool0, model.tip),)


def validate_space(space: ScenarioSpace) -> None:
    """Range checks; raises ScenarioError naming the field."""
    check_limits(space)
    check_ranges(space.parameters, LIMITS, WHOLE, "parameters")
    names, _ = target_capsules(robot_model_of(space.robot))
    if space.parameters.target_link.max > len(names) - 1:
        raise ScenarioError("parameters.target_link.max", space.parameters.target_link.max,
                            f"0 <= target_link <= {len(names) - 1} (the capsules of the "
                            f"{robot_model_of(space.robot).name}: {', '.join(names)})")
    if space.robot.path.log is not None:  # the robot's log, checked before any search
        validate_robot(space.robot)
    if space.robot.mode not in ("kinematic", "dynamic"):  # checked before any search
        raise ScenarioError("robot.mode", space.robot.mode, "kinematic | dynamic")
    if space.contact_geometry not in ROBOT_GEOMETRIES:
        raise ScenarioError("contact_geometry", space.contact_geometry,
                            " | ".join(ROBOT_GEOMETRIES))
    for i, q in enumerate(space.tracked):
        if q not in human_body.POINTS or q in space.tracked[:i]:
            raise ScenarioError(f"tracked[{i}]", q, "body points, each once: "
                                + " | ".join(human_body.POINTS))
    if space.recording is not None:
        validate_recording(space)


def load_space(path: str | Path) -> ScenarioSpace:
    """Load and validate a space file (its task path's ``file``, and a recording block's
    files, relative to it)."""
    def validate(space: ScenarioSpace) -> None:
        read_robot_file(space.robot, Path(path).parent)
        read_task_path(space.robot, Path(path).parent)
        read_robot_log(space.robot, Path(path).parent)
        if space.recording is not None:
            read_recording_block(space.recording, Path(path).parent)
        validate_space(space)

    return load_document(path, ScenarioSpace, validate)


def parameter_ranges(space: ScenarioSpace) -> dict[str, Range]:
    """The space's parameters and their ranges, in order: ``NAMES`` of ``parameters``,
    or a recording block's (``recorded.RECORDING_NAMES``)."""
    block = space.parameters if space.recording is None else space.recording.parameters
    return {f.name: getattr(block, f.name) for f in dc.fields(block)}


def lower_upper(space: ScenarioSpace) -> tuple[np.ndarray, np.ndarray]:
    """The box's corners as two vectors in the order of :func:`parameter_ranges`."""
    ranges = parameter_ranges(space).values()
    return np.array([r.min for r in ranges]), np.array([r.max for r in ranges])


def free_parameters(space: ScenarioSpace) -> list[str]:
    """Names of the parameters whose range is not a single value."""
    return [n for n, r in parameter_ranges(space).items() if r.max > r.min]


def to_point(space: ScenarioSpace, unit: np.ndarray) -> dict[str, float]:
    """Maps a point of the unit cube over the free parameters to parameter values."""
    ranges = parameter_ranges(space)
    values = {n: float(r.min) for n, r in ranges.items()}
    for name, u in zip(free_parameters(space), np.asarray(unit, dtype=float)):
        r = ranges[name]
        values[name] = float(r.min + min(max(u, 0.0), 1.0) * (r.max - r.min))
    for name in WHOLE:
        if name in values:
            values[name] = float(round(values[name]))
    return values


def contact_assumption(space: ScenarioSpace) -> str:
    """What contact means in the space's scenarios, in words."""
    if space.contact_geometry == "capsules":
        return (f"contact means a segment of an operator's body within "
                f"{space.contact_distance:g} m of a robot capsule (the tool of "
                f"{space.robot.payload_radius:g} m radius"
                f"{f', {space.robot.tool_length:g} m long' if space.robot.tool_length else ''})")
    return (f"contact means a segment's axis within {space.contact_distance:g} m of the tool "
            "flange (the seed's tool point; the other links are not checked)")


def assumptions(space: ScenarioSpace, config: ControllerConfig) -> list[str]:
    """The assumptions under which a verdict over ``space`` holds, in words."""
    if space.recording is not None:
        return recording_assumptions(space, config) + [contact_assumption(space)] \
            + list(space.notes)
    p = space.parameters
    heads = " and a helmet" if p.heads.max >= 1 else ""
    postures = ", ".join(POSTURE_NAMES[int(p.posture.min):int(p.posture.max) + 1])
    names, _ = target_capsules(robot_model_of(space.robot))
    links = sorted({names[int(i)] for i in range(int(p.target_link.min),
                                                 int(p.target_link.max) + 1)})
    occluded = ", ".join(hidden_bodies(space, p.heads.max >= 1, int(p.occluded_bodies.max)))
    lines = [
        f"{how_many(p.operators, 'operator')}, each a whole body "
        f"(head, neck, trunk, shoulders, arms and hands as capsules of the table's sizes) "
        f"in the postures {postures}, tracked by "
        + (f"two gloves{heads}" if not space.tracked else "markers at its "
           + ", ".join(space.tracked)) + "; no other body enters the cell",
        f"every operator starts {span(p.start_distance, ' m')} from "
        f"the point it approaches and stands still for at least {space.settle_time:g} s",
        f"no body point moves faster than {p.peak_speed.max:g} m/s (ISO 13855: 2.0 m/s) or "
        f"accelerates faster than {p.acceleration.max:g} m/s^2 (each posture moves rigidly)",
        f"approaches aim at points of the {', '.join(links)} (capsule axes), from azimuth "
        f"{span(p.azimuth_deg, ' deg')}, elevation {span(p.elevation_deg, ' deg')}; "
        "straight lines "
        + ("with a retreat of up to "f"{p.retreat_distance.max:g} m before reversing"
           if p.retreat_distance.max > 0 else "without retreat")
        + f", reaching up to {p.overshoot.max:g} m past the target",
        f"sensor: {config.sensor.rate_hz:g} Hz, noise std {span(p.noise_std, ' m')} "
        f"(bounded at {space.noise_bound_sigmas:g} sigma for proofs), "
        f"latency {span(p.latency, ' s')}, dropped frames up to "
        f"{p.dropout.max:g} s, occlusion of up to {occluded} of every operator for up to "
        f"{p.occlusion.max:g} s",
        (f"up to {int(p.outlier_frames.max)} outlier frames of every operator's bodies, "
         f"{span(p.outlier_offset, ' m')} from their true positions"
         if p.outlier_frames.max >= 1 else "no outlier frames"),
        (f"every tracked body's reported position within {p.pivot_offset.max:g} m of the "
         "body point it marks (a live mapping gives each body's pivot, or at_point: a Motive "
         "rigid body's pivot left at its markers' centroid can be 0.15 m off a helmet's head "
         "centre, sensing.pivots; the runtime refuses a mapping that leaves more)"),
        "the robot stops as its stopping data says"
        + ("" if p.braking_time_scale.min == p.braking_time_scale.max == 1.0 else
           f", times scaled by {span(p.braking_time_scale)}"),
        contact_assumption(space),
    ]
    return lines + list(space.notes)


def approach_times(peak_speed: float, acceleration: float, length: float) -> float:
    """Duration of a rest-to-rest straight move, s."""
    ta, tc, _ = segment_profile(np.array([length]), peak_speed, acceleration)
    return float(2.0 * ta[0] + tc[0])


def target_point(space: ScenarioSpace, values: dict[str, float], path) -> np.ndarray:
    """The point a space's approaches aim at (see the module docstring), m."""
    q = joint_path_state(path, values["target_phase"] * path.cycle_time)[0]
    model = robot_model_of(space.robot)
    points = robot_points(q, tool_length=space.robot.tool_length, model=model)[0]
    a, b = target_capsules(model)[1][int(round(values["target_link"]))]
    return points[a] + values["target_along"] * (points[b] - points[a])


def make_scenario(space: ScenarioSpace, config: ControllerConfig, values: dict[str, float],
                  *, name: str = "sample", path=None, validate: bool = True) -> Scenario:
    """The scenario of one point of the space (``values`` by parameter name).

    ``path``: the space robot's joint path, if the caller has it already (building it is
    most of the cost for many points). ``validate=False`` skips the range checks, for
    candidates that are only ranked, never simulated (simulated ones are made again
    with the checks). A recording space's points: ``recorded.recorded_scenario``."""
    v = values
    path = joint_path(space.robot) if path is None else path
    if space.recording is not None:
        return recorded_scenario(space, config, values, name=name, path=path,
                                 validate=validate)
    onset = space.settle_time + v["onset_phase"] * path.cycle_time
    target = target_point(space, v, path)
    n_ops = int(round(v["operators"]))
    heads = int(round(v["heads"])) >= 1
    operators, end, directions = [], onset, []
    for j in range(n_ops):
        az = math.radians(v["azimuth_deg"] + 360.0 * j / n_ops)
        el = math.radians(v["elevation_deg"])
        u = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
        directions.append(u)
        start = target + v["start_distance"] * u
        waypoints = [Waypoint(0.0, start.tolist())]
        t = onset
        if v["retreat_distance"] > 0.0:
            away = start + v["retreat_distance"] * u
            waypoints.append(Waypoint(t, away.tolist()))
            t += approach_times(v["peak_speed"], v["acceleration"], v["retreat_distance"])
            t += 1e-6
        end_point = target - v["overshoot"] * u  # reaching on through the target
        waypoints.append(Waypoint(t, end_point.tolist()))
        length = float(np.linalg.norm(end_point - np.array(waypoints[-2].position)))
        end = max(end, t + approach_times(v["peak_speed"], v["acceleration"], length))
        points = posture_offsets(int(round(v["posture"])), az)
        tracked = tracked_bodies(space, heads)
        # each reported ``pivot_offset`` from its point, away from the robot (the worst
        # way: the monitor takes the operator for farther than it is; sensing.pivots)
        bodies = [Body(name=n, point=q, offset=points[q].tolist(),
                       pivot=(v["pivot_offset"] * u).tolist()) for n, q in tracked]
        posture = [PosturePoint(point=q, offset=points[q].tolist()) for q in human_body.POINTS
                   if q not in dict(tracked).values()]
        operators.append(OperatorConfig(
            name=f"operator_{j}", max_speed=v["peak_speed"], max_acceleration=v["acceleration"],
            bodies=bodies, posture=posture, waypoints=waypoints))
    duration = end + space.tail_time
    sensor = dc.replace(config.sensor, noise_std=v["noise_std"], latency=v["latency"],
                        dropouts=[], occlusions=[], faults=[])
    if v["dropout"] > MIN_GAP:
        sensor.dropouts = [Interval(onset, onset + v["dropout"])]
    hidden = hidden_bodies(space, heads, int(round(v["occluded_bodies"])))
    if v["occlusion"] > MIN_GAP:
        sensor.occlusions = [Occlusion(f"{o.name}/{b.name}", onset, onset + v["occlusion"])
                             for o in operators for b in o.bodies if b.name in hidden]
    frames = int(round(v["outlier_frames"]))
    if frames >= 1:  # from the first capture after the delay, exactly ``frames`` captures
        period = 1.0 / sensor.rate_hz
        after = onset + max(v["occlusion"], v["dropout"]) + v["outlier_delay"]
        first = math.ceil(after / period - 1e-9) * period
        sensor.faults = [SensorFault("outlier", f"{o.name}/{b.name}", "", first,
                                     first + (frames - 0.5) * period,
                                     (v["outlier_offset"] * u).tolist())
                         for o, u in zip(operators, directions) for b in o.bodies]
        duration = max(duration, first + frames * period + space.tail_time)
    robot = dc.replace(space.robot, braking_time_scale=v["braking_time_scale"],
                       cycles=int(math.ceil(duration / path.cycle_time)) + 1)
    scenario = Scenario(name=name, duration=duration, contact_geometry=space.contact_geometry,
                        contact_distance=space.contact_distance, robot=robot, controller=config,
                        sensor=sensor, operators=operators)
    if validate:
        validate_scenario(scenario)
    return scenario


def tracked_bodies(space: ScenarioSpace, heads: bool) -> list[tuple[str, str]]:
    """(name, body point) of every tracked body of a space's operator: the gloves and,
    with ``heads``, the helmet (:data:`TRACKED`); or the space's ``tracked`` points,
    named as in :data:`TRACKED` where they are there, else after the point."""
    if not space.tracked:
        return [(n, q) for n, q in TRACKED if heads or q != "head"]
    names = {q: n for n, q in TRACKED}
    return [(names.get(q, q), q) for q in space.tracked]


def hidden_bodies(space: ScenarioSpace, heads: bool, count: int) -> tuple[str, ...]:
    """The names of the first ``count`` bodies an occlusion hides: the right hand, the
    left hand, the head, then the others in the order the space tracks them."""
    names = [n for n, _ in tracked_bodies(space, heads)]
    first = [n for n, _ in TRACKED if n in names]
    return tuple(first + [n for n in names if n not in first])[:count]


def posture_offsets(index: int, azimuth: float = math.pi) -> dict[str, np.ndarray]:
    """Every body point's offset from the lead point of posture ``index`` (:data:`POSTURES`),
    m, for an approach from ``azimuth`` (rad): the operator faces the target, along
    -(cos azimuth, sin azimuth, 0)."""
    _, lead, points = POSTURES[index]
    f = -np.array([math.cos(azimuth), math.sin(azimuth), 0.0])
    frame = np.array([f, np.cross([0.0, 0.0, 1.0], f), [0.0, 0.0, 1.0]])
    origin = np.mean([points[q] for q in lead], axis=0)
    return {q: (np.array(x) - origin) @ frame for q, x in points.items()}


def space_postures(space: ScenarioSpace) -> list[np.ndarray]:
    """Every posture a scripted space's operators take (its ``posture`` range), (10, 3)
    offsets of the body points (``human_body.POINTS``) from the lead point (one azimuth:
    a posture turns with its approach, which changes no distance in it)."""
    p = space.parameters.posture
    return [np.array([posture_offsets(k)[q] for q in human_body.POINTS])
            for k in range(int(p.min), int(p.max) + 1)]


def posture_reach(space: ScenarioSpace) -> float:
    """The farthest any body point of the space's postures is from its operator's
    reference point (the approaching hand), m."""
    return max(float(np.linalg.norm(x, axis=1).max()) for x in space_postures(space))


def corners(space: ScenarioSpace) -> np.ndarray:
    """Every vertex of the unit cube over the free parameters, (2^d, d)."""
    d = len(free_parameters(space))
    return np.array(list(itertools.product((0.0, 1.0), repeat=d)), dtype=float).reshape(2**d, d)


def describe(values: dict[str, float]) -> dict[str, float]:
    """Parameter values rounded for reports."""
    return {k: float(np.round(x, 6)) for k, x in values.items()}


def explained_operators(space: ScenarioSpace) -> tuple[list[list[str]], list[str], float,
                                                        float]:
    """What ``explain`` takes of a space's operators: (each operator's tracked body
    points, their names, the fastest any body point moves, m/s, the sensor noise per
    axis the proofs bound it by, m). A box of approaches: one operator, tracked at
    :func:`tracked_bodies` (a helmet where any of its points has one), its peak speed and
    ``noise_bound_sigmas`` times its largest noise std; a recording: its mapping's
    operators and points, its recorded speed at the largest time scale and its largest
    noise std."""
    if space.recording is not None:
        block = space.recording
        ops = recorded_operators(block)
        p = block.parameters
        return ([list(b.points_marked) for _, b in ops], [o for o, _ in ops],
                recorded_speed(block) * p.time_scale.max, p.noise_std.max)
    p = space.parameters
    return ([[q for _, q in tracked_bodies(space, p.heads.max >= 1.0)]], ["operator"],
            p.peak_speed.max, space.noise_bound_sigmas * p.noise_std.max)


def space_cell(config: ControllerConfig, space: ScenarioSpace) -> ResolvedCell:
    """What ``config`` means on the space's robot for the space's operators
    (:func:`explained_operators`), resolved once (``config.resolved_cell``): the value the
    proofs, the search and the Drake replays of a verification take. Another operator set
    of the space (two operators, with or without a helmet) has its recipe from
    ``ResolvedCell.recipe_for``."""
    points, names, _, _ = explained_operators(space)
    return resolve(config, space.robot, points=points, names=names)
