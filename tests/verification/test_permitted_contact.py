"""Contact where ISO/TS 15066 allows it (safety.mode: ssm_pfl), in the Drake diagram: a
head approach never touches while the robot moves, a hand touched below its limit is
permitted and above it is a counterexample, a hand that can be pressed against a
declared surface keeps pure SSM; and the proofs' power and force limiting premises."""

import dataclasses

import numpy as np
import pytest

from safety_systems.cell.human_body import SEGMENT_NAMES
from safety_systems.config.configuration import pfl_terms
from safety_systems.config.scenario import Box, load_controller_config
from safety_systems.outputs.metrics import robot_contact_state, robot_speed, true_pairs
from safety_systems.ssm.true_measures import moving
from verification.proof.theorems import prove_permitted_contact
from verification.search.evaluate_drake import evaluate_drake
from verification.spaces.box import Range
from verification.spaces.space import free_parameters, load_space, make_scenario, to_point

REACH = load_space("tests/verification/data/pfl_reach.yaml")
DEFAULT = load_space("models/spaces/default.yaml")
HEAD, NECK, HAND = (SEGMENT_NAMES.index(n) for n in ("head", "neck", "hand_right"))


def _config(name, **safety):
    config = load_controller_config(f"models/configs/{name}.yaml")
    return dataclasses.replace(config, safety=dataclasses.replace(config.safety, **safety))


# The seed's estimated speeds on the whole robot, with power and force limiting: the robot
# runs on near a still hand and meets it at its cap.
SEED_PFL = _config("seed_estimated", mode="ssm_pfl", robot_geometry="capsules")


def _contacts(run):
    """(segment, relative speed) of every pair in contact while the robot moves."""
    clearance, _, v_r = true_pairs(run)
    speed = robot_speed(robot_contact_state(run)[1])
    touch = (np.nan_to_num(clearance, nan=np.inf) < 0.0) & moving(speed)[:, None, None]
    _, segment, _ = np.nonzero(touch)
    return segment % len(SEGMENT_NAMES), v_r[touch]


def test_a_hand_touched_below_its_limit_is_permitted():
    scenario = make_scenario(REACH, SEED_PFL, to_point(REACH, np.array([0.0])), name="below")
    drake, run = evaluate_drake(scenario)
    segment, v = _contacts(run)
    limits = pfl_terms(scenario.robot, scenario.controller).limits
    assert np.any(segment == HAND)  # the robot moved while touching the hand
    assert drake.stopped_before_contact < 0.0  # so SSM alone calls it a violation
    assert np.all(v[segment == HAND] <= limits[HAND])
    # the property's figure is the least limit - relative speed over the contacts (m/s)
    assert drake.permitted_contact == pytest.approx(np.min(limits[segment] - v))
    assert drake.permitted_contact >= 0.0


def test_a_hand_touched_above_its_limit_is_a_counterexample():
    # The tool sweeps at up to 1.4 m/s, faster than the hand may be met (about 1.25 m/s);
    # stopping data that claim a stop in 2 cm and brakes 2.7 times slower than that data
    # leave the robot above the hand's cap when the reach (over the target, the forearm
    # leading) meets it.
    wrong = _config("seed_estimated", mode="ssm_pfl", robot_geometry="capsules",
                    stopping_time=0.05, stopping_distance=0.02, d_min=0.0, delta_s=1.0)
    space = dataclasses.replace(REACH, parameters=dataclasses.replace(
        REACH.parameters, peak_speed=Range(1.254, 1.254), start_distance=Range(1.123, 1.123),
        acceleration=Range(6.974, 6.974), onset_phase=Range(0.876, 0.876),
        target_phase=Range(0.684, 0.684), posture=Range(1.0, 1.0),
        braking_time_scale=Range(2.687, 2.687)))
    scenario = make_scenario(space, wrong, to_point(space, np.zeros(0)), name="above")
    drake, run = evaluate_drake(scenario)
    segment, v = _contacts(run)
    limits = pfl_terms(scenario.robot, scenario.controller).limits
    assert np.isfinite(drake.permitted_contact) and drake.permitted_contact < 0.0
    assert drake.permitted_contact == pytest.approx(np.min(limits[segment] - v))
    assert np.all(~np.isin(segment, (HEAD, NECK)))  # a permitted region, too fast
    worst = segment[np.argmin(limits[segment] - v)]
    assert v[segment == worst].max() > limits[worst]


