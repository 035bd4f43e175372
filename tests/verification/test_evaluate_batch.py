"""The batched evaluator agrees with the Drake diagram (the ground truth)."""

import dataclasses

import numpy as np
import pytest

from safety_systems.scenario import load_controller_config
from verification.evaluate_batch import evaluate_batch, evaluate_many
from verification.evaluate_drake import evaluate_drake
from verification.space import Range, free_parameters, load_space, make_scenario, to_point

TOLERANCE = 1e-9  # m: the two evaluators run the same maths in the same order
SPACE = load_space("models/spaces/default.yaml")
# Everything the evaluators model, varying at once.
WIDE = dataclasses.replace(SPACE, parameters=dataclasses.replace(
    SPACE.parameters, latency=Range(0.0, 0.03), dropout=Range(0.0, 0.15),
    occlusion=Range(0.0, 0.4), braking_time_scale=Range(1.0, 1.8),
    noise_std=Range(0.0, 0.005)))


def _config(name, **safety):
    config = load_controller_config(f"models/configs/{name}.yaml")
    return dataclasses.replace(config, safety=dataclasses.replace(config.safety, **safety))


@pytest.mark.parametrize("config", [
    _config("seed_estimated"),
    _config("iso"),
    _config("iso", human_speed="estimated_with_floor", human_uncertainty_sigmas=2.0),
], ids=["estimated", "iso", "floor_with_sigmas"])
def test_batch_agrees_with_drake_on_random_scenarios(config):
    rng = np.random.default_rng(20261122)
    d = len(free_parameters(WIDE))
    points = [to_point(WIDE, rng.uniform(size=d)) for _ in range(2)]
    scenarios = [make_scenario(WIDE, config, p, name=f"s{i}") for i, p in enumerate(points)]
    batch = evaluate_many(scenarios)
    assert np.isfinite(batch.robustness).any()  # the robot moved near someone
    for i, scenario in enumerate(scenarios):
        drake, _ = evaluate_drake(scenario)
        if np.isinf(drake.stopped_before_contact):  # never moving near a body
            assert batch.robustness[i] == drake.stopped_before_contact
        else:
            assert abs(drake.stopped_before_contact - batch.robustness[i]) <= TOLERANCE
        assert drake.protective_violation_time == pytest.approx(
            batch.protective_violation_time[i], abs=1e-9)
        assert drake.protective_deepest_intrusion == pytest.approx(
            batch.protective_deepest_intrusion[i], abs=TOLERANCE)


def test_batch_order_and_grouping_do_not_change_results():
    config = _config("seed_estimated")
    rng = np.random.default_rng(5)
    d = len(free_parameters(SPACE))
    scenarios = [make_scenario(SPACE, config, to_point(SPACE, rng.uniform(size=d)))
                 for _ in range(16)]  # 1 or 2 operators: two shapes, two batches
    together = np.stack(dataclasses.astuple(evaluate_many(scenarios)))
    # Alone, a scenario shares its robot's state with no other (see _advance): the same
    # figures bit for bit.
    alone = np.stack([dataclasses.astuple(evaluate_many([s])) for s in scenarios], axis=1)
    np.testing.assert_array_equal(together, alone[..., 0])
    reversed_ = np.stack(dataclasses.astuple(evaluate_many(scenarios[::-1])))[:, ::-1]
    np.testing.assert_array_equal(together, reversed_)


def test_batch_rejects_mixed_shapes():
    config = _config("seed_estimated")
    one = make_scenario(SPACE, config, dict(to_point(SPACE, np.full(14, 0.5)), operators=1.0))
    two = make_scenario(SPACE, config, dict(to_point(SPACE, np.full(14, 0.5)), operators=2.0))
    with pytest.raises(ValueError, match="operator shape"):
        evaluate_batch([one, two])


def test_unit_noise_table_is_the_sensors_draws_kept_and_grown():
    from safety_systems.systems.mocap_sensor import unit_noise
    from verification.evaluate_batch import unit_noise_table

    short = unit_noise_table(12345, 3, 4).copy()
    longer = unit_noise_table(12345, 3, 9)  # the kept table, grown
    assert longer.shape == (9, 3, 3)
    np.testing.assert_array_equal(longer[:4], short)
    for k in (0, 3, 8):
        np.testing.assert_array_equal(longer[k].ravel(), unit_noise(12345, k, 3))
    assert unit_noise_table(12345, 3, 2).shape[0] >= 2  # a shorter need reuses it
