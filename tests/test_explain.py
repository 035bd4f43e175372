"""``safety-systems explain``: the resolved terms of a configuration or a params.yaml as
tables, their figures the monitor's (``outputs.explanation``), bad input in one line."""

import contextlib
import dataclasses
import io
import json
from pathlib import Path

import numpy as np
import pytest

from safety_systems.cli import main
from safety_systems.config.params_file import (
    Params,
    deployed_controller,
    deployed_robot,
    params_text,
)
from safety_systems.config.resolved_cell import resolve
from safety_systems.config.scenario import RobotConfig, load_controller_config
from safety_systems.outputs.explanation import level_distances, segment_figures
from safety_systems.ssm.formulas import level_at_or_above

MODELS = Path(__file__).parents[1] / "models"
ISO, TUNED = MODELS / "configs" / "iso.yaml", MODELS / "configs" / "tuned.yaml"


def _cli(*argv) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in argv])
    return code, out.getvalue(), err.getvalue()


def _row(text: str, segment: str) -> list[str]:
    return next(line.split() for line in text.splitlines() if line.startswith(segment + " "))


@pytest.mark.parametrize("path", [ISO, TUNED])
def test_explain_prints_each_segments_s_and_what_dominates(path):
    code, out, err = _cli("explain", path)
    assert code == 0, err
    cell = resolve(load_controller_config(path), names=["operator"])
    figures = {(f.segment, f.rate): f for f in segment_figures(cell)}
    for segment in cell.segment_names:
        row = _row(out, segment)
        shown = [float(x) for x in row[-8::2]]  # "S word" at k = 1, 0.6, 0.4, 0.2
        assert shown == [round(figures[segment, k].s, 3) for k in (1.0, 0.6, 0.4, 0.2)]
        assert row[-7] == "human"  # v_H (T_s + T_r) is the largest term of both
    assert "stopping data: placeholder" in out and "trusted: stopping data" in out
    assert "trusted: hand speed" in out and "trusted: sensor noise" in out


def test_explains_s_at_a_rate_is_the_monitors_function_of_its_terms(tmp_path):
    # tuned.yaml, S by speed: at k = 0.4 (level 26) the stop from that level, T_r's robot
    # term at 0.4 V_R and v_H = 2.0 m/s, by the monitor's body_protective_distance.
    code, _, err = _cli("explain", TUNED, "--rates", 0.4, "--json", tmp_path / "e.json")
    assert code == 0, err
    data = json.loads((tmp_path / "e.json").read_text())
    cell = resolve(load_controller_config(TUNED))
    hand = next(r for r in data["segments"] if r["segment"] == "operator/hand_right")
    g = int(level_at_or_above(0.4, 64))
    assert hand["level"] == g == 26
    expected = level_distances(cell, 2.0, 0.4 * cell.speed_bound)[g]
    assert hand["S"] == pytest.approx(float(expected), abs=1e-12)
    f = cell.config.safety
    by_hand = (2.0 * (cell.level_stops[0][g] + f.reaction_time)
               + 0.4 * cell.speed_bound * f.reaction_time + cell.level_stops[1][g]
               + f.intrusion_distance + f.human_uncertainty + f.robot_uncertainty)
    assert hand["S"] == pytest.approx(by_hand, abs=1e-9)  # Eq. 1, term by term
    assert sum(hand["terms"][t] for t in ("human speed x time", "robot speed x T_r",
                                          "stopping distance", "C", "Z_d + Z_r")) \
        == pytest.approx(hand["S"], abs=1e-12)
    # the override's command: slower where S by speed allows it, a stop inside S
    commands = np.array(data["commands"])
    assert commands.shape == (1, 5) and commands[0, 0] == 0.0 and commands[0, -1] == 1.0


def test_a_params_yaml_brings_its_robot_and_is_explained_when_uncertified(tmp_path):
    config = load_controller_config(TUNED)
    robot = dataclasses.replace(RobotConfig(model="ur10e"))
    params = tmp_path / "params.yaml"
    params.write_text(params_text(Params(controller=deployed_controller(config),
                                         robot=deployed_robot(robot, tmp_path))))
    code, out, err = _cli("explain", params)
    assert code == 0, err
    assert "NOT CERTIFIED (explained all the same)" in err and "certificate.json" in err
    assert out.startswith("robot ur10e;")
    direct = _cli("explain", TUNED, "--robot", "ur10e")[1]
    assert out == direct  # the same terms: the params.yaml's robot is the UR10e


@pytest.mark.parametrize("argv, words", [
    (["explain", "no/such.yaml"], "no/such.yaml"),
    (["explain", ISO, "--robot", "ur99"], "--robot: got 'ur99'"),
    (["explain", ISO, "--rates", "1.5"], "--rates: got 1.5"),
    (["explain", ISO, "--robot", "ur10e", "--space", MODELS / "spaces" / "default.yaml"],
     "--robot: got 'ur10e'; allowed: omitted with --space"),
])
def test_bad_input_is_one_line_and_exit_2(argv, words):
    code, out, err = _cli(*argv)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and words in err


def test_a_bad_field_names_the_file(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(ISO.read_text().replace("reaction_time: 0.20", "reaction_time: -1"))
    code, _, err = _cli("explain", bad)
    assert code == 2 and err.count("\n") == 1
    assert str(bad) in err and "reaction_time" in err
