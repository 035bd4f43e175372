"""Speed and sample efficiency of the verification layer, measured in one run.

    python benchmarks/bench_verify.py [--seeds 10] [--budgets 200,4096] [--batch 512]
        [--parts throughput,proof,search,fraction,costs] [--configs seed,subtle,contact]
        [--searches ours,UniformRandom,DualAnnealing]

Prints, each beside its goal:
1. the batched evaluator's throughput in 10-second scenarios per second on one core,
   measuring both properties ("stopped before contact" and the separation invariant)
   (after a small warm-up batch has loaded the compiled code): the whole cell (the iso
   configuration, the robot as capsules, two operators of 12 segments each (gloves
   and helmet tracked, the rest bounded by their envelopes) over the default space)
   beside the tool point (the seed's configuration, one operator of 12 segments with its
   two gloves tracked, over the flange space), and the ratio to the Drake diagram on the
   whole-cell scenarios; and
   the same whole-cell measure of the three-ball operator (two gloves and a head: its
   last commit, checked out in a temporary git worktree and measured in a child process
   right after) with the whole operator's price as the ratio of the two (issue 31:
   at most 2x), and of issue 33's reference commit (177f5a8, three balls too) with this
   code's ratio to it (issue 33: above 1); each commit's figure beside its ratio to its
   own tool point and to this run's Drake diagram (those ratios carry from machine to
   machine, the absolute figures move about 30%); and this code's closed loop alone (a
   copy whose batched evaluator never computes the true properties: the most any change
   to their computation alone can give) beside issue 33's reference;
2. the wall time to prove the iso configuration over the default space (the proof
   alone, and ``verify`` with a 64-simulation cross-check on 2 workers);
3. time to the first counterexample (``search``), at verify's default budget (200) and
   at 4096 (``--budgets``, in simulation-equivalents: ``verification.search.counts``),
   for the seed's configuration, a subtly unsafe one (``benchmarks/subtle_unsafe.yaml``,
   separation) and a contact mutant (``benchmarks/contact_unsafe.yaml``) over the
   default space, both properties searched as ``verify`` does, ``--seeds`` searches
   each, in this process (one core; the compiled code loaded first, not timed): for this
   project's falsifier and for psy-taliro's UniformRandom and DualAnnealing (the
   ``bench`` extra: ``pip install -e '.[bench]'``) on the same batched evaluator and the
   same box, one scenario per evaluation, with the same budget in evaluations, stopping
   at the first cost below 0 (the smallest robustness of the two properties):
   falsified out of ``--seeds``, psy-taliro's also within this project's CPU time on
   the same seed (at the same CPU time), the median cost to the first counterexample
   (for this project every evaluation of any model in order, priced: the candidates
   ranked before it and the simulations up to it; a search that found none counts as
   the budget + 1) and the median CPU seconds until it was found (for this project,
   when the batch that held it was done), and the ratios (where no search can do
   better, every seed falsified or each found at its first evaluation, a tie is
   printed as one, not as ahead); then the Drake diagram's wall time to confirm this
   project's first counterexample (the run stops a quarter second after the violation
   shows) beside the whole run's;
4. how much of the default space the subtle configuration and the contact mutant leave
   unsafe (``fraction``: 16384 Sobol points simulated);
5. what each kind of evaluation costs in simulations (``costs``), beside the prices a
   budget uses.

Run it on an otherwise idle machine, pinned to one core (``taskset -c 0``). The
throughput is one core's, timed as this process' CPU time (so other work on the machine
slows it less than it would a wall clock, but still shares the caches), the best of
``REPEATS`` runs of the same batch, the three-ball operator's by the same function.
"""

import argparse
import dataclasses
import inspect
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from safety_systems.config.scenario import load_controller_config
from verification.search.evaluate_batch import evaluate_many
from verification.search.evaluate_drake import evaluate_drake
from verification.proof.theorems import prove
from verification.search.counts import COST
from verification.search.runner import Runner
from verification.search.strategies import falsify, sweep_points
from verification.spaces.space import (
    free_parameters,
    load_space,
    make_scenario,
    space_cell,
    to_point,
)
from verification.verify import verify

