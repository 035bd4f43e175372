"""``safety-systems verify``: exit codes, report files and replayable counterexamples."""

import json
from pathlib import Path

import pytest

from safety_systems.cli import main
from safety_systems.scenario import load_scenario
from safety_systems.simulation import simulate
from verification.evaluate_drake import robustness_of_run

MODELS = Path(__file__).parents[2] / "models"
SPACE = str(MODELS / "spaces" / "default.yaml")
REPORT_KEYS = {"verdict", "method", "assumptions", "min_robustness", "simulations",
               "counterexamples"}


def test_iso_configuration_is_proved(tmp_path, capsys):
    out = tmp_path / "iso"
    code = main(["verify", str(MODELS / "configs" / "iso.yaml"), "--space", SPACE, "--out",
                 str(out), "--budget", "6", "--workers", "1", "--quiet"])
    report = json.loads((out / "report.json").read_text())
    assert code == 0 and report["verdict"] == "proved"
    # Every premise says whether it was checked here or trusted from the files, and the
    # placeholder stopping data is named in words, in the report and on the console.
    premises = report["proof"]["premises"]
    assert {p["basis"] for p in premises} == {"checked", "trusted"}
    assert all(p["holds"] for p in premises)
    assert report["braking_data"] == "placeholder"
    markdown = (out / "report.md").read_text()
    assert "built-in placeholder" in markdown and "*trusted*" in markdown
    assert "built-in placeholder" in capsys.readouterr().err
    assert "capsules" in report["property"]
    assert REPORT_KEYS <= set(report) and report["simulations"] == 6
    # None: +inf, the robot never moved while a hand was present.
    assert report["min_robustness"] is None or report["min_robustness"] > 0.0
    assert report["counterexamples"] == []
    assert "z3" in report["method"] and report["proof"]["margin_at_worst_corner"] > 0.0
    assert any("2 m/s" in a for a in report["assumptions"])
    assert (out / "report.md").read_text().startswith("# Verification: PROVED")
    assert (out / "robustness.png").stat().st_size > 5_000


def test_previous_behaviour_is_falsified_on_the_whole_cell_space(tmp_path):
    out = tmp_path / "previous"
    code = main(["verify", str(MODELS / "configs" / "iso_previous.yaml"), "--space", SPACE,
                 "--out", str(out), "--budget", "6", "--workers", "1", "--quiet"])
    report = json.loads((out / "report.json").read_text())
    assert code == 1 and report["verdict"] == "falsified"
    assert not report["proof"]["proved"]
    failed = [p["statement"] for p in report["proof"]["premises"] if not p["holds"]]
    assert len(failed) == 3  # the tool point, the expire rule, no gate
    assert all(c["drake_robustness"] < 0.0 for c in report["counterexamples"])


def test_seed_configuration_is_falsified_and_replayable(tmp_path):
    out = tmp_path / "seed"
    code = main(["verify", str(MODELS / "configs" / "seed_estimated.yaml"), "--space", SPACE,
                 "--out", str(out), "--budget", "8", "--workers", "1", "--seed", "1",
                 "--quiet"])
    report = json.loads((out / "report.json").read_text())
    assert code == 1 and report["verdict"] == "falsified"
    assert report["simulations_to_first_counterexample"] <= 8
    worst = report["counterexamples"][0]
    assert worst["drake_robustness"] < 0.0 and set(worst["parameters"]) >= {"peak_speed"}
    # The scenario file replays the violation through the simulate pipeline.
    run = simulate(load_scenario(worst["scenario"]))
    assert robustness_of_run(run).stopped_before_contact == pytest.approx(
        worst["drake_robustness"], abs=1e-12)
    assert (out / "replay.html").stat().st_size > 100_000


@pytest.mark.parametrize("args, field", [
    (["--budget", "0"], "--budget"),
    (["--seed", "-1"], "--seed"),
])
def test_bad_arguments_exit_2(tmp_path, capsys, args, field):
    code = main(["verify", str(MODELS / "configs" / "iso.yaml"), "--space", SPACE, "--out",
                 str(tmp_path), *args])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and field in err[0]


def test_bad_space_file_exits_2(tmp_path, capsys):
    bad = tmp_path / "space.yaml"
    bad.write_text("parameters:\n  peak_speed: {min: 0.5, max: 3.0}\n")
    code = main(["verify", str(MODELS / "configs" / "iso.yaml"), "--space", str(bad), "--out",
                 str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "parameters.peak_speed" in err[0]


def test_erga_controller_is_verified_in_the_diagram(tmp_path):
    # Seed 004's one-step prediction against the default space's lunges: the search
    # runs the ERGA in the Drake diagram (the batched evaluator models Eq. 12 only).
    out = tmp_path / "erga"
    code = main(["verify", str(MODELS / "configs" / "erga.yaml"), "--space", SPACE, "--out",
                 str(out), "--budget", "3", "--workers", "1", "--seed", "1", "--quiet"])
    report = json.loads((out / "report.json").read_text())
    assert not report["proof"]["proved"]
    assert code == 1 and report["verdict"] == "falsified"
    assert report["counterexamples"][0]["drake_robustness"] < 0.0
