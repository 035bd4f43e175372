"""Seed 004's two simulations (Section IV-A/B) on the UR5e, and the compare command."""

import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest

from safety_systems.cli import main
from safety_systems.outputs.compare import compare, controller_metrics, markdown_table
from safety_systems.config.scenario import Body, OperatorConfig, Waypoint, load_scenario
from safety_systems.diagrams.simulation import simulate
from safety_systems.outputs.table_1 import SEED_JERK_SD

SCENARIOS = Path(__file__).parents[1] / "models" / "scenarios"


@pytest.fixture(scope="module")
def rows():
    scenarios = [load_scenario(SCENARIOS / f"erga_{s}.yaml") for s in ("positive", "negative")]
    return {(r["scenario"], r["controller"]): r
            for r in compare(scenarios, ["erga", "none", "bimodal", "hwang"])}


@pytest.mark.parametrize("name", ["erga_positive", "erga_negative"])
def test_without_speed_alteration_the_hand_is_hit(rows, name):
    assert rows[(name, "none")]["max_danger_index"] > 1.0


@pytest.mark.parametrize("name", ["erga_positive", "erga_negative"])
def test_erga_keeps_clear_and_reaches_the_goal(rows, name):
    erga = rows[(name, "erga")]
    assert erga["max_danger_index"] < 1.0
    assert erga["goal_reached"]
    # It waits for the hand: later than the unaltered run, as the seed's 29th sample.
    assert rows[(name, "none")]["goal_time"] < erga["goal_time"] < 3.5
    # The robot backs away or waits: its speed leaves the pre-programmed 50 mm/s.
    assert min(erga["samples"]) < 0.045


@pytest.mark.parametrize("name", ["erga_positive", "erga_negative"])
def test_every_controller_but_none_keeps_the_danger_index_below_1(rows, name):
    for kind in ("erga", "hwang", "bimodal"):
        assert rows[(name, kind)]["max_danger_index"] < 1.0, kind
        assert not rows[(name, kind)]["contact"], kind
    assert rows[(name, "none")]["contact"]


@pytest.mark.parametrize("name", ["erga_positive", "erga_negative"])
def test_jerk_sd_orders_as_table_1(rows, name):
    # Seed 004, Table 1: the proposed method lowest, Hwang's and Morato's above it.
    erga = rows[(name, "erga")]["jerk_sd"]
    assert 0.0 < erga < rows[(name, "hwang")]["jerk_sd"]
    assert erga < rows[(name, "bimodal")]["jerk_sd"]


@pytest.mark.parametrize("name", ["erga_positive", "erga_negative"])
def test_hwang_alters_speed_abruptly(rows, name):
    hwang, none, erga = (np.array(rows[(name, k)]["samples"]) for k in ("hwang", "none", "erga"))
    limit = load_scenario(SCENARIOS / f"{name}.yaml").controller.alteration.speed_limit
    assert not np.array_equal(hwang, none)
    # Seed 004's Fig. 11(b): Hwang's speed goes to the limit, within one period, with no
    # smoothing: from V_pre to the retreat at -250 mm/s, where ERGA's largest change
    # is 0.6 V_pre.
    v_pre = rows[(name, "hwang")]["v_pre"]
    assert hwang[:25].min() <= -0.9 * limit
    assert np.abs(np.diff(hwang[1:25])).max() >= limit
    assert np.abs(np.diff(erga[1:25])).max() < 0.65 * v_pre


@pytest.mark.parametrize("name", ["erga_positive", "erga_negative"])
def test_a_colliding_run_scores_lower_on_safety(rows, name):
    runs = [r for (scenario, _), r in rows.items() if scenario == name]
    hit = [r["evaluation"]["safety_score"] for r in runs if r["contact"]]
    clear = [r["evaluation"]["safety_score"] for r in runs if not r["contact"]]
    assert hit and clear and max(hit) < min(clear)
    assert all(r["contact"] == (r["max_danger_index"] >= 1.0) for r in runs)


def test_comparison_prints_table_1_beside_ours_and_explains_big_differences(rows):
    text = markdown_table(list(rows.values()))
    notes = text.split("Differences beyond")[1] if "Differences beyond" in text else ""
    for name, seed in SEED_JERK_SD.items():
        for kind, seed_sd in seed.items():
            ours = 1000.0 * rows[(name, kind)]["jerk_sd"]
            line = next(x for x in text.splitlines() if x.startswith(f"| {name} |")
                        and f"({kind}) |" in x)
            assert f"| {ours:.1f} | {seed_sd:.1f} | {ours / seed_sd:.2f} |" in line
            explained = re.search(rf"- {name}, {kind}: ours is [0-9.]+ x", notes) is not None
            assert explained == (not 0.5 <= ours / seed_sd <= 2.0), (name, kind)