ROOT = Path(__file__).parents[1]
SPACE = load_space(ROOT / "models" / "spaces" / "default.yaml")
FLANGE = load_space(ROOT / "models" / "spaces" / "flange.yaml")
SEED = load_controller_config(ROOT / "models" / "configs" / "seed_estimated.yaml")
ISO = load_controller_config(ROOT / "models" / "configs" / "iso.yaml")
# iso.yaml's contact terms alone (without the Z_r the separation invariant asks for):
# with it the robot is at rest near bodies in most scenarios, and scenarios at rest cost
# little, which would flatter the throughput. The whole-cell throughput is taken on this.
ISO_MOVING = dataclasses.replace(ISO, safety=dataclasses.replace(ISO.safety,
                                                                 robot_uncertainty=0.0))
SUBTLE = load_controller_config(ROOT / "benchmarks" / "subtle_unsafe.yaml")
CONTACT = load_controller_config(ROOT / "benchmarks" / "contact_unsafe.yaml")
DEFAULT_BUDGET = 200  # verify's


# The figures of this run, as --json writes them: every printed row, and the search's,
# costs', fraction's, proof's and confirmation's figures by name.
FIGURES: dict = {"rows": []}


def _row(name: str, figure: str, goal: str, meets: bool | None) -> None:
    verdict = "" if meets is None else ("yes" if meets else "NO")
    print(f"{name:72s} {figure:>14s} {goal:>12s} {verdict:>6s}")
    FIGURES["rows"].append({"measure": name, "figure": figure, "goal": goal, "met": meets})


def _ten_second_scenarios(n: int, seed: int, space=SPACE, config=ISO, **fixed) -> list:
    """``n`` uniform points of ``space`` (with the ``fixed`` parameters), each run for 10 s."""
    rng = np.random.default_rng(seed)
    d = len(free_parameters(space))
    out = []
    for u in rng.uniform(size=(n, d)):
        s = make_scenario(space, config, dict(to_point(space, u), **fixed))
        out.append(dataclasses.replace(s, duration=10.0, robot=dataclasses.replace(
            s.robot, cycles=3)))
    return out


REPEATS = 3  # each throughput: the best of this many timed runs of the same batch


def _best_rate(evaluate, scenarios: list, batch: int, repeats: int) -> tuple:
    """(scenarios per second of ``evaluate(scenarios, batch_size=batch)`` in this process'
    CPU time, one core's however loaded, the best of ``repeats`` runs: other work on the
    machine only adds time; the last run's result). The three-ball measure runs this same
    function on its commit's code."""
    best = math.inf
    for _ in range(repeats):
        start = time.process_time()
        result = evaluate(scenarios, batch_size=batch)
        best = min(best, time.process_time() - start)
    return len(scenarios) / best, result


# Its source as this process loaded it, for the children (read now: a later edit of this
# file while a run goes on would otherwise hand them other lines).
_BEST_RATE_SOURCE = inspect.getsource(_best_rate)


def _rate(batch: int, **kind) -> tuple[float, float]:
    """(10 s scenarios per second, the share of them in which the robot never moved while
    a body was present)."""
    scenarios = _ten_second_scenarios(batch, 0, **kind)
    evaluate_many(_ten_second_scenarios(4, 2, **kind))  # loads the compiled code (not timed)
    rate, result = _best_rate(evaluate_many, scenarios, batch, REPEATS)
    return rate, float(np.mean(np.isposinf(result.robustness)))


# Earlier commits measured beside this code, in the same run: the last commit whose
# operator is three balls (two gloves and a head; the whole operator's price is measured
# against it), and the commit whose figure issue 33 compared (three balls too: A/B on one
# machine 2-3% faster than 9273221 on the busier batch, the cost of the by-speed branches
# 0dd7d00 added to the compiled ticks; ``ab_throughput.py`` measures any commits).
THREE_BALL_COMMIT = "9273221"
ISSUE_33_COMMIT = "177f5a8"

_COMMIT_CHILD = """
import dataclasses, json, math, sys, time
sys.path.insert(0, "benchmarks")
import bench_verify as b
import safety_systems
BEST_RATE
def rate(**kind):
    b.evaluate_many(b._ten_second_scenarios(4, 2, **kind))  # (not timed)
    return _best_rate(b.evaluate_many, b._ten_second_scenarios(BATCH, 0, **kind), BATCH,
                      REPEATS)[0]
cell = {"space": b.SPACE, "config": b.ISO_MOVING, "operators": 2.0, "heads": 1.0}
busy = dataclasses.replace(b.ISO_MOVING, safety=dataclasses.replace(
    b.ISO_MOVING.safety, human_speed="estimated"))
iso = rate(**cell)
print(json.dumps({"iso": iso, "busy": rate(**dict(cell, config=busy)),
                  "tool": rate(space=b.FLANGE, config=b.SEED, operators=1.0),
                  "module": b.__file__, "package": safety_systems.__file__}))
"""


