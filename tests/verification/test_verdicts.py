"""Verdicts never more confident than their evidence: disagreements are ``inconclusive``,
every evaluator runs the space's robot mode, ``--require`` and the exit-code table, and
the vacuous share of the box."""

import dataclasses
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

import verification.search.runner as runner_module
import verification.verify as verify_module
from safety_systems.cli import main
from safety_systems.config.scenario import load_controller_config, load_scenario
from safety_systems.diagrams.simulation import simulate
from verification.search.evaluate_batch import evaluate_batch, evaluate_many
from verification.search.evaluate_drake import evaluate_drake, robustness_of_run
from verification.proof.theorems import Proof
from verification.report import vacuous_warnings
from verification.search.strategies import SearchLog
from verification.spaces.space import free_parameters, load_space, make_scenario, to_point
from verification.verdicts import EXIT_TABLE, REQUIREMENTS, VERDICTS, exit_code
from verification.verify import disagreements, replay_choice

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
SPACE = str(MODELS / "spaces" / "default.yaml")
ISO = str(MODELS / "configs" / "iso.yaml")
SEED = str(MODELS / "configs" / "seed_estimated.yaml")
PLANTED = -0.25  # m: the violation the perturbed batched evaluator invents


def _documented_exit_table() -> dict:
    """The documentation's exit-code table of verify (docs/explanation/verification.md,
    moved there from the README): {row: {require: code}}."""
    text = (ROOT / "docs" / "explanation" / "verification.md").read_text()
    head = re.search(r"^\| verdict \|(.*)\|$", text, re.M)
    requires = re.findall(r"`--require (\w+)`", head.group(1))
    rows = {}
    for line in text[head.end():].lstrip("\n").splitlines():
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in line.strip("|").split("|")]
        if set(cells[0]) <= set("-"):
            continue
        rows[cells[0].strip("`")] = dict(zip(requires, map(int, cells[1:])))
    return rows


def _verify(config, out, *more, space=SPACE, budget="6"):
    return main(["verify", str(config), "--space", str(space), "--out", str(out), "--budget",
                 budget, "--workers", "1", "--quiet", *more])


def _report(out) -> dict:
    return json.loads((Path(out) / "report.json").read_text())


def _contact(out) -> dict:
    """The contact property's part of the report."""
    return _report(out)["properties"]["contact"]


def _inf(x):
    return math.inf if x is None else x


# --- the exit-code table --------------------------------------------------------------

def test_the_documented_table_is_the_exit_code_rule_and_the_help_lists_it(capsys):
    table = _documented_exit_table()
    assert set(table) == set(VERDICTS) | {"bad input (one line naming the file or option)"}
    for verdict in VERDICTS:
        assert set(table[verdict]) == set(REQUIREMENTS)
        for require, code in table[verdict].items():
            assert exit_code(verdict, require) == code, (verdict, require)
    assert set(table["bad input (one line naming the file or option)"].values()) == {2}
    # Only a passed verdict under --require proved changes the code.
    assert table["passed"]["proved"] not in {table[v]["none"] for v in VERDICTS} | {2}
    with pytest.raises(SystemExit):
        main(["verify", "--help"])
    shown = capsys.readouterr().out
    assert EXIT_TABLE.splitlines()[0] in shown and "--require {proved,passed,none}" in shown
    codes = {int(c) for c in re.findall(r"^  (\d)  ", EXIT_TABLE, re.M)}
    assert codes == {c for row in table.values() for c in row.values()}


def _dynamic_space(tmp_path) -> Path:
    text = Path(SPACE).read_text()
    assert "  mode: kinematic\n" in text
    path = tmp_path / "dynamic.yaml"
    path.write_text(text.replace("  mode: kinematic\n", "  mode: dynamic\n"))
    return path


