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
import os
from pathlib import Path

import numpy as np

from safety_systems.files.output_files import write_text
from safety_systems.cell.robot_model import is_ur5e
from safety_systems.config.resolved_cell import ResolvedCell
from safety_systems.config.scenario import ControllerConfig, dump_scenario, robot_model_of
from verification.search.counts import Tally
from verification.search.evaluate_drake import cut_short, evaluate_drake
from verification.proof.theorems import (
    Proof,
    prove,
    prove_permitted_contact,
    prove_separation,
)
from verification.phases import Phases, verify_seconds
from verification.properties import PROPERTIES, mode_properties
from verification.search.runner import FIELDS, Runner
from verification.search.strategies import SWEEPS, SearchLog, falsify, sweep
from verification.spaces.box import ScenarioSpace
from verification.spaces.space import (
    assumptions,
    describe,
    free_parameters,
    make_scenario,
    space_cell,
    to_point,
)
from verification.verdicts import VERDICT_ORDER

METHODS = ("falsify",) + SWEEPS
CONFIRM = 5  # counterexamples replayed in Drake per property, worst first
CROSS_CHECK = 5  # further scenarios replayed in Drake, drawn at random from the search's
PROPERTY_CHOICES = ("contact", "separation", "permitted_contact", "both")
PHASES = 4  # proofs, search, Drake replays, report
PROVERS = {"contact": prove, "separation": prove_separation,
           "permitted_contact": prove_permitted_contact}


def proofs_of(cell: ResolvedCell, space: ScenarioSpace) -> dict:
    """The proof of each property the configuration resolved in ``cell``
    (``spaces.space.space_cell``) is verified for (:data:`PROVERS`)."""
    return _prove(cell, space, mode_properties(cell.config.safety.mode))


def _prove(cell: ResolvedCell, space: ScenarioSpace, names) -> dict:
    """The proof of each property in ``names`` (:data:`PROVERS`)."""
    return {name: PROVERS[name](cell, space) for name in names}


def selected_properties(choice: str, mode: str = "ssm") -> tuple[str, ...]:
    """The properties a ``--property`` choice names: ``both``, the two a configuration of
    ``safety.mode`` ``mode`` is verified for (``properties.mode_properties``: under
    ``ssm`` stopped before contact and the separation invariant, under ``ssm_pfl``
    permitted contact and the invariant's SSM part)."""
    if choice not in PROPERTY_CHOICES:
        raise ValueError(f"property: got {choice!r}; allowed: {' | '.join(PROPERTY_CHOICES)}")
    return mode_properties(mode) if choice == "both" else (choice,)


