"""Outcome measures of a run: true separations, motion, task time, stops (plain functions).

True separations are clearances between the real robot and the operators present in the
cell, every segment of each (``safety_systems.cell.human_body``: head, neck, trunk,
shoulders, arms and hands as capsules between its true body points; a recorded
operator's segments between points its recording does not hold are the envelopes of
those it does, ``configuration.truth_recipe``), as the scenario's ``contact_geometry``
defines contact (``configuration.contact_capsules``): the UR5e's capsules with the cell's
real tool, or the seed's tool flange and the segments' axes (``tool_point``). The
robot is where forward kinematics of the actual joint positions puts it. "Moving" means
the robot's speed, the fastest of its capsules' axis ends (the tool flange on the tool
point), exceeds ``ssm.true_measures.MOVING_SPEED`` (1 mm/s); motion is permitted and
a pair's margin taken by the same module's compiled rules, which the batched evaluator
calls too.

**Separation margin** (the separation invariant's measure, ``verification.properties``):
at each control tick where the safety controller permits motion (its commanded path
speed is not 0; every protective stop commands 0), the smallest d_true - S_true over
every segment present and every capsule of the real robot, where d_true is the pair's true
clearance and S_true is seed 000's Eqs. 9-11 (ISO/TS 15066 Eq. 1) evaluated on the truth:
the pair's true directed speeds (Eqs. 6-7; the human speed by the configuration's mode:
``iso`` its constant speeds, ``estimated`` the true directed speed,
``estimated_with_floor`` the larger of the two), the configuration's T_r and C, and the
simulated robot's own stopping time and distance (``safety_systems.cell.stopping``: its
brakes, scaled by its ``braking_time_scale``, on its path), not the configuration's
claim. Interpretation: Z_d and Z_r are left out of S_true. They are the allowances for
the uncertainty of the measured human and robot positions (ISO/TS 15066, 5.5.4.2.3);
on true positions there is nothing for them to allow for, and kept in S_true they would
stand on both sides of the comparison, so no allowance could ever make up for the
sensing error. They stay in the monitor's S, which is where that error is made up for
(the proof, ``verification.proof``, states how much Z_d + Z_r the invariant needs).
"""

import math

import numpy as np

from safety_systems.config.configuration import contact_capsules, robot_model_of, truth_recipe
from safety_systems.cell.robot_geometry import capsule_ends, robot_points
from safety_systems.cell.robot_model import is_ur5e
from safety_systems.config.resolved_cell import ResolvedCell, scenario_cell
from safety_systems.config.scenario import Scenario
from safety_systems.ssm.separation import pair_figures
from safety_systems.diagrams.simulation import Run
from safety_systems.ssm.formulas import monitor_protective_distances
from safety_systems.cell.stopping import (
    StoppingByRate,
    StoppingData,
    rate_index,
    stops_by_rate,
    true_stopping,
)
from safety_systems.sensing.stops import REJECT_CAUSES, SIMULATED_CAUSES, STOP_REASONS
from safety_systems.sensing.tracks import TRACK_HIDDEN, TRACK_LOST
from safety_systems.cell.ur5e import tool0_position_and_velocity
from safety_systems.ssm.true_measures import moving, permitted, true_segments



def tool_state(run: Run) -> tuple[np.ndarray, np.ndarray]:
    """True tool position (T, 3) and speed (T,) from the logged joint state: tool0 (the
    flange) of the scenario's robot."""
    model = robot_model_of(run.scenario.robot)
    if is_ur5e(model):
        p, v = tool0_position_and_velocity(run["q"], run["v"])
    else:
        points, velocities = robot_points(run["q"], run["v"], model=model)
        p, v = points[..., model.tool0, :], velocities[..., model.tool0, :]
    return p, np.linalg.norm(v, axis=-1)


def robot_contact_state(run: Run) -> tuple[np.ndarray, np.ndarray]:
    """The real robot's contact capsules' ends (T, K, 2, 3) and their velocities."""
    scenario = run.scenario
    capsules = contact_capsules(scenario.robot, scenario.contact_geometry)
    return capsule_ends(run["q"], capsules, run["v"])


def robot_speed(end_velocities: np.ndarray) -> np.ndarray:
    """(T,) the robot's speed: the fastest capsule axis end (every axis point is slower)."""
    return np.linalg.norm(end_velocities, axis=-1).reshape(len(end_velocities), -1).max(axis=1)