@pytest.mark.parametrize("verdict", ["proved", "passed", "falsified"])
def test_each_verdict_exits_as_the_table_says(tmp_path, verdict):
    # A run per verdict, then the same --out again under each --require (the search is
    # resumed from its cache; the proof and the Drake replays run again).
    config, space, more = {"proved": (ISO, SPACE, []),
                           "passed": (ISO, _dynamic_space(tmp_path), []),  # no proof there
                           "falsified": (SEED, SPACE, ["--seed", "1"])}[verdict]
    budget = {"passed": "3", "falsified": "32"}.get(verdict, "6")
    table = _documented_exit_table()[verdict]
    for require in REQUIREMENTS:
        code = _verify(config, tmp_path / "out", "--require", require, *more, space=space,
                       budget=budget)
        assert _report(tmp_path / "out")["verdict"] == verdict
        assert code == table[require], require


@pytest.mark.parametrize("require", REQUIREMENTS)
def test_bad_input_exits_2_under_every_require(tmp_path, capsys, require):
    code = _verify(ISO, tmp_path, "--require", require, "--seed", "-1")
    err = capsys.readouterr().err.strip().splitlines()
    assert code == _documented_exit_table()["bad input (one line naming the file or option)"][
        require] and len(err) == 1 and "--seed" in err[0]


# --- planted disagreements: inconclusive ----------------------------------------------

@pytest.fixture
def batch_invents_a_violation(monkeypatch):
    """The batched evaluator, perturbed: the first scenario of every chunk it evaluates
    is reported as a violation of ``PLANTED`` m (the Drake diagram is left alone)."""
    real = runner_module._evaluate_chunk

    def perturbed(chunk, cell=None):
        figures = real(chunk, cell)
        figures[0, 0] = PLANTED
        return figures

    monkeypatch.setattr(runner_module, "_evaluate_chunk", perturbed)


def test_a_search_violation_drake_does_not_reproduce_is_inconclusive(
        tmp_path, capsys, batch_invents_a_violation):
    out = tmp_path / "planted"
    code = _verify(ISO, out)
    report, contact = _report(out), _contact(out)
    # iso.yaml is proved on this space, so the proof contradicts the search too.
    assert report["verdict"] == "inconclusive" and contact["proof"]["proved"]
    assert contact["verdict"] == "inconclusive"
    assert report["properties"]["separation"]["verdict"] == "proved"  # left alone
    assert code == _documented_exit_table()["inconclusive"]["none"] == 3
    assert contact["counterexamples"] == [] and contact["unconfirmed_counterexamples"]
    assert contact["disagreements"]  # one per chunk the search evaluated
    for d in contact["disagreements"]:
        assert d["robustness"] == PLANTED and _inf(d["drake_robustness"]) >= 0.0
        assert d["proof"] == "proved" and len(d["conflicts"]) == 2
    d = contact["disagreements"][0]
    # The file reproduces the Drake side of it through the simulate pipeline.
    assert Path(d["scenario"]).parent.name == "disagreements"
    run = simulate(load_scenario(d["scenario"]))
    assert robustness_of_run(run).stopped_before_contact == _inf(d["drake_robustness"])
    # Both figures side by side, with the file, in report.md and on the console.
    markdown = (out / "report.md").read_text()
    assert markdown.startswith("# Verification: INCONCLUSIVE")
    drake = "+inf" if d["drake_robustness"] is None else f"{d['drake_robustness']:.4f}"
    row = f"| proved | {PLANTED:.4f} | {drake} |"
    assert any(line.startswith(row) and d["scenario"] in line for line in markdown.splitlines())
    err = capsys.readouterr().err
    assert f"contact: search robustness {PLANTED:.4f} m, Drake {drake} m" in err
    assert d["scenario"] in err


def test_a_drake_violation_the_search_missed_is_inconclusive(tmp_path, monkeypatch):
    # The other way round: the Drake replays perturbed to violate by 0.1 m where the
    # batched evaluator (and the proof) find every scenario safe.
    real = verify_module.evaluate_drake

    def violating(scenario, **kw):
        rho, run = real(scenario, **kw)
        return dataclasses.replace(rho, stopped_before_contact=-0.1), run

    monkeypatch.setattr(verify_module, "evaluate_drake", violating)
    out = tmp_path / "drake"
    assert _verify(ISO, out, "--property", "contact") == 3
    report, contact = _report(out), _contact(out)
    assert report["verdict"] == "inconclusive"
    assert contact["disagreements"] and all(
        d["drake_robustness"] == -0.1 and _inf(d["robustness"]) >= 0.0
        and "the Drake diagram violates where the search did not" in d["conflicts"]
        and Path(d["scenario"]).exists() for d in contact["disagreements"])
    assert len(contact["disagreements"]) == len(contact["drake_replays"])


