"""Every evaluation of a model of the loop is counted, and ``--stop-at-first`` stops."""

import json
from pathlib import Path

import numpy as np
import pytest

import verification.search.ranking as ranking_module
import verification.search.runner as runner_module
import verification.search.strategies as search_module
import verification.verify as verify_module
from safety_systems.cli import main
from safety_systems.config.scenario import load_controller_config
from verification.search.counts import COST, Tally
from verification.report import write_report
from verification.spaces.space import load_space
from verification.verify import verify

MODELS = Path(__file__).parents[3] / "models"
SPACE = load_space(MODELS / "spaces" / "default.yaml")


class Counting:
    """Wraps the evaluators verify reaches (the batched simulations, both rankings and
    the Drake diagram) and counts what each call evaluates (and prices it); after every batch of
    simulations it notes the counts so far and which properties the batch violated."""

    def __init__(self, monkeypatch):
        self.counts = {"simulations": 0, "margins": 0, "dangers": 0, "drake": 0}
        self.batches = []  # (counts after the batch, contact violated, separation violated)
        chunk, bound = runner_module._evaluate_chunk, search_module.bound_scores
        danger, drake = search_module.danger_scores, verify_module.evaluate_drake

        def counted_chunk(scenarios, cell=None):
            figures = chunk(scenarios, cell)
            self.counts["simulations"] += len(scenarios)
            self.batches.append((dict(self.counts), bool((figures[0] < 0).any()),
                                 bool((figures[2] < 0).any())))
            return figures

        def ranking(fn, kind):
            def counted(space, config, points, **kw):
                self.counts[kind] += len(points)
                return fn(space, config, points, **kw)
            return counted

        def counted_drake(scenario, **kw):
            self.counts["drake"] += 1
            return drake(scenario, **kw)

        monkeypatch.setattr(runner_module, "_evaluate_chunk", counted_chunk)
        monkeypatch.setattr(search_module, "bound_scores", ranking(bound, "margins"))
        monkeypatch.setattr(ranking_module, "bound_scores",
                            ranking(bound, "margins"))  # (margin_corner's)
        monkeypatch.setattr(search_module, "danger_scores", ranking(danger, "dangers"))
        monkeypatch.setattr(verify_module, "evaluate_drake", counted_drake)

    def total(self) -> dict:
        return _priced(self.counts)

    def at_first(self, column: int) -> dict:
        """The counts after the first batch that violated contact (0) or separation (1)."""
        return _priced(next(c for c, *bad in self.batches if bad[column]))


def _priced(counts: dict) -> dict:
    """Counts with their total and their cost in simulation-equivalents, the search's
    and with the Drake runs: each count times its kind's price (``counts.COST``)."""
    search = sum(COST[k] * counts[k] for k in ("simulations", "margins", "dangers"))
    return {**counts, "total": sum(counts.values()), "search_cost": round(search, 3),
            "cost": round(search + COST["drake"] * counts["drake"], 3)}


