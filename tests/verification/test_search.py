import dataclasses

import numpy as np
import pytest

import verification.runner as runner_module
from safety_systems.scenario import load_controller_config
from verification.runner import Runner
from verification.search import SWEEPS, danger_scores, falsify, sweep, sweep_points
from verification.space import free_parameters, load_space

SPACE = load_space("models/spaces/default.yaml")
SEED_CONFIG = load_controller_config("models/configs/seed_estimated.yaml")
D = len(free_parameters(SPACE))


@pytest.mark.parametrize("method", SWEEPS)
def test_sweep_points_fill_the_unit_cube(method):
    points = sweep_points(method, 64, 3, seed=1)
    assert points.ndim == 2 and points.shape[1] == 3
    assert np.all((points >= 0.0) & (points <= 1.0))
    expected = {"grid": 64, "corners": 8}.get(method, 64)
    assert len(points) == expected
    assert len(np.unique(points.round(12), axis=0)) == expected
    if method in ("sobol", "halton", "uniform"):
        np.testing.assert_array_equal(points, sweep_points(method, 64, 3, seed=1))
        assert not np.array_equal(points, sweep_points(method, 64, 3, seed=2))


def test_grid_is_at_least_two_per_axis_and_bad_method_rejected():
    assert len(sweep_points("grid", 10, 3)) == 8  # 2^3: largest full grid <= 10
    with pytest.raises(ValueError, match="method"):
        sweep_points("random", 10, 3)


def test_danger_score_orders_a_lunge_into_the_path_before_a_hand_far_away():
    # Same approach; one from far with a slow walk, one a fast lunge from close by.
    far = np.full(D, 0.5)
    lunge = far.copy()
    names = free_parameters(SPACE)
    far[names.index("start_distance")], lunge[names.index("start_distance")] = 1.0, 0.0
    far[names.index("peak_speed")], lunge[names.index("peak_speed")] = 0.0, 1.0
    far[names.index("overshoot")], lunge[names.index("overshoot")] = 0.0, 1.0
    scores = danger_scores(SPACE, SEED_CONFIG, np.array([far, lunge]))
    assert scores[1] < scores[0]


@pytest.mark.parametrize("name", ["seed", "tracks_expire"])
def test_danger_scores_order_candidates_as_the_closed_loop_does(name):
    # The ranking is a reduced model: it must order candidates as the closed loop does,
    # or the search spends its budget on safe ones. "tracks_expire" is the case where every
    # track of an operator ends: the reduced model once stopped the robot there (Eq. 12 of
    # an infinite distance) where the loop runs it at full speed, ranking every
    # counterexample last.
    from scipy.stats import spearmanr

    from verification.evaluate_batch import evaluate_many
    from verification.space import make_scenario, to_point

    iso = load_controller_config("models/configs/iso.yaml")  # its contact terms alone:
    iso = dataclasses.replace(iso, safety=dataclasses.replace(iso.safety,
                                                              robot_uncertainty=0.0))
    config = {"seed": SEED_CONFIG, "tracks_expire": dataclasses.replace(
        iso, tracker=dataclasses.replace(iso.tracker, hidden_bodies="expire",
                                         max_coast_time=0.5, exit_radius=1e-6))}[name]
    points = sweep_points("sobol", 256, D, seed=7)
    rho = evaluate_many([make_scenario(SPACE, config, to_point(SPACE, u)) for u in points]
                        ).robustness
    scores = danger_scores(SPACE, config, points)
    finite = np.isfinite(rho)
    assert finite.sum() > 100 and (rho < 0).sum() >= 3
    assert spearmanr(scores[finite], rho[finite]).correlation > 0.8
    # Of the n best-ranked candidates (n: the violations among them all), most violate.
    best = np.argsort(scores, kind="stable")[:int((rho < 0).sum())]
    assert np.mean(rho[best] < 0.0) >= 0.8


def test_danger_scores_split_over_workers_are_the_same():
    points = sweep_points("sobol", 512, D, seed=3)
    with Runner(workers=2) as runner:  # two parts of 256, each run to the common horizon
        split = danger_scores(SPACE, SEED_CONFIG, points, runner=runner)
    np.testing.assert_array_equal(split, danger_scores(SPACE, SEED_CONFIG, points))


@pytest.fixture(scope="module")
def seed_search():
    with Runner(workers=1) as runner:
        return falsify(SPACE, SEED_CONFIG, runner, budget=40, seed=1, stop_at_first=True)


def test_falsifies_the_seed_configuration(seed_search):
    first = seed_search.first_violation()
    assert first is not None and seed_search.robustness[first - 1] < 0.0
    assert np.all(seed_search.robustness[:first - 1] >= 0.0)


def test_search_is_deterministic_for_a_seed(seed_search):
    with Runner(workers=2) as runner:  # other processes, same answers
        again = falsify(SPACE, SEED_CONFIG, runner, budget=40, seed=1, stop_at_first=True)
    np.testing.assert_array_equal(np.array(again.points), np.array(seed_search.points))
    np.testing.assert_array_equal(again.robustness, seed_search.robustness)


def test_interrupted_sweep_resumes_without_repeating_work(tmp_path, monkeypatch):
    cache = tmp_path / "evaluations.jsonl"
    calls = []
    real = runner_module._evaluate_chunk

    def counting(chunk):
        calls.append(len(chunk))
        if len(calls) == 2:
            raise KeyboardInterrupt  # the machine goes down during the second chunk
        return real(chunk)

    monkeypatch.setattr(runner_module, "_evaluate_chunk", counting)
    with pytest.raises(KeyboardInterrupt):
        with Runner(workers=1, chunk=4, cache_path=cache) as runner:
            sweep(SPACE, SEED_CONFIG, runner, method="sobol", budget=8, seed=0)
    assert len(cache.read_text().splitlines()) == 4
    calls.clear()
    with Runner(workers=1, chunk=4, cache_path=cache) as runner:
        resumed = sweep(SPACE, SEED_CONFIG, runner, method="sobol", budget=8, seed=0)
    assert calls == [4]  # only the unfinished chunk ran
    calls.clear()
    with Runner(workers=1, chunk=4, cache_path=cache) as runner:
        again = sweep(SPACE, SEED_CONFIG, runner, method="sobol", budget=8, seed=0)
    assert calls == []
    np.testing.assert_array_equal(again.robustness, resumed.robustness)
    monkeypatch.setattr(runner_module, "_evaluate_chunk", real)
    with Runner(workers=1) as runner:
        fresh = sweep(SPACE, SEED_CONFIG, runner, method="sobol", budget=8, seed=0)
    np.testing.assert_array_equal(fresh.robustness, resumed.robustness)

