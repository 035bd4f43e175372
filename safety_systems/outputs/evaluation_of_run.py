"""Seed 001's evaluation metric (Tables IX-X, ``safety_systems.planning.evaluation``) of a
simulated run: the run's motion, torques, closest distances and closing speeds, against
the ideal run of the same path."""

import numpy as np

from safety_systems.cell.joint_path import joint_path_state
from safety_systems.cell.ur5e import tool0_position_and_velocity
from safety_systems.cell.robot_plant import inverse_dynamics_torques
from safety_systems.config.configuration import joint_path, robot_model_of
from safety_systems.diagrams.simulation import Run
from safety_systems.outputs.metrics import task_time
from safety_systems.planning.evaluation import Thresholds, evaluate
from safety_systems.ssm.formulas import directed_speeds


def evaluation_of_run(run: Run, *, contact: bool, every: int = 5) -> dict:
    """Seed 001's metric (``safety_systems.planning.evaluation``) of a run, up to the end of its
    task (or of the run), sampled every ``every`` control ticks; ``contact``: whether the
    robot touched an operator anywhere in the run (the metric's contact gate)."""
    finished = task_time(run)
    elapsed = finished if finished is not None else float(run.time[-1])
    rows = np.flatnonzero(run.time <= elapsed + 1e-9)[::every]
    progress = float(run["follower.path_state"][rows[-1], 0])
    q, v = run["q"][rows], run["v"][rows]
    a = run["follower.joint_accelerations_desired"][rows]
    p_tool, v_tool = tool0_position_and_velocity(q, v)
    bodies = run.bodies("operators.positions_true")[rows]
    d = np.where(run["operators.present"][rows] > 0.5,
                 np.linalg.norm(bodies - p_tool[:, None, :], axis=-1), np.inf)
    nearest = np.argmin(d, axis=1)
    v_bodies = run.bodies("operators.velocities_true")[rows]
    v_h, v_r = directed_speeds(p_tool, v_tool, bodies, v_bodies)
    pick = np.arange(len(rows))
    path = joint_path(run.scenario.robot)
    dt = float(run.time[rows[1]] - run.time[rows[0]]) if len(rows) > 1 else 1.0
    s_ideal = np.arange(0.0, max(progress, dt), dt)
    q_ideal, _, a_ideal = joint_path_state(path, s_ideal)
    zones = run.scenario.controller.zones
    torques = inverse_dynamics_torques(robot_model_of(run.scenario.robot), q, v, a)
    return evaluate(time=run.time[rows], q=q, v=v, a=a, torques=torques, progress=progress,
                    elapsed=elapsed, closest=d[pick, nearest],
                    closing_speed=(v_h + v_r)[pick, nearest], ideal_q=q_ideal,
                    ideal_a=a_ideal, ideal_duration=max(progress, dt), contact=contact,
                    thresholds=Thresholds(unsafe=zones.yellow_distance,
                                          comfortable=zones.green_distance))