def test_an_unconfirmed_violation_beside_confirmed_ones_is_still_inconclusive(
        tmp_path, monkeypatch):
    # The seed's configuration is falsified on this space; plant a violation on the
    # safest scenario of the first chunk (later ones would crowd the worst-first replays
    # with planted ones): confirmed counterexamples stay listed, but the verdict cannot
    # be "falsified" while the evaluators contradict each other.
    real = runner_module._evaluate_chunk
    planted = []

    def perturbed(chunk, cell=None):
        figures = real(chunk, cell)
        if not planted:
            figures[0, int(np.argmax(figures[0]))] = -5.0
            planted.append(True)
        return figures

    monkeypatch.setattr(runner_module, "_evaluate_chunk", perturbed)
    out = tmp_path / "seed"
    assert _verify(SEED, out, "--seed", "1", "--property", "contact", budget="32") == 3
    report, contact = _report(out), _contact(out)
    assert report["verdict"] == "inconclusive" and not contact["proof"]["proved"]
    assert contact["counterexamples"]
    assert all(c["drake_robustness"] < 0.0 for c in contact["counterexamples"])
    assert any(d["robustness"] == -5.0 and _inf(d["drake_robustness"]) >= 0.0
               for d in contact["disagreements"])


def _proof(proved: bool) -> Proof:
    return Proof(proved, "", {}, [], None, {})


@pytest.mark.parametrize("proved, search, drake, conflicts", [
    (False, 0.3, 0.3, 0),
    (False, math.inf, math.inf, 0),
    (False, -0.2, -0.2, 0),  # falsified: both evaluators agree
    (False, -0.2, 0.1, 1),
    (False, 0.1, -0.2, 1),
    (True, 0.3, 0.3, 0),
    (True, -0.2, -0.2, 1),  # both violate where the proof says none does
    (True, -0.2, math.inf, 2),
    (True, math.inf, -0.2, 2),
])
def test_what_counts_as_a_disagreement(proved, search, drake, conflicts):
    replay = {"robustness": search, "drake_robustness": drake, "simulation": 1,
              "scenario": "x.yaml"}
    found = disagreements(_proof(proved), [replay])
    assert sum(len(d["conflicts"]) for d in found) == conflicts
    for d in found:
        assert (d["robustness"], d["drake_robustness"], d["scenario"]) == (search, drake,
                                                                          "x.yaml")


def test_replays_take_the_worst_violations_then_a_random_sample():
    log = SearchLog()
    rho = [0.5, -0.1, math.inf, -0.3, 0.2, math.inf, 0.05, -0.1, 0.7, 0.9, 1.0]
    for i, r in enumerate(rho):
        log.points.append([i / 10.0] if i != 7 else [0.1])  # 7 repeats 1's point
        log.figures.append([r, 0.0, 0.0, 0.0])
    chosen = replay_choice(log, seed=3)
    assert chosen[:2] == [(3, "violation"), (1, "violation")]
    sample = [i for i, why in chosen if why == "sample"]
    assert len(sample) == verify_module.CROSS_CHECK and len(set(sample)) == len(sample)
    assert all(rho[i] >= 0.0 for i in sample) and 7 not in sample
    assert chosen == replay_choice(log, seed=3) and chosen != replay_choice(log, seed=4)
    safe = SearchLog([[0.0], [0.5]], [[math.inf] * 4, [0.4, 0, 0, 0]])
    assert replay_choice(safe, seed=0)[0] == (1, "worst")


# --- the robot mode -------------------------------------------------------------------

