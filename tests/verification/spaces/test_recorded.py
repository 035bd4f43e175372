"""Scenario spaces built around a recording (``verification.spaces.recorded``): the file
loads strictly, a point's scenario is the recording moved in time and space, an extra
occlusion hides the bodies from the sensor, and ``verify`` searches the space in the
Drake diagram, counts every run, and never claims a proof."""

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from pydrake.common.yaml import yaml_dump_typed

import verification.search.evaluate_drake as evaluate_drake_module
import verification.verify as verify_module
from safety_systems.config.scenario import load_controller_config, load_scenario
from safety_systems.diagrams.simulation import simulate
from safety_systems.sensing.motive_csv import read_motive_csv
from safety_systems.sensing.recording_mapping import load_mapping, to_cell
from verification.search.counts import COST
from verification.search.evaluate_drake import evaluate_drake
from verification.spaces.recorded import RECORDING_NAMES
from verification.report import write_report
from verification.spaces.space import free_parameters, load_space, make_scenario, to_point
from verification.verify import verify

MODELS = Path(__file__).parents[3] / "models"
SPACE_FILE = MODELS / "spaces" / "recording.yaml"
SPACE = load_space(SPACE_FILE)
ISO = load_controller_config(MODELS / "configs" / "iso.yaml")
UNSAFE = MODELS / "configs" / "seed_estimated.yaml"  # the seed's: estimated speeds, no Z
RATE = 100.0  # Hz, approach.csv's samples
DT = 1.0 / 500.0  # s, the control period


def _point(**given) -> dict:
    """Parameter values: the box's lower corner, then ``given``."""
    values = to_point(SPACE, np.zeros(len(free_parameters(SPACE))))
    values.update(given)
    return values


def test_the_shipped_space_loads_and_round_trips(tmp_path):
    assert list(free_parameters(SPACE)) == [n for n in RECORDING_NAMES if n not in (
        "offset_z", "braking_time_scale")]
    # A unit point lands on the ranges, in the recording block's order.
    values = to_point(SPACE, np.full(len(free_parameters(SPACE)), 0.5))
    assert values["time_scale"] == pytest.approx(1.0) and values["yaw_deg"] == 0.0
    assert values["occluded_bodies"] == 2.0 and values["time_shift"] == 1.5
    (tmp_path / "again.yaml").write_text(yaml_dump_typed(SPACE))
    assert load_space(tmp_path / "again.yaml") == SPACE


BAD = [  # (path in the YAML tree, value, field named, what is allowed says)
    (("recording", "parameters", "time_scale"), {"min": 0.0, "max": 1.3},
     "recording.parameters.time_scale", "within [0.1, 10]"),
    (("recording", "parameters", "time_shift"), {"min": -0.5, "max": 1.0},
     "recording.parameters.time_shift", "min >= -start"),
    (("recording", "parameters", "time_shift"), {"min": 0.0, "max": 11.5},
     "recording.parameters.time_shift", "the recording ends at 12 s"),
    (("recording", "parameters", "occlusion_start"), {"min": 3.0, "max": 7.5},
     "recording.parameters.occlusion_start", "seen for settle_time"),
    (("recording", "parameters", "occluded_bodies"), {"min": 1.0, "max": 4.0},
     "recording.parameters.occluded_bodies", "1 to 3"),
    (("recording", "parameters", "occluded_bodies"), {"min": 1.0, "max": 2.5},
     "recording.parameters.occluded_bodies", "whole numbers"),
    (("recording", "file"), "../recordings/none.csv", "recording.file", "a readable file"),
    (("recording", "mapping"), "../recordings/approach.yaml", "recording.mapping",
     "a mapping file"),
    (("parameters",), {"peak_speed": {"min": 1.0, "max": 2.0}}, "parameters",
     "none with a recording block"),
    (("tracked",), ["head"], "tracked", "unused with a recording block"),
    (("recording", "parameters", "yaw"), {"min": 0.0, "max": 1.0},
     "recording.parameters.yaw", "one of the fields"),
]