def tree_rates(tree: Path, what: str, batch: int) -> dict | None:
    """The whole-cell and tool-point throughputs of the code in ``tree`` (its own
    ``bench_verify`` scenarios: for the three-ball commits, their default space),
    measured as :func:`throughput` measures this one's, in a child process, right after
    this one's (same machine, same core). None, said, where the child fails or ran other
    code than the tree's. (A fresh tree's compiled code is built first, for minutes, and
    not timed.)"""
    run = subprocess.run(
        [sys.executable, "-c", _COMMIT_CHILD.replace(
            "BEST_RATE", _BEST_RATE_SOURCE).replace(
            "BATCH", str(batch)).replace("REPEATS", str(REPEATS))],
        cwd=tree, env={**os.environ, "PYTHONPATH": str(tree)}, capture_output=True,
        text=True, check=False)
    if run.returncode != 0:
        print(f"the measure of {what} failed: {run.stderr.strip().splitlines()[-1:]}")
        return None
    rates = json.loads(run.stdout.strip().splitlines()[-1])
    for key in ("module", "package"):
        if not rates[key].startswith(str(tree)):  # (not this tree's code)
            print(f"the measure of {what} ran {rates[key]}, not the tree's")
            return None
    return rates


def commit_rates(commit: str, batch: int) -> dict | None:
    """:func:`tree_rates` of ``commit``'s code, checked out in a temporary git worktree.
    None where git or that commit is not there."""
    with tempfile.TemporaryDirectory() as tmp:
        tree = Path(tmp) / commit
        made = subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(tree),
                               commit], capture_output=True, text=True, check=False)
        if made.returncode != 0:
            print(f"commit {commit} could not be checked out: {made.stderr.strip()}")
            return None
        try:
            return tree_rates(tree, commit, batch)
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tree)],
                           capture_output=True, check=False)


# The batched evaluator's one test that opens the true properties at a tick (both of them
# and permitted contact; they only observe the loop: nothing in it reads them).
PROPERTIES_AT_A_TICK = \
    "            if moving or allowed or open_floor > -np.inf:  # (they count only then)\n"
EVALUATOR = Path("verification") / "search" / "evaluate_batch.py"


def loop_alone_rates(batch: int) -> dict | None:
    """:func:`tree_rates` of a copy of this code (its packages, benchmarks and models, as
    they are on disk) in which the batched evaluator never computes the true properties:
    its test that opens them at a tick (:data:`PROPERTIES_AT_A_TICK`) made false. The
    properties are observers (the sensor, tracker, envelopes, monitor, override and robot
    read nothing of them), so the copy runs the same closed loop and what it saves is all
    that the properties cost: its throughput is the most any change to their computation
    alone can give. None where that test is not found once."""
    source = (ROOT / EVALUATOR).read_text()
    if source.count(PROPERTIES_AT_A_TICK) != 1:
        print(f"{EVALUATOR}: the properties' test is not there once; the loop alone is not "
              "measured")
        return None
    with tempfile.TemporaryDirectory() as tmp:
        tree = Path(tmp) / "loop_alone"
        for folder in ("safety_systems", "verification", "benchmarks", "models"):
            shutil.copytree(ROOT / folder, tree / folder,
                            ignore=shutil.ignore_patterns("__pycache__", "results"))
        (tree / EVALUATOR).write_text(source.replace(
            PROPERTIES_AT_A_TICK, "            if False:  # the loop alone: no properties\n"))
        return tree_rates(tree, "the loop alone", batch)