def run_true_segments(run: Run) -> tuple[np.ndarray, ...]:
    """The operators' true segments at every logged tick (``true_measures.true_segments``
    of ``configuration.truth_recipe``): ends and their velocities (T, M, 2, 3), radius
    (T, M), present (T, M)."""
    return true_segments(truth_recipe(run.scenario), run["operators.points_true"],
                         run["operators.point_velocities_true"],
                         run["operators.operators_present"])


def true_pairs(run: Run) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(clearance, v_human_directed, v_robot_directed) of every segment and contact
    capsule, each (T, M, K), from the true positions and velocities; NaN where a
    segment's operator is absent."""
    scenario = run.scenario
    ends, end_velocities = robot_contact_state(run)
    capsules = contact_capsules(scenario.robot, scenario.contact_geometry)
    h_ends, h_velocities, h_radius, present = run_true_segments(run)
    figures = pair_figures(ends, end_velocities, capsules.radius, h_ends, h_velocities,
                           h_radius)
    absent = ~present[:, :, None]
    return tuple(np.where(absent, np.nan, x) for x in figures)


def true_separations(run: Run) -> np.ndarray:
    """(T, M) true clearance of each segment to the robot (the nearest contact capsule);
    NaN where its operator is absent."""
    return true_pairs(run)[0].min(axis=-1)


def min_separation_while_moving(separations: np.ndarray, speed: np.ndarray) -> float:
    """Smallest true separation over the instants when the tool moves (inf if none)."""
    closest = np.min(np.where(np.isnan(separations), np.inf, separations), axis=-1,
                     initial=np.inf)
    return float(np.min(closest[moving(speed)], initial=np.inf))


def command_signal(controller_type: str) -> str:
    """The logged signal that carries a controller's commanded path speed: k of the
    SpeedOverride, the scale of a seed-004 speed controller or of the zones."""
    return {"ssm_override": "override.path_speed_commanded",
            "zones": "zones.path_speed_commanded"}.get(controller_type,
                                                        "speed.path_speed_commanded")


def commanded(run: Run) -> np.ndarray:
    """(T,) the safety controller's commanded path speed at each tick."""
    return run[command_signal(run.scenario.controller.type)][:, 0]


def robot_stopping(scenario: Scenario, cell: ResolvedCell | None = None) -> StoppingData:
    """The simulated robot's own stopping data on the scenario's path, for the real
    robot's capsules (``safety_systems.cell.stopping``), under the stopping data of the
    resolved ``cell`` (the PathFollower's; None: the scenario's, resolved here)."""
    from safety_systems.config.configuration import joint_path

    robot = scenario.robot
    return true_stopping(joint_path(robot), contact_capsules(robot, scenario.contact_geometry),
                         scenario_cell(scenario, cell, "scenario").braking,
                         robot.braking_time_scale, 1.0 / robot.control_rate_hz)


def true_protective_args(scenario: Scenario, cell: ResolvedCell | None = None) -> dict:
    """The keywords of ``ssm.monitor_protective_distances`` that give S_true (see the
    module docstring): the configuration's human-speed mode and speeds, T_r and C, the
    simulated robot's stopping time and distance (:func:`robot_stopping`), no Z_d or Z_r."""
    f = scenario.controller.safety
    stop = robot_stopping(scenario, cell)
    return dict(mode=f.human_speed, reaction_time=f.reaction_time, stopping_time=stop.time,
                stopping_distance=stop.distance, intrusion_distance=f.intrusion_distance,
                iso_speed=f.iso_human_speed, iso_reduced_speed=f.iso_reduced_human_speed)


def robot_stops_by_rate(scenario: Scenario, cell: ResolvedCell | None = None
                        ) -> StoppingByRate:
    """The simulated robot's stops from every grid rate on the scenario's path, for the
    real robot's capsules (``safety_systems.cell.stopping.stops_by_rate``), under the
    stopping data of the resolved ``cell`` (None: the scenario's, resolved here)."""
    from safety_systems.config.configuration import joint_path

    robot = scenario.robot
    return stops_by_rate(joint_path(robot), contact_capsules(robot, scenario.contact_geometry),
                         scenario_cell(scenario, cell, "scenario").braking,
                         robot.braking_time_scale, 1.0 / robot.control_rate_hz)