def column(name: str) -> int:
    """The column of a property's robustness in the runner's figures."""
    return FIELDS.index({"contact": "robustness", "separation": "separation",
                         "permitted_contact": "permitted_contact"}[name])


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
    # when the first violation was found by the search and confirmed in Drake (see
    # ``first_counterexample``)
    first_counterexample: dict | None = None

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
    # every evaluation of a model of the loop, by kind and in total, and the CPU and
    # wall seconds of the whole run (``verification.search.counts``)
    evaluations: dict = dataclasses.field(default_factory=dict)
    stopped_at_first: str | None = None  # the property confirmed first (--stop-at-first)
    unchecked: list = dataclasses.field(default_factory=list)  # properties left unchecked
    # the space's robot where it is not the UR5e (its model, joints, URDF and the URDF's
    # SHA-256: ``deploy.certificate.robot_identity``); None: the UR5e
    robot: dict | None = None
    safety_mode: str = "ssm"  # the configuration's safety.mode
    # the placeholder stopping data's warning for the space's robot ("" where the
    # configuration gives its own data: ``ResolvedCell.braking_warning``)
    braking_warning: str = ""

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
           properties: str = "both", phases: Phases | None = None,
           cell: ResolvedCell | None = None) -> Outcome:
    """Runs proofs and search for ``config`` over ``space``, for the ``properties``
    chosen (``contact``, ``separation``, ``permitted_contact`` or ``both``: the two of
    the configuration's ``safety.mode``, :func:`selected_properties`); writes scenario files of confirmed
    counterexamples under ``out / "counterexamples"`` and of disagreements under
    ``out / "disagreements"``. ``stop_at_first``: the falsifier replays each violation
    it finds in the Drake diagram at once and returns at the first one Drake confirms
    (the other properties are then left unchecked, and no cross-check replays are
    made); ``candidates``: how many the falsifier's reduced model ranks. Every
    evaluation of a model of the loop is counted (``Outcome.evaluations``). ``phases``
    names the first three of ``PHASES`` as they start (the caller the report's).
    ``cell``: ``config`` resolved on the space (``spaces.space.space_cell``; None: resolved
    here, once): the proofs, the search and the Drake replays all take it."""
    if method not in METHODS:
        raise ValueError(f"method: got {method!r}; allowed: {' | '.join(METHODS)}")
    names = selected_properties(properties, config.safety.mode)
    tally = Tally()  # the clocks start here: proofs, search and replays all count
    if cell is None:
        cell = space_cell(config, space)
    else:
        cell.check_config(config, "verify")
    out.mkdir(parents=True, exist_ok=True)
    phases = Phases("verify", PHASES, on=False) if phases is None else phases
    cores = workers or os.cpu_count() or 1
    in_drake = space.recording is not None or space.robot.mode == "dynamic"
    most = len(names) * (CONFIRM + CROSS_CHECK)  # Drake replays at most
    phases.start(f"proving {len(names)} properties over the whole box",
                 left=verify_seconds(budget, most, cores, in_drake))
    proofs = _prove(cell, space, names)
    phases.start(f"searching ({method}): a budget of {budget} simulation-equivalents",
                 left=verify_seconds(budget, most, cores, in_drake))
    drake_runs: dict = {}  # Drake's figures by simulation index, shared by the properties
    confirmations: dict = {}  # name -> the replay entries made during the search
    first_confirmed: dict = {}  # name -> tally snapshot when first confirmed in Drake

    def confirm(log: SearchLog, j: int, i: int) -> bool:
        """Replays simulation i, a violation of the property in column j, in Drake."""
        name = next(n for n in names if column(n) == j)
        entry = _replay(space, cell, log, out, i, "violation", name, drake_runs, tally,
                        confirmations.setdefault(name, []))
        if entry["drake_robustness"] < 0.0:
            first_confirmed.setdefault(name, tally.snapshot())
            return True
        return False

    with Runner(workers=workers, scheduler=scheduler, cache_path=out / "evaluations.jsonl",
                progress=progress, total=budget, tally=tally) as runner:
        if method == "falsify":
            log = falsify(space, cell, runner, budget=budget, seed=seed,
                          stop_at_first=stop_at_first, candidates=candidates,
                          objectives=[column(name) for name in names],
                          confirm=confirm if stop_at_first else None)
        else:
            log = sweep(space, cell, runner, method=method, budget=budget, seed=seed)
    stopped = next((n for n in names if n in first_confirmed), None)
    replays = 0 if stopped is not None else len({i for name in names for i, _ in
                                                 replay_choice(log, seed, column(name))})
    phases.start(f"replaying {replays} scenarios of the search in the Drake diagram",
                 left=verify_seconds(0, replays, cores, in_drake))
    results = {}
    for name in names:
        if stopped is not None:  # --stop-at-first: only what the search replayed
            if name not in confirmations:
                continue
            replays = confirmations[name]
        else:
            replays = replay_in_drake(space, cell, log, out, seed=seed, name=name,
                                      drake_runs=drake_runs, tally=tally,
                                      first_confirmed=first_confirmed)
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
                                        replays, conflicts,
                                        first_counterexample(log, column(name),
                                                             first_confirmed.get(name)))
    verdict = min((r.verdict for r in results.values()), key=VERDICT_ORDER.index)
    proved = [r.proof.method for r in results.values() if r.verdict == "proved"]
    how = (proved[0] if verdict == "proved" else f"search ({method}, seed {seed})"
           + (f"; proof: {proved[0]}" if proved else ""))
    return Outcome(verdict, how, results, log, assumptions(space, config),
                   free_parameters(space), seed, budget,
                   hashlib.sha256(config_text.encode()).hexdigest(), space.contact_geometry,
                   space.robot.mode, tally.snapshot(), stopped,
                   [n for n in names if n not in results], _robot(space),
                   config.safety.mode, cell.braking_warning)


def _robot(space: ScenarioSpace) -> dict | None:
    """The space's robot as a report names it, None for the UR5e (the default robot, named
    by omission as a scenario file names it)."""
    model = robot_model_of(space.robot)
    if is_ur5e(model):
        return None
    return {"model": model.name, "joints": list(model.joint_names), "urdf": model.urdf.name,
            "urdf_sha256": model.sha256}