def _crossing():
    """Seed 004's positive simulation with the hand crossing the tool's line instead: at
    the tool sphere's height, along -x through y = 0.11 m at 0.1 m/s from t = 0, over the
    line at t = 1.5 s, coming at the robot's sphere from ahead and to the side."""
    scenario = load_scenario(SCENARIOS / "erga_positive.yaml")
    hand = OperatorConfig(name="operator", max_speed=0.1, max_acceleration=10.0,
                          bodies=[Body(name="right_hand", point="hand_right")],
                          waypoints=[Waypoint(time=0.0, position=[0.518, 0.11, 0.7185]),
                                     Waypoint(time=0.0001, position=[0.218, 0.11, 0.7185])])
    return dataclasses.replace(scenario, name="crossing", operators=[hand], jerk_window=[])


@pytest.fixture(scope="module")
def crossing_runs():
    scenario = _crossing()
    return {kind: simulate(dataclasses.replace(
        scenario, controller=dataclasses.replace(scenario.controller, type=kind)))
        for kind in ("hwang", "none")}


def test_hwang_on_a_scripted_crossing_backs_away_where_none_hits(crossing_runs):
    runs = crossing_runs
    out = {kind: controller_metrics(run) for kind, run in runs.items()}
    hwang, none = out["hwang"], out["none"]
    assert none["max_danger_index"] > 5.0 and none["contact"]
    assert hwang["samples"] != none["samples"]
    assert min(hwang["samples"]) < 0.0  # it backs away along its path, then resumes
    assert hwang["goal_reached"] and hwang["goal_time"] > none["goal_time"]
    # Every decision keeps the predicted DI one period ahead below 1 (the penalty index).
    # The seed's scheme checks that pose only, not the motion up to it, and the robot
    # takes a few ms to reverse, so the true DI may pass 1 in between (here by ~2 %):
    # still a fifth of the unaltered run's.
    assert runs["hwang"]["speed.danger_index"].max() < 1.0
    assert hwang["max_danger_index"] < none["max_danger_index"] / 5.0


def test_hwang_on_a_scripted_crossing_selects_the_limits_abruptly(crossing_runs):
    # Seed 004, Section IV-C: Hwang's method selects speeds at the limits and switches
    # abruptly. Its choices (piecewise constant between decisions) reach within 10 % of
    # the +-250 mm/s limits, and at least one step between consecutive decisions spans
    # half the speed range or more.
    limit = _crossing().controller.alteration.speed_limit
    selected = crossing_runs["hwang"]["speed.speed_selected"][:, 0]
    assert np.abs(selected).max() >= 0.9 * limit
    assert np.abs(np.diff(selected)).max() >= 0.5 * (2.0 * limit)


def test_erga_is_smoother_than_bimodal_stop_and_go(rows):
    for name in ("erga_positive", "erga_negative"):
        assert rows[(name, "bimodal")]["jerk_sd"] > rows[(name, "erga")]["jerk_sd"]
        assert rows[(name, "bimodal")]["jerk_sd_percent"] > 100.0


def test_compare_command_writes_table_json_and_plot(tmp_path, capsys):
    out = tmp_path / "cmp"
    code = main(["compare", str(SCENARIOS / "erga_positive.yaml"), "--controllers",
                 "erga,none", "--out", str(out)])
    assert code == 0
    table = (out / "comparison.md").read_text()
    assert table.startswith("| scenario | controller | max DI")
    assert "| erga_positive | erga |" in table and "| erga_positive | none |" in table
    data = json.loads((out / "comparison.json").read_text())
    assert {r["controller"] for r in data["rows"]} == {"erga", "none"}
    assert data["provenance"]["inputs"] and data["provenance"]["drake_version"]
    assert (out / "comparison.png").stat().st_size > 10_000
    assert "erga_positive" in capsys.readouterr().out


def test_compare_rejects_unknown_controller(tmp_path, capsys):
    code = main(["compare", str(SCENARIOS / "erga_positive.yaml"), "--controllers", "magic",
                 "--out", str(tmp_path)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "--controllers" in err[0] and "magic" in err[0]
