"""``safety-systems verify``: proof where it applies, search everywhere, confirmed results.

Each property checked (``verification.properties.PROPERTIES``: ``contact``, "stopped
before contact", and ``separation``, the separation invariant) gets a verdict:
- ``falsified``: a counterexample found by the batched evaluator was replayed in the
  Drake diagram and violates the property there too;
- ``proved``: ``verification.proof`` proved the property over the whole box (and the
  search, run as a cross-check, found nothing);
- ``passed``: the search found no counterexample, but there is no proof.

The verdict of the run is the weakest of its properties' (falsified, then passed, then
proved).
"""

import dataclasses
import hashlib
from pathlib import Path

import numpy as np

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

METHODS = ("falsify",) + SWEEPS
CONFIRM = 5  # counterexamples replayed in Drake per property, worst first
PROPERTY_CHOICES = ("contact", "separation", "both")
VERDICT_ORDER = ("falsified", "passed", "proved")  # weakest first
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
    """One property's verdict, proof and counterexamples."""

    name: str
    verdict: str
    proof: Proof
    counterexamples: list  # dicts, worst first, confirmed in Drake
    unconfirmed: list  # batch violations that Drake did not reproduce (should be empty)

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

    @property
    def counterexamples(self) -> list:
        """Every property's confirmed counterexamples (each names its property)."""
        return [c for p in self.properties.values() for c in p.counterexamples]

    @property
    def unconfirmed(self) -> list:
        return [c for p in self.properties.values() for c in p.unconfirmed]

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
    counterexamples under ``out / "counterexamples"``. ``stop_at_first`` ends a
    falsifying search of each property at its first violation instead of spending the
    whole budget; ``candidates``: how many the falsifier ranks before simulating."""
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
    results = {}
    for name in names:
        confirmed, unconfirmed = _confirm(space, config, log, out, name)
        verdict = "falsified" if confirmed else ("proved" if proofs[name].proved else "passed")
        results[name] = PropertyOutcome(name, verdict, proofs[name], confirmed, unconfirmed)
    verdict = min((r.verdict for r in results.values()), key=VERDICT_ORDER.index)
    proved = [r.proof.method for r in results.values() if r.verdict == "proved"]
    how = (proved[0] if verdict == "proved" else f"search ({method}, seed {seed})"
           + (f"; proof: {proved[0]}" if proved else ""))
    return Outcome(verdict, how, results, log, assumptions(space, config),
                   free_parameters(space), seed, budget,
                   hashlib.sha256(config_text.encode()).hexdigest(), space.contact_geometry)


def _confirm(space, config, log, out, name):
    """Replays the worst batch violations of property ``name`` in Drake; returns
    (confirmed, unconfirmed)."""
    rho = log.column(column(name))
    order = [int(i) for i in np.argsort(rho, kind="stable") if rho[i] < 0.0]
    seen, confirmed, unconfirmed = set(), [], []
    field = PROPERTIES[name]
    for i in order:
        key = tuple(np.round(log.points[i], 12))
        if key in seen:
            continue
        seen.add(key)
        if len(confirmed) + len(unconfirmed) >= CONFIRM:
            break
        values = to_point(space, np.array(log.points[i]))
        label = f"{name}_counterexample_{len(confirmed)}"
        scenario = make_scenario(space, config, values, name=label)
        drake, _ = evaluate_drake(scenario)
        entry = {"property": name, "parameters": describe(values), "robustness": float(rho[i]),
                 "drake_robustness": getattr(drake, field),
                 "drake": dataclasses.asdict(drake), "simulation": i + 1}
        if getattr(drake, field) < 0.0:
            path = out / "counterexamples" / f"{scenario.name}.yaml"
            path.parent.mkdir(exist_ok=True)
            path.write_text(dump_scenario(scenario))
            entry["scenario"] = str(path)
            confirmed.append(entry)
        else:
            unconfirmed.append(entry)
    return confirmed, unconfirmed
