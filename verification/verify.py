"""``safety-systems verify``: proof where it applies, search everywhere, confirmed results.

Each property checked (``verification.properties.PROPERTIES``: ``contact``, "stopped
before contact", and ``separation``, the separation invariant) gets a verdict:
- ``inconclusive``: the evidence contradicts itself: a violation the search found is not
  reproduced in the Drake diagram, a Drake replay violates where the search did not, or
  the proof says no scenario of the box violates while a simulation (either evaluator)
  shows one. One evaluator, or the proof, is wrong; that is a defect to look into, so
  this verdict wins over every other (confirmed counterexamples are still listed);
- ``falsified``: a counterexample found by the search was replayed in the Drake diagram
  and violates the property there too;
- ``proved``: ``verification.proof`` proved the property over the whole box (and the
  search, run as a cross-check, found nothing);
- ``passed``: the search found no counterexample, but there is no proof.

The verdict of the run is the weakest of its properties' (``VERDICT_ORDER``).

Every verdict comes with Drake replays of the search's figures (:func:`replay_in_drake`):
per property, the worst violations, or the worst scenario when there is none, and a few
scenarios drawn at random, each replayed in the diagram in the space's robot mode and
compared with the search's figure (a scenario replayed for one property serves the
other too). The search honours the robot mode too: the batched evaluator models the
kinematic robot; a dynamic robot's scenarios run in the Drake diagram
(``evaluate_batch.evaluate_many``). The proofs cover the kinematic robot only and say so
(``Proof.robot_mode``).

Exit codes: ``verification.verdicts`` (the README's table).
"""

import dataclasses
import hashlib
from pathlib import Path

import numpy as np

from safety_systems.output_files import write_text
from safety_systems.scenario import ControllerConfig, dump_scenario
from verification.evaluate_drake import evaluate_drake
from verification.proof import Proof, prove, prove_separation
from verification.properties import PROPERTIES
from verification.runner import FIELDS, Runner
from verification.search import SWEEPS, SearchLog, falsify, sweep
from verification.space import (
    ScenarioSpace,
    assumptions,
    describe,
    free_parameters,
    make_scenario,
    to_point,
)
from verification.verdicts import VERDICT_ORDER

METHODS = ("falsify",) + SWEEPS
CONFIRM = 5  # counterexamples replayed in Drake per property, worst first
CROSS_CHECK = 5  # further scenarios replayed in Drake, drawn at random from the search's
PROPERTY_CHOICES = ("contact", "separation", "both")
PROVERS = {"contact": prove, "separation": prove_separation}


def selected_properties(choice: str) -> tuple[str, ...]:
    """The properties a ``--property`` choice names."""
    if choice not in PROPERTY_CHOICES:
        raise ValueError(f"property: got {choice!r}; allowed: {' | '.join(PROPERTY_CHOICES)}")
    return tuple(PROPERTIES) if choice == "both" else (choice,)


def column(name: str) -> int:
    """The column of a property's robustness in the runner's figures."""
    return FIELDS.index({"contact": "robustness", "separation": "separation"}[name])


@dataclasses.dataclass
class PropertyOutcome:
    """One property's verdict, proof, Drake replays and what they showed."""

    name: str
    verdict: str
    proof: Proof
    counterexamples: list  # dicts, worst first: Drake replays that violate
    unconfirmed: list  # search violations that Drake did not reproduce (should be empty)
    replays: list = dataclasses.field(default_factory=list)  # every Drake replay (dicts)
    disagreements: list = dataclasses.field(default_factory=list)  # see ``disagreements``

    @property
    def column(self) -> int:
        return column(self.name)


@dataclasses.dataclass
class Outcome:
    """Everything ``verify`` found; ``report.write_report`` turns it into files."""

    verdict: str  # the weakest of the properties' verdicts
    method: str
    properties: dict  # name -> PropertyOutcome
    log: SearchLog
    assumptions: list
    free_parameters: list
    seed: int
    budget: int
    config_sha256: str
    contact_geometry: str = "capsules"
    robot_mode: str = "kinematic"

    def _all(self, field: str) -> list:
        return [x for p in self.properties.values() for x in getattr(p, field)]

    @property
    def counterexamples(self) -> list:
        """Every property's confirmed counterexamples (each names its property)."""
        return self._all("counterexamples")

    @property
    def unconfirmed(self) -> list:
        return self._all("unconfirmed")

    @property
    def disagreements(self) -> list:
        return self._all("disagreements")

    @property
    def proof(self) -> Proof:
        """The first property's proof."""
        return next(iter(self.properties.values())).proof


