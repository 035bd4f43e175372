"""The separation invariant (issue: distance never below S while motion is permitted)."""

import dataclasses
import math

import numpy as np
import pytest

from safety_systems.cell import human_body
from safety_systems.config.configuration import contact_capsules
from safety_systems.outputs.metrics import command_signal, robot_stopping, summarize
from safety_systems.cell.robot_geometry import capsule_ends
from safety_systems.config.scenario import (
    Body,
    load_controller_config,
    load_scenario,
    operator_posture,
)
from safety_systems.diagrams.simulation import simulate
from verification.search.evaluate_drake import robustness_of_run
from verification.proof.theorems import prove, prove_separation
from verification.report import write_report
from verification.spaces.box import Range
from verification.spaces.space import load_space, space_cell
from verification.verify import verify

INSPECTION = load_scenario("models/scenarios/inspection_seed.yaml")


def _suited(scenario):
    """The scenario with every operator tracked at all ten body points (a motion-capture
    suit: the monitor's envelopes are the segments, plus the tracking allowance), its
    posture unchanged."""
    operators = []
    for o in scenario.operators:
        posture = operator_posture(o)
        marked = {b.point or b.name for b in o.bodies} | {"hand_right", "hand_left"}
        extra = [Body(name=q, point=q, offset=posture[human_body.point_index(q)].tolist())
                 for q in human_body.POINTS if q not in marked]
        operators.append(dataclasses.replace(o, bodies=list(o.bodies) + extra))
    return dataclasses.replace(scenario, operators=operators)


SUITED = _suited(INSPECTION)


def _plain_s(scenario, v_h, v_r, t_stop, b_stop):
    """Seed Eqs. 9-11 on the truth, written out (no Z_d, Z_r; see
    safety_systems.outputs.metrics)."""
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


def _nearest(P, Q, A, B):
    """(s, t) of the nearest points P + s (Q - P), A + t (B - A), by enumeration: the
    interior stationary point of the squared distance if it lies in the unit square, and
    each edge's clamped one-dimensional minimum; the least of them."""
    d1, d2, r = Q - P, B - A, P - A

    def gap(s, t):
        return float(np.linalg.norm(A + t * d2 - P - s * d1))

    def clamp(x):
        return min(max(x, 0.0), 1.0)

    a, e = float(d1 @ d1), float(d2 @ d2)
    options = []
    for s in (0.0, 1.0):
        t = 0.0 if e == 0.0 else clamp(float((P + s * d1 - A) @ d2) / e)
        options.append((gap(s, t), s, t))
    for t in (0.0, 1.0):
        s = 0.0 if a == 0.0 else clamp(float((A + t * d2 - P) @ d1) / a)
        options.append((gap(s, t), s, t))
    m = np.array([[a, -float(d1 @ d2)], [-float(d1 @ d2), e]])
    if abs(np.linalg.det(m)) > 1e-12 * max(a * e, 1e-300):
        s, t = np.linalg.solve(m, [-float(d1 @ r), float(d2 @ r)])
        if 0.0 <= s <= 1.0 and 0.0 <= t <= 1.0:
            options.append((gap(s, t), s, t))
    return min(options)[1:]


def _plain_loop(run):
    """The invariant's robustness by a loop over ticks, segments and capsules on the
    logged signals: each scripted operator's true segment between its two true points
    (``human_body.SEGMENTS``; radii the table's, 0 on the tool point), the nearest pair of
    axis points by enumeration, the human speed its faster end's along the line."""
    scenario = run.scenario
    capsules = contact_capsules(scenario.robot, scenario.contact_geometry)
    ends, velocities = capsule_ends(run["q"], capsules, run["v"])
    n = human_body.NUM_POINTS
    points = run["operators.points_true"].reshape(len(run.time), -1, 3)
    point_v = run["operators.point_velocities_true"].reshape(len(run.time), -1, 3)
    present = run["operators.operators_present"]
    command = run[command_signal(scenario.controller.type)][:, 0]
    table = human_body.DEFAULT_DIMENSIONS
    tool_point = scenario.contact_geometry == "tool_point"
    stop = robot_stopping(scenario)
    worst = math.inf
    for t in range(len(run.time)):
        if command[t] == 0.0:
            continue
        for k in range(present.shape[1]):
            if present[t, k] < 0.5:
                continue
            for _, a_name, b_name, r_name in human_body.SEGMENTS:
                ia = n * k + human_body.point_index(a_name)
                ib = n * k + human_body.point_index(b_name)
                P, Q, vP, vQ = points[t, ia], points[t, ib], point_v[t, ia], point_v[t, ib]
                r_seg = 0.0 if tool_point else table[r_name]
                for j in range(len(capsules.radius)):
                    a, b = ends[t, j]
                    va, vb = velocities[t, j]
                    s, u = _nearest(P, Q, a, b)
                    point, v_point = a + u * (b - a), va + u * (vb - va)
                    line = point - (P + s * (Q - P))  # segment -> robot
                    dist = float(np.linalg.norm(line))
                    direction = line / dist
                    v_h = max(float(vP @ direction), float(vQ @ direction))  # towards it
                    v_r = float(-v_point @ direction)  # the robot towards the segment
                    clearance = dist - capsules.radius[j] - r_seg
                    worst = min(worst, clearance - _plain_s(scenario, v_h, v_r, stop.time,
                                                           stop.distance))
    return worst


def _with_controller(scenario, name, **safety):
    config = load_controller_config(f"models/configs/{name}.yaml")
    config = dataclasses.replace(config, safety=dataclasses.replace(config.safety, **safety))
    return dataclasses.replace(scenario, controller=config)


