"""``safety-systems export``: the parameters run exactly as the configuration they came
from, and the export refuses a report of another configuration."""

import json
from pathlib import Path

from safety_systems.config.params_file import load_params
from safety_systems.config.scenario import load_controller_config

MODELS = Path(__file__).parents[3] / "models"
ISO = MODELS / "configs" / "iso.yaml"
SCENARIO = MODELS / "scenarios" / "inspection_seed.yaml"


def test_export_load_and_simulate_behaves_as_the_source_configuration(exported, tmp_path,
                                                                      cli):
    params = exported / "export" / "params.yaml"
    assert load_params(params).controller == load_controller_config(ISO)
    runs = {}
    for name, config in (("source", ISO), ("params", params)):
        out = tmp_path / name
        code, _, err = cli(["simulate", SCENARIO, "--config", config, "--out", out,
                            "--duration", "24", "--quiet"])
        assert code == 0, err
        summary = json.loads((out / "summary.json").read_text())
        del summary["provenance"]
        runs[name] = ((out / "trace.csv").read_bytes(), summary)
    assert runs["params"] == runs["source"]
    # The run is not trivial: the technician comes close and the robot stops for it.
    assert runs["source"][1]["stopped_time"] > 1.0


def test_export_refuses_a_report_of_another_configuration(exported, tmp_path, cli):
    other = tmp_path / "other.yaml"
    other.write_text(ISO.read_text() + "# edited\n")
    code, _, err = cli(["export", other, "--report", exported / "verified" / "report.json",
                        "--out", tmp_path / "x"])
    assert code == 2 and "another configuration" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "x").exists()


def test_export_refuses_a_changed_space(exported, tmp_path, cli):
    report = json.loads((exported / "verified" / "report.json").read_text())
    space = tmp_path / "space.yaml"
    space.write_text(Path(report["space"]).read_text() + "# changed\n")
    inputs = report["provenance"]["inputs"]
    inputs[str(space)] = inputs[report["space"]]  # as verified, then edited
    report["space"] = str(space)
    path = tmp_path / "report.json"
    path.write_text(json.dumps(report))
    code, _, err = cli(["export", ISO, "--report", path, "--out", tmp_path / "x"])
    assert code == 2 and "space file as verified" in err


def test_export_refuses_a_report_of_one_property(exported, tmp_path, cli):
    report = json.loads((exported / "verified" / "report.json").read_text())
    del report["properties"]["separation"]
    path = tmp_path / "report.json"
    path.write_text(json.dumps(report))
    code, _, err = cli(["export", ISO, "--report", path, "--out", tmp_path / "x"])
    assert code == 2 and "both properties" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "x").exists()