def throughput(batch: int) -> None:
    cell = {"space": SPACE, "config": ISO_MOVING, "operators": 2.0, "heads": 1.0}
    iso_rate, cell_vacuous = _rate(batch, **cell)
    # The same cell with estimated human speeds (the seed's Eq. 10) on the capsules: the
    # robot keeps moving near the bodies, where every tick evaluates every pair.
    busy = dataclasses.replace(ISO_MOVING, safety=dataclasses.replace(
        ISO_MOVING.safety, human_speed="estimated"))
    busy_rate, busy_vacuous = _rate(batch, **dict(cell, config=busy))
    cell_rate = min(iso_rate, busy_rate)
    tool_rate, tool_vacuous = _rate(batch, space=FLANGE, config=SEED, operators=1.0)
    drake = _ten_second_scenarios(3, 1, **cell)
    start = time.perf_counter()
    for s in drake:
        evaluate_drake(s)
    drake_rate = len(drake) / (time.perf_counter() - start)
    _row(f"batched, capsules, 2 ops x 12 segments, both properties, 10 s scen./s/core ({batch})",
         f"{cell_rate:.0f}", ">= 1000", cell_rate >= 1000)
    _row("  iso.yaml's contact terms", f"{iso_rate:.0f}", "", None)
    _row("    of them never moving near a body", f"{100 * cell_vacuous:.0f}%", "", None)
    _row("  the same with estimated human speeds (the lower is the figure above)",
         f"{busy_rate:.0f}", "", None)
    _row("    of them never moving near a body", f"{100 * busy_vacuous:.0f}%", "", None)
    _row("batched, tool point, 1 operator x 12 segments (2 gloves tracked), 10 s scen./s/core",
         f"{tool_rate:.0f}", "", None)
    _row("  of them never moving near a body (the seed's configuration)",
         f"{100 * tool_vacuous:.0f}%", "", None)
    _row("  ratio capsules / tool point", f"{cell_rate / tool_rate:.2f}x", "", None)
    _row("Drake diagram, capsules, 2 operators x 12 segments, 10 s scenarios/s/core",
         f"{drake_rate:.2f}", "", None)
    _row("  ratio batched / Drake", f"{cell_rate / drake_rate:.0f}x", "", None)
    figures = FIGURES["throughput"] = {
        "batch": batch, "iso": iso_rate, "busy": busy_rate, "whole_cell": cell_rate,
        "vacuous_iso": cell_vacuous, "vacuous_busy": busy_vacuous, "tool_point": tool_rate,
        "vacuous_tool_point": tool_vacuous, "drake": drake_rate, "commits": {}}
    # Earlier commits' code, measured right after (A/B on this machine): each figure
    # beside its ratios to its own tool point and to this run's Drake diagram, which
    # carry from machine to machine where the absolute figures do not.
    _row("this code: whole cell / tool point, / Drake (the lower figure above)",
         f"{cell_rate / tool_rate:.3f} {cell_rate / drake_rate:.0f}x", "", None)
    three, reference = None, None
    for commit, what in ((THREE_BALL_COMMIT, "the three-ball operator's last commit"),
                         (ISSUE_33_COMMIT, "issue 33's three-ball reference")):
        rates = commit_rates(commit, batch)
        if rates is None:
            continue
        low = min(rates["iso"], rates["busy"])
        figures["commits"][commit] = {"what": what, **{k: rates[k] for k in
                                                        ("iso", "busy", "tool")},
                                      "whole_cell": low}
        _row(f"{what} ({commit}), the same measure", f"{low:.0f}", "", None)
        _row("    iso.yaml's contact terms / with estimated human speeds",
             f"{rates['iso']:.0f} / {rates['busy']:.0f}", "", None)
        _row("    its tool point; whole cell / tool point, / this run's Drake",
             f"{rates['tool']:.0f}; {low / rates['tool']:.3f} {low / drake_rate:.0f}x", "", None)
        if commit == THREE_BALL_COMMIT:
            three = low
            _row(f"  this code / {commit} (whole cell, the lower figures)",
                 f"{cell_rate / low:.3f}x", "", None)
        else:
            reference = low
            _row(f"  this code / {commit}: above its figure (issue 33)",
                 f"{cell_rate / low:.3f}x", "> 1x", cell_rate > low)
    if three is not None:
        _row("  price of the whole operator (three-ball / whole, the lower figures)",
             f"{three / cell_rate:.2f}x", "<= 2x", three / cell_rate <= 2.0)
    # Where the whole operator's time goes: the same code without the true properties.
    # If even that is below issue 33's reference, no change to the properties' computation
    # alone can meet it.
    alone = loop_alone_rates(batch)
    if alone is not None:
        low = min(alone["iso"], alone["busy"])
        figures["loop_alone"] = {**{k: alone[k] for k in ("iso", "busy", "tool")},
                                 "whole_cell": low}
        _row("this code without the true properties (the closed loop alone), the same measure",
             f"{low:.0f}", "", None)
        _row("    iso.yaml's contact terms / with estimated human speeds; its tool point",
             f"{alone['iso']:.0f} / {alone['busy']:.0f}; {alone['tool']:.0f}", "", None)
        _row("  the properties' share of this code's time (whole cell)",
             f"{100 * (1 - cell_rate / low):.0f}%", "", None)
        if reference is not None:
            _row(f"  the loop alone / {ISSUE_33_COMMIT} (with its properties)",
                 f"{low / reference:.3f}x", "", None)


