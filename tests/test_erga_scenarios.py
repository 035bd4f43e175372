"""Seed 004's two simulations (Section IV-A/B) on the UR5e, and the compare command."""

import json
from pathlib import Path

import pytest

from safety_systems.cli import main
from safety_systems.compare import compare
from safety_systems.scenario import load_scenario

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
