"""Ground truth: run a scenario in the Drake diagram and measure both properties."""

import numpy as np

from safety_systems.metrics import (
    command_signal,
    commanded,
    permitted,
    robot_contact_state,
    robot_speed,
    true_pairs,
    true_protective_distances,
)
from safety_systems.scenario import Scenario
from safety_systems.simulation import Run, simulate_workcell
from safety_systems.workcell import MakeWorkcell
from verification.properties import Robustness, separation_invariant, stopped_before_contact

LOGGED = ("q", "v", "operators.positions_true", "operators.velocities_true",
          "operators.present", "follower.path_state", "tracker.rejected_frames")


def robustness_of_run(run: Run) -> Robustness:
    """Both properties from a run's logs."""
    scenario = run.scenario
    speed = robot_speed(robot_contact_state(run)[1])
    clearance, v_h, v_r = true_pairs(run)
    dt = 1.0 / scenario.robot.control_rate_hz
    rho = stopped_before_contact(clearance.min(axis=-1), speed, scenario.contact_distance)
    separation, time = separation_invariant(
        clearance, true_protective_distances(scenario, v_h, v_r), permitted(commanded(run)),
        dt)
    return Robustness(rho, rho + scenario.contact_distance, separation, time)


def evaluate_drake(scenario: Scenario) -> tuple[Robustness, Run]:
    """Simulates ``scenario`` in the diagram (only the signals the properties need are
    logged) and returns its robustness and the run."""
    logged = LOGGED + (command_signal(scenario.controller.type),)
    run = simulate_workcell(MakeWorkcell(scenario, logged=logged))
    return robustness_of_run(run), run


def robustness_values(results: list[Robustness]) -> np.ndarray:
    return np.array([r.stopped_before_contact for r in results])
