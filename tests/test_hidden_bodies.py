"""Both hands (and the head) hidden near the robot, in the Drake diagram: safe when hidden
bodies stay hazards (growing balls), unsafe with the previous rule (tracks ended after
the coast time when their last estimate lies beyond the exit radius from the base)."""

import numpy as np
import pytest

from safety_systems.outputs.metrics import summarize
from safety_systems.config.scenario import scenario_from_text
from safety_systems.diagrams.simulation import simulate
from safety_systems.sensing.stops import STOP_SEPARATION
from safety_systems.sensing.tracks import TRACK_HIDDEN, TRACK_NONE
from verification.search.evaluate_drake import robustness_of_run

# An operator 2.6 m out from the base (about 2 m from the arm, just outside S), beyond
# the old rule's 2.5 m exit radius. At t = 3 s every one of its bodies goes out of view
# for 3 s, while it walks up to the robot's path at 1.8 m/s.
SCENARIO = """
name: hidden_near_the_robot
duration: 8.0
robot: {cycles: 3}
controller:
  sensor:
    rate_hz: 20.0
    noise_std: 0.0002
    latency: 0.02
    occlusions:
    - {body: op/right, start: 3.0, end: 6.0}
    - {body: op/left, start: 3.0, end: 6.0}
    - {body: op/head, start: 3.0, end: 6.0}
  tracker: {hidden_bodies: HIDDEN, max_coast_time: 0.5, exit_radius: 2.5}
  safety:
    human_speed: iso
    iso_human_speed: 2.0
    iso_reduced_human_speed: 2.0
    reaction_time: 0.20
    stopping_time: 0.54
    stopping_distance: 0.26
    intrusion_distance: 0.09
    occlusion_speed: 2.0
    delta_s: 1.0
operators:
- name: op
  max_speed: 1.8
  max_acceleration: 3.0
  bodies:
  - {name: right, offset: [0.0, -0.2, 0.0]}
  - {name: left, offset: [0.0, 0.2, 0.0]}
  - {name: head, offset: [0.3, 0.0, 0.45], radius: 0.12}
  waypoints:
  - {time: 0.0, position: [2.6, 0.0, 0.3]}
  - {time: 3.0, position: [0.45, 0.05, 0.3]}
"""


def _run(rule):
    scenario = scenario_from_text(SCENARIO.replace("HIDDEN", rule))
    run = simulate(scenario)
    return run, robustness_of_run(run)


@pytest.fixture(scope="module")
def runs():
    return {rule: _run(rule) for rule in ("hazard", "expire")}


def test_hidden_bodies_stay_hazards_and_the_robot_stays_stopped(runs):
    run, rho = runs["hazard"]
    hidden = (run.time > 3.15) & (run.time < 6.0)
    status = run["tracker.track_status"][hidden]
    assert np.all(status == TRACK_HIDDEN)  # never ended, however long hidden
    # The balls grow at 2 m/s from where the bodies were last seen: within 0.3 s they
    # come inside S and the robot stops, for as long as they stay hidden and after.
    k = run["override.path_speed_commanded"][:, 0]
    reason = run["override.stop_reason"][:, 0]
    assert np.all(k[(run.time > 0.2) & (run.time < 3.0)] > 0.0)
    stopped = (run.time > 3.3) & (run.time < 8.0)
    assert np.all(k[stopped] == 0.0) and np.all(reason[stopped] == STOP_SEPARATION)
    assert rho.stopped_before_contact >= 0.0  # safe: never moving near the operator
    summary = summarize(run)
    assert summary["hidden_time"]["op/right"] == pytest.approx(3.0, abs=0.06)


def test_the_previous_rule_ends_the_tracks_and_the_robot_hits_the_operator(runs):
    run, rho = runs["expire"]
    status = run["tracker.track_status"]
    ended = (run.time > 3.6) & (run.time < 6.0)
    assert np.all(status[ended] == TRACK_NONE)  # ended by time: beyond 2.5 m of the base
    k = run["override.path_speed_commanded"][:, 0]
    assert np.all(k[ended] == 1.0)  # full speed towards someone it cannot see
    assert rho.stopped_before_contact < 0.0  # contact while moving
