"""Hands faster than ISO 13855's 2.0 m/s (real hands reach 2.5-3.4 m/s): a space may
state operators up to 3 m/s and more, a configuration whose speeds cover them is proved
over it, and one whose speeds do not is not (its premises say why)."""

import dataclasses as dc
from pathlib import Path

import numpy as np

from safety_systems.config.scenario import load_controller_config
from verification.proof.theorems import prove
from verification.search.evaluate_batch import evaluate_many
from verification.spaces.space import (
    free_parameters,
    load_space,
    make_scenario,
    space_cell,
    to_point,
)

MODELS = Path(__file__).parents[3] / "models"
SPACE = load_space(MODELS / "spaces" / "default.yaml")  # (peak speeds up to 2.0 m/s)
ISO = load_controller_config(MODELS / "configs" / "iso.yaml")


def _fast_space(peak: float, folder: Path):
    """The default space, as a file, with operators up to ``peak`` m/s (outliers 1.5 m
    off, past the wider gate a faster gate speed opens)."""
    text = (MODELS / "spaces" / "default.yaml").read_text()
    for old, new in (("peak_speed: {min: 0.5, max: 2.0}",
                      f"peak_speed: {{min: 0.5, max: {peak}}}"),
                     ("outlier_offset: {min: 1.0, max: 2.0}",
                      "outlier_offset: {min: 1.5, max: 1.5}")):
        assert old in text
        text = text.replace(old, new)
    (folder / "fast.yaml").write_text(text)
    return load_space(folder / "fast.yaml")


def _fast_config(v: float):
    """iso.yaml with every speed the proof reads at ``v`` m/s: the ISO human speed, the
    hidden bodies' growth and the gate's."""
    return dc.replace(ISO, safety=dc.replace(ISO.safety, iso_human_speed=v,
                                             iso_reduced_human_speed=v, occlusion_speed=v),
                      tracker=dc.replace(ISO.tracker, gate_speed=v))


def test_a_three_metre_per_second_space_is_proved_with_a_configuration_that_covers_it(
        tmp_path):
    space = _fast_space(3.0, tmp_path)
    assert space.parameters.peak_speed.max == 3.0
    proof = prove(space_cell(_fast_config(3.0), space), space)
    assert proof.proved and proof.box["peak_speed"] == [SPACE.parameters.peak_speed.min, 3.0]
    # ISO 13855's 2.0 m/s: its premises fail, and say so
    refused = prove(space_cell(ISO, space), space)
    assert not refused.proved
    failing = " ".join(x.statement for x in refused.premises if not x.holds)
    assert "v_max 3 m/s" in failing


def test_a_three_metre_per_second_operator_runs_in_the_batched_evaluator(tmp_path):
    space = _fast_space(3.0, tmp_path)
    rng = np.random.default_rng(3)
    d = len(free_parameters(space))
    scenarios = [make_scenario(space, _fast_config(3.0), dict(
        to_point(space, u), peak_speed=3.0, operators=1.0, heads=1.0))
        for u in rng.uniform(size=(4, d))]
    assert all(o.max_speed == 3.0 for s in scenarios for o in s.operators)
    result = evaluate_many(scenarios)
    assert not np.isnan(result.robustness).any()


def test_a_three_metre_per_second_configuration_is_tuned_exported_and_checked(tmp_path):
    """iso.yaml's file with every human speed at 3 m/s (ISO human speeds, hidden bodies'
    growth, the gate) over the tune tests' small space with operators up to 3 m/s: tune
    chooses a configuration, export certifies it and check accepts it, as for any other."""
    import json

    import yaml

    from tests.verification.conftest import SMALL_SPACE, TUNE_BLOCK, run_cli

    text = (MODELS / "configs" / "iso.yaml").read_text()
    for key in ("gate_speed", "iso_human_speed", "iso_reduced_human_speed",
                "occlusion_speed"):
        assert f"  {key}: 2.0\n" in text
        text = text.replace(f"  {key}: 2.0\n", f"  {key}: 3.0\n")
    (tmp_path / "fast.yaml").write_text(text)
    space = SMALL_SPACE.read_text()
    assert "peak_speed: {min: 1.0, max: 2.0}" in space
    (tmp_path / "space.yaml").write_text(space.replace("peak_speed: {min: 1.0, max: 2.0}",
                                                       "peak_speed: {min: 1.0, max: 3.0}"))
    (tmp_path / "tune.yaml").write_text(TUNE_BLOCK)
    task = yaml.safe_load((MODELS / "scenarios" / "inspection_seed.yaml").read_text())
    task["duration"], task["robot"]["cycles"] = 25.0, 3
    (tmp_path / "task.yaml").write_text(yaml.safe_dump(task, sort_keys=False))
    code, _, err = run_cli(["tune", tmp_path / "fast.yaml", "--tune", tmp_path / "tune.yaml",
                            "--space", tmp_path / "space.yaml", "--tasks",
                            tmp_path / "task.yaml", "--out", tmp_path / "tune", "--budget",
                            "6", "--candidates", "3", "--screen", "4", "--workers", "1",
                            "--quiet"])
    assert code == 0, err
    chosen = json.loads((tmp_path / "tune" / "tune.json").read_text())["chosen"]
    report = json.loads(Path(chosen["report"]).read_text())
    assert report["verdict"] == "proved" and report["box"]["peak_speed"][1] == 3.0
    code, _, err = run_cli(["export", chosen["config"], "--report", chosen["report"], "--tune",
                            tmp_path / "tune" / "tune.json", "--out", tmp_path / "export",
                            "--quiet"])
    assert code == 0, err
    exported = (tmp_path / "export" / "params.yaml").read_text()
    for key in ("iso_human_speed", "occlusion_speed", "gate_speed"):
        assert f"{key}: 3.0" in exported
    code, out, err = run_cli(["check", tmp_path / "export" / "params.yaml"])
    assert code == 0, err