def verify(config: ControllerConfig, space: ScenarioSpace, out: Path, *, budget: int,
           method: str = "falsify", workers: int | None = None, scheduler: str | None = None,
           seed: int = 0, progress: bool = False, config_text: str = "",
           stop_at_first: bool = False, candidates: int = 8192,
           properties: str = "both") -> Outcome:
    """Runs proofs and search for ``config`` over ``space``, for the ``properties``
    chosen (``contact``, ``separation`` or ``both``); writes scenario files of confirmed
    counterexamples under ``out / "counterexamples"`` and of disagreements under
    ``out / "disagreements"``. ``stop_at_first`` ends a falsifying search of each
    property at its first violation instead of spending the whole budget;
    ``candidates``: how many the falsifier ranks before simulating."""
    if method not in METHODS:
        raise ValueError(f"method: got {method!r}; allowed: {' | '.join(METHODS)}")
    names = selected_properties(properties)
    out.mkdir(parents=True, exist_ok=True)
    proofs = {name: PROVERS[name](config, space) for name in names}
    with Runner(workers=workers, scheduler=scheduler, cache_path=out / "evaluations.jsonl",
                progress=progress, total=budget) as runner:
        if method == "falsify":
            log = falsify(space, config, runner, budget=budget, seed=seed,
                          stop_at_first=stop_at_first, candidates=candidates,
                          objectives=[column(name) for name in names])
        else:
            log = sweep(space, config, runner, method=method, budget=budget, seed=seed)
    drake_runs: dict = {}  # Drake's figures by simulation index, shared by the properties
    results = {}
    for name in names:
        replays = replay_in_drake(space, config, log, out, seed=seed, name=name,
                                  drake_runs=drake_runs)
        confirmed = [r for r in replays if r["drake_robustness"] < 0.0]
        unconfirmed = [r for r in replays if r["robustness"] < 0.0 <= r["drake_robustness"]]
        conflicts = disagreements(proofs[name], replays)
        if conflicts:
            verdict = "inconclusive"
        elif confirmed:
            verdict = "falsified"
        elif proofs[name].proved:
            verdict = "proved"
        else:
            verdict = "passed"
        results[name] = PropertyOutcome(name, verdict, proofs[name], confirmed, unconfirmed,
                                        replays, conflicts)
    verdict = min((r.verdict for r in results.values()), key=VERDICT_ORDER.index)
    proved = [r.proof.method for r in results.values() if r.verdict == "proved"]
    how = (proved[0] if verdict == "proved" else f"search ({method}, seed {seed})"
           + (f"; proof: {proved[0]}" if proved else ""))
    return Outcome(verdict, how, results, log, assumptions(space, config),
                   free_parameters(space), seed, budget,
                   hashlib.sha256(config_text.encode()).hexdigest(), space.contact_geometry,
                   space.robot.mode)


def replay_choice(log: SearchLog, seed: int, j: int = 0) -> list[tuple[int, str]]:
    """Which of the log's simulations to replay in Drake for the property in column
    ``j``, each with why: up to ``CONFIRM`` distinct violations, worst first
    (``violation``), or, with none, the smallest finite robustness (``worst``); then up
    to ``CROSS_CHECK`` of the other distinct non-violating ones drawn at random for
    ``seed`` (``sample``)."""
    rho = log.column(j)
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
        chosen += [(rest[k], "sample") for k in sorted(pick)]
    return chosen


def replay_in_drake(space, config, log, out: Path, *, seed: int = 0, name: str = "contact",
                    drake_runs: dict | None = None) -> list[dict]:
    """Replays :func:`replay_choice` for property ``name`` in the Drake diagram (the
    space's robot mode): per replay the search's figure beside Drake's (and Drake's
    figures of every property, ``drake``). Scenario files are written for Drake
    violations (``counterexamples/``) and for search violations Drake does not
    reproduce (``disagreements/``). ``drake_runs`` keeps Drake's figures by simulation
    for the next property."""
    drake_runs = {} if drake_runs is None else drake_runs
    j, field = column(name), PROPERTIES[name]
    rho = log.column(j)
    replays, n_confirmed, n_other = [], 0, 0
    for i, why in replay_choice(log, seed, j):
        values = to_point(space, np.array(log.points[i]))
        scenario = make_scenario(space, config, values)
        if i not in drake_runs:
            drake_runs[i] = evaluate_drake(scenario)[0]
        drake = drake_runs[i]
        entry = {"property": name, "parameters": describe(values), "why": why,
                 "robustness": float(rho[i]), "drake_robustness": getattr(drake, field),
                 "drake": dataclasses.asdict(drake), "simulation": i + 1}
        if getattr(drake, field) < 0.0:
            folder, label = "counterexamples", f"{name}_counterexample_{n_confirmed}"
            n_confirmed += 1
        elif rho[i] < 0.0:
            folder, label = "disagreements", f"{name}_disagreement_{n_other}"
            n_other += 1
        else:
            folder = None
        if folder is not None:
            path = out / folder / f"{label}.yaml"
            path.parent.mkdir(exist_ok=True)
            write_text(path, dump_scenario(dataclasses.replace(scenario, name=label)))
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
            found.append({"property": r.get("property", "contact"), "conflicts": conflicts,
                          "robustness": r["robustness"],
                          "drake_robustness": r["drake_robustness"],
                          "proof": "proved" if proof.proved else "not proved",
                          "simulation": r["simulation"], "scenario": r["scenario"]})
    return found
