"""Ground truth: run a scenario in the Drake diagram and measure both properties."""

import numpy as np

from safety_systems.metrics import robot_contact_state, robot_speed, true_pairs
from safety_systems.scenario import Scenario
from safety_systems.simulation import Run, simulate_workcell
from safety_systems.workcell import MakeWorkcell, assumed_stopping
from verification.properties import Robustness, protective_intrusion, stopped_before_contact

LOGGED = ("q", "v", "operators.positions_true", "operators.velocities_true",
          "operators.present", "follower.path_state", "tracker.rejected_frames")


def protective_args(scenario: Scenario) -> dict:
    """The configuration's terms of S, for the true-speed protective distance."""
    f = scenario.controller.safety
    t_s, b = assumed_stopping(scenario.controller)
    return dict(reaction_time=f.reaction_time, stopping_time=t_s, stopping_distance=b,
                intrusion_distance=f.intrusion_distance, human_uncertainty=f.human_uncertainty,
                robot_uncertainty=f.robot_uncertainty)


def robustness_of_run(run: Run) -> Robustness:
    """Both properties from a run's logs."""
    scenario = run.scenario
    speed = robot_speed(robot_contact_state(run)[1])
    clearance, v_h, v_r = true_pairs(run)
    dt = 1.0 / scenario.robot.control_rate_hz
    time, deepest = protective_intrusion(clearance, speed, v_h, v_r, dt,
                                         **protective_args(scenario))
    rho = stopped_before_contact(clearance.min(axis=-1), speed, scenario.contact_distance)
    return Robustness(rho, rho + scenario.contact_distance, time, deepest)


def evaluate_drake(scenario: Scenario) -> tuple[Robustness, Run]:
    """Simulates ``scenario`` in the diagram (only the signals the properties need are
    logged) and returns its robustness and the run."""
    run = simulate_workcell(MakeWorkcell(scenario, logged=LOGGED))
    return robustness_of_run(run), run


def robustness_values(results: list[Robustness]) -> np.ndarray:
    return np.array([r.stopped_before_contact for r in results])