@pytest.mark.parametrize("where, value, field, allowed", BAD)
def test_a_bad_recording_space_gives_exit_2_and_one_line(tmp_path, cli, where, value, field,
                                                         allowed):
    shutil.copytree(MODELS / "recordings", tmp_path / "recordings")
    (tmp_path / "spaces").mkdir()
    tree = yaml.safe_load(SPACE_FILE.read_text())
    node = tree
    for key in where[:-1]:
        node = node[key]
    node[where[-1]] = value
    path = tmp_path / "spaces" / "bad.yaml"
    path.write_text(yaml.safe_dump(tree, sort_keys=False))
    code, out, err = cli(["check", "space", path])
    assert code == 2 and out == ""
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"safety-systems: {path}: {field}"), err
    assert "got" in lines[0] and allowed in lines[0]


def test_a_mapping_the_recording_does_not_fit_is_named(tmp_path, cli):
    shutil.copytree(MODELS / "recordings", tmp_path / "recordings")
    mapping = tmp_path / "recordings" / "approach_mapping.yaml"
    mapping.write_text(mapping.read_text().replace("recorded: Helmet", "recorded: Hat"))
    (tmp_path / "spaces").mkdir()
    shutil.copy(SPACE_FILE, tmp_path / "spaces")
    code, _, err = cli(["check", "space", tmp_path / "spaces" / "recording.yaml"])
    assert code == 2 and len(err.splitlines()) == 1
    assert "recording.file" in err and "Hat" in err


