"""``safety-systems verify``: exit codes, report files and replayable counterexamples."""

import dataclasses
import json
from pathlib import Path

import pytest

from safety_systems.cli import main
from safety_systems.config.scenario import load_scenario
from safety_systems.diagrams.simulation import simulate
from verification.search.evaluate_drake import robustness_of_run

MODELS = Path(__file__).parents[2] / "models"
SPACE = str(MODELS / "spaces" / "default.yaml")
REPORT_KEYS = {"verdict", "method", "assumptions", "properties", "simulations"}
PROPERTY_KEYS = {"verdict", "property", "min_robustness", "counterexamples", "proof",
                 "simulations_to_first_counterexample", "unconfirmed_counterexamples"}


def test_iso_configuration_is_proved(tmp_path, capsys):
    out = tmp_path / "iso"
    code = main(["verify", str(MODELS / "configs" / "iso.yaml"), "--space", SPACE, "--out",
                 str(out), "--budget", "6", "--workers", "1", "--quiet"])
    report = json.loads((out / "report.json").read_text())
    assert code == 0 and report["verdict"] == "proved"
    assert REPORT_KEYS <= set(report) and report["simulations"] == 6
    assert set(report["properties"]) == {"contact", "separation"}
    for name, p in report["properties"].items():
        assert PROPERTY_KEYS <= set(p) and p["verdict"] == "proved", name
        # Every premise says whether it was checked here or trusted from the files.
        premises = p["proof"]["premises"]
        assert {x["basis"] for x in premises} == {"checked", "trusted"}
        assert all(x["holds"] for x in premises)
        # None: +inf, the robot never moved (was never let move) while a body was present.
        assert p["min_robustness"] is None or p["min_robustness"] > 0.0
        assert p["counterexamples"] == []
        assert p["proof"]["margin_at_worst_corner"] > 0.0 and "capsules" in p["property"]
    assert report["properties"]["separation"]["proof"]["needed_allowance"] == 0.0
    # The placeholder stopping data is named in words, in the report and on the console.
    assert report["braking_data"] == "placeholder"
    markdown = (out / "report.md").read_text()
    assert "built-in placeholder" in markdown and "*trusted*" in markdown
    assert "built-in placeholder" in capsys.readouterr().err
    assert "z3" in report["method"]
    assert any("2 m/s" in a for a in report["assumptions"])
    assert markdown.startswith("# Verification: PROVED")
    assert "## contact: PROVED" in markdown and "## separation: PROVED" in markdown
    assert (out / "robustness.png").stat().st_size > 5_000


def test_one_property_alone(tmp_path):
    out = tmp_path / "contact"
    code = main(["verify", str(MODELS / "configs" / "iso.yaml"), "--space", SPACE, "--out",
                 str(out), "--budget", "3", "--workers", "1", "--quiet", "--property",
                 "contact"])
    report = json.loads((out / "report.json").read_text())
    assert code == 0 and set(report["properties"]) == {"contact"}


def test_previous_behaviour_is_falsified_on_the_whole_cell_space(tmp_path):
    out = tmp_path / "previous"
    code = main(["verify", str(MODELS / "configs" / "iso_previous.yaml"), "--space", SPACE,
                 "--out", str(out), "--budget", "200", "--workers", "1", "--quiet"])
    report = json.loads((out / "report.json").read_text())
    assert code == 1 and report["verdict"] == "falsified"
    contact = report["properties"]["contact"]
    assert contact["verdict"] == "falsified" and not contact["proof"]["proved"]
    failed = [p["statement"] for p in contact["proof"]["premises"] if not p["holds"]]
    assert len(failed) == 3  # the tool point, the expire rule, no gate
    assert all(c["drake_robustness"] < 0.0 for c in contact["counterexamples"])


def test_seed_configuration_is_falsified_and_replayable(tmp_path):
    out = tmp_path / "seed"
    code = main(["verify", str(MODELS / "configs" / "seed_estimated.yaml"), "--space", SPACE,
                 "--out", str(out), "--budget", "32", "--workers", "1", "--seed", "1",
                 "--quiet"])
    report = json.loads((out / "report.json").read_text())
    assert code == 1 and report["verdict"] == "falsified"
    contact = report["properties"]["contact"]
    assert contact["verdict"] == "falsified"
    assert contact["simulations_to_first_counterexample"] <= 8
    worst = contact["counterexamples"][0]
    assert worst["drake_robustness"] < 0.0 and set(worst["parameters"]) >= {"peak_speed"}
    # The scenario file replays the violation through the simulate pipeline (the
    # confirmation stopped a quarter second after it showed: the same run up to there).
    run = simulate(load_scenario(worst["scenario"]))
    until = worst["drake_stopped_at"]
    assert until is not None and until < run.time[-1]
    early = dataclasses.replace(run, time=run.time[run.time <= until + 1e-9], signals={
        k: v[run.time <= until + 1e-9] for k, v in run.signals.items()})
    assert robustness_of_run(early).stopped_before_contact == pytest.approx(
        worst["drake_robustness"], abs=1e-12)
    assert robustness_of_run(run).stopped_before_contact <= worst["drake_robustness"]
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
    bad.write_text("parameters:\n  peak_speed: {min: 0.5, max: 4.5}\n")
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
    contact = report["properties"]["contact"]
    assert not contact["proof"]["proved"]
    assert code == 1 and report["verdict"] == "falsified"
    assert contact["counterexamples"][0]["drake_robustness"] < 0.0
