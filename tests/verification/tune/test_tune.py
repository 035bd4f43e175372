"""``safety-systems tune``: the chosen configuration re-verifies with the same verdict, is
never slower than iso.yaml on the tuning scenarios, and the report compares it with
iso.yaml and the seed's; measured properties are refused."""

import dataclasses
import json
from pathlib import Path

import pytest

from safety_systems.outputs.metrics import task_time
from safety_systems.config.configuration import frame_timeout, with_controller
from safety_systems.config.scenario import load_controller_config, load_scenario
from safety_systems.diagrams.simulation import simulate
from verification.spaces.space import load_space, space_cell
from verification.verify import verify

MODELS = Path(__file__).parents[3] / "models"
ISO = MODELS / "configs" / "iso.yaml"
SMALL_SPACE = Path(__file__).parents[1] / "small_space.yaml"


def _result(tuned: Path) -> dict:
    return json.loads((tuned / "tune" / "tune.json").read_text())


def test_the_chosen_configuration_reverifies_with_the_same_verdict(tuned, tmp_path):
    result = _result(tuned)
    chosen = result["chosen"]
    assert chosen["verdict"] == "proved"
    config = load_controller_config(chosen["config"])
    # Another seed of the search, a fresh folder: the same verdict.
    outcome = verify(config, load_space(SMALL_SPACE), tmp_path, budget=6, workers=1, seed=1)
    assert outcome.verdict == chosen["verdict"]
    assert all(p.proof.proved for p in outcome.properties.values())


def test_the_robot_speed_term_is_tuned_and_exported(tuned):
    chosen = _result(tuned)["chosen"]
    value = chosen["values"]["safety.robot_speed"]
    assert value in ("directed", "fastest_point")
    assert load_controller_config(chosen["config"]).safety.robot_speed == value
    params = (tuned / "export" / "params.yaml").read_text()
    assert f'controller.safety.robot_speed: "{value}"' in params
    cert = json.loads((tuned / "export" / "certificate.json").read_text())
    assert cert["cell"]["monitor"]["robot_speed"] == value


def test_the_chosen_configuration_is_never_slower_than_iso_on_the_tuning_scenarios(tuned):
    result = _result(tuned)
    task = load_scenario(tuned / "task.yaml")
    task = dataclasses.replace(task, duration=60.0)
    # Measured again here from whole runs (not tune's early-stopping runs).
    times = {name: task_time(simulate(with_controller(task, load_controller_config(path))))
             for name, path in (("chosen", result["chosen"]["config"]), ("iso", ISO))}
    assert times["iso"] is not None and times["chosen"] is not None
    assert times["chosen"] <= times["iso"]
    rows = {r["configuration"]: r for r in result["table"]}
    assert rows["chosen"]["tasks"]["inspection"]["task_time"] == pytest.approx(
        times["chosen"], abs=1e-9)
    assert rows["iso.yaml"]["tasks"]["inspection"]["task_time"] == pytest.approx(
        times["iso"], abs=1e-9)


def test_the_report_compares_with_iso_and_the_seed_and_states_the_vacuous_share(tuned):
    result = _result(tuned)
    rows = {r["configuration"]: r for r in result["table"]}
    assert set(rows) == {"chosen", "iso.yaml", "seed_estimated.yaml"}
    assert rows["seed_estimated.yaml"]["verdict"] == "falsified"
    assert rows["iso.yaml"]["verdict"] == "proved"
    for row in rows.values():
        t = row["tasks"]["inspection"]
        assert t["lost_time"] == pytest.approx(t["task_time"] - t["no_operator"])
        assert set(row["vacuous"]) == {"contact", "separation"}
    markdown = (tuned / "tune" / "tune.md").read_text()
    assert "| chosen | proved | inspection |" in markdown
    assert "| seed_estimated.yaml | falsified | inspection |" in markdown
    # Every scenario of this small box is within iso.yaml's S of the robot: said in words.
    assert rows["iso.yaml"]["vacuous"]["contact"]["share"] == 1.0
    assert "iso.yaml, contact: 100% of the evaluated scenarios are vacuous" in markdown
    assert "safety-systems export" in markdown


