"""``safety-systems verify``: proof where it applies, search everywhere, confirmed results.

The verdict is one of
- ``inconclusive``: the evidence contradicts itself: a violation the search found is not
  reproduced in the Drake diagram, a Drake replay violates where the search did not, or
  the proof says no scenario of the box violates while a simulation (either evaluator)
  shows one. One evaluator, or the proof, is wrong; that is a defect to look into, so
  this verdict wins over every other (confirmed counterexamples are still listed);
- ``falsified``: a counterexample found by the search was replayed in the Drake diagram
  and violates "stopped before contact" there too;
- ``proved``: ``verification.proof`` proved the property over the whole box (and the
  search, run as a cross-check, found nothing);
- ``passed``: the search found no counterexample, but there is no proof.

Every verdict comes with Drake replays of the search's figures (:func:`replay_in_drake`):
the worst violations, or the worst scenario when there is none, and a few scenarios
drawn at random, each replayed in the diagram in the space's robot mode and compared
with the search's figure. The search honours the robot mode too: the batched evaluator
models the kinematic robot; a dynamic robot's scenarios run in the Drake diagram
(``evaluate_batch.evaluate_many``). The proof covers the kinematic robot only and says
so (``Proof.robot_mode``).

Exit codes: ``verification.verdicts`` (the README's table).
"""

import dataclasses
import hashlib
from pathlib import Path

import numpy as np

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
CROSS_CHECK = 5  # further scenarios replayed in Drake, drawn at random from the search's


@dataclasses.dataclass
class Outcome:
    """Everything ``verify`` found; ``report.write_report`` turns it into files."""

    verdict: str
    method: str
    proof: Proof
    log: SearchLog
    assumptions: list
    counterexamples: list  # dicts, worst first: Drake replays that violate
    unconfirmed: list  # search violations that Drake did not reproduce (should be empty)
    free_parameters: list
    seed: int
    budget: int
    config_sha256: str
    contact_geometry: str = "capsules"
    robot_mode: str = "kinematic"
    replays: list = dataclasses.field(default_factory=list)  # every Drake replay (dicts)
    disagreements: list = dataclasses.field(default_factory=list)  # see ``disagreements``


def verify(config: ControllerConfig, space: ScenarioSpace, out: Path, *, budget: int,
           method: str = "falsify", workers: int | None = None, scheduler: str | None = None,
           seed: int = 0, progress: bool = False, config_text: str = "",
           stop_at_first: bool = False, candidates: int = 8192) -> Outcome:
    """Runs proof and search for ``config`` over ``space``; writes scenario files of
    confirmed counterexamples under ``out / "counterexamples"`` and of disagreements
    under ``out / "disagreements"``. ``stop_at_first`` ends a falsifying search at its
    first violation instead of spending the whole budget; ``candidates``: how many the
    falsifier ranks before simulating."""
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
    replays = replay_in_drake(space, config, log, out, seed=seed)
    confirmed = [r for r in replays if r["drake_robustness"] < 0.0]
    unconfirmed = [r for r in replays if r["robustness"] < 0.0 <= r["drake_robustness"]]
    conflicts = disagreements(proof, replays)
    if conflicts:
        verdict = "inconclusive"
    elif confirmed:
        verdict = "falsified"
    elif proof.proved:
        verdict = "proved"
    else:
        verdict = "passed"
    how = proof.method if verdict == "proved" else f"search ({method}, seed {seed})"
    return Outcome(verdict, how, proof, log, assumptions(space, config), confirmed, unconfirmed,
                   free_parameters(space), seed, budget,
                   hashlib.sha256(config_text.encode()).hexdigest(), space.contact_geometry,
                   space.robot.mode, replays, conflicts)


def replay_choice(log: SearchLog, seed: int) -> list[tuple[int, str]]:
    """Which of the log's simulations to replay in Drake, each with why: up to
    ``CONFIRM`` distinct violations, worst first (``violation``), or, with none, the
    smallest finite robustness (``worst``); then up to ``CROSS_CHECK`` of the other
    distinct non-violating ones drawn at random for ``seed`` (``sample``)."""
    rho = log.robustness
    first: dict[tuple, int] = {}
    for i, p in enumerate(log.points):
        first.setdefault(tuple(np.round(p, 12)), i)
    distinct = sorted(first.values())
    order = sorted(distinct, key=lambda i: rho[i])  # stable: the earlier of equal ones
    chosen = [(i, "violation") for i in order if rho[i] < 0.0][:CONFIRM]
    if not chosen and order and np.isfinite(rho[order[0]]):
        chosen = [(order[0], "worst")]
    taken = {i for i, _ in chosen}
    rest = [i for i in distinct if i not in taken and rho[i] >= 0.0]
    if rest:
        pick = np.random.default_rng(seed).choice(len(rest), min(CROSS_CHECK, len(rest)),
                                                  replace=False)
        chosen += [(rest[j], "sample") for j in sorted(pick)]
    return chosen


def replay_in_drake(space, config, log, out: Path, *, seed: int = 0) -> list[dict]:
    """Replays :func:`replay_choice` in the Drake diagram (the space's robot mode): per
    replay the search's figure beside Drake's. Scenario files are written for Drake
    violations (``counterexamples/``) and for search violations Drake does not
    reproduce (``disagreements/``)."""
    rho = log.robustness
    replays, n_confirmed, n_other = [], 0, 0
    for i, why in replay_choice(log, seed):
        values = to_point(space, np.array(log.points[i]))
        scenario = make_scenario(space, config, values)
        drake, _ = evaluate_drake(scenario)
        entry = {"parameters": describe(values), "why": why, "robustness": float(rho[i]),
                 "drake_robustness": drake.stopped_before_contact,
                 "protective_violation_time": drake.protective_violation_time,
                 "protective_deepest_intrusion": drake.protective_deepest_intrusion,
                 "simulation": i + 1}
        if drake.stopped_before_contact < 0.0:
            folder, name = "counterexamples", f"counterexample_{n_confirmed}"
            n_confirmed += 1
        elif rho[i] < 0.0:
            folder, name = "disagreements", f"disagreement_{n_other}"
            n_other += 1
        else:
            folder = None
        if folder is not None:
            path = out / folder / f"{name}.yaml"
            path.parent.mkdir(exist_ok=True)
            path.write_text(dump_scenario(dataclasses.replace(scenario, name=name)))
            entry["scenario"] = str(path)
        replays.append(entry)
    return replays


def disagreements(proof: Proof, replays: list[dict]) -> list[dict]:
    """The replays whose figures contradict each other or the proof: one dict per
    scenario, with the search's figure, Drake's, the proof's claim, what disagrees
    (``conflicts``, in words) and the scenario file that reproduces it."""
    found = []
    for r in replays:
        search_bad, drake_bad = r["robustness"] < 0.0, r["drake_robustness"] < 0.0
        conflicts = []
        if search_bad and not drake_bad:
            conflicts.append("the search's violation is not reproduced in the Drake diagram")
        if drake_bad and not search_bad:
            conflicts.append("the Drake diagram violates where the search did not")
        if proof.proved and (search_bad or drake_bad):
            conflicts.append("the proof says no scenario of the box violates")
        if conflicts:
            found.append({"conflicts": conflicts, "robustness": r["robustness"],
                          "drake_robustness": r["drake_robustness"],
                          "proof": "proved" if proof.proved else "not proved",
                          "simulation": r["simulation"], "scenario": r["scenario"]})
    return found
