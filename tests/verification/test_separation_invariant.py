"""The separation invariant (issue: distance never below S while motion is permitted)."""

import dataclasses
import math

import numpy as np
import pytest

from safety_systems.configuration import contact_body_radii, contact_capsules
from safety_systems.metrics import command_signal, robot_stopping, summarize
from safety_systems.robot_geometry import capsule_ends
from safety_systems.scenario import load_controller_config, load_scenario
from safety_systems.simulation import simulate
from verification.evaluate_drake import robustness_of_run

INSPECTION = load_scenario("models/scenarios/inspection.yaml")


def _plain_s(scenario, v_h, v_r, t_stop, b_stop):
    """Seed Eqs. 9-11 on the truth, written out (no Z_d, Z_r; see safety_systems.metrics)."""
    f = scenario.controller.safety
    t = t_stop + f.reaction_time
    rest = v_r * f.reaction_time + b_stop + f.intrusion_distance
    if f.human_speed == "estimated":
        return v_h * t + rest
    if f.human_speed == "estimated_with_floor":
        return max(v_h, f.iso_human_speed) * t + rest
    s = f.iso_human_speed * t + rest  # iso, with ISO 13855's 1.6 m/s rule above 0.5 m
    if s > 0.5:
        s = max(f.iso_reduced_human_speed * t + rest, 0.5)
    return s


def _plain_loop(run):
    """The invariant's robustness by a loop over ticks, bodies and capsules on the logged
    signals: the nearest axis point by clamped projection, speeds along the line."""
    scenario = run.scenario
    capsules = contact_capsules(scenario.robot, scenario.contact_geometry)
    ends, velocities = capsule_ends(run["q"], capsules, run["v"])
    bodies = run.bodies("operators.positions_true")
    body_v = run.bodies("operators.velocities_true")
    present = run["operators.present"]
    command = run[command_signal(scenario.controller.type)][:, 0]
    radii = contact_body_radii(scenario)
    stop = robot_stopping(scenario)
    worst = math.inf
    for t in range(len(run.time)):
        if command[t] == 0.0:
            continue
        for i in range(bodies.shape[1]):
            if present[t, i] < 0.5:
                continue
            p, w = bodies[t, i], body_v[t, i]
            for j in range(len(capsules.radius)):
                a, b = ends[t, j]
                va, vb = velocities[t, j]
                axis = b - a
                length2 = float(axis @ axis)
                u = 0.0 if length2 == 0.0 else min(max(float((p - a) @ axis) / length2, 0.0), 1.0)
                point, v_point = a + u * axis, va + u * (vb - va)
                line = point - p  # body -> robot
                dist = float(np.linalg.norm(line))
                direction = line / dist
                v_h = float(w @ direction)  # the body towards the robot
                v_r = float(-v_point @ direction)  # the robot towards the body
                clearance = dist - capsules.radius[j] - radii[i]
                worst = min(worst, clearance - _plain_s(scenario, v_h, v_r, stop.time,
                                                       stop.distance))
    return worst


def _with_controller(scenario, name, **safety):
    config = load_controller_config(f"models/configs/{name}.yaml")
    config = dataclasses.replace(config, safety=dataclasses.replace(config.safety, **safety))
    return dataclasses.replace(scenario, controller=config)


@pytest.mark.parametrize("scenario", [
    INSPECTION,  # the seed's configuration: estimated speeds, the tool point
    _with_controller(INSPECTION, "iso", iso_reduced_human_speed=1.6),  # capsules, iso rule
    _with_controller(INSPECTION, "iso", human_speed="estimated_with_floor",
                     iso_human_speed=0.5),
], ids=["seed", "iso", "floor"])
def test_robustness_of_a_drake_run_equals_a_plain_loop(scenario):
    scenario = dataclasses.replace(scenario, duration=30.0)
    run = simulate(scenario)
    rho = robustness_of_run(run)
    assert math.isfinite(rho.separation)
    assert rho.separation == pytest.approx(_plain_loop(run), abs=1e-9)
    summary = summarize(run)
    assert summary["min_separation_margin"] == pytest.approx(rho.separation, abs=1e-12)
    t = summary["min_separation_margin_time"]
    assert 0.0 <= t <= scenario.duration


def test_the_seed_inspection_run_breaks_the_invariant_without_contact():
    # The seed's own experiment: no contact while moving, but the robot is let move with
    # an operator inside the S its own formula asks for (the estimated speeds lag).
    rho = robustness_of_run(simulate(INSPECTION))
    assert rho.stopped_before_contact > 0.0
    assert rho.separation < 0.0 and rho.separation_violation_time > 0.0