def _yaw(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def test_a_points_scenario_is_the_recording_moved_in_time_and_space():
    # Recording time 0.5 + 1.25 t: every fourth control tick falls on a sample.
    values = _point(time_shift=0.5, time_scale=1.25, yaw_deg=35.0, offset_x=0.15,
                    offset_y=-0.1)
    scenario = make_scenario(SPACE, ISO, values)
    assert scenario.duration == pytest.approx((12.0 - 0.5) / 1.25)
    run = simulate(scenario)
    tau = 0.5 + 1.25 * run.time
    on_sample = np.isclose(tau * RATE, np.round(tau * RATE), atol=1e-6)
    index = np.round(tau[on_sample] * RATE).astype(int)
    # The file's numbers, through the mapping, turned and moved here by hand.
    recording = read_motive_csv(MODELS / "recordings" / "approach.csv")
    mapping = load_mapping(MODELS / "recordings" / "approach_mapping.yaml")
    order = [recording.body(b.recorded) for b in mapping.operators[0].bodies]
    cell = to_cell(mapping.capture_to_cell, recording.positions[:, order])
    expected = cell[index] @ _yaw(35.0).T + np.array([0.15, -0.1, 0.0])
    truth = run.bodies("operators.positions_true")[on_sample]
    tracked = np.all(np.isfinite(expected), axis=2)
    assert on_sample.sum() > 1000 and tracked.sum() > 3000
    np.testing.assert_allclose(truth[tracked], expected[tracked], rtol=0, atol=1e-12)
    # Speeds scale with the time scale: the velocity is 1.25 times the recording's slope.
    k = np.flatnonzero(on_sample)[600]
    i = index[600]
    slope = (cell[i + 1, 0] - cell[i, 0]) * RATE
    np.testing.assert_allclose(run.bodies("operators.velocities_true")[k, 0],
                               1.25 * _yaw(35.0) @ slope, rtol=0, atol=1e-9)


def test_an_extra_occlusion_hides_the_bodies_in_the_sensors_frames():
    # Both gloves hidden from recording time 6.0 (scenario time (6.0 - 1.0) / 1.0 = 5 s)
    # for 0.6 s; the head stays in sight.
    values = _point(time_shift=1.0, time_scale=1.0, occlusion_start=6.0, occlusion=0.6,
                    occluded_bodies=2.0)
    scenario = make_scenario(SPACE, ISO, values)
    assert [(o.body, o.start, o.end) for o in scenario.sensor.occlusions] == [
        ("technician/right_glove", 5.0, 5.6), ("technician/left_glove", 5.0, 5.6)]
    run = simulate(scenario)
    captured = run["mocap.sample_time"][:, 0]
    valid = run["mocap.valid"]
    inside = (captured >= 5.0 + 1e-9) & (captured < 5.6 - 1e-9)
    before = (captured > 4.0) & (captured < 5.0 - 1e-9)
    assert inside.sum() > 100 and before.sum() > 100
    assert np.all(valid[inside, :2] == 0.0) and np.all(valid[inside, 2] == 1.0)
    assert np.all(valid[before] == 1.0)
    measured = run.bodies("mocap.positions_measured")
    assert np.isnan(measured[inside, :2]).all() and np.isfinite(measured[inside, 2]).all()


class Calls:
    """Counts the Drake runs of the search (through ``evaluate_many``) and of verify's
    replays."""

    def __init__(self, monkeypatch):
        self.search = self.replays = 0
        drake = evaluate_drake_module.evaluate_drake

        def searched(scenario, **kw):
            self.search += 1
            return drake(scenario, **kw)

        def replayed(scenario, **kw):
            self.replays += 1
            return drake(scenario, **kw)

        monkeypatch.setattr(evaluate_drake_module, "evaluate_drake", searched)
        monkeypatch.setattr(verify_module, "evaluate_drake", replayed)


def test_verify_falsifies_the_seeds_configuration_counts_every_run_and_replays_it(
        tmp_path, monkeypatch):
    calls = Calls(monkeypatch)
    config = load_controller_config(UNSAFE)
    outcome = verify(config, SPACE, tmp_path, budget=8, workers=1, seed=0)
    report = write_report(outcome, tmp_path, config_path=str(UNSAFE),
                          space_path=str(SPACE_FILE), replay=False)
    assert report["verdict"] == "falsified"
    assert report["evaluations"] == {
        "simulations": calls.search, "margins": 0, "dangers": 0, "drake": calls.replays,
        "total": calls.search + calls.replays, "search_cost": calls.search,
        "cost": calls.search + COST["drake"] * calls.replays}
    assert 0 < calls.search <= report["simulations"] <= 8 and calls.replays > 0
    separation = report["properties"]["separation"]
    assert separation["verdict"] == "falsified" and separation["counterexamples"]
    for p in report["properties"].values():
        assert p["proof"]["proved"] is False
        assert "never proved" in p["proof"]["premises"][-1 - sum(
            x["basis"] == "trusted" for x in p["proof"]["premises"])]["statement"]
    # The counterexample's file reproduces the search's figure, run in full.
    worst = separation["counterexamples"][0]
    replayed, _ = evaluate_drake(load_scenario(worst["scenario"]))
    assert replayed.separation == worst["robustness"] < 0.0


def test_verify_passes_iso_within_a_small_budget(tmp_path, cli):
    code, _, err = cli(["verify", MODELS / "configs" / "iso.yaml", "--space", SPACE_FILE,
                        "--out", tmp_path, "--budget", "8", "--workers", "1", "--quiet"])
    assert code == 0, err
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["verdict"] == "passed" and report["simulations"] == 8
    for p in report["properties"].values():
        assert p["verdict"] == "passed" and p["min_robustness"] > 0.0
        assert not p["counterexamples"] and p["proof"]["proved"] is False
    assert report["box"]["time_scale"] == [0.7, 1.3]
    # the shipped mapping places every body at its point (at_point): nothing to warn of
    assert ".pivot" not in err
    assert not any("neither pivot nor at_point" in a for a in report["assumptions"])


def test_verify_names_a_recorded_body_whose_pivot_is_unknown(tmp_path, cli):
    """A helmet reported at its markers' centroid (its mapping gives neither pivot nor
    at_point): verify says so in one line naming it and the 0.15 m pivot offset a proof's
    tracking allowance would have to cover, and the report's assumptions name it
    (issue 46)."""
    shutil.copytree(MODELS / "recordings", tmp_path / "recordings")
    text = SPACE_FILE.read_text().replace("../recordings/", "recordings/")
    (tmp_path / "recording.yaml").write_text(text)
    mapping = tmp_path / "recordings" / "approach_mapping.yaml"
    mapping.write_text(mapping.read_text().replace("streaming_id: 3, at_point: true",
                                                   "streaming_id: 3"))
    code, _, err = cli(["verify", MODELS / "configs" / "iso.yaml", "--space",
                        tmp_path / "recording.yaml", "--out", tmp_path / "v", "--budget", "2",
                        "--workers", "1", "--quiet"])
    assert code == 0, err
    warned = [line for line in err.splitlines() if ".pivot" in line]
    assert len(warned) == 1 and warned[0].startswith("safety-systems: warning: ")
    assert "operators[0].bodies[2].pivot: technician's Helmet (marking the head)" in warned[0]
    assert "may be 0.15 m off it" in warned[0]
    report = json.loads((tmp_path / "v" / "report.json").read_text())
    named = [a for a in report["assumptions"] if "neither pivot nor at_point" in a]
    assert len(named) == 1 and "technician's Helmet (head, up to 0.15 m off)" in named[0]
    assert "pivot offset of 0.15 m" in named[0]
    assert named[0] in (tmp_path / "v" / "report.md").read_text()


def test_tune_over_a_recording_space_needs_allow_passed(tmp_path, cli):
    code, out, err = cli(["tune", MODELS / "configs" / "iso.yaml", "--tune",
                          MODELS / "tune" / "ssm.yaml", "--space", SPACE_FILE, "--out",
                          tmp_path / "out"])
    assert code == 2 and out == "" and len(err.splitlines()) == 1
    assert "--allow: got 'proved'" in err and "never proved" in err
    assert not (tmp_path / "out").exists()


def test_the_certificate_gives_the_recorded_bodies_points_from_the_mapping(tmp_path):
    # A recording space's tracked bodies are the mapping's (its ``tracked`` keeps its
    # default, unused): the certificate's whole-cell figures and the assessor's page say
    # which body point each marks, each body by name. A mapping with other points shows
    # through.
    from verification.deploy.assessor_report import _bodies as in_words
    from verification.deploy.export import _bodies

    folder = tmp_path / "recordings"
    shutil.copytree(MODELS / "recordings", folder)
    shutil.copy(MODELS / "spaces" / "recording.yaml", tmp_path / "recording.yaml")
    text = (tmp_path / "recording.yaml").read_text().replace("../recordings/", "recordings/")
    (tmp_path / "recording.yaml").write_text(text)
    mapping = next(folder.glob("*mapping*.yaml"))
    mapping.write_text(mapping.read_text().replace("point: head", "point: chest"))
    space = load_space(tmp_path / "recording.yaml")
    bodies = _bodies(ISO, space)
    expected = {f"{o.name}/{b.name}": b.point for o in load_mapping(mapping).operators
                for b in o.bodies}
    assert bodies["tracked"] == expected and "chest" in expected.values()
    assert "technician/head (chest)" in in_words(bodies)
    default = _bodies(ISO, load_space(MODELS / "spaces" / "default.yaml"))
    assert default["tracked"] == ["hand_right", "hand_left", "head"]
    assert default["dimensions"]["upper_arm"] == ISO.body.upper_arm

def test_the_speed_premise_measures_the_part_of_the_recording_the_space_plays():
    """approach.csv: the technician stands for its first 2 s and walks at up to 1.59 m/s
    later; a space that plays only the first 2 s is measured over those (the premise of
    its hidden-body balls and its gate then asks what that motion needs)."""
    import dataclasses as dc

    from verification.spaces.recorded import played_window, recorded_speed

    block = SPACE.recording
    p = block.parameters
    still = dc.replace(p, time_shift=dc.replace(p.time_shift, min=0.0, max=0.0),
                       time_scale=dc.replace(p.time_scale, min=1.0, max=1.0))
    first = dc.replace(block, start=0.0, duration=2.0, parameters=still)
    assert played_window(first) == (0.0, 2.0)
    assert recorded_speed(first) < 0.2 < 1.5 < recorded_speed(block)
    # the box's shifts and scales widen the window: 3 s of shift, 2 s at 1.3x
    wide = dc.replace(block, start=0.0, duration=2.0)
    assert played_window(wide) == pytest.approx((0.0, 3.0 + 2.0 * 1.3))
    assert recorded_speed(wide) >= recorded_speed(first)
