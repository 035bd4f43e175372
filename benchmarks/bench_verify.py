"""Speed and sample efficiency of the verification layer, measured in one run.

    python benchmarks/bench_verify.py [--seeds 10] [--budget 100] [--batch 512]

Prints, each beside its goal:
1. the batched evaluator's throughput in 10-second scenarios per second on one core
   (after a small warm-up batch has loaded the compiled code), and its ratio to the
   Drake diagram on the same kind of scenarios;
2. for the seed's configuration over the default space: in how many of ``--seeds``
   searches the falsifier found a counterexample and the median number of closed-loop
   simulations to the first one (and the time of the reduced-model ranking of
   candidates that comes first, not counted as simulations), beside uniform random
   sampling with the same budget
   (its first violation, in sampling order), and with a longer uniform budget to
   measure its median;
3. the wall time to prove the iso configuration over the default space (the proof
   alone, and ``verify`` with a 64-simulation cross-check on 2 workers).
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
SEED = load_controller_config(ROOT / "models" / "configs" / "seed_estimated.yaml")
ISO = load_controller_config(ROOT / "models" / "configs" / "iso.yaml")


def _row(name: str, figure: str, goal: str, meets: bool | None) -> None:
    verdict = "" if meets is None else ("yes" if meets else "NO")
    print(f"{name:58s} {figure:>14s} {goal:>12s} {verdict:>6s}")


def _ten_second_scenarios(n: int, seed: int) -> list:
    rng = np.random.default_rng(seed)
    d = len(free_parameters(SPACE))
    out = []
    for u in rng.uniform(size=(n, d)):
        s = make_scenario(SPACE, SEED, dict(to_point(SPACE, u), operators=1.0))
        out.append(dataclasses.replace(s, duration=10.0, robot=dataclasses.replace(
            s.robot, cycles=3)))
    return out


def throughput(batch: int) -> None:
    scenarios = _ten_second_scenarios(batch, 0)
    evaluate_many(_ten_second_scenarios(4, 2))  # loads the compiled code (not timed)
    start = time.perf_counter()
    evaluate_many(scenarios, batch_size=batch)
    batch_rate = batch / (time.perf_counter() - start)
    drake = _ten_second_scenarios(3, 1)
    start = time.perf_counter()
    for s in drake:
        evaluate_drake(s)
    drake_rate = len(drake) / (time.perf_counter() - start)
    _row(f"batched evaluator, 10 s scenarios/s/core (batch {batch})", f"{batch_rate:.1f}",
         ">= 1000", batch_rate >= 1000)
    _row("Drake diagram, 10 s scenarios/s/core", f"{drake_rate:.2f}", "", None)
    _row("ratio batched / Drake", f"{batch_rate / drake_rate:.0f}x", "", None)


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
    _row(f"iso config: proof alone (proved: {proof.proved})", f"{alone:.1f} s", "", None)
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        outcome = verify(ISO, SPACE, Path(out), budget=64, workers=2)
        total = time.perf_counter() - start
    _row(f"iso config: verify with 64 sims on 2 workers ({outcome.verdict})", f"{total:.1f} s",
         "< 60 s", total < 60.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--budget", type=int, default=100)
    parser.add_argument("--uniform-budget", type=int, default=1000,
                        help="a longer uniform run, to measure its median")
    parser.add_argument("--batch", type=int, default=512)
    args = parser.parse_args()
    print(f"{'measure':58s} {'figure':>14s} {'goal':>12s} {'met':>6s}")
    throughput(args.batch)
    proof_time()
    first_violations(args.seeds, args.budget, args.uniform_budget)


if __name__ == "__main__":
    main()