def test_tune_shows_its_progress_phase_by_phase(tuned):
    """Without --quiet, tune draws a progress bar per phase on stderr (it runs for
    minutes), with each candidate's fate printed above it."""
    err = (tuned / "tune_stderr.txt").read_text()
    phases = ["tune: phase 1 of 6: verifying and timing 2 reference configurations "
              "(iso.yaml, seed_estimated.yaml) (about ",
              "tune: phase 2 of 6: screening ",
              " candidates: the counterexamples kept, then the proofs (about ",
              "tune: phase 3 of 6: refining the 3 best proved candidates by their proofs",
              "tune: phase 4 of 6: simulating the tasks of up to 4 candidates, verifying each "
              "one faster than the best so far (about ",
              "tune: phase 5 of 6: timing the chosen configuration's tasks (about ",
              "tune: phase 6 of 6: pricing 1 levers for the chosen configuration"]
    at = [err.find(p) for p in phases]
    assert -1 not in at and at == sorted(at), (at, err[:3000])
    assert " left in all)" in err and "step" in err
    out = (tuned / "tune_stdout.txt").read_text()
    assert "candidate 0:" in out and "time lost:" in out


def test_progress_prints_said_lines_above_its_bar_and_nothing_when_off(capsys):
    from verification.tune.tuner import Progress

    said = []
    with Progress(True, 2) as bar:
        bar.phase("a phase", 2, left=(100.0, 700.0))
        bar.step()
        bar.write("a line", said.append)
        bar.step()
    assert said == ["a line"] and ("tune: phase 1 of 2: a phase (about 2 min to 12 min left "
                                   "in all)") in capsys.readouterr().err
    with Progress(False, 2) as bar:
        bar.phase("a phase", 2)
        bar.step()
        bar.write("a line", said.append)
    assert said == ["a line", "a line"] and capsys.readouterr().err == ""


def test_counterexamples_are_kept_and_later_candidates_replayed_against_them(tuned):
    result = _result(tuned)
    kept = result["counterexamples"]
    assert kept and all(k["found_for"] == "seed_estimated.yaml" for k in kept)
    assert all(Path(k["file"]).is_file() for k in kept)
    screened = result["screen"]["points"]
    assert result["counts"]["counterexample_replays"] >= screened * len(kept) - len(kept)


def test_a_kept_counterexample_rejects_a_candidate_that_fails_it(tuned):
    from verification.search.runner import Runner
    from verification.tune.tuner import Candidate, Kept, Tuner

    result = _result(tuned)
    k = result["counterexamples"][0]
    scenario = load_scenario(k["file"])
    tuner = Tuner(load_controller_config(ISO), [], load_space(SMALL_SPACE), [],
                  tuned / "unused", space_path=str(SMALL_SPACE), workers=1)
    tuner.kept = [Kept(scenario, "seed", k["property"], k["robustness"], k["file"])]
    seed = load_controller_config(MODELS / "configs" / "seed_estimated.yaml")
    candidates = [Candidate(1, {}, tuner.cell_of(seed)),
                  Candidate(2, {}, tuner.cell_of(load_controller_config(ISO)))]
    with Runner(workers=1) as runner:
        tuner.recheck(runner, candidates)
    assert candidates[0].status == "counterexample" and k["file"] in candidates[0].reason
    assert candidates[1].status == "screened" and candidates[1].checked == 1


@pytest.mark.parametrize("name, needle", [
    ("sensor.rate_hz", "measured"), ("sensor.latency", "measured"),
    ("braking.stopping_time", "measured"), ("safety.stopping_distance", "measured"),
    ("tracker.exits", "layout"), ("type", "not a parameter"),
    ("safety.link_radii", "single number"), ("safety.nothing", "field of the configuration"),
])
def test_tune_refuses_measured_and_unknown_parameters(tmp_path, cli, name, needle):
    block = tmp_path / "tune.yaml"
    block.write_text(f"tune:\n- {{name: {name}, min: 0.1, max: 0.2}}\n")
    code, _, err = cli(["tune", ISO, "--tune", block, "--space", SMALL_SPACE, "--out",
                        tmp_path / "out"])
    assert code == 2 and needle in err and len(err.splitlines()) == 1
    assert name in err and str(block) in err
    assert not (tmp_path / "out").exists()