@pytest.mark.parametrize("scenario", [
    INSPECTION,  # the seed's configuration: estimated speeds, the tool point
    _with_controller(SUITED, "iso", iso_reduced_human_speed=1.6),  # capsules, iso rule
    _with_controller(SUITED, "iso", human_speed="estimated_with_floor",
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
    # The seed's own experiment with the technician in a suit: no contact while moving,
    # but the robot is let move with an operator inside the S its own formula asks for
    # (the estimated speeds lag). With the seed's two gloves only, the envelopes of the
    # untracked body keep the robot far enough that the same run holds the invariant.
    rho = robustness_of_run(simulate(SUITED))
    assert rho.stopped_before_contact > 0.0
    assert rho.separation < 0.0 and rho.separation_violation_time > 0.0
    gloves = robustness_of_run(simulate(INSPECTION))
    assert gloves.stopped_before_contact > 0.0 and gloves.separation > 0.0


# --- verify: the three outcomes the separation invariant exists for -------------------

DEFAULT = load_space("models/spaces/default.yaml")
ISO = load_controller_config("models/configs/iso.yaml")
SEED = load_controller_config("models/configs/seed_estimated.yaml")


def _run_verify(config, space, out, properties="both", budget=40, stop_at_first=False):
    return verify(config, space, out, budget=budget, workers=1, seed=0, candidates=2048,
                  properties=properties, stop_at_first=stop_at_first)


def test_the_seed_configuration_breaks_the_invariant_on_the_default_space(tmp_path):
    outcome = _run_verify(SEED, DEFAULT, tmp_path, properties="separation", stop_at_first=True)
    separation = outcome.properties["separation"]
    assert outcome.verdict == separation.verdict == "falsified"
    worst = separation.counterexamples[0]
    assert worst["drake_robustness"] < 0.0 and worst["robustness"] < 0.0
    # It replays in the Drake diagram, and says whether the same scenario makes contact
    # (up to where the confirming run stopped, a quarter second after the violation).
    rho = robustness_of_run(simulate(load_scenario(worst["scenario"])))
    if worst["drake_stopped_at"] is None:
        assert rho.separation == pytest.approx(worst["drake_robustness"], abs=1e-12)
        assert worst["drake"]["stopped_before_contact"] == rho.stopped_before_contact
    else:  # the whole run is at least as bad as its start
        assert rho.separation <= worst["drake_robustness"] + 1e-12
        assert rho.stopped_before_contact <= worst["drake"]["stopped_before_contact"] + 1e-12
    report = write_report(outcome, tmp_path, config_path="seed", space_path="default",
                          replay=False)
    assert "stopped before contact" in (tmp_path / "report.md").read_text().split(
        "### Counterexamples")[1]
    assert report["properties"]["separation"]["verdict"] == "falsified"


def test_iso_is_proved_for_both_properties_and_needs_its_allowance():
    assert prove(space_cell(ISO, DEFAULT), DEFAULT).proved
    proof = prove_separation(space_cell(ISO, DEFAULT), DEFAULT)
    assert proof.proved and proof.needed_allowance == 0.0
    # Without the Z_r its file explains, the proof says how much is missing, and exactly
    # that much more proves it.
    bare = dataclasses.replace(ISO, safety=dataclasses.replace(ISO.safety,
                                                               robot_uncertainty=0.0))
    short = prove_separation(space_cell(bare, DEFAULT), DEFAULT)
    assert not short.proved and 0.5 < short.needed_allowance < ISO.safety.robot_uncertainty
    enough = dataclasses.replace(bare, safety=dataclasses.replace(
        bare.safety, robot_uncertainty=short.needed_allowance + 1e-9))
    assert prove_separation(space_cell(enough, DEFAULT), DEFAULT).proved
    slightly_less = dataclasses.replace(bare, safety=dataclasses.replace(
        bare.safety, robot_uncertainty=short.needed_allowance - 1e-6))
    assert not prove_separation(space_cell(slightly_less, DEFAULT), DEFAULT).proved


def test_a_sensing_lag_beyond_what_t_r_covers_avoids_contact_but_breaks_the_invariant(
        tmp_path):
    # Frames 0.25-0.3 s late where iso.yaml assumes 0.02 s, and a frame timeout (0.4 s)
    # that lets the late frames through: contact is still proved (the proof counts the
    # 0.4 s and iso.yaml's margins cover it), but the robot is let move with bodies inside
    # the S their true speeds ask for, because it sees them where they were.
    # (operators in suits: with gloves and a helmet only, the envelopes' width hides it)
    space = dataclasses.replace(DEFAULT, tracked=list(human_body.POINTS),
                                parameters=dataclasses.replace(DEFAULT.parameters,
                                                               latency=Range(0.25, 0.3)))
    mutant = dataclasses.replace(ISO, tracker=dataclasses.replace(ISO.tracker,
                                                                  frame_timeout=0.4))
    outcome = _run_verify(mutant, space, tmp_path, budget=60)
    contact, separation = outcome.properties["contact"], outcome.properties["separation"]
    assert contact.verdict == "proved" and not contact.counterexamples
    assert outcome.log.robustness.min() > 0.0
    assert separation.verdict == "falsified" and outcome.verdict == "falsified"
    for c in separation.counterexamples:
        assert c["drake_robustness"] < 0.0 and c["drake"]["stopped_before_contact"] > 0.0
    assert not prove_separation(space_cell(mutant, space), space).proved
