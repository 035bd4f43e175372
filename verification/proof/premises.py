"""The premises both theorems share (``verification.proof.theorems``): each a statement
that is *checked* (against this model, the configuration and the space) or *trusted*
(taken from the files and the real cell), and the box the theorem is stated over."""

import dataclasses
import math
from pathlib import Path

import numpy as np

from safety_systems.cell import human_body
from safety_systems.cell.placeholder_stops import PLACEHOLDER_STOPS
from safety_systems.cell.robot_log import peak_joint_speeds
from safety_systems.cell.robot_model import KIND_UR, is_ur5e, placeholder_name
from safety_systems.config.configuration import contact_capsules, joint_path
from safety_systems.config.resolved_cell import ResolvedCell
from safety_systems.config.scenario import ControllerConfig, robot_log_of, robot_model_of
from safety_systems.ssm.formulas import SPEED_LEVELS
from verification.proof.margins import (
    check_cell,
    least_level_separation,
)
from verification.proof.robot_bounds import (
    braking_is_monotone,
    revolute_only,
)
from verification.proof.tracking_error import ERROR_HORIZON, estimate_error_coefficients
from verification.spaces.box import ScenarioSpace, stop_times_words
from verification.spaces.recorded import recorded_reach
from verification.spaces.space import posture_reach, space_postures

COVERED_MODE = "kinematic"  # the theorem's robot follows its braked reference exactly


@dataclasses.dataclass(frozen=True)

class Premise:
    """One premise of the theorem: ``basis`` is ``checked`` (by ``prove``, against this
    model, the configuration and the space) or ``trusted`` (taken from the files and the
    real cell; ``holds`` is then what the files say, not a finding)."""

    statement: str
    holds: bool
    basis: str


def operators_reach(space: ScenarioSpace) -> float:
    """A bound on how far from the robot base any body point of the space's scenarios
    gets, m: the farthest point of the robot, then the start distance, a retreat, the
    overshoot and the farthest body point of a posture from its operator's reference
    (``spaces.space.posture_reach``; a recording space's: ``recorded.recorded_reach``)."""
    if space.recording is not None:
        return recorded_reach(space)
    p = space.parameters
    robot = robot_model_of(space.robot).base_reach + space.robot.tool_length
    return (robot + p.start_distance.max + p.retreat_distance.max + p.overshoot.max
            + posture_reach(space))


def body_model_holds(cell: ResolvedCell, space: ScenarioSpace) -> list[str]:
    """Why the space's operators are not bodies the monitor's model allows (empty when
    they are): each posture's edges, head-shoulder distance and leans against the
    configuration's dimensions (the cell's ``body``; ``human_body.posture_violations``),
    and the segments' radii the properties measure (the table's) against the monitor's."""
    dims, table = cell.body, human_body.DEFAULT_DIMENSIONS
    out = [f"posture {k}: {x}" for k, points in enumerate(space_postures(space))
           for x in human_body.posture_violations(points, dims)]
    out += [f"{name} {dims[name]:g} m < {table[name]:g} m (the segments measured)"
            for _, _, _, name in human_body.SEGMENTS if dims[name] < table[name]]
    return sorted(set(out))


def tracks_never_end(config: ControllerConfig, space: ScenarioSpace) -> bool:
    """No body of the space comes into an exit region or beyond the cell's walls (where
    its track would end): every region lies beyond ``operators_reach`` of the base."""
    reach, t = operators_reach(space), config.tracker

    def inside_ball(box) -> bool:  # the box meets the ball of radius reach about the base
        nearest = np.clip(0.0, box.min, box.max)
        return float(np.linalg.norm(nearest)) <= reach

    walls_far = t.cell is None or (np.all(np.array(t.cell.min) <= -reach)
                                   and np.all(np.array(t.cell.max) >= reach))
    return bool(walls_far and not any(inside_ball(box) for box in t.exits))


def monitor_covers_contact(cell: ResolvedCell, space: ScenarioSpace) -> bool:
    """The monitor's robot (the cell's ``capsules``) contains the property's: capsules
    against capsules (same axes, radii and tool at least as large), capsules against the
    tool point (the flange lies on the tool capsule's axis), or the tool point against
    the tool point."""
    f, robot = cell.config.safety, space.robot
    if space.contact_geometry == "tool_point":
        return True
    if f.robot_geometry == "tool_point":
        return False
    mine = cell.capsules
    real = contact_capsules(robot, space.contact_geometry)
    return bool(np.all(mine.radius >= real.radius) and mine.tool_length >= real.tool_length)