def first_counterexample(log: SearchLog, j: int, confirmed: dict | None) -> dict | None:
    """The first violation of the property in column j: its simulation's number, and
    the evaluations of each kind made and the CPU and wall seconds spent when the search
    found it (by then the whole batch that held it was simulated) and when the Drake
    diagram first confirmed a violation of it (None if never); None if none found."""
    found = log.first.get(j)
    if found is None and log.first_violation(j) is not None:  # (a column not watched)
        found = {"simulation": log.first_violation(j)}
    if found is None:
        return None
    return {"simulation": found["simulation"],
            "found": {k: v for k, v in found.items() if k != "simulation"} or None,
            "confirmed": confirmed}


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


def replay_in_drake(space, cell: ResolvedCell, log, out: Path, *, seed: int = 0,
                    name: str = "contact", drake_runs: dict | None = None,
                    tally: Tally | None = None, first_confirmed: dict | None = None
                    ) -> list[dict]:
    """Replays :func:`replay_choice` for property ``name`` in the Drake diagram (the
    space's robot mode; the configuration resolved in ``cell``,
    ``spaces.space.space_cell``): per replay the search's figure beside Drake's (and Drake's
    figures of every property, ``drake``). Scenario files are written for Drake
    violations (``counterexamples/``) and for search violations Drake does not
    reproduce (``disagreements/``). ``drake_runs`` keeps Drake's figures by simulation
    for the next property; ``tally`` counts the Drake runs, and ``first_confirmed``
    gets its snapshot when the property's first violation is confirmed."""
    drake_runs = {} if drake_runs is None else drake_runs
    replays: list = []
    for i, why in replay_choice(log, seed, column(name)):
        entry = _replay(space, cell, log, out, i, why, name, drake_runs, tally, replays)
        if (entry["drake_robustness"] < 0.0 and first_confirmed is not None
                and tally is not None):
            first_confirmed.setdefault(name, tally.snapshot())
    return replays


def _replay(space, cell: ResolvedCell, log, out: Path, i: int, why: str, name: str,
            drake_runs: dict, tally: Tally | None, replays: list) -> dict:
    """Simulation i of the log replayed in the Drake diagram for property ``name``, as
    an entry appended to ``replays`` (see :func:`replay_in_drake`). A violation's replay
    stops a quarter second after Drake shows it (``evaluate_drake``'s ``stop_on``); a
    run cut short serves another property only where it shows that one violated too,
    else the scenario is run again in full."""
    field = PROPERTIES[name]
    rho = log.column(column(name))[i]
    values = to_point(space, np.array(log.points[i]))
    scenario = make_scenario(space, cell.config, values)
    known = drake_runs.get(i)
    if known is None or (known[1] is not None and getattr(known[0], field) >= 0.0):
        drake, run = (evaluate_drake(scenario, stop_on=name, cell=cell) if why == "violation"
                      else evaluate_drake(scenario, cell=cell))
        known = drake_runs[i] = (drake, float(run.time[-1]) if cut_short(run) else None)
        if tally is not None:
            tally.add("drake")
    drake, short = known
    entry = {"property": name, "parameters": describe(values), "why": why,
             "robustness": float(rho), "drake_robustness": getattr(drake, field),
             # the Drake run stopped here (s), a quarter second after the violation
             # showed (its figures are the run's so far), or None: it ran to the end
             "drake": dataclasses.asdict(drake), "drake_stopped_at": short,
             "simulation": i + 1}
    n_confirmed = sum(1 for r in replays if r["drake_robustness"] < 0.0)
    n_other = sum(1 for r in replays if r["robustness"] < 0.0 <= r["drake_robustness"])
    if getattr(drake, field) < 0.0:
        folder, label = "counterexamples", f"{name}_counterexample_{n_confirmed}"
    elif rho < 0.0:
        folder, label = "disagreements", f"{name}_disagreement_{n_other}"
    else:
        folder = None
    if folder is not None:
        path = out / folder / f"{label}.yaml"
        path.parent.mkdir(exist_ok=True)
        write_text(path, dump_scenario(dataclasses.replace(scenario, name=label)))
        entry["scenario"] = str(path)
    replays.append(entry)
    return entry


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