def _first(log, objectives) -> dict | None:
    """The earliest first violation of the ``objectives`` (columns) in a search's log:
    its simulation's number, and the evaluations and CPU seconds by then."""
    firsts = [log.first[j] for j in objectives if j in log.first]
    return min(firsts, key=lambda f: f["simulation"]) if firsts else None


def ours(space, config, seed: int, budget: int, objectives) -> dict:
    """This project's falsifier, stopping at the first violation of any objective: the
    cost in order up to it, in simulation-equivalents (``counts.COST``: the rankings made
    before it and the simulations up to and including it), all evaluations made by
    then, CPU seconds by then; with none found, ``found`` False and the whole run's CPU."""
    with Runner(workers=1) as runner:
        log = falsify(space, space_cell(config, space), runner, budget=budget, seed=seed,
                      stop_at_first=True, objectives=objectives)
    first = _first(log, objectives)
    if first is None:
        return {"found": False, "cpu": runner.tally.cpu_seconds(),
                "made": runner.tally.search_cost()}
    e = first["evaluations"]
    ranked = COST["margins"] * e["margins"] + COST["dangers"] * e["dangers"]
    return {"found": True, "evaluations": ranked + first["simulation"],
            "made": e["search_cost"], "simulations": first["simulation"],
            "rankings": ranked, "cpu": first["cpu_seconds"],
            "point": log.points[first["simulation"] - 1]}


class _Objective:
    """psy-taliro's objective: one scenario at a time through the same batched evaluator
    (``evaluate_many``) over the same unit box; the cost is the smallest robustness of the
    ``objectives``. Notes the evaluation and the CPU time of the first violation."""

    def __init__(self, space, config, objectives):
        self.space, self.config, self.objectives = space, config, list(objectives)
        self.calls, self.first, self.start = 0, None, time.process_time()

    def eval_sample(self, sample) -> float:
        from verification.search.runner import FIELDS  # (the figures' order)

        self.calls += 1
        scenario = make_scenario(self.space, self.config,
                                 to_point(self.space, np.asarray(sample.values)))
        r = evaluate_many([scenario])
        cost = min(float(getattr(r, FIELDS[j])[0]) for j in self.objectives)
        if cost < 0.0 and self.first is None:
            self.first = {"evaluations": self.calls, "made": self.calls,
                          "cpu": time.process_time() - self.start}
        return cost

    def eval_samples(self, samples):
        return [self.eval_sample(s) for s in samples]


def taliro(name: str, space, config, seed: int, budget: int, objectives) -> dict | None:
    """psy-taliro's ``name`` optimizer (UniformRandom or DualAnnealing), stopping at the
    first cost below 0 (``min_cost=0.0``), with ``budget`` evaluations."""
    from staliro.optimizers import DualAnnealing, Optimizer, UniformRandom
    from staliro.signals import Interval

    optimizer = {"UniformRandom": UniformRandom, "DualAnnealing": DualAnnealing}[name](
        min_cost=0.0)
    objective = _Objective(space, config, objectives)
    d = len(free_parameters(space))
    optimizer.optimize(objective, Optimizer.Params(seed=seed, budget=budget,
                                                   input_bounds=[Interval(0.0, 1.0)] * d))
    if objective.first is None:
        return {"found": False, "cpu": time.process_time() - objective.start,
                "made": objective.calls}
    return {"found": True, **objective.first}


