"""Both hands (and the head) hidden near the robot, in the Drake diagram: safe when hidden
bodies stay hazards (growing balls, and every segment bounded from them grows with
them), unsafe with the previous rule (tracks ended after the coast time when their last
estimate lies beyond the exit radius from the base)."""

import numpy as np
import pytest

from safety_systems.outputs.metrics import hidden, summarize, true_separations
from safety_systems.outputs.run_files import trace_table
from safety_systems.config.scenario import scenario_from_text
from safety_systems.diagrams.simulation import simulate
from safety_systems.sensing.stops import STOP_SEPARATION
from safety_systems.sensing.tracks import TRACK_HIDDEN, TRACK_NONE
from verification.search.evaluate_drake import robustness_of_run

# An operator 3.1 m out from the base (its hands 2.4 m from the arm; the envelope of its
# lower trunk, bounded from the hands and the head, 2 m: just outside S), beyond the old
# rule's 2.5 m exit radius. At t = 3 s every one of its bodies goes out of view for 3 s,
# while it walks up to the robot's path at 1.8 m/s.
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
  - {name: right, point: hand_right, offset: [0.0, -0.2, 0.0]}
  - {name: left, point: hand_left, offset: [0.0, 0.2, 0.0]}
  - {name: head, point: head, offset: [0.3, 0.0, 0.45]}
  waypoints:
  - {time: 0.0, position: [3.1, 0.0, 0.3]}
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
    # Every segment is bounded from hidden bodies only: all twelve hidden with them.
    assert np.all(run["envelopes.segment_status"][hidden] == TRACK_HIDDEN)


def test_the_trace_shows_the_bodies_hidden_and_the_operator_within_s(runs):
    run, _ = runs["hazard"]
    header, rows = trace_table(run)
    column = {name: rows[:, j] for j, name in enumerate(header)}
    assert [h for h in header if h.startswith("op")] == [
        "op:d_true", "op:nearest_true", "op:d_measured", "op:nearest_measured", "op:S",
        "op/right:hidden", "op/left:hidden", "op/head:hidden"]
    for i, body in enumerate(run.body_names):  # per body slot
        np.testing.assert_array_equal(column[f"{body}:hidden"], hidden(run)[:, i])
        on = column[f"{body}:hidden"] > 0.5
        assert 3.0 < run.time[on].min() < 3.1 and 6.0 < run.time[on].max() < 6.1
    # Before the bodies hide the nearest segment's d is beyond its S; while they are
    # hidden it falls below (the envelopes grow at 2 m/s), and the robot is held.
    before = (run.time > 0.2) & (run.time < 3.0)
    assert np.all(column["op:d_measured"][before] > column["op:S"][before])
    stopped = (run.time > 3.3) & (run.time < 6.0)
    assert np.all(column["op:d_measured"][stopped] < column["op:S"][stopped])
    # The true clearance: the least over the operator's segments, the operator walking in
    # to under 0.1 m of the held robot.
    np.testing.assert_allclose(column["op:d_true"], np.nanmin(true_separations(run), axis=1))
    assert np.nanmin(column["op:d_true"][stopped]) < 0.1


def test_the_previous_rule_ends_the_tracks_and_the_robot_hits_the_operator(runs):
    run, rho = runs["expire"]
    status = run["tracker.track_status"]
    ended = (run.time > 3.6) & (run.time < 6.0)
    assert np.all(status[ended] == TRACK_NONE)  # ended by time: beyond 2.5 m of the base
    k = run["override.path_speed_commanded"][:, 0]
    assert np.all(k[ended] == 1.0)  # full speed towards someone it cannot see
    assert rho.stopped_before_contact < 0.0  # contact while moving
