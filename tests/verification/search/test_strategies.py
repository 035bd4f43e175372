
import numpy as np
import pytest

import verification.search.runner as runner_module
from safety_systems.config.scenario import load_controller_config
from verification.search.runner import Runner
from verification.search.strategies import SWEEPS, falsify, sweep, sweep_points
from verification.spaces.space import free_parameters, load_space, space_cell

SPACE = load_space("models/spaces/default.yaml")
SEED_CONFIG = load_controller_config("models/configs/seed_estimated.yaml")
SEED_CELL = space_cell(SEED_CONFIG, SPACE)
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


@pytest.fixture(scope="module")
def seed_search():
    with Runner(workers=1) as runner:
        return falsify(SPACE, SEED_CELL, runner, budget=40, seed=1, stop_at_first=True)


def test_falsifies_the_seed_configuration(seed_search):
    first = seed_search.first_violation()
    assert first is not None and seed_search.robustness[first - 1] < 0.0
    assert np.all(seed_search.robustness[:first - 1] >= 0.0)


def test_search_is_deterministic_for_a_seed(seed_search):
    with Runner(workers=2) as runner:  # other processes, same answers
        again = falsify(SPACE, SEED_CELL, runner, budget=40, seed=1, stop_at_first=True)
    np.testing.assert_array_equal(np.array(again.points), np.array(seed_search.points))
    np.testing.assert_array_equal(again.robustness, seed_search.robustness)


def test_interrupted_sweep_resumes_without_repeating_work(tmp_path, monkeypatch):
    cache = tmp_path / "evaluations.jsonl"
    calls = []
    real = runner_module._evaluate_chunk

    def counting(chunk, cell=None):
        calls.append(len(chunk))
        if len(calls) == 2:
            raise KeyboardInterrupt  # the machine goes down during the second chunk
        return real(chunk, cell)

    monkeypatch.setattr(runner_module, "_evaluate_chunk", counting)
    with pytest.raises(KeyboardInterrupt):
        with Runner(workers=1, chunk=4, cache_path=cache) as runner:
            sweep(SPACE, SEED_CELL, runner, method="sobol", budget=8, seed=0)
    assert len(cache.read_text().splitlines()) == 4
    calls.clear()
    with Runner(workers=1, chunk=4, cache_path=cache) as runner:
        resumed = sweep(SPACE, SEED_CELL, runner, method="sobol", budget=8, seed=0)
    assert calls == [4]  # only the unfinished chunk ran
    calls.clear()
    with Runner(workers=1, chunk=4, cache_path=cache) as runner:
        again = sweep(SPACE, SEED_CELL, runner, method="sobol", budget=8, seed=0)
    assert calls == []
    np.testing.assert_array_equal(again.robustness, resumed.robustness)
    monkeypatch.setattr(runner_module, "_evaluate_chunk", real)
    with Runner(workers=1) as runner:
        fresh = sweep(SPACE, SEED_CELL, runner, method="sobol", budget=8, seed=0)
    np.testing.assert_array_equal(fresh.robustness, resumed.robustness)


def test_the_opening_batch_is_the_first_sobol_points_simulated_unranked():
    # The opening batch is drawn before the rest of the Sobol set, and is its start.
    with Runner(workers=1) as runner:
        log = falsify(SPACE, SEED_CELL, runner, budget=16, seed=4, opening=2, quick=0,
                      explore=0)
    np.testing.assert_array_equal(np.array(log.points[:2]),
                                  sweep_points("sobol", 16384, D, seed=4)[:2])
    assert runner.tally.margins == runner.tally.dangers == 0  # nothing ranked: the CMA-ES phase came next


def test_margin_corner_finds_the_parameters_that_move_the_proofs_margins():
    # The margins fall with the hand's speed (its peak, or what its acceleration allows
    # over the leg: ranking.hand_speeds) and depend on nothing else (ranking.bound_scores;
    # the noise is in the envelopes' allowance, a premise, not in the margins): the
    # coordinate search puts exactly those at their top ends
    # (the acceleration matters once the peak is at its top, in the second sweep) and
    # leaves every other parameter where it started. (iso.yaml: its occlusion_speed
    # covers every hand, so no hidden-hand shortfall moves them; the seed's does not.)
    from verification.search.counts import Tally
    from verification.search.ranking import bound_scores, margin_corner

    iso = space_cell(load_controller_config("models/configs/iso.yaml"), SPACE)
    tally = Tally()
    found = margin_corner(SPACE, iso, [0, 1], tally=tally)
    names = free_parameters(SPACE)
    for column in (0, 1):
        corner, moves = found[column]
        assert sorted(np.array(names)[moves]) == ["acceleration", "peak_speed"]
        assert np.all(corner[moves] == 1.0) and np.all(corner[~moves] == 0.5)
        # the corner scores no higher than any of a set of random points
        pool = np.random.default_rng(0).uniform(size=(256, D))
        assert bound_scores(SPACE, iso, corner[None])[0, column] <= \
            bound_scores(SPACE, iso, pool)[:, column].min()
    assert 0 < tally.margins <= 3 * 2 * 2 * D  # counted: at most 3 sweeps, 2 ends
    # The seed's hidden bodies fall behind a fast hand: how long and how many are hidden
    # move its margins too (ranking.hidden_shortfall), at their top ends.
    for corner, moves in margin_corner(SPACE, SEED_CELL, [0, 1]).values():
        for name in ("occlusion", "occluded_bodies", "peak_speed"):
            assert moves[names.index(name)] and corner[names.index(name)] == 1.0


def test_the_focus_phase_simulates_the_margins_corner_first():
    # After the opening point, the falsifier simulates points whose margin-moving
    # parameters lie within FOCUS_WIDTH of the corner, the rest spread over their ranges.
    from verification.search.strategies import FOCUS_WIDTH

    names = free_parameters(SPACE)
    with Runner(workers=1) as runner:
        log = falsify(SPACE, SEED_CELL, runner, budget=64, seed=3, quick=32, explore=0,
                      objectives=(0,))
    focused = np.array(log.points[1:17])
    for name in ("peak_speed", "acceleration"):
        assert np.all(focused[:, names.index(name)] >= 1.0 - FOCUS_WIDTH)
    spread = focused[:, names.index("azimuth_deg")]
    assert spread.min() < 0.25 and spread.max() > 0.75
    assert runner.tally.margins > 0