# s CPU to the first counterexample (median), at verify's default budget and at 4096
GOALS = {"seed": 1.0, "subtle": 1.0, "contact": 1.0}


def first_counterexamples(seeds: int, budgets: list[int], which: list[str],
                          searches: list[str]) -> None:
    """Each search on each configuration at each budget, ``seeds`` times."""
    configs = {"seed": (SEED, "seed config (seed_estimated.yaml)"),
               "subtle": (SUBTLE, "subtle config (subtle_unsafe.yaml)"),
               "contact": (CONTACT, "contact mutant (contact_unsafe.yaml)")}
    objectives = [0, 2]  # contact and separation, as verify's default
    with Runner(workers=1) as runner:  # loads the compiled code (not timed)
        falsify(SPACE, space_cell(ISO, SPACE), runner, budget=16, seed=99,
                objectives=objectives)
    warm = make_scenario(SPACE, ISO, to_point(SPACE, np.full(20, 0.5)))
    evaluate_many([warm])
    evaluate_drake(warm)  # (the diagram's first build loads the robot model: not timed)
    for budget in budgets:
        for key in which:
            config, label = configs[key]
            rows = {}
            for search in searches:
                results = []
                for seed in range(seeds):
                    if search == "ours":
                        r = ours(SPACE, config, seed, budget, objectives)
                    else:
                        r = taliro(search, SPACE, config, seed, budget, objectives)
                    results.append(r)
                    print(f"  {key} budget {budget} {search} seed {seed}: "
                          + (f"{r['evaluations']:g} in order ({r['made']:g} made), "
                             f"{r['cpu']:.3f} s CPU" if r["found"] else
                             f"none ({r['made']:g} made, {r['cpu']:.3f} s CPU)"), flush=True)
                rows[search] = results
            _table(f"{label}, budget {budget}", rows, budget, GOALS[key])
            FIGURES.setdefault("search", {}).setdefault(key, {})[str(budget)] = {
                search: _summary(results, budget, rows.get("ours") if search != "ours"
                                 else None) for search, results in rows.items()}
            if "ours" in rows and any(r["found"] for r in rows["ours"]):
                confirm = confirm_time(config, next(r for r in rows["ours"] if r["found"]))
                FIGURES["search"][key][str(budget)]["confirm"] = confirm


def _summary(results: list[dict], budget: int, mine: list[dict] | None = None) -> dict:
    """A search's figures over the seeds, as the table prints them (medians; a search
    that found nothing counts as budget + 1 evaluations and inf CPU seconds); beside
    this project's results ``mine``, the seeds it falsified within this project's CPU
    time on the same seed (``within_ours_cpu``)."""
    out = {"seeds": len(results), "falsified": sum(r["found"] for r in results),
           "median_evaluations": _median(results, "evaluations", budget + 1),
           "median_cpu": _median(results, "cpu", math.inf)}
    if mine is not None:
        out["within_ours_cpu"] = _within(results, mine)
    if results and "simulations" in next((r for r in results if r["found"]), {}):
        out.update(median_simulations=_median(results, "simulations", budget + 1),
                   median_rankings=_median(results, "rankings", 0))
    return out


def _within(results: list[dict], mine: list[dict]) -> int:
    """At the same CPU time: the seeds a search falsified within the CPU this project
    took on the same seed (to its first, or its whole run where it found none)."""
    return sum(t["found"] and t["cpu"] <= o["cpu"] for t, o in zip(results, mine))


def _median(results, key, cap):
    """Median of ``key`` over the seeds; a search that found nothing counts as ``cap``."""
    return statistics.median(r[key] if r["found"] else cap for r in results)