@pytest.mark.parametrize("start", [3.0, 3.5, 4.0])
def test_a_head_approach_never_touches_while_the_robot_moves(start):
    # The trunk leaning in, the head leading (posture 4), at the forearm and the tool
    # from beyond S, under ISO's speeds with power and force limiting and S by speed: the
    # robot may run on at the arms' caps, never into the head or the neck.
    config = _config("iso", mode="ssm_pfl", stopping="by_speed")
    point = dict(to_point(DEFAULT, np.full(len(free_parameters(DEFAULT)), 0.5)), posture=4.0,
                 start_distance=start, operators=1.0, occlusion=0.0, outlier_frames=0.0,
                 target_link=2.0 if start < 3.5 else 6.0, peak_speed=2.0)
    scenario = make_scenario(DEFAULT, config, point, name="head")
    drake, run = evaluate_drake(scenario)
    segment, _ = _contacts(run)
    assert not np.any(np.isin(segment, (HEAD, NECK)))
    assert drake.permitted_contact >= 0.0
    clearance, _, _ = true_pairs(run)
    speed = robot_speed(robot_contact_state(run)[1])
    head = np.nan_to_num(clearance[:, [HEAD, NECK]], nan=np.inf).min(axis=(1, 2))
    assert np.all(head[moving(speed)] > 0.0)
    assert np.isfinite(head[moving(speed)]).any()  # the robot moved while it was there


# A bench under the hand: its top 2 cm below the hand's ball (CLAMP_GAP is 5 cm), 9 cm
# below the tool's capsule.
BENCH = Box([0.3, -0.6, -0.2], [0.9, 0.6, 0.06])


def test_a_hand_that_can_be_pressed_against_a_declared_surface_keeps_pure_ssm():
    point = to_point(REACH, np.array([0.0]))
    free = make_scenario(REACH, SEED_PFL, point, name="free")
    _, run = evaluate_drake(free)
    assert np.any(_contacts(run)[0] == HAND)  # met at its cap, without the bench
    config = dataclasses.replace(SEED_PFL, safety=dataclasses.replace(
        SEED_PFL.safety, fixed_surfaces=[BENCH]))
    clamped = make_scenario(REACH, config, point, name="clamped")
    drake, run = evaluate_drake(clamped)
    assert not np.any(_contacts(run)[0] == HAND)  # never touched while the robot moves
    assert drake.permitted_contact >= 0.0
    assert np.all(run["override.segment_caps"][-1][[HAND]] == 0.0)


def test_the_proof_states_and_checks_the_power_and_force_limiting_premises():
    config = _config("iso", mode="ssm_pfl", stopping="by_speed")
    proof = prove_permitted_contact(config, DEFAULT)
    statements = [p.statement for p in proof.premises]
    assert any("c_i V_R <= v_i" in s for s in statements)
    assert any("Annex A" in s and p.basis == "trusted"
               for s, p in zip(statements, proof.premises))
    assert proof.property == "permitted_contact"
    # a declared surface with too little clamping margin: the premise fails, no proof
    tight = dataclasses.replace(config, safety=dataclasses.replace(
        config.safety, fixed_surfaces=[BENCH], clamp_margin=0.0))
    tight_proof = prove_permitted_contact(tight, DEFAULT)
    assert not tight_proof.proved
    assert any("clamping" in p.statement and not p.holds for p in tight_proof.premises)
    roomy = dataclasses.replace(tight, safety=dataclasses.replace(tight.safety,
                                                                  clamp_margin=2.0))
    assert prove_permitted_contact(roomy, DEFAULT).proved == proof.proved
