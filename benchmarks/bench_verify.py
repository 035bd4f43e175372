"""Speed and sample efficiency of the verification layer, measured in one run.

    python benchmarks/bench_verify.py [--seeds 10] [--budget 100] [--batch 512]
                                      [--parts throughput,proof,search]

Prints, each beside its goal:
1. the batched evaluator's throughput in 10-second scenarios per second on one core,
   measuring both properties ("stopped before contact" and the separation invariant)
   (after a small warm-up batch has loaded the compiled code): the whole cell (the iso
   configuration, the robot as capsules, two operators of three bodies each (two hands
   and a head) over the default space) beside the tool point (the seed's configuration,
   one operator's two hands over the flange space), and the ratio to the Drake diagram
   on the whole-cell scenarios;
2. for the seed's configuration over the default space: in how many of ``--seeds``
   searches the falsifier found a counterexample and the median number of closed-loop
   simulations to the first one (and the time of the reduced-model ranking of
   candidates that comes first, not counted as simulations), beside uniform random
   sampling with the same budget
   (its first violation, in sampling order), and with a longer uniform budget to
   measure its median;
3. the wall time to prove the iso configuration over the default space (the proof
   alone, and ``verify`` with a 64-simulation cross-check on 2 workers).

Run it on an otherwise idle machine: the throughput is one core's, timed as this
process' CPU time (so other work on the machine slows it less than it would a wall
clock, but still shares the caches).
"""

import argparse
import dataclasses
import inspect
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from safety_systems.scenario import load_controller_config
from verification.evaluate_batch import evaluate_many
from verification.evaluate_drake import evaluate_drake
from verification.proof import prove
from verification.runner import Runner
from verification.search import (
    SearchLog,
    danger_scores,
    evaluate_points,
    falsify,
    sweep_points,
)
from verification.space import free_parameters, load_space, make_scenario, to_point
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


def _row(name: str, figure: str, goal: str, meets: bool | None) -> None:
    verdict = "" if meets is None else ("yes" if meets else "NO")
    print(f"{name:72s} {figure:>14s} {goal:>12s} {verdict:>6s}")


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


def _rate(batch: int, **kind) -> tuple[float, float]:
    """(10 s scenarios per second, the share of them in which the robot never moved while
    a body was present)."""
    scenarios = _ten_second_scenarios(batch, 0, **kind)
    evaluate_many(_ten_second_scenarios(4, 2, **kind))  # loads the compiled code (not timed)
    start = time.process_time()  # this process' CPU time: one core's, however loaded
    result = evaluate_many(scenarios, batch_size=batch)
    rate = batch / (time.process_time() - start)
    return rate, float(np.mean(np.isposinf(result.robustness)))


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
    _row(f"batched, capsules, 2 ops x 3 bodies, both properties, 10 s scen./s/core ({batch})",
         f"{cell_rate:.0f}", ">= 1000", cell_rate >= 1000)
    _row("  iso.yaml's contact terms", f"{iso_rate:.0f}", "", None)
    _row("    of them never moving near a body", f"{100 * cell_vacuous:.0f}%", "", None)
    _row("  the same with estimated human speeds (the lower is the figure above)",
         f"{busy_rate:.0f}", "", None)
    _row("    of them never moving near a body", f"{100 * busy_vacuous:.0f}%", "", None)
    _row("batched, tool point, 1 operator x 2 hands, 10 s scenarios/s/core", f"{tool_rate:.0f}",
         "", None)
    _row("  of them never moving near a body (the seed's configuration)",
         f"{100 * tool_vacuous:.0f}%", "", None)
    _row("  ratio capsules / tool point", f"{cell_rate / tool_rate:.2f}x", "", None)
    _row("Drake diagram, capsules, 2 operators x 3 bodies, 10 s scenarios/s/core",
         f"{drake_rate:.2f}", "", None)
    _row("  ratio batched / Drake", f"{cell_rate / drake_rate:.0f}x", "", None)


def first_violations(seeds: int, budget: int, uniform_budget: int) -> None:
    d = len(free_parameters(SPACE))
    found, uniform = [], []
    with Runner(workers=1) as runner:
        for seed in range(seeds):
            log = falsify(SPACE, SEED, runner, budget=budget, seed=seed, stop_at_first=True)
            found.append(log.first_violation())
            # Uniform random sampling in order; its first violation within the budgets.
            points = sweep_points("uniform", max(budget, uniform_budget), d, seed=1000 + seed)
            sample = SearchLog()
            evaluate_points(SPACE, SEED, runner, points, sample)
            uniform.append(sample.first_violation())
            print(f"  seed {seed}: falsifier {found[-1]}, uniform {uniform[-1]}", flush=True)

    def median(values, cap):  # searches without a violation count as cap + 1
        return statistics.median(v if v is not None and v <= cap else cap + 1 for v in values)

    hits = sum(v is not None for v in found)
    same = sum(v is not None and v <= budget for v in uniform)
    _row(f"seed config: falsifier searches with a counterexample (budget {budget})",
         f"{hits}/{seeds}", f"{seeds}/{seeds}", hits == seeds)
    _row("  uniform random with the same budget", f"{same}/{seeds}", "", None)
    m_f = median(found, budget)
    m_same = median(uniform, budget)
    m_long = median(uniform, max(budget, uniform_budget))
    _row("  median simulations to the first, falsifier", f"{m_f:g}", "<= 10", m_f <= 10)
    pool = inspect.signature(falsify).parameters["candidates"].default
    start = time.perf_counter()
    danger_scores(SPACE, SEED, sweep_points("sobol", pool, d, seed=0))
    _row(f"  before them: {pool} candidates ranked by a reduced model (not counted)",
         f"{time.perf_counter() - start:.1f} s", "", None)
    _row(f"  median, uniform random (budget {budget})",
         f"{m_same:g}" + (" (none)" if m_same > budget else ""), "", None)
    _row(f"  median, uniform random (budget {max(budget, uniform_budget)})",
         f"{m_long:g}" + (" (none)" if m_long > max(budget, uniform_budget) else ""), "", None)
    sign = ">" if m_long > max(budget, uniform_budget) else ""
    _row("  uniform / falsifier (longer uniform budget)", f"{sign}{m_long / m_f:.1f}x",
         ">= 10x", m_long / m_f >= 10)


def proof_time() -> None:
    start = time.perf_counter()
    proof = prove(ISO, SPACE)
    alone = time.perf_counter() - start
    _row(f"iso config, default space: proof alone (proved: {proof.proved})", f"{alone:.1f} s",
         "< 60 s", alone < 60.0)
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        outcome = verify(ISO, SPACE, Path(out), budget=64, workers=2)
        total = time.perf_counter() - start
    _row(f"iso config: verify with 64 sims on 2 workers ({outcome.verdict})", f"{total:.1f} s",
         "", None)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--budget", type=int, default=100)
    parser.add_argument("--uniform-budget", type=int, default=1000,
                        help="a longer uniform run, to measure its median")
    parser.add_argument("--batch", type=int, default=512)
    parser.add_argument("--parts", default="throughput,proof,search",
                        help="which measures, comma-separated (default: all three)")
    args = parser.parse_args()
    parts = set(args.parts.split(","))
    print(f"{'measure':72s} {'figure':>14s} {'goal':>12s} {'met':>6s}")
    if "throughput" in parts:
        throughput(args.batch)
    if "proof" in parts:
        proof_time()
    if "search" in parts:
        first_violations(args.seeds, args.budget, args.uniform_budget)


if __name__ == "__main__":
    main()