def _table(label: str, rows: dict, budget: int, goal: float) -> None:
    n = len(next(iter(rows.values())))
    mine = rows.get("ours")
    for search, results in rows.items():
        hits = sum(r["found"] for r in results)
        evaluations = _median(results, "evaluations", budget + 1)
        cpu = _median(results, "cpu", math.inf)
        name = "this project" if search == "ours" else f"psy-taliro {search}"
        _row(f"{label}: {name}: falsified", f"{hits}/{n}", f"{n}/{n}" if search == "ours"
             else "", hits == n if search == "ours" else None)
        _row("  median evaluations to the first (in order, simulation-equivalents; none "
             "found: budget + 1)",
             f"{evaluations:g}", "", None)
        _row("  median CPU s to the first (none found: inf)", f"{cpu:.3f}",
             f"<= {goal:g}" if search == "ours" else "", cpu <= goal if search == "ours"
             else None)
        if search == "ours":
            sims = _median(results, "simulations", budget + 1)
            made = _median(results, "made", budget + 1)
            _row("    of which closed-loop simulations (median)", f"{sims:g}", "", None)
            _row("    of which candidates ranked, simulation-equivalents (median)",
                 f"{_median(results, 'rankings', 0):g}", "", None)
            _row("    all evaluations made by then, whole batches (median)", f"{made:g}", "",
                 None)
        elif mine is not None:
            m_hits = sum(r["found"] for r in mine)
            _row("  falsified within this project's CPU time, seed by seed",
                 f"{_within(results, mine)}/{n}",
                 "", None)
            mine_e = _median(mine, "evaluations", budget + 1)
            # Where both find it at the first evaluation (the least any search can take),
            # both did the same work: one scenario on the same evaluator.
            floor = mine_e == evaluations == 1
            for what, ours_v, theirs in (
                    ("successes", m_hits, hits),
                    ("evaluations", mine_e, evaluations),
                    ("CPU s", _median(mine, "cpu", math.inf), cpu)):
                better = ours_v > theirs if what == "successes" else ours_v < theirs
                ratio = (theirs / ours_v if what != "successes" else ours_v / max(theirs, 1)) \
                    if ours_v else math.inf
                tied = ((what == "successes" and ours_v == theirs == n)
                        or (floor and what != "successes"))
                _row(f"    ratio, {'ours / theirs' if what == 'successes' else 'theirs / ours'}"
                     f" ({what}; > 1: this project ahead)", f"{ratio:.2f}x",
                     "> 1", better or (None if tied else False))
                if tied and not better:
                    _row("      a tie at the " + ("most: every seed falsified" if what ==
                         "successes" else "least: the first evaluation, for both"), "", "",
                         None)


def confirm_time(config, found: dict) -> dict:
    """Wall seconds to confirm a counterexample in the Drake diagram, building the
    diagram included (the run stops a quarter second after the violation shows),
    beside the full run's."""
    scenario = make_scenario(SPACE, config, to_point(SPACE, np.asarray(found["point"])))
    rho = evaluate_many([scenario])
    name = "contact" if rho.robustness[0] < 0.0 else "separation"
    start = time.perf_counter()
    evaluate_drake(scenario, stop_on=name)
    confirm = time.perf_counter() - start
    start = time.perf_counter()
    evaluate_drake(scenario)
    whole = time.perf_counter() - start
    _row(f"  Drake confirmation of the first one ({name}, {scenario.duration:.1f} s "
         "scenario), wall s", f"{confirm:.2f}", "<= 1", confirm <= 1.0)
    _row("    the whole scenario in Drake, wall s", f"{whole:.2f}", "", None)
    return {"property": name, "wall": confirm, "whole_wall": whole}


def fraction(n: int) -> None:
    """How much of the default space the subtle configuration and the contact mutant
    leave unsafe: a scrambled Sobol set of n points (seed 11) simulated, violations
    counted per property, with a Clopper-Pearson 95% upper bound (the Sobol points read
    as a random sample)."""
    from scipy.stats import beta

    points = sweep_points("sobol", n, len(free_parameters(SPACE)), seed=11)
    for label, config in (("subtle config", SUBTLE), ("contact mutant", CONTACT)):
        r = evaluate_many([make_scenario(SPACE, config, to_point(SPACE, u)) for u in points])
        for name, rho in (("contact", r.robustness), ("separation", r.separation)):
            k = int(np.sum(rho < 0.0))
            upper = beta.ppf(0.975, k + 1, n - k)
            _row(f"{label}: {name} violated in {k} of {n} Sobol points; 95% upper bound",
                 f"{100.0 * k / n:.3f}%", "", None)
            FIGURES.setdefault("fraction", {}).setdefault(label, {})[name] = {
                "violating": k, "points": n, "upper_95": float(upper)}
            _row("  (Clopper-Pearson upper bound)", f"{100.0 * upper:.3f}%", "", None)