def true_protective_distances(scenario: Scenario, v_human_directed: np.ndarray,
                              v_robot_directed: np.ndarray,
                              rate: np.ndarray | None = None,
                              cell: ResolvedCell | None = None) -> np.ndarray:
    """S_true of pairs with these true directed speeds (any shape). With ``safety.stopping:
    by_speed`` the stop is the simulated robot's from its path rate at each tick (``rate``,
    the first axis's; the grid rate at or above it, ``StoppingByRate.at``), as ISO/TS
    15066's S_s from the current speed; else the stop from full speed. ``cell``: the
    scenario's resolved cell (None: resolved here)."""
    cell = scenario_cell(scenario, cell, "scenario")
    args = true_protective_args(scenario, cell)
    if scenario.controller.safety.stopping != "by_speed":
        return monitor_protective_distances(v_human_directed, v_robot_directed, **args)
    if rate is None:
        raise ValueError("S_true by speed needs the path rate at each tick")
    v_h, v_r = np.broadcast_arrays(np.asarray(v_human_directed, dtype=float),
                                   np.asarray(v_robot_directed, dtype=float))
    stops = robot_stops_by_rate(scenario, cell)
    index = np.array([rate_index(r) for r in np.asarray(rate, dtype=float)], dtype=int)
    out = np.empty(v_h.shape)
    for j in np.unique(index):
        rows = index == j
        out[rows] = monitor_protective_distances(
            v_h[rows], v_r[rows], **(args | dict(stopping_time=float(stops.time[j]),
                                                 stopping_distance=float(stops.distance[j]))))
    return out


def true_rate(run: Run) -> np.ndarray:
    """(T,) the robot's path rate at each logged tick (the PathFollower's sigma)."""
    return run["follower.path_state"][:, 1]


def separation_margins(clearance: np.ndarray, s_true: np.ndarray,
                       allowed: np.ndarray) -> np.ndarray:
    """(T,) the smallest d_true - S_true over the pairs (T, M, K) (NaN where a segment is
    absent) at ticks where motion is ``allowed`` (T,), or over the segments where it is
    allowed (T, M) (``true_measures.ssm_permitted``: speed and separation monitoring's
    part under ``safety.mode: ssm_pfl``); +inf at the others and where no operator is
    present."""
    gap = np.where(np.isnan(clearance) | np.isnan(s_true), np.inf, clearance - s_true)
    if np.ndim(allowed) == 2:
        gap = np.where(allowed[:, :, None], gap, np.inf)
        allowed = np.asarray(allowed).any(axis=1)
    smallest = gap.reshape(gap.shape[0], math.prod(gap.shape[1:])).min(axis=1, initial=np.inf)
    return np.where(allowed, smallest, np.inf)


def run_separation_margins(run: Run) -> np.ndarray:
    """(T,) :func:`separation_margins` of a run."""
    clearance, v_h, v_r = true_pairs(run)
    s_true = true_protective_distances(run.scenario, v_h, v_r, true_rate(run), run.cell)
    return separation_margins(clearance, s_true, permitted(commanded(run)))


def separation_while_moving(run: Run) -> tuple[np.ndarray, float]:
    """True separations (T, M) (``true_separations``) and their smallest value while the
    robot moves (inf if it never does with an operator present)."""
    sep = true_separations(run)
    return sep, min_separation_while_moving(sep, robot_speed(robot_contact_state(run)[1]))


def contact_while_moving(min_separation: float, contact_distance: float) -> bool:
    """Contact as the safety properties define it: a true separation below the scenario's
    contact distance while the robot moves."""
    return bool(min_separation < contact_distance)


def task_time(run: Run) -> float | None:
    """Time at which the path parameter reached its end, or None if it did not."""
    finished = np.flatnonzero(run["follower.path_state"][:, 2] > 0.5)
    return float(run.time[finished[0]]) if finished.size else None


def stopped_time(run: Run) -> float:
    """Seconds the controller held the robot at rest (path rate 0) before the task ended."""
    rate = run["follower.path_state"][:, 1]
    unfinished = run["follower.path_state"][:, 2] < 0.5
    dt = np.diff(run.time, append=run.time[-1])
    return float(np.sum(dt[(rate == 0.0) & unfinished]))


def stop_reasons(run: Run) -> np.ndarray:
    """(T,) why the robot was held at each tick (``safety_systems.sensing.stops`` codes): the
    SpeedOverride's ``stop_reason``, or, for controllers without one, the tracker's
    fault (they stop on it too)."""
    key = "override.stop_reason" if "override.stop_reason" in run.signals else "tracker.fault"
    return run[key][:, 0]