def test_the_tune_files_levers_are_priced_for_the_chosen_configuration(tuned):
    """The fixture's tune file has one lever (a banded suit at 120 Hz, cost 3): tune.json
    and tune.md give its fitted terms, proofs and time lost, and stdout says it."""
    result = json.loads((tuned / "tune" / "tune.json").read_text())
    (row,) = result["levers"]
    assert row["lever"] == {"sensor_set": "gloves+helmet+belt+elbows", "rate_hz": 120.0,
                            "latency": 0.02, "cost": 3.0, "stopping_name": "",
                            "braking": {"stop_category": 1, "speed_fraction": [],
                                        "stopping_time": [], "stopping_distance": []},
                            "stopping_time": None, "stopping_distance": None}
    assert row["proved"] and set(row["proofs"]) == {"contact", "separation"}
    chosen = load_controller_config(result["chosen"]["config"])
    assert row["frame_timeout"] < frame_timeout(chosen)  # 120 Hz against 20
    assert row["reaction_time"] <= chosen.safety.reaction_time
    assert row["total_lost"] == pytest.approx(sum(row["lost"].values()))
    iso = next(r for r in result["table"] if r["configuration"] == "iso.yaml")
    assert row["reduction"] == pytest.approx(1.0 - row["total_lost"] / iso["total_lost_time"])
    text = (tuned / "tune" / "tune.md").read_text()
    assert "## What sensing buys" in text and "| gloves+helmet+belt+elbows, 120 Hz, 20 ms | 3 |" \
        in text
    chosen_row = next(r for r in result["table"] if r["configuration"] == "chosen")
    won = chosen_row["total_lost_time"] - row["total_lost"]
    assert text.split("| gloves+helmet+belt+elbows, 120 Hz, 20 ms | 3 |")[1].split("\n")[0] \
        .endswith(f" | {won:.2f} | {won / 3.0:.2f} |")
    assert "lever gloves+helmet+belt+elbows, 120 Hz, 20 ms: proved, lost" in \
        (tuned / "tune_stdout.txt").read_text()


def test_the_report_says_what_holds_the_robot_under_the_chosen_configuration(tuned):
    """tune.json's chosen row and tune.md name, per task, the stop causes' seconds and the
    segment that held the robot, as simulate's summary does for the same run."""
    result = json.loads((tuned / "tune" / "tune.json").read_text())
    chosen = next(r for r in result["table"] if r["configuration"] == "chosen")
    (task,) = result["tasks"]
    held = chosen["held"][task]
    config = load_controller_config(result["chosen"]["config"])
    scenario = load_scenario(tuned / "task.yaml")
    from safety_systems.outputs.held import held_by

    assert held == json.loads(json.dumps(held_by(simulate(with_controller(scenario, config)))))
    text = (tuned / "tune" / "tune.md").read_text()
    assert "## What holds the robot under the chosen configuration" in text
    assert f"| {task} | {sum(held['causes'].values()):.1f} |" in text


def test_tune_refuses_levers_for_a_recorded_task(tmp_path, cli):
    block = tmp_path / "tune.yaml"
    block.write_text("tune:\n- {name: safety.d_min, min: 0.1, max: 0.2}\n"
                     "levers:\n- {sensor_set: full suit, rate_hz: 120}\n")
    code, _, err = cli(["tune", ISO, "--tune", block, "--space", SMALL_SPACE, "--tasks",
                        MODELS / "recordings" / "approach.yaml", "--out", tmp_path / "out"])
    assert code == 2 and len(err.splitlines()) == 1, err
    assert "levers" in err and "approach.yaml" in err and str(block) in err
    assert not (tmp_path / "out").exists()


def test_tune_refuses_an_unknown_sensor_set(tmp_path, cli):
    block = tmp_path / "tune.yaml"
    block.write_text("tune:\n- {name: safety.d_min, min: 0.1, max: 0.2}\n"
                     "levers:\n- {sensor_set: helmet only, rate_hz: 120}\n")
    code, _, err = cli(["tune", ISO, "--tune", block, "--space", SMALL_SPACE, "--out",
                        tmp_path / "out"])
    assert code == 2 and len(err.splitlines()) == 1, err
    assert "levers[0].sensor_set" in err and "helmet only" in err and "gloves+helmet" in err
    assert str(block) in err and not (tmp_path / "out").exists()


