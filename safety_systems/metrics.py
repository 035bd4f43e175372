"""Outcome measures of a run: true separations, motion, task time, stops (plain functions).

"Moving" means the tool flange's true speed exceeds ``MOVING_SPEED`` (1 mm/s). True
separations are between the true tool position (forward kinematics of the actual joint
positions) and the true positions of the bodies present in the cell.
"""

import numpy as np

from safety_systems.simulation import Run
from safety_systems.ssm import separation_distances
from safety_systems.stops import REJECT_CAUSES, STOP_REASONS
from safety_systems.tracks import TRACK_HIDDEN, TRACK_LOST
from safety_systems.ur5e import tool0_position_and_velocity

MOVING_SPEED = 1e-3  # m/s


def tool_state(run: Run) -> tuple[np.ndarray, np.ndarray]:
    """True tool position (T, 3) and speed (T,) from the logged joint state."""
    p, v = tool0_position_and_velocity(run["q"], run["v"])
    return p, np.linalg.norm(v, axis=-1)


def true_separations(run: Run, tool_position: np.ndarray | None = None) -> np.ndarray:
    """(T, N) true distances from the tool to each body; NaN where a body is absent."""
    if tool_position is None:
        tool_position = tool_state(run)[0]
    d = separation_distances(tool_position, run.bodies("operators.positions_true"))
    return np.where(run["operators.present"] > 0.5, d, np.nan)


def min_separation_while_moving(separations: np.ndarray, speed: np.ndarray) -> float:
    """Smallest true separation over the instants when the tool moves (inf if none)."""
    moving = speed > MOVING_SPEED
    closest = np.min(np.where(np.isnan(separations), np.inf, separations), axis=-1,
                     initial=np.inf)
    return float(np.min(closest[moving], initial=np.inf))


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
    """(T,) why the robot was held at each tick (``safety_systems.stops`` codes): the
    SpeedOverride's ``stop_reason``, or, for controllers without one, the tracker's
    fault (they stop on it too)."""
    key = "override.stop_reason" if "override.stop_reason" in run.signals else "tracker.fault"
    return run[key][:, 0]


def protective_stops(run: Run) -> dict:
    """Protective stops by cause: how many times one began and the seconds it lasted."""
    reasons = stop_reasons(run)
    dt = np.diff(run.time, append=run.time[-1])
    out = {}
    for code, name in enumerate(STOP_REASONS[1:], start=1):
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
    """The summary written to ``summary.json`` (see ``safety_systems.outputs``)."""
    scenario = run.scenario
    p, speed = tool_state(run)
    sep = true_separations(run, p)
    min_sep = min_separation_while_moving(sep, speed)
    finite = float(np.nanmin(sep)) if np.any(np.isfinite(sep)) else None
    return {
        "scenario": scenario.name,
        "mode": scenario.robot.mode,
        "human_speed": scenario.controller.safety.human_speed,
        "duration": float(run.time[-1]),
        "cycles": scenario.robot.cycles,
        "task_time": task_time(run),
        "min_separation_while_moving": min_sep if np.isfinite(min_sep) else None,
        "contact_distance": scenario.contact_distance,
        "contact_while_moving": bool(min_sep < scenario.contact_distance),
        "stopped_time": stopped_time(run),
        "min_separation": finite,
        "max_tool_speed": float(np.max(speed)),
        "protective_stops": protective_stops(run),
        "rejected_frames": rejected_frames(run),
        "hidden_time": hidden_time(run),
    }
