"""The falsifier's reduced model: it orders candidates as the closed loop does."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from safety_systems.cell.human_body import POINTS as BODY_POINTS
from safety_systems.config.scenario import load_controller_config
from safety_systems.config.configuration import scripted_operators
from verification.search.counts import Tally
from verification.search.evaluate_batch import evaluate_many
from verification.proof.margins import margin
from verification.proof.theorems import prove, prove_separation
from verification.search.ranking import bound_scores, danger_scores, hand_speeds
from verification.search.runner import Runner
from verification.search.strategies import sweep_points
from verification.spaces.space import (
    free_parameters,
    load_space,
    make_scenario,
    space_cell,
    to_point,
)

SPACE = load_space("models/spaces/default.yaml")
SUITED = dataclasses.replace(SPACE, tracked=list(BODY_POINTS))  # every body point tracked
SEED_CONFIG = load_controller_config("models/configs/seed_estimated.yaml")
D = len(free_parameters(SPACE))


def test_danger_scores_order_a_slow_walk_and_a_fast_approach_as_the_closed_loop_does():
    # Two approaches from the far end of the space, one a slow walk, one at the fastest
    # speed with the longest overshoot. Under the seed's estimated speeds the fast one is
    # stopped for early and the slow walk comes closer while the robot moves; under
    # iso.yaml's fixed 2 m/s the slow walk is the safer: the ranking must order the pair
    # as the closed loop does under each (in both scores), which no ranking blind to the
    # configuration could. Both accelerate gently (0.25 of the space's range): at the
    # middle of it, with the tighter envelopes of issue 47, the two came within 0.01 m of
    # each other in iso.yaml's separation margin, too close to call an order.
    names = free_parameters(SPACE)
    slow = np.full(D, 0.5)
    slow[names.index("start_distance")] = 1.0
    slow[names.index("acceleration")] = 0.25
    slow[names.index("peak_speed")] = slow[names.index("overshoot")] = 0.0
    fast = slow.copy()
    fast[names.index("peak_speed")] = fast[names.index("overshoot")] = 1.0
    orders = []
    for config in (SEED_CONFIG, load_controller_config("models/configs/iso.yaml")):
        scores = danger_scores(SPACE, space_cell(config, SPACE), np.array([slow, fast]))
        assert scores.shape == (2, 2)
        loop = evaluate_many([make_scenario(SPACE, config, to_point(SPACE, u))
                              for u in (slow, fast)])
        for column, rho in ((0, loop.robustness), (1, loop.separation)):
            assert np.all(np.isfinite(rho)) and abs(rho[1] - rho[0]) > 0.02, (column, rho)
            assert np.sign(scores[1, column] - scores[0, column]) == np.sign(rho[1] - rho[0])
        orders.append(np.sign(scores[1] - scores[0]))
    assert np.all(orders[0] != orders[1])


@pytest.mark.parametrize("name", ["seed", "tracks_expire"])
def test_danger_scores_order_candidates_as_the_closed_loop_does(name):
    # The ranking is a reduced model: it must order candidates as the closed loop does,
    # or the search spends its budget on safe ones. "tracks_expire" is the case where every
    # track of an operator ends: the reduced model once stopped the robot there (Eq. 12 of
    # an infinite distance) where the loop runs it at full speed, ranking every
    # counterexample last.
    from scipy.stats import spearmanr

    iso = load_controller_config("models/configs/iso.yaml")  # its contact terms alone:
    iso = dataclasses.replace(iso, safety=dataclasses.replace(iso.safety,
                                                              robot_uncertainty=0.0))
    config = {"seed": SEED_CONFIG, "tracks_expire": dataclasses.replace(
        iso, tracker=dataclasses.replace(iso.tracker, hidden_bodies="expire",
                                         max_coast_time=0.5, exit_radius=1e-6))}[name]
    points = sweep_points("sobol", 256, D, seed=7)
    result = evaluate_many([make_scenario(SPACE, config, to_point(SPACE, u)) for u in points])
    tally = Tally()
    scores = danger_scores(SPACE, space_cell(config, SPACE), points, tally=tally)
    assert tally.dangers == len(points) and tally.simulations == 0
    for column, rho in ((0, result.robustness), (1, result.separation)):
        finite = np.isfinite(rho) & np.isfinite(scores[:, column])
        assert finite.sum() > 100, column
        assert spearmanr(scores[finite, column], rho[finite]).correlation > 0.7, column
    rho = result.robustness
    assert (rho < 0).sum() >= 3
    assert spearmanr(scores[np.isfinite(rho), 0], rho[np.isfinite(rho)]).correlation > 0.8
    # Of the n best-ranked candidates (n: the violations among them all), most violate.
    best = np.argsort(scores[:, 0], kind="stable")[:int((rho < 0).sum())]
    assert np.mean(rho[best] < 0.0) >= 0.8


def _by_speed(robot_uncertainty):
    iso = load_controller_config("models/configs/iso.yaml")
    return dataclasses.replace(iso, safety=dataclasses.replace(
        iso.safety, stopping="by_speed", robot_speed="fastest_point", reaction_time=0.1,
        intrusion_distance=0.0, robot_uncertainty=robot_uncertainty))


def test_danger_scores_model_the_by_speed_override():
    # safety.stopping: by_speed: the reduced model commands the speed levels at the rate
    # now and takes S_true's stop from the true rate, as the loop does (modelled as the
    # full-speed override it ranked the separation figures at a Spearman 0.4, and most of
    # the permitted candidates not at all).
    from scipy.stats import spearmanr

    # Operators in suits (every body point tracked): with gloves and a helmet the untracked
    # segments' envelopes keep nearly every candidate of this variant clear.
    config = _by_speed(0.08)  # under half the 0.178 m its proof asks for
    points = sweep_points("sobol", 256, D, seed=7)
    result = evaluate_many([make_scenario(SUITED, config, to_point(SUITED, u))
                            for u in points])
    scores = danger_scores(SUITED, space_cell(config, SUITED), points)
    for column, rho in ((0, result.robustness), (1, result.separation)):
        finite = np.isfinite(rho) & np.isfinite(scores[:, column])
        assert finite.sum() > 200, column
        assert spearmanr(scores[finite, column], rho[finite]).correlation > 0.85, column
    # The violations of the invariant are ranked near the top: half of them in the first
    # eighth, all in the first half (the full-speed model put the last at 227 of 256).
    rho = result.separation
    rank = np.argsort(np.argsort(scores[:, 1], kind="stable"))[rho < 0.0]
    assert rank.size >= 5 and np.median(rank) < len(points) // 8
    assert rank.max() < len(points) // 2


def test_bound_scores_are_the_least_speed_level_s_margins():
    # Under by_speed the proofs' margin is the least over the speed levels, pointwise.
    config = _by_speed(0.22)
    names = free_parameters(SPACE)
    worst = np.full(D, 0.5)
    for name in ("peak_speed", "acceleration", "start_distance", "noise_std"):
        worst[names.index(name)] = 1.0
    scores = bound_scores(SPACE, space_cell(config, SPACE), worst[None, :])
    for column, prover in enumerate((prove, prove_separation)):
        proof = prover(space_cell(config, SPACE), SPACE)
        assert scores[0, column] == pytest.approx(proof.margin_at_worst_corner, abs=1e-12)
        assert scores[0, column] == pytest.approx(min(proof.terms["level_margins"].values()),
                                                  abs=1e-12)


def test_danger_scores_split_over_workers_are_the_same():
    points = sweep_points("sobol", 512, D, seed=3)
    with Runner(workers=2) as runner:  # two parts of 256, each run to the common horizon
        split = danger_scores(SPACE, space_cell(SEED_CONFIG, SPACE), points, runner=runner)
    np.testing.assert_array_equal(split, danger_scores(SPACE, space_cell(SEED_CONFIG, SPACE),
                                                       points))


KNOWN = json.loads((Path(__file__).parents[1] / "data" / "known_counterexamples.json")
                   .read_text())
ISO = load_controller_config("models/configs/iso.yaml")
ISO_CELL = space_cell(ISO, SPACE)


def _variant(safety: dict):
    return dataclasses.replace(ISO, safety=dataclasses.replace(ISO.safety, **safety))


def test_hand_speeds_are_the_fastest_the_approaching_hand_moves():
    points = sweep_points("sobol", 64, D, seed=2)
    for u, v in zip(points, hand_speeds(SPACE, points)):
        scenario = make_scenario(SPACE, ISO, to_point(SPACE, u))
        path = scripted_operators(scenario)[0].path
        assert v == pytest.approx(float(np.max(path.peak_speeds)), rel=1e-12)


def test_bound_scores_are_the_proofs_margins_at_each_point():
    # The worst corner of the proofs' box (the fastest hand) scores what the proofs report
    # there; elsewhere the margin, pointwise; each candidate one ranking.
    names = free_parameters(SPACE)
    worst = np.full(D, 0.5)
    for name in ("peak_speed", "acceleration", "start_distance", "noise_std"):
        worst[names.index(name)] = 1.0
    mild = worst.copy()
    mild[names.index("peak_speed")], mild[names.index("noise_std")] = 0.2, 0.0
    tally = Tally()
    scores = bound_scores(SPACE, space_cell(ISO, SPACE), np.array([worst, mild]), tally=tally)
    assert tally.margins == 2 and tally.total == 2
    for column, (prover, prop) in enumerate(((prove, "contact"),
                                              (prove_separation, "separation"))):
        assert scores[0, column] == pytest.approx(prover(ISO_CELL, SPACE).margin_at_worst_corner,
                                                  abs=1e-12)
        values = to_point(SPACE, mild)
        assert scores[1, column] == pytest.approx(
            margin(ISO_CELL, SPACE, prop).at(values["peak_speed"]), abs=1e-12)
        assert scores[1, column] > scores[0, column]


@pytest.mark.parametrize("known", KNOWN["sets"], ids=lambda k: k["property"])
def test_ranking_never_pushes_known_counterexamples_below_the_budget(known):
    # A fixed set of counterexamples the closed loop found in a Sobol set: they still are
    # counterexamples, and among that set the falsifier's ranking puts every one of them
    # within the exploration a 4096-simulation search spends (the first 2048 ranked).
    config = _variant(known["safety"])
    space = dataclasses.replace(SPACE, tracked=known["tracked"])
    column = {"contact": 0, "separation": 1}[known["property"]]
    points = np.array(known["points"])
    result = evaluate_many([make_scenario(space, config, to_point(space, u)) for u in points])
    figures = result.robustness if column == 0 else result.separation
    assert np.all(figures < 0.0)
    pool = sweep_points("sobol", 16384, D, seed=11)
    np.testing.assert_allclose(pool[known["sobol_index"]], points, atol=1e-12)
    scores = bound_scores(space, space_cell(config, space), pool)[:, column]
    order = np.argsort(scores, kind="stable")
    rank = np.argsort(order)[known["sobol_index"]]
    assert rank.max() < 4096 // 2, rank