def setting(cell: ResolvedCell, space: ScenarioSpace, prop: str):
    """What both theorems share: the box's extremes, the tracker's error coefficients and
    the premises, checked and trusted (``prop``: ``contact`` or ``separation``, which
    needs no ordering of braking speeds and no contact distance), for the cell resolved
    for the space's robot (``spaces.space.space_cell``)."""
    check_cell(cell, space)
    config = cell.config
    f, t, p = config.safety, config.tracker, space.parameters
    h = 1.0 / space.robot.control_rate_hz
    period = 1.0 / config.sensor.rate_hz
    scale = p.braking_time_scale.max
    v_max, noise = p.peak_speed.max, space.noise_bound_sigmas * p.noise_std.max
    alpha, beta, converged = estimate_error_coefficients(config)
    e_worst = math.sqrt(3.0) * (alpha * noise + beta * v_max)  # m, Euclidean
    allowance = config.body.tracking_allowance
    misfits = body_model_holds(cell, space)
    outliers = p.outlier_frames.max >= 1
    gate_widest = ((t.gate_speed + v_max) * p.outlier_frames.max * period + t.gate_width
                   + f.human_uncertainty + e_worst + math.sqrt(3.0) * noise)
    placeholder = cell.braking_source == "placeholder"
    model = cell.model
    checked = model_premises(cell, space) + [
        ("the space's operators are bodies the monitor's model allows (every posture's "
         "segments within the configuration's body dimensions and lean limits, the "
         "measured segments' radii within the monitor's)"
         + (": " + "; ".join(misfits[:3]) if misfits else ""), not misfits),
        (f"the envelopes' tracking allowance covers the tracker's error and where the sensor "
         f"reports a body from its point: tracking_allowance {allowance:g} m >= E "
         f"{e_worst:.4f} m (the error of an estimate at its capture time, at the box's "
         f"largest noise and speed) + the space's largest pivot offset "
         f"{p.pivot_offset.max:g} m (sensing.pivots)", allowance >= e_worst + p.pivot_offset.max),
        (f"hidden bodies stay hazards: tracks end only where bodies leave "
         f"(hidden_bodies: {t.hidden_bodies}) and a hidden body's region grows at least as "
         f"fast as any body point (occlusion_speed {f.occlusion_speed:g} >= v_max "
         f"{v_max:g} m/s)", t.hidden_bodies == "hazard" and f.occlusion_speed >= v_max),
        ("no body point of the space reaches an exit region or the cell's walls (where a "
         f"track would end): all within {operators_reach(space):.2f} m of the base",
         tracks_never_end(config, space)),
        (f"frames within the noise bound pass the gate (gate_speed {t.gate_speed:g} >= "
         f"v_max and gate_width {t.gate_width:g} m >= E + sqrt(3) noise "
         f"{e_worst + math.sqrt(3.0) * noise:.4f} m)",
         not t.gate or (t.gate_speed >= v_max
                        and t.gate_width >= e_worst + math.sqrt(3.0) * noise)),
        ((f"the space's outlier frames all fall outside the gate: offset "
          f"{p.outlier_offset.min:g} m > the widest gate an outlier of a run of "
          f"{int(p.outlier_frames.max)} frames can meet, {gate_widest:.3f} m")
         if outliers else "the space has no outlier frames",
         not outliers or (t.gate and p.outlier_offset.min > gate_widest)),
        ("every body is seen before its onset (settle time > frame timeout)",
         space.settle_time > cell.frame_timeout),
    ]
    checked += log_premises(cell, space, placeholder)[0]
    by_speed = f.stopping == "by_speed"
    if prop == "contact" or by_speed:
        checked.append(("a braking step preserves the order of speeds"
                        + (" (so a stop from a lower speed level takes no longer and travels "
                           "no farther)" if by_speed else ""),
                        braking_is_monotone(cell.braking, h, scale)))
    if by_speed:
        least = least_level_separation(cell, space)
        checked.append((f"d >= dS S_max(g) gives d >= S_max(g) at every speed level: dS = 1 "
                        f"or the monitor's S is never negative (dS {f.delta_s:g}; the least S "
                        f"at any level {least:.4f} m)", f.delta_s == 1.0 or least >= 0.0))
    checked.append((f"the tracker's error recursion converged within {ERROR_HORIZON} frames",
                    converged))
    trusted = [
        ("the stopping data describes the real robot's stops"
         + (" from every speed (S by speed uses its rows below full speed)"
            if by_speed else "") + ", " + stop_times_words(p.braking_time_scale)
         + ((" (THE BUILT-IN PLACEHOLDER DERIVED FROM UR5/CB3 DATA, NOT MEASURED ON THIS "
             "CELL)" if is_ur5e(model) else
             f" (THE BUILT-IN PLACEHOLDER FOR THE {model.name.upper()}, DERIVED FROM "
             "PUBLISHED FIGURES (models/README.md), NOT MEASURED ON THIS CELL)")
            if placeholder else " (the configuration's braking table)")),
        f"no point of any operator's body moves faster than v_max = {v_max:g} m/s (ISO "
        "13855: 2.0 m/s for hands and arms)",
        "every operator's body is within the monitor's model (cell/human_body.py): segment "
        "lengths and radii at most the configuration's body dimensions (defaults: 95th "
        f"percentiles of adult men), the trunk within {config.body.trunk_lean_deg:g} deg "
        f"and the neck within {config.body.neck_lean_deg:g} deg of the vertical, each "
        "shoulder within head_shoulder of the head, the cell's z axis up, and every "
        "tracked body where its mapping says (a glove on the hand, a helmet on the head), "
        f"reported within {p.pivot_offset.max:g} m of the body point it marks (a live "
        "mapping gives each body's pivot offset or at_point; the runtime refuses one that "
        "leaves a body farther off, as a helmet's unmoved pivot may be, 0.15 m: "
        "sensing.pivots)",
        f"sensor noise stays below {space.noise_bound_sigmas:g} sigma per axis "
        f"({noise:g} m) in every frame the gate accepts: no marker swap or reflection "
        "passes it",
        "the real robot follows its braked reference as exactly as the kinematic model "
        "does (its tracking error is not covered)",
        ("the UR5e model's capsules contain the real arm (they contain its collision "
         "geometry: tests/test_robot_geometry.py) and the tool fits its payload capsule"
         if is_ur5e(model) else
         f"the {model.name} model's capsules contain the real arm (they contain its "
         f"URDF's collision geometry, {model.urdf.name}: tests/cell/test_capsule_fit.py) "
         "and the tool fits its payload capsule"),
        "bodies come into the cell only through its exits and are tracked before they "
        "come near the robot (the space's operators stand still for the settle time)",
    ]
    trusted += log_premises(cell, space, placeholder)[1]
    premises = ([Premise(x, bool(ok), "checked") for x, ok in checked]
                + [Premise(x, True, "trusted") for x in trusted])
    box = {"peak_speed": [p.peak_speed.min, p.peak_speed.max],
           "noise_std": [p.noise_std.min, p.noise_std.max],
           "braking_time_scale": [p.braking_time_scale.min, p.braking_time_scale.max],
           "latency": [p.latency.min, p.latency.max], "dropout": [p.dropout.min, p.dropout.max],
           "occlusion": [p.occlusion.min, p.occlusion.max],
           "outlier_frames": [p.outlier_frames.min, p.outlier_frames.max],
           "start_distance": [p.start_distance.min, p.start_distance.max],
           "acceleration": [p.acceleration.min, p.acceleration.max]}
    return premises, box, placeholder, (alpha, beta), scale


