"""``safety-systems verify``: proof where it applies, search everywhere, confirmed results.

The verdict is one of
- ``falsified``: a counterexample found by the batched evaluator was replayed in the
  Drake diagram and violates "stopped before contact" there too;
- ``proved``: ``verification.proof`` proved the property over the whole box (and the
  search, run as a cross-check, found nothing);
- ``passed``: the search found no counterexample, but there is no proof.
"""

import dataclasses
import hashlib
from pathlib import Path

import numpy as np

from safety_systems.output_files import write_text
from safety_systems.scenario import ControllerConfig, dump_scenario
from verification.evaluate_drake import evaluate_drake
from verification.proof import Proof, prove
from verification.runner import Runner
from verification.search import SWEEPS, SearchLog, falsify, sweep
from verification.space import (
    ScenarioSpace,
    assumptions,
    describe,
    free_parameters,
    make_scenario,
    to_point,
)

METHODS = ("falsify",) + SWEEPS
CONFIRM = 5  # counterexamples replayed in Drake, worst first


@dataclasses.dataclass
class Outcome:
    """Everything ``verify`` found; ``report.write_report`` turns it into files."""

    verdict: str
    method: str
    proof: Proof
    log: SearchLog
    assumptions: list
    counterexamples: list  # dicts, worst first
    unconfirmed: list  # batch violations that Drake did not reproduce (should be empty)
    free_parameters: list
    seed: int
    budget: int
    config_sha256: str
    contact_geometry: str = "capsules"


def verify(config: ControllerConfig, space: ScenarioSpace, out: Path, *, budget: int,
           method: str = "falsify", workers: int | None = None, scheduler: str | None = None,
           seed: int = 0, progress: bool = False, config_text: str = "",
           stop_at_first: bool = False, candidates: int = 8192) -> Outcome:
    """Runs proof and search for ``config`` over ``space``; writes scenario files of
    confirmed counterexamples under ``out / "counterexamples"``. ``stop_at_first`` ends
    a falsifying search at its first violation instead of spending the whole budget;
    ``candidates``: how many the falsifier ranks before simulating."""
    if method not in METHODS:
        raise ValueError(f"method: got {method!r}; allowed: {' | '.join(METHODS)}")
    out.mkdir(parents=True, exist_ok=True)
    proof = prove(config, space)
    with Runner(workers=workers, scheduler=scheduler, cache_path=out / "evaluations.jsonl",
                progress=progress, total=budget) as runner:
        if method == "falsify":
            log = falsify(space, config, runner, budget=budget, seed=seed,
                          stop_at_first=stop_at_first, candidates=candidates)
        else:
            log = sweep(space, config, runner, method=method, budget=budget, seed=seed)
    confirmed, unconfirmed = _confirm(space, config, log, out)
    if confirmed:
        verdict = "falsified"
    elif proof.proved:
        verdict = "proved"
    else:
        verdict = "passed"
    how = proof.method if verdict == "proved" else f"search ({method}, seed {seed})"
    return Outcome(verdict, how, proof, log, assumptions(space, config), confirmed, unconfirmed,
                   free_parameters(space), seed, budget,
                   hashlib.sha256(config_text.encode()).hexdigest(), space.contact_geometry)


def _confirm(space, config, log, out):
    """Replays the worst batch violations in Drake; returns (confirmed, unconfirmed)."""
    rho = log.robustness
    order = [int(i) for i in np.argsort(rho, kind="stable") if rho[i] < 0.0]
    seen, confirmed, unconfirmed = set(), [], []
    for i in order:
        key = tuple(np.round(log.points[i], 12))
        if key in seen:
            continue
        seen.add(key)
        if len(confirmed) + len(unconfirmed) >= CONFIRM:
            break
        values = to_point(space, np.array(log.points[i]))
        scenario = make_scenario(space, config, values, name=f"counterexample_{len(confirmed)}")
        drake, _ = evaluate_drake(scenario)
        entry = {"parameters": describe(values), "robustness": float(rho[i]),
                 "drake_robustness": drake.stopped_before_contact,
                 "protective_violation_time": drake.protective_violation_time,
                 "protective_deepest_intrusion": drake.protective_deepest_intrusion,
                 "simulation": i + 1}
        if drake.stopped_before_contact < 0.0:
            path = out / "counterexamples" / f"{scenario.name}.yaml"
            path.parent.mkdir(exist_ok=True)
            write_text(path, dump_scenario(scenario))
            entry["scenario"] = str(path)
            confirmed.append(entry)
        else:
            unconfirmed.append(entry)
    return confirmed, unconfirmed