def test_report_counts_equal_the_evaluator_calls(tmp_path, monkeypatch):
    calls = Counting(monkeypatch)
    config = load_controller_config(MODELS / "configs" / "iso_previous.yaml")
    out = tmp_path / "previous"
    # (a budget of 240: the reduced model runs from MIN_DANGER candidates, 224 and more)
    outcome = verify(config, SPACE, out, budget=240, workers=1, seed=2, candidates=256)
    report = write_report(outcome, out, config_path="iso_previous.yaml",
                          space_path="default.yaml", replay=False)
    assert json.loads((out / "report.json").read_text())["evaluations"] == report["evaluations"]
    # All four kinds were used, and the report's counts are the calls made.
    assert min(calls.counts.values()) > 0
    assert report["evaluations"] == calls.total()
    # the run's seconds are recorded (what they are is the benchmarks' business)
    assert all(type(report[k]) is float for k in ("cpu_seconds", "wall_seconds"))
    assert calls.counts["simulations"] <= report["simulations"] <= 240  # (repeats: cached)
    assert report["evaluations"]["search_cost"] <= 240  # the budget bounds them all
    for column, name in enumerate(("contact", "separation")):
        first = report["properties"][name]["first_counterexample"]
        assert first["found"]["evaluations"] == calls.at_first(column), name
        assert first["found"]["evaluations"]["total"] <= report["evaluations"]["total"]
        confirmed = first["confirmed"]
        assert 1 <= confirmed["evaluations"]["drake"] <= calls.counts["drake"]
        assert confirmed["evaluations"]["simulations"] == calls.counts["simulations"]
        # confirmed after it was found: by then a Drake run more had been made
        assert confirmed["evaluations"]["total"] > first["found"]["evaluations"]["total"]
        assert confirmed["evaluations"]["drake"] > first["found"]["evaluations"]["drake"]
    markdown = (out / "report.md").read_text()
    assert f"{calls.total()['total']} in all" in markdown
    assert "first counterexample confirmed in the Drake diagram after" in markdown


def test_tally_counts_by_kind_and_refuses_unknown_kinds():
    tally = Tally()
    tally.add("simulations", 3)
    tally.add("margins", 500)
    tally.add("dangers", 2)
    tally.add("drake")
    assert tally.evaluations() == {"simulations": 3, "margins": 500, "dangers": 2, "drake": 1,
                                   "total": 506, "search_cost": 3 + 2.0 + 7.0,
                                   "cost": 12.0 + COST["drake"]}
    with pytest.raises(ValueError, match="kind"):
        tally.add("rankings")
    with pytest.raises(ValueError, match="kind"):
        tally.add("proofs")


def test_stop_at_first_returns_at_the_first_confirmed_counterexample(tmp_path, monkeypatch):
    calls = Counting(monkeypatch)
    out = tmp_path / "seed"
    code = main(["verify", str(MODELS / "configs" / "seed_estimated.yaml"), "--space",
                 str(MODELS / "spaces" / "default.yaml"), "--out", str(out), "--budget", "200",
                 "--workers", "1", "--quiet", "--stop-at-first"])
    report = json.loads((out / "report.json").read_text())
    assert code == 1 and report["verdict"] == "falsified"
    name = report["stopped_at_first"]
    assert name in ("contact", "separation")
    stopped = report["properties"][name]
    # One Drake run: the first violation the search found, confirmed; nothing after it.
    assert calls.counts["drake"] == 1 and report["evaluations"] == calls.total()
    assert len(stopped["counterexamples"]) == 1 and len(stopped["drake_replays"]) == 1
    assert stopped["counterexamples"][0]["drake_robustness"] < 0.0
    assert stopped["counterexamples"][0]["drake_stopped_at"] is not None  # cut short
    assert stopped["first_counterexample"]["confirmed"]["evaluations"] == calls.total()
    # The search ended with the batch that held it: 200 was the budget.
    assert len(calls.batches) == 1  # the opening batch held it
    assert report["simulations"] == calls.counts["simulations"] <= 8
    assert set(report["unchecked_properties"]) | set(report["properties"]) == {
        "contact", "separation"}
    assert "stopped at the first confirmed counterexample" in (out / "report.md").read_text()


def test_workers_cpu_time_is_counted():
    from verification.search.runner import Runner
    from verification.spaces.space import make_scenario, to_point

    config = load_controller_config(MODELS / "configs" / "seed_estimated.yaml")
    scenarios = [make_scenario(SPACE, config, to_point(SPACE, u))
                 for u in np.linspace(0.1, 0.9, 6)[:, None].repeat(20, axis=1)]
    tally = Tally()
    with Runner(workers=2, chunk=3, tally=tally) as runner:
        runner.evaluate(scenarios)
        runner.evaluate(scenarios)  # (read back: not evaluated again)
    assert tally.simulations == 6 and tally.worker_cpu > 0.0
    assert tally.cpu_seconds() >= tally.worker_cpu
