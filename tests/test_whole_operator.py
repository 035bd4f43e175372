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
from safety_systems.config.scenario import Waypoint, load_controller_config
from safety_systems.outputs.metrics import robot_contact_state, robot_speed, true_pairs
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


def forearm_across_a_link(config):
    """An operator standing still from the start with the middle of the right forearm on
    the wrist (target_link 3, wrist 1) where the robot passes at mid-cycle, the hand
    beyond it (posture reach_past): the glove 0.18 m past the wrist, the forearm across."""
    scenario = make_scenario(SPACE, config, _point(posture=1.0, target_link=3.0,
                                                   target_along=0.5, target_phase=0.5,
                                                   overshoot=0.0, elevation_deg=0.0,
                                                   azimuth_deg=90.0), name="forearm_across")
    operator = scenario.operators[0]
    still = dataclasses.replace(operator, waypoints=[Waypoint(0.0, operator.waypoints[-1]
                                                               .position)])
    return dataclasses.replace(scenario, duration=12.0, operators=[still])


def elbow_first_push(config):
    """An elbow-first push at 2 m/s (posture elbow_first) at the upper arm from 3 m."""
    return make_scenario(SPACE, config, _point(posture=2.0, target_link=1.0,
                                               target_along=0.8, peak_speed=2.0,
                                               acceleration=10.0, start_distance=3.0,
                                               overshoot=0.3), name="elbow_push")


CASES = {"forearm_across_a_link": forearm_across_a_link, "elbow_first_push": elbow_first_push}


@pytest.mark.parametrize("config", sorted(CONFIGS))
@pytest.mark.parametrize("case", sorted(CASES))
def test_no_segment_meets_the_moving_robot(case, config):
    scenario = CASES[case](CONFIGS[config])
    drake, run = evaluate_drake(scenario)
    batch = evaluate_batch([scenario])
    # never moving with any segment of the operator touching a link (contact distance 0)
    assert drake.stopped_before_contact > 0.0
    assert abs(batch.robustness[0] - drake.stopped_before_contact) <= 1e-9
    assert abs(batch.separation[0] - drake.separation) <= 1e-9
    # the robot did move (the case tests something), and the arm did come to the robot:
    # while it was at rest, the forearm or the upper arm touched or nearly touched a link
    clearance = true_pairs(run)[0].min(axis=-1)  # (T, M)
    still = ~moving(robot_speed(robot_contact_state(run)[1]))
    assert (~still).any()
    arm = clearance[:, [FOREARM, UPPER_ARM]].min(axis=1)
    assert np.nanmin(arm[still]) < 0.25
    assert np.nanmin(arm[~still]) > 0.0


@pytest.mark.parametrize("case", sorted(CASES))
def test_the_arm_is_where_the_gloves_are_not(case):
    # What the three-ball model missed: at the closest the arm comes to a link while the
    # robot is at rest, the gloves and the head (balls of the old radii, 0.05 and 0.12 m)
    # are farther from every link than the forearm or the upper arm.
    scenario = CASES[case](CONFIGS["iso"])
    _, run = evaluate_drake(scenario)
    clearance = true_pairs(run)[0].min(axis=-1)
    arm = clearance[:, [FOREARM, UPPER_ARM]].min(axis=1)
    t = int(np.nanargmin(arm))
    seg = human_body.SEGMENT_NAMES
    hands = [clearance[t, seg.index(n)] + human_body.DEFAULT_DIMENSIONS["hand_radius"] - 0.05
             for n in ("hand_left", "hand_right")]
    head = clearance[t, seg.index("head")] + human_body.DEFAULT_DIMENSIONS["head_radius"] - 0.12
    assert min(hands + [head]) > arm[t] + 0.05, (hands, head, arm[t])


def test_the_cases_postures_are_the_bodies_the_model_allows():
    for k in (1, 2):
        points = np.array([posture_offsets(k)[q] for q in human_body.POINTS])
        assert human_body.posture_violations(points, human_body.dimensions()) == []