def log_premises(cell: ResolvedCell, space: ScenarioSpace, placeholder: bool
                 ) -> tuple[list[tuple], list[str]]:
    """(checked, trusted) premises of a robot log path (none for another path): the log
    named with its SHA-256 and its fastest joint at path rate 1 (the bounds V_R and D are
    the log's path's, ``robot_bounds``); that speed within the placeholder stopping
    data's full speed (checked), or the configured stopping data measured from it
    (trusted)."""
    g = space.robot.path.log
    if g is None:
        return [], []
    model = cell.model
    log = robot_log_of(space.robot)
    peak = peak_joint_speeds(joint_path(space.robot))
    j = int(np.argmax(peak))
    fastest = f"{math.degrees(peak[j]):.1f} deg/s ({log.fields[j]})"
    trusted = [f"the robot runs its log {Path(log.file).name} (SHA-256 {log.sha256}) as "
               f"recorded, its fastest joint {fastest} at path rate 1"]
    if placeholder:
        full = PLACEHOLDER_STOPS[placeholder_name(model)].speed
        return [(f"the log's joints are no faster than the placeholder stopping data's full "
                 f"speed ({fastest} <= {math.degrees(full):.0f} deg/s)",
                 bool(np.all(peak <= full)))], trusted
    return [], trusted + [f"the configuration's stopping data were measured from the "
                          f"log's speed or faster (its fastest joint {fastest})"]


def model_premises(cell: ResolvedCell, space: ScenarioSpace) -> list[tuple]:
    """The premises on the controller and the robot that both theorems share, as
    (statement, holds) pairs."""
    config, model = cell.config, cell.model
    f = config.safety
    return [
        ("the controller is the SSM speed override (seed 000, Eq. 12)"
         if f.stopping != "by_speed" else
         f"the controller is the SSM speed override with S by speed (ssm.by_speed_command: "
         f"{SPEED_LEVELS} levels, S from the stop at the level of the rate now and of the "
         "command)", config.type == "ssm_override"),
        (f"the space's robot is in {COVERED_MODE} mode, the one this theorem covers "
         f"(robot.mode: {space.robot.mode}; a dynamic robot's tracking error is not in "
         "the margin)", space.robot.mode == COVERED_MODE),
        ("the human-speed term is a constant floor (iso or estimated_with_floor)",
         f.human_speed in ("iso", "estimated_with_floor")),
        ("the monitor's robot contains the one contact is measured against "
         f"({f.robot_geometry} against {space.contact_geometry})",
         monitor_covers_contact(cell, space)),
    ] + ([] if model.kind == KIND_UR else [
        # (a UR's closed form is six revolute joints by construction: nothing to check)
        (f"every joint of the {model.name} turns (the bound on a "
         "capsule point's acceleration is a revolute chain's)",
         revolute_only(model))])
