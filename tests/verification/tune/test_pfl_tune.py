"""tune can choose power and force limiting (safety.mode ssm_pfl) and its speed cap, and
export, check and the certificate carry them (issue 36)."""

import json
from pathlib import Path

import pytest
import yaml

from safety_systems.config.scenario import load_controller_config
from tests.verification.conftest import MODELS, SMALL_SPACE, SPACE, TUNE_BLOCK, run_cli
from verification.tune.tunable import load_tunable, with_values

BENCH_TUNE_PFL = MODELS.parent / "benchmarks" / "results" / "bench_tune_pfl.json"

# Power and force limiting that a proof can reach (issue 46): a robot force limit low
# enough that its contact detection keeps a lasting contact within the quasi-static
# compressions (the caps then follow from it: mm/s), and room for clamping.
PFL_BLOCK = TUNE_BLOCK + """\
- {name: safety.mode, choices: [ssm_pfl]}
- {name: safety.pfl_speed, min: 0.2, max: 1.0}
- {name: safety.contact_stop_force, min: 50.0, max: 60.0}
- {name: safety.clamp_margin, min: 1.9, max: 2.0}
"""


def test_a_power_and_force_limiting_configuration_is_tuned_exported_and_checked(tmp_path):
    (tmp_path / "tune.yaml").write_text(PFL_BLOCK)
    task = yaml.safe_load((MODELS / "scenarios" / "inspection_seed.yaml").read_text())
    task["duration"], task["robot"]["cycles"] = 25.0, 3
    (tmp_path / "task.yaml").write_text(yaml.safe_dump(task, sort_keys=False))
    code, _, err = run_cli(["tune", MODELS / "configs" / "iso.yaml", "--tune",
                            tmp_path / "tune.yaml", "--space", SMALL_SPACE, "--tasks",
                            tmp_path / "task.yaml", "--out", tmp_path / "tune", "--budget",
                            "6", "--candidates", "3", "--screen", "4", "--workers", "1",
                            "--quiet"])
    assert code == 0, err
    result = json.loads((tmp_path / "tune" / "tune.json").read_text())
    chosen = result["chosen"]
    assert chosen["values"]["safety.mode"] == "ssm_pfl"
    assert 0.2 <= chosen["values"]["safety.pfl_speed"] <= 1.0
    report = json.loads(Path(chosen["report"]).read_text())
    # verified for the mode's two properties, each proved with its premises listed
    assert report["safety_mode"] == "ssm_pfl"
    assert sorted(report["properties"]) == ["permitted_contact", "separation"]
    assert report["verdict"] == "proved"
    premises = report["properties"]["permitted_contact"]["proof"]["premises"]
    assert any("c_i V_R <= v_i" in p["statement"] and p["holds"] for p in premises)
    assert any("a contact that lasts" in p["statement"] and p["holds"] for p in premises)
    assert "speed and separation monitoring's part only" in \
        report["properties"]["separation"]["property"]
    code, _, err = run_cli(["export", chosen["config"], "--report", chosen["report"], "--tune",
                            tmp_path / "tune" / "tune.json", "--out", tmp_path / "export",
                            "--quiet"])
    assert code == 0, err
    exported = (tmp_path / "export" / "params.yaml").read_text()
    assert 'controller.safety.mode: "ssm_pfl"' in exported
    assert "controller.safety.pfl_speed: " in exported
    page = (tmp_path / "export" / "report.html").read_text()
    assert "with power and force limiting" in page and "Annex A" in page
    code, _, err = run_cli(["check", tmp_path / "export" / "params.yaml"])
    assert code == 0, err
    # a mode edited in the exported file is another controller than the certified one
    params = tmp_path / "export" / "params.yaml"
    params.write_text(exported.replace('controller.safety.mode: "ssm_pfl"',
                                       'controller.safety.mode: "ssm"'))
    code, _, err = run_cli(["check", params])
    assert code != 0


def test_the_shipped_pfl_configuration_is_the_recorded_candidate_of_the_pfl_tune():
    """models/configs/pfl.yaml is iso.yaml with the values of the fastest ssm_pfl candidate
    that bench_tune's PFL run recorded (benchmarks/results/bench_tune_pfl.json,
    ``fastest_pfl``), and its comment cites that candidate and the time it lost."""
    row = json.loads(BENCH_TUNE_PFL.read_text())["fastest_pfl"]
    assert row["values"]["safety.mode"] == "ssm_pfl"
    assert row["proved"] == {"permitted_contact": True, "separation": True}
    iso, _ = load_tunable(MODELS / "configs" / "iso.yaml", MODELS / "tune" / "ssm_pfl.yaml")
    path = MODELS / "configs" / "pfl.yaml"
    assert load_controller_config(path) == with_values(iso, row["values"])
    comment = " ".join(line.lstrip("# ") for line in path.read_text().splitlines()
                       if line.startswith("#"))
    assert f"candidate {row['index']} " in comment
    assert f"lost {row['total_lost_time']:.3f} s" in comment


@pytest.mark.slow
def test_the_shipped_pfl_configuration_is_proved_over_the_default_space(tmp_path):
    """models/configs/pfl.yaml (issue 46: the fastest ssm_pfl candidate of the PFL tune)
    proves what it claims, both of its mode's properties, over the default space."""
    config = MODELS / "configs" / "pfl.yaml"
    assert yaml.safe_load(config.read_text())["safety"]["mode"] == "ssm_pfl"
    code, _, err = run_cli(["verify", config, "--space", SPACE, "--out", tmp_path / "v",
                            "--workers", "1", "--quiet"])
    report = json.loads((tmp_path / "v" / "report.json").read_text())
    assert report["safety_mode"] == "ssm_pfl"
    verdicts = {name: p["verdict"] for name, p in report["properties"].items()}
    assert len(verdicts) == 2 and set(verdicts.values()) == {"proved"}, (code, err, verdicts)
    assert report["verdict"] == "proved" and code == 0, (code, err)
