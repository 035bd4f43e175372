"""Levers (``verification.tune.levers``): a sensing choice fitted to the proofs, and the
tasks worn with its sensor set."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from safety_systems.cell.braking import default_braking_table
from safety_systems.cell.human_body import POINTS
from safety_systems.cell.sensor_sets import SENSOR_SETS, points_of
from safety_systems.config.scenario import (
    BrakingConfig,
    actual_sensor,
    load_controller_config,
    load_scenario,
    operator_posture,
)
from safety_systems.files.input_error import InputError
from verification.spaces.space import load_space, space_cell
from verification.tune.levers import (
    Lever,
    check_levers,
    fit,
    lever_space,
    sensed,
    stopped,
    under,
    wearing,
)
from verification.tune.tunable import check_block, load_levers, load_tunable
from verification.tune.tuner import proofs_of

MODELS = Path(__file__).parents[3] / "models"
TUNED = MODELS / "configs" / "tuned.yaml"


def test_a_sensor_set_names_body_points_and_an_unknown_one_is_refused():
    for name, points in SENSOR_SETS.items():
        assert set(points) <= set(POINTS) and {"hand_left", "hand_right"} <= set(points), name
    with pytest.raises(KeyError, match="gloves\\+helmet"):
        points_of("helmet only")


def test_an_operator_wears_the_set_at_its_own_posture_and_keeps_its_gloves():
    task = load_scenario(MODELS / "scenarios" / "inspection_seed.yaml")
    worn = wearing(task, Lever("gloves+helmet+belt", 120.0, 0.005))
    before, after = task.operators[0], worn.operators[0]
    assert after.bodies[:len(before.bodies)] == before.bodies  # the gloves as written
    added = {b.point: b for b in after.bodies[len(before.bodies):]}
    assert set(added) == {"head", "pelvis"}
    truth = dict(zip(POINTS, operator_posture(before)))
    for point, body in added.items():
        np.testing.assert_allclose(body.offset, truth[point])
    # the posture the operator takes is the same: the bodies only mark it
    np.testing.assert_allclose(operator_posture(after), operator_posture(before))
    sensor = actual_sensor(worn)
    assert (sensor.rate_hz, sensor.latency) == (120.0, 0.005)
    assert sensor.noise_std == actual_sensor(task).noise_std


def test_faster_sensing_shortens_the_frame_timeout_and_reaction_by_the_same_seconds():
    config = load_controller_config(TUNED)
    out = sensed(config, Lever("gloves", 120.0, 0.02), 0.002)
    # tuned.yaml: 0.074 s at 20 Hz, 20 ms, 1 ms processing: 3 ms above its sensor's due
    assert out.tracker.frame_timeout == pytest.approx(1 / 120 + 0.02 + 0.001 + 0.003)
    gained = config.tracker.frame_timeout - out.tracker.frame_timeout
    assert out.safety.reaction_time == pytest.approx(config.safety.reaction_time - gained)
    assert out.safety.reaction_time >= out.tracker.frame_timeout + 0.002 - 1e-12
    assert (out.sensor.rate_hz, out.sensor.latency) == (120.0, 0.02)


def test_the_fitted_allowance_is_the_least_the_proofs_allow():
    config = load_controller_config(TUNED)
    space = load_space(MODELS / "spaces" / "default.yaml")
    lever = Lever("gloves+helmet", 120.0, 0.02)
    fitted = fit(config, lever, space)
    assert fitted.proved
    z_r = fitted.config.safety.robot_uncertainty
    assert 0.0 < z_r < config.safety.robot_uncertainty  # faster sensing needs less
    box = lever_space(space, lever)
    assert box.tracked == list(points_of("gloves+helmet"))
    assert box.parameters.latency.max == 0.02
    less = dataclasses.replace(fitted.config, safety=dataclasses.replace(
        fitted.config.safety, robot_uncertainty=z_r - 1e-4))
    proofs = proofs_of(space_cell(less, box), box)
    assert not proofs["separation"].proved  # 0.1 mm less and the invariant's proof fails


def test_slower_sensing_than_the_configuration_asks_for_more_allowance():
    """A lever worse than the configuration's own sensing (a longer latency) raises Z_r to
    what the proofs need, or leaves the row unproved: never a proved row on less."""
    config = load_controller_config(TUNED)
    space = load_space(MODELS / "spaces" / "default.yaml")
    fitted = fit(config, Lever("gloves", 20.0, 0.04), space)
    assert fitted.config.safety.robot_uncertainty > config.safety.robot_uncertainty
    assert fitted.proved == all(p.proved for p in fitted.proofs.values())


def test_a_tune_under_a_lever_searches_the_same_headroom_above_the_faster_loop():
    config, block = load_tunable(MODELS / "configs" / "iso.yaml", MODELS / "tune" / "ssm.yaml")
    lever = Lever("full suit", 240.0, 0.005)
    moved_config, moved = under(config, block, lever)
    assert (moved_config.sensor.rate_hz, moved_config.sensor.latency) == (240.0, 0.005)
    gain = (1 / 20 + 0.02) - (1 / 240 + 0.005)  # iso.yaml: 20 Hz, 20 ms
    for before, after in zip(block, moved):
        if before.name in ("tracker.frame_timeout", "safety.reaction_time"):
            assert after.min == pytest.approx(before.min - gain)
            assert after.max == pytest.approx(before.max - gain)
        else:
            assert after == before
    # the block stays one tune accepts: T_r's least above the faster loop's own reaction
    check_block(moved, moved_config, control_period=0.002)


def _scaled_placeholder(scale: float) -> BrakingConfig:
    table = default_braking_table()
    return BrakingConfig(speed_fraction=[float(x) for x in table.speed_fraction],
                         stopping_time=[float(x) * scale for x in table.stopping_time],
                         stopping_distance=[float(x) * scale for x in table.stopping_distance])


def test_stopping_data_as_a_lever_scales_the_configurations_stop_and_is_proved():
    """A lever's stopping data (rows by speed): its rows replace the table, and T_s and B (the
    configuration's stop on its path) scale by its full-speed stop against the table's; the
    proofs then run on it (the simulated robot brakes by it too)."""
    config = load_controller_config(TUNED)
    lever = Lever("gloves+helmet+belt+elbows", 120.0, 0.005, braking=_scaled_placeholder(0.7),
                  stopping_name="0.7 x the placeholder")
    assert lever.label.endswith(", stopping data 0.7 x the placeholder")
    out = stopped(config, lever)
    assert out.braking == lever.braking
    assert out.safety.stopping_time == pytest.approx(0.7 * config.safety.stopping_time)
    assert out.safety.stopping_distance == pytest.approx(0.7 * config.safety.stopping_distance)
    assert stopped(config, Lever("gloves")) is config  # none given: the configuration's
    fitted = fit(config, lever, load_space(MODELS / "spaces" / "default.yaml"))
    assert fitted.proved and fitted.config.braking == lever.braking


def test_a_levers_stopping_data_is_checked_as_a_configurations(tmp_path):
    bad = BrakingConfig(speed_fraction=[0.5, 0.9], stopping_time=[0.2, 0.4],
                        stopping_distance=[0.1, 0.2])
    with pytest.raises(InputError, match=r"levers\[1\]\.braking\.speed_fraction"):
        check_levers([Lever("gloves"), Lever("gloves", braking=bad)])
    block = tmp_path / "tune.yaml"
    block.write_text("tune:\n- {name: safety.d_min, min: 0.1, max: 0.2}\nlevers:\n"
                     "- {sensor_set: gloves, braking: {speed_fraction: [0.5, 0.9], "
                     "stopping_time: [0.2, 0.4], stopping_distance: [0.1, 0.2]}}\n")
    with pytest.raises(InputError, match=r"levers\[0\]\.braking\.speed_fraction") as e:
        load_levers(block)
    assert str(block) in str(e.value)


def test_a_lever_may_give_the_stop_its_rows_imply_and_needs_rows_to_give_it():
    """T_s and B given with a lever's rows (a path's stops, a cell's measured full-speed
    stop) are taken as given, not scaled from the configuration's; without rows they are
    refused in one line naming the lever's field."""
    config = load_controller_config(TUNED)
    lever = Lever("gloves", braking=_scaled_placeholder(0.3), stopping_time=0.17,
                  stopping_distance=0.09)
    out = stopped(config, lever)
    assert (out.safety.stopping_time, out.safety.stopping_distance) == (0.17, 0.09)
    assert out.braking == lever.braking
    with pytest.raises(InputError, match=r"levers\[0\]\.stopping_distance"):
        check_levers([Lever("gloves", stopping_distance=0.09)])