def costs(n: int = 512) -> None:
    """What each kind of evaluation costs, CPU per evaluation over a closed-loop
    simulation's (its scenario built included), on n Sobol points of the default space
    for iso.yaml and the subtle file, beside the prices a budget uses
    (``counts.COST``)."""
    from verification.search.ranking import bound_scores, danger_scores

    points = sweep_points("sobol", n, len(free_parameters(SPACE)), seed=5)

    def cpu(work) -> float:
        start = time.process_time()
        work()
        return time.process_time() - start

    for label, config in (("iso", ISO), ("subtle", SUBTLE)):
        evaluate_many([make_scenario(SPACE, config, to_point(SPACE, u)) for u in points[:8]])
        cell = space_cell(config, SPACE)
        danger_scores(SPACE, cell, points[:8])
        sim = cpu(lambda: evaluate_many([make_scenario(SPACE, config, to_point(SPACE, u))
                                         for u in points])) / n
        margin = cpu(lambda: bound_scores(SPACE, cell, np.tile(points, (8, 1)))) / (8 * n)
        danger = cpu(lambda: danger_scores(SPACE, cell, points)) / n
        drake = cpu(lambda: evaluate_drake(make_scenario(SPACE, config,
                                                         to_point(SPACE, points[0]))))
        _row(f"{label}: a simulation, its scenario built included, CPU ms", f"{sim * 1e3:.2f}",
             "", None)
        FIGURES.setdefault("costs", {})[label] = {
            "simulation_cpu_ms": sim * 1e3, "margins": margin / sim, "dangers": danger / sim,
            "drake": drake / sim}
        for kind, each in (("margins", margin), ("dangers", danger), ("drake", drake)):
            _row(f"  {kind}: simulation-equivalents each (the budget's price: "
                 f"{COST[kind]:g})", f"{each / sim:.4g}", "", None)


def proof_time() -> None:
    start = time.perf_counter()
    proof = prove(space_cell(ISO, SPACE), SPACE)
    alone = time.perf_counter() - start
    _row(f"iso config, default space: proof alone (proved: {proof.proved})", f"{alone:.1f} s",
         "< 60 s", alone < 60.0)
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        outcome = verify(ISO, SPACE, Path(out), budget=64, workers=2)
        total = time.perf_counter() - start
    _row(f"iso config: verify with 64 sims on 2 workers ({outcome.verdict})", f"{total:.1f} s",
         "", None)
    FIGURES["proof"] = {"proof_alone_wall": alone, "proved": proof.proved,
                        "verify_64_wall": total, "verdict": outcome.verdict}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--budgets", default=f"{DEFAULT_BUDGET},4096",
                        help="search budgets, comma-separated, in simulation-equivalents "
                             "(psy-taliro: evaluations)")
    parser.add_argument("--batch", type=int, default=512)
    parser.add_argument("--parts", default="throughput,proof,search,fraction,costs",
                        help="which measures, comma-separated (default: all five)")
    parser.add_argument("--configs", default="seed,subtle,contact",
                        help="for search: seed,subtle,contact")
    parser.add_argument("--searches", default="ours,UniformRandom,DualAnnealing",
                        help="for search: ours and psy-taliro's UniformRandom,DualAnnealing")
    parser.add_argument("--fraction-points", type=int, default=16384)
    parser.add_argument("--json", type=Path, default=None,
                        help="also write the figures printed to this JSON file")
    args = parser.parse_args()
    FIGURES.update(argv=sys.argv[1:], load_1min=os.getloadavg()[0])
    parts = set(args.parts.split(","))
    searches = args.searches.split(",")
    if any(x != "ours" for x in searches):
        try:
            import staliro  # noqa: F401
        except ImportError:
            print("psy-taliro is not installed (pip install -e '.[bench]'): its searches "
                  "are left out")
            searches = [x for x in searches if x == "ours"]
    print(f"{'measure':72s} {'figure':>14s} {'goal':>12s} {'met':>6s}")
    if "throughput" in parts:
        throughput(args.batch)
    if "proof" in parts:
        proof_time()
    if "search" in parts:
        first_counterexamples(args.seeds, [int(b) for b in args.budgets.split(",")],
                              args.configs.split(","), searches)
    if "fraction" in parts:
        fraction(args.fraction_points)
    if "costs" in parts:
        costs()
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(FIGURES, indent=1, default=float) + "\n")


if __name__ == "__main__":
    main()
