"""The whole operator in the loop (issue 31's "must show"): an operator standing still with
a forearm across a link, and an elbow-first push at 2 m/s, never let the robot move
while any segment of the operator is within contact of it, under iso.yaml and the tuned
configuration, in the Drake diagram and in the batched evaluator, which agree; and the
three-ball monitor (gloves and head as balls) would have let the robot into them."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from safety_systems.cell import human_body
from safety_systems.cell.joint_path import joint_path_state
from safety_systems.cell.robot_geometry import capsule_ends
from safety_systems.config.configuration import contact_capsules, joint_path
from safety_systems.config.scenario import load_controller_config, operator_posture
from safety_systems.outputs.metrics import robot_contact_state, robot_speed, true_pairs
from safety_systems.ssm.separation import pair_figures
from safety_systems.ssm.true_measures import moving
from verification.search.evaluate_batch import evaluate_batch
from verification.search.evaluate_drake import evaluate_drake
from verification.spaces.space import (
    free_parameters,
    load_space,
    make_scenario,
    posture_offsets,
    to_point,
)

MODELS = Path(__file__).resolve().parents[1] / "models"
SPACE = load_space(MODELS / "spaces" / "default.yaml")
CONFIGS = {name: load_controller_config(MODELS / "configs" / f"{name}.yaml")
           for name in ("iso", "tuned")}
FOREARM = human_body.SEGMENT_NAMES.index("forearm_right")
UPPER_ARM = human_body.SEGMENT_NAMES.index("upper_arm_right")


def _point(**values):
    base = to_point(SPACE, np.full(len(free_parameters(SPACE)), 0.5))
    return base | dict(operators=1.0, outlier_frames=0.0, occlusion=0.0, dropout=0.0,
                       latency=0.0, noise_std=0.0002, braking_time_scale=1.0,
                       retreat_distance=0.0) | values


def _stay(scenario, seconds):
    """The scenario run ``seconds`` longer, the operators staying where they arrived."""
    duration = scenario.duration + seconds
    robot = dataclasses.replace(scenario.robot, cycles=scenario.robot.cycles + int(seconds) + 1)
    return dataclasses.replace(scenario, duration=duration, robot=robot)


def forearm_across_a_link(config):
    """An operator walking in at 0.5 m/s from 4 m and then standing still with the middle
    of the right forearm on the last wrist (target_link 5, wrist 3: vertical) where the
    robot passes at mid-cycle, the hand 0.18 m beyond it (posture reach_past: the
    forearm across the link, from the side: square to the arm's plane), for 10 s
    more."""
    return _stay(make_scenario(SPACE, config, _point(
        posture=1.0, target_link=5.0, target_along=0.5, target_phase=0.5, overshoot=0.0,
        elevation_deg=0.0, azimuth_deg=-36.0, start_distance=4.0, peak_speed=0.5,
        acceleration=1.0), name="forearm_across"), 10.0)


def elbow_first_push(config):
    """An elbow-first push at 2 m/s (posture elbow_first) at the upper arm, where the
    robot's upper arm is at mid-cycle, from 4 m, the elbow on 0.1 m past its axis."""
    return make_scenario(SPACE, config, _point(posture=2.0, target_link=1.0,
                                               target_along=0.8, target_phase=0.5,
                                               peak_speed=2.0, acceleration=10.0,
                                               start_distance=4.0, overshoot=0.1),
                         name="elbow_push")


CASES = {"forearm_across_a_link": forearm_across_a_link, "elbow_first_push": elbow_first_push}


@pytest.mark.parametrize("config", sorted(CONFIGS))
@pytest.mark.parametrize("case", sorted(CASES))
def test_no_segment_meets_the_moving_robot(case, config):
    scenario = CASES[case](CONFIGS[config])
    drake, run = evaluate_drake(scenario)
    batch = evaluate_batch([scenario])
    # never moving with any segment of the operator touching a link (contact distance 0)
    assert drake.stopped_before_contact > 0.0
    for ours, theirs in ((batch.robustness[0], drake.stopped_before_contact),
                         (batch.separation[0], drake.separation)):
        assert ours == theirs or abs(ours - theirs) <= 1e-9
    # the robot did move (the case tests something), never with the arm touching it;
    # where the robot would have gone on, the arm lies inside its links
    # (test_the_arm_is_where_the_gloves_are_not)
    clearance = true_pairs(run)[0].min(axis=-1)  # (T, M)
    still = ~moving(robot_speed(robot_contact_state(run)[1]))
    assert (~still).any()
    arm = clearance[:, [FOREARM, UPPER_ARM]].min(axis=1)
    assert np.nanmin(arm[~still]) > 0.0


@pytest.mark.parametrize("case", sorted(CASES))
def test_the_arm_is_where_the_gloves_are_not(case):
    # What the three-ball model missed: with the robot where the approach aims (the target
    # phase) and the operator where it ends, the arm lies inside a link while the gloves
    # and the head (balls of the old radii, 0.05 and 0.12 m) are clear of every link.
    scenario = CASES[case](CONFIGS["iso"])
    values = dict(scenario.operators[0].waypoints[-1].__dict__)
    phase = {"forearm_across_a_link": 0.5, "elbow_first_push": 0.5}[case]
    path = joint_path(scenario.robot)
    q = joint_path_state(path, phase * path.cycle_time)[0]
    capsules = contact_capsules(scenario.robot, scenario.contact_geometry)
    ends, end_v = capsule_ends(q, capsules, np.zeros(6))
    where = np.array(values["position"]) + operator_posture(scenario.operators[0])
    seg = human_body.SEGMENTS
    h_ends = np.array([[where[human_body.point_index(a)], where[human_body.point_index(b)]]
                       for _, a, b, _ in seg])
    radii = np.array([human_body.DEFAULT_DIMENSIONS[r] for *_, r in seg])
    clearance = pair_figures(ends, end_v, capsules.radius, h_ends, np.zeros_like(h_ends),
                             radii)[0].min(axis=-1)
    names = human_body.SEGMENT_NAMES
    arm = min(clearance[names.index(n)] for n in ("forearm_right", "upper_arm_right"))
    old = {"hand_left": 0.05, "hand_right": 0.05, "head": 0.12}
    balls = [clearance[names.index(n)] + human_body.DEFAULT_DIMENSIONS[
        "hand_radius" if n.startswith("hand") else "head_radius"] - r for n, r in old.items()]
    assert arm < 0.0 < min(balls), (arm, balls)


def test_the_cases_postures_are_the_bodies_the_model_allows():
    for k in (1, 2):
        points = np.array([posture_offsets(k)[q] for q in human_body.POINTS])
        assert human_body.posture_violations(points, human_body.dimensions()) == []