def protective_stops(run: Run) -> dict:
    """Protective stops by cause: how many times one began and the seconds it lasted (the
    wait for the first frame apart: :func:`first_frame_wait`)."""
    return stops_by_cause(stop_reasons(run), run.time, SIMULATED_CAUSES)


def first_frame_wait(reasons: np.ndarray, time: np.ndarray) -> float:
    """Seconds the robot was held from the first tick because no frame had come yet (a
    ``stale_frame`` hold from tick 0): the start, not a fault, so
    :func:`stops_by_cause` leaves it out of the ``stale_frame`` stops."""
    end = first_frame_ticks(reasons)
    return float(time[end] - time[0]) if end else 0.0


def first_frame_ticks(reasons: np.ndarray) -> int:
    """The ticks of the hold from tick 0 until the first frame (:func:`first_frame_wait`);
    none where no frame ever came (that is a fault: the stream never delivered)."""
    held = np.asarray(reasons) == STOP_REASONS.index("stale_frame")
    return 0 if held.all() else int(np.argmin(held))


def stops_by_cause(reasons: np.ndarray, time: np.ndarray, causes=STOP_REASONS[1:]) -> dict:
    """:func:`protective_stops` of stop reasons (T,) at times (T,), for the ``causes``
    named (by default every one, the live runtime's too); the hold from the first tick
    until the first frame (:func:`first_frame_wait`) is not a stop."""
    dt = np.diff(time, append=time[-1]) if time.size else time
    reasons = np.array(reasons, dtype=float)
    reasons[:first_frame_ticks(reasons)] = -1.0  # (no cause)
    out = {}
    for name in causes:
        code = STOP_REASONS.index(name)
        on = reasons == code
        starts = int(np.count_nonzero(on[1:] & ~on[:-1]) + (on[0] if on.size else 0))
        out[name] = {"count": starts, "time": float(np.sum(dt[on]))}
    return out


def rejected_frames(run: Run) -> dict:
    """Measurements the tracker rejected over the run, by cause."""
    counts = run["tracker.rejected_frames"][-1] if len(run.time) else np.zeros(4)
    return {name: int(c) for name, c in zip(REJECT_CAUSES, counts)}


def hidden(run: Run) -> np.ndarray:
    """(T, N) whether each body's track is hidden (a ball) or lost at each tick."""
    status = run["tracker.track_status"]
    return (status == TRACK_HIDDEN) | (status == TRACK_LOST)


def hidden_time(run: Run) -> dict:
    """Seconds each body spent hidden (tracked as a growing ball, or lost)."""
    dt = np.diff(run.time, append=run.time[-1])
    return {name: float(np.sum(dt[column]))
            for name, column in zip(run.body_names, hidden(run).T)}


def summarize(run: Run) -> dict:
    """The summary written to ``summary.json`` (see ``safety_systems.outputs.run_files``)."""
    scenario = run.scenario
    _, speed = tool_state(run)
    sep, min_sep = separation_while_moving(run)
    finite = float(np.nanmin(sep)) if np.any(np.isfinite(sep)) else None
    margins = run_separation_margins(run)
    worst = int(np.argmin(margins)) if margins.size else 0
    margin = float(margins[worst]) if margins.size and np.isfinite(margins[worst]) else None
    return {
        "scenario": scenario.name,
        "mode": scenario.robot.mode,
        "human_speed": scenario.controller.safety.human_speed,
        "duration": float(run.time[-1]),
        "cycles": scenario.robot.cycles,
        "task_time": task_time(run),
        "min_separation_while_moving": min_sep if np.isfinite(min_sep) else None,
        "contact_geometry": scenario.contact_geometry,
        "contact_distance": scenario.contact_distance,
        "contact_while_moving": contact_while_moving(min_sep, scenario.contact_distance),
        "stopped_time": stopped_time(run),
        # d_true - S_true, smallest while motion was permitted (None: never with a body
        # present), and when
        "min_separation_margin": margin,
        "min_separation_margin_time": float(run.time[worst]) if margin is not None else None,
        "min_separation": finite,
        "max_tool_speed": float(np.max(speed)),
        "first_frame_wait": first_frame_wait(stop_reasons(run), run.time),
        "protective_stops": protective_stops(run),
        "rejected_frames": rejected_frames(run),
        "hidden_time": hidden_time(run),
    }