def test_the_batched_evaluator_refuses_a_dynamic_robot_and_evaluate_many_runs_drake():
    space = load_space(SPACE)
    config = load_controller_config(ISO)  # its contact terms, which let the robot move nearer
    config = dataclasses.replace(config, safety=dataclasses.replace(config.safety,
                                                                    robot_uncertainty=0.0))
    dynamic = dataclasses.replace(space, robot=dataclasses.replace(space.robot,
                                                                   mode="dynamic"))
    rng = np.random.default_rng(11)
    d = len(free_parameters(space))
    # Scenarios where the robot moves near a body, so the mode can show in the figure.
    for _ in range(40):
        values = to_point(space, rng.uniform(size=d))
        kinematic = evaluate_batch([make_scenario(space, config, values)]).robustness[0]
        if math.isfinite(kinematic):
            break
    assert math.isfinite(kinematic)
    scenario = make_scenario(dynamic, config, values)
    with pytest.raises(ValueError, match="kinematic robot only"):
        evaluate_batch([scenario])
    many = evaluate_many([scenario]).robustness[0]
    assert many == evaluate_drake(scenario)[0].stopped_before_contact
    assert many != kinematic  # the plant's tracking error shows: the mode was honoured


def test_a_dynamic_space_is_searched_and_replayed_dynamic_and_not_proved(tmp_path):
    out = tmp_path / "dynamic"
    assert _verify(ISO, out, space=_dynamic_space(tmp_path), budget="3") == 0
    report = _report(out)
    assert report["verdict"] == "passed" and report["robot_mode"] == "dynamic"
    for p in report["properties"].values():
        proof = p["proof"]
        assert proof["covers_robot_mode"] == "kinematic" and not proof["proved"]
        failed = [x["statement"] for x in proof["premises"] if not x["holds"]]
        assert len(failed) == 1 and "robot.mode: dynamic" in failed[0]
        # The search ran the diagram in dynamic mode: its figures are Drake's, exactly.
        assert p["drake_replays"]
        for r in p["drake_replays"]:
            assert r["robustness"] == r["drake_robustness"]
    assert "robot mode: dynamic" in (out / "report.md").read_text()


def test_an_unknown_robot_mode_exits_2_with_one_line(tmp_path, capsys):
    bad = tmp_path / "space.yaml"
    bad.write_text(Path(SPACE).read_text().replace("  mode: kinematic\n", "  mode: rigid\n"))
    code = _verify(ISO, tmp_path / "out", space=bad)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "robot.mode" in err[0] and "rigid" in err[0]


# --- the vacuous share ----------------------------------------------------------------

def test_vacuous_share_of_a_sobol_sweep_is_reported_and_said_in_words(tmp_path, capsys):
    out = tmp_path / "sobol"
    assert _verify(ISO, out, "--method", "sobol", "--property", "contact", budget="32") == 0
    report = _contact(out)
    figures = [json.loads(line)["figures"][0]
               for line in (out / "evaluations.jsonl").read_text().splitlines()]
    vacuous = report["vacuous"]
    assert vacuous["evaluated"] == {"share": np.isinf(figures).mean(),
                                    "vacuous": int(np.isinf(figures).sum()), "of": 32}
    drake = [r["drake_robustness"] for r in report["drake_replays"]]
    assert vacuous["drake_replays"]["vacuous"] == drake.count(None)
    assert vacuous["drake_replays"]["of"] == len(drake) > 1
    # More than half of this box never moves the robot near anyone (the figure).
    assert vacuous["evaluated"]["share"] > 0.5
    words = "contact: more than half of the evaluated scenarios"
    assert words in (out / "report.md").read_text() and words in capsys.readouterr().err


@pytest.mark.parametrize("evaluated, drake, said", [
    ((16, 32), (3, 6), 0),  # exactly one half: not above it
    ((17, 32), (3, 6), 1),
    ((17, 32), (4, 6), 2),
    ((0, 32), (0, 0), 0),
])
def test_vacuous_words_only_above_one_half(evaluated, drake, said):
    def share(k, n):
        return {"share": k / n if n else None, "vacuous": k, "of": n}

    report = {"properties": {"contact": {
        "verdict": "proved", "vacuous": {"definition": "never moved", "evaluated":
                                         share(*evaluated), "drake_replays": share(*drake)}}}}
    assert len(vacuous_warnings(report)) == said