@pytest.mark.parametrize("entry, needle", [
    ("{name: safety.reaction_time, min: 0.05, max: 0.2}", "loop's own reaction time"),
    ("{name: tracker.frame_timeout, min: 0.06, max: 0.09}", "more than one sensor period"),
    ("{name: safety.d_min, min: 0.1, max: 9.0}", "d_min <= 5"),
    ("{name: safety.d_min, min: 0.3, max: 0.1}", "max >= min"),
    ("{name: safety.human_speed, choices: [iso, fast]}", "iso"),
    ("{name: safety.human_speed, min: 0.0, max: 1.0}", "choices"),
])
def test_tune_refuses_bad_bounds(tmp_path, cli, entry, needle):
    config = tmp_path / "config.yaml"
    config.write_text(ISO.read_text() + f"tune:\n- {entry}\n")  # the block in the config
    code, _, err = cli(["tune", config, "--space", SMALL_SPACE, "--out", tmp_path / "out"])
    assert code == 2 and needle in err and len(err.splitlines()) == 1, err
    assert str(config) in err


def test_refining_lowers_the_proxy_and_keeps_both_proofs(tmp_path):
    from verification.proof.theorems import prove, prove_separation
    from verification.tune.tuner import Candidate, Tuner, proxy_distance
    from verification.tune.tunable import load_tunable, with_values

    config, block = load_tunable(ISO, MODELS / "tune" / "ssm.yaml")
    space = load_space(MODELS / "spaces" / "default.yaml")
    tuner = Tuner(config, block, space, [], tmp_path, space_path="default.yaml")
    start = {"safety.human_speed": "iso", "safety.robot_speed": "fastest_point",
             "safety.stopping": "by_speed", "tracker.frame_timeout": 0.09,
             "safety.reaction_time": 0.15, "safety.intrusion_distance": 0.1,
             "safety.robot_uncertainty": 0.3, "safety.delta_s": 1.2, "safety.d_min": 0.2,
             "tracker.velocity_process_noise": 0.1}
    assert set(start) == {p.name for p in block}
    c = Candidate(1, start, space_cell(with_values(config, start), space))
    c.proxy = proxy_distance(c.cell)
    cell = c.cell
    assert prove(cell, space).proved and prove_separation(cell, space).proved
    refined = tuner.refine(c, 2)
    assert refined is not None and refined.proxy < c.proxy - 0.1
    assert refined.proxy == pytest.approx(proxy_distance(refined.cell))
    assert prove(space_cell(refined.config, space), space).proved
    assert prove_separation(space_cell(refined.config, space), space).proved
    # It went as far as the proofs let it: a little less Z_r no longer proves.
    z_r = refined.config.safety.robot_uncertainty
    assert z_r < 0.25
    tighter = dataclasses.replace(refined.config, safety=dataclasses.replace(
        refined.config.safety, robot_uncertainty=z_r - 0.01))
    assert not prove_separation(space_cell(tighter, space), space).proved
    # The frame timeout, on which the proxy does not depend, went to the end where the
    # proofs have more room, and T_r followed it down to the loop's own reaction time.
    assert refined.values["tracker.frame_timeout"] == 0.074
    assert refined.config.safety.reaction_time == pytest.approx(0.074 + 0.002)


def test_t_r_may_go_as_low_as_the_least_frame_timeout_the_block_allows():
    from safety_systems.files.input_error import InputError
    from verification.tune.tunable import TunedParameter, check_block

    config = load_controller_config(ISO)
    t_r = TunedParameter(name="safety.reaction_time", min=0.076, max=0.2)
    timeout = TunedParameter(name="tracker.frame_timeout", min=0.074, max=0.096)
    check_block([timeout, t_r], config, control_period=0.002)  # 0.074 + a tick
    with pytest.raises(InputError, match="loop's own reaction time"):
        check_block([t_r], config, control_period=0.002)  # iso.yaml's own: 0.096 + a tick
    with pytest.raises(InputError, match="loop's own reaction time"):
        check_block([dataclasses.replace(timeout, min=0.08), t_r], config,
                    control_period=0.002)
