"""``safety-systems tune``: the fastest configuration that is still verified safe.

The search runs over the tunable parameters (``verification.tune.tunable``) of a base
configuration. Its objective is the total task time of the nominal task scenarios
(``verification.tune.tasks``); its constraint is the verdict of ``verify`` over the scenario
space: ``proved`` (or ``passed`` with ``allow="passed"``) for both properties. The
costs differ by orders of magnitude, so each candidate meets the cheap tests first:

1. the screen, for ``screen`` times as many Sobol points of the parameters' box as will
   be simulated (rounded up to a power of two), and the base configuration: the
   configuration's own rules, T_r not below the loop's reaction time, every
   counterexample kept so far replayed in the batched evaluator (a violation rejects the
   candidate) and the two proofs
   (``verification.proof``, milliseconds each; under ``allow="proved"`` an unproved
   candidate is rejected here);
2. the candidates left are taken in order of a proxy (:func:`proxy_distance`), the
   mean over the speed levels of the distance beyond which a still operator lets the
   robot run at that level (for ``stopping: full_speed`` every level's is the
   full-speed distance: ΔS times S for a body and a robot at rest, at least d_min; it
   only orders candidates: every figure that decides is measured): the base
   configuration first, then up to ``candidates`` more. Each is
   replayed against the counterexamples kept since its screen, then its task
   scenarios are run in the Drake diagram;
3. a candidate whose total task time beats the best so far is verified in full
   (``verification.verify``: proofs, the falsifying search with ``budget``
   simulations, Drake replays); the first verdict that meets the constraint makes it
   the best so far. A rejected candidate's confirmed counterexamples are kept, and
   every later candidate is replayed against them first.

The references (``models/configs/iso.yaml`` and the seed's ``seed_estimated.yaml``)
are verified and timed the same way, with a run with no operator beside each, for the
comparison in ``tune.md``; a reference's counterexamples are kept too.

Last, with ``levers`` (a tune file's ``levers:``), the chosen configuration is priced
under each: fitted to that sensing and proved on the space with its tracked points
(``verification.tune.levers``), and the tasks run with their operators wearing its
sensor set, for the table of what each lever buys in ``tune.md``.
"""

import dataclasses
import math
import os
import shutil
import time
from pathlib import Path

import numpy as np
from pydrake.common.yaml import yaml_dump_typed

from safety_systems.files.documents import read_text
from safety_systems.files.input_error import InputError
from safety_systems.files.output_files import write_text
from safety_systems.config.scenario import (
    ControllerConfig,
    Scenario,
    load_controller_config,
    load_scenario,
    validate_controller,
)
from safety_systems.ssm.formulas import monitor_protective_distances
from safety_systems.config.resolved_cell import ResolvedCell
from verification.phases import DRAKE_REAL_TIME, Phases, verify_seconds
from verification.properties import mode_properties
from verification.search.runner import Runner
from verification.search.strategies import sweep_points
from verification.spaces.box import ScenarioSpace
from verification.spaces.space import space_cell
from verification.tune.levers import price, record
from verification.tune.tasks import TaskRun, lost_time, run_task, total
from verification.verify import CONFIRM, CROSS_CHECK, proofs_of
from verification.tune.tunable import REACTION_TIME, TunedParameter, values_at, with_values

MODELS = Path(__file__).parents[2] / "models"
REFERENCES = {"iso.yaml": MODELS / "configs" / "iso.yaml",
              "seed_estimated.yaml": MODELS / "configs" / "seed_estimated.yaml"}
TASKS = (MODELS / "scenarios" / "inspection_seed.yaml", MODELS / "scenarios" / "co_kitting.yaml")
ALLOW = ("proved", "passed")
SCREEN = 16  # screened points per simulated candidate


def property_columns(config: ControllerConfig) -> dict:
    """The properties a configuration is verified for (its ``safety.mode``'s:
    ``properties.mode_properties``) and the runner's column of each."""
    from verification.verify import column

    return {name: column(name) for name in mode_properties(config.safety.mode)}


@dataclasses.dataclass
class Kept:
    """A confirmed counterexample kept for the rest of the search."""

    scenario: Scenario
    found_for: str  # the configuration it was found for
    property: str
    robustness: float  # in the Drake diagram, m
    file: str  # its copy under DIR/counterexamples/


@dataclasses.dataclass
class Candidate:
    """One configuration the search looked at, and how far it got."""

    index: int
    values: dict
    cell: ResolvedCell | None  # what its configuration means on the space (None: invalid)
    status: str = "screened"  # invalid | counterexample | unproved | ... | accepted
    reason: str = ""
    proved: dict = dataclasses.field(default_factory=dict)  # property -> bool
    proxy: float = math.inf
    full_speed: float = math.inf  # full_speed_distance
    checked: int = 0  # kept counterexamples replayed so far
    tasks: list = dataclasses.field(default_factory=list)  # TaskRun
    objective: float = math.inf
    verdict: str | None = None
    report: str | None = None  # its report.json
    report_dict: dict | None = dataclasses.field(default=None, repr=False)

    @property
    def config(self) -> ControllerConfig | None:
        return None if self.cell is None else self.cell.config

    def record(self) -> dict:
        return {"index": self.index, "values": self.values, "status": self.status,
                "reason": self.reason, "proved": self.proved,
                "full_speed_distance": None if math.isinf(self.full_speed) else self.full_speed,
                "proxy_distance": None if math.isinf(self.proxy) else self.proxy,
                "task_times": {t.task: t.task_time for t in self.tasks},
                "total_task_time": None if math.isinf(self.objective) else self.objective,
                "verdict": self.verdict, "report": self.report}


REFINE_SEEDS = 3  # proved candidates of the lowest proxy that are refined
REFINE_STEPS = 6  # bisections per number


def level_distances(cell: ResolvedCell) -> np.ndarray:
    """Beyond what distance a still operator lets the robot (at rest) run at each speed
    level g / SPEED_LEVELS: ΔS times the monitor's S (Eqs. 9-11) for a body and a robot at
    rest with that level's stop (the cell's ``level_stops``; every level's is the
    full-speed stop under ``stopping: full_speed``), at least d_min (the human speed by
    the configuration's mode; the stops the cell's robot's)."""
    f = cell.config.safety
    t_s, b = cell.level_stops
    s = np.array([float(monitor_protective_distances(
        np.zeros(1), np.zeros(1), mode=f.human_speed, reaction_time=f.reaction_time,
        stopping_time=float(t), stopping_distance=float(d),
        intrusion_distance=f.intrusion_distance, human_uncertainty=f.human_uncertainty,
        robot_uncertainty=f.robot_uncertainty, iso_speed=f.iso_human_speed,
        iso_reduced_speed=f.iso_reduced_human_speed)[0]) for t, d in zip(t_s, b)])
    return np.maximum(f.delta_s * np.maximum(s, 0.0), f.d_min)


def full_speed_distance(cell: ResolvedCell) -> float:
    """Beyond what distance a still operator lets the robot (at rest) run at full speed
    (:func:`level_distances` at the top level)."""
    return float(level_distances(cell)[-1])


def proxy_distance(cell: ResolvedCell) -> float:
    """The proxy that orders candidates: the mean of :func:`level_distances` (the
    full-speed distance under ``stopping: full_speed``; lower under ``by_speed``, where
    the robot runs slower instead of standing nearer than that)."""
    return float(np.mean(level_distances(cell)))


def config_text(config: ControllerConfig, header: list[str]) -> str:
    """A configuration file's text: ``header`` as comments, then every field."""
    return "".join(f"# {line}\n" for line in header) + yaml_dump_typed(config)


class Tuner:
    """The state of one tune run (see the module docstring)."""

    def __init__(self, config: ControllerConfig, block: list[TunedParameter],
                 space: ScenarioSpace, tasks: list[Scenario], out: Path, *, space_path: str,
                 allow: str = "proved", budget: int = 200, candidates: int = 24,
                 screen: int = SCREEN, workers: int | None = None,
                 scheduler: str | None = None, seed: int = 0, references: dict | None = None,
                 origin: dict | None = None, say=None, progress: bool = False,
                 levers: list | None = None):
        if allow not in ALLOW:
            raise ValueError(f"allow: got {allow!r}; allowed: {' | '.join(ALLOW)}")
        self.config, self.block, self.space, self.tasks = config, block, space, tasks
        self.out, self.space_path, self.allow = out, space_path, allow
        self.budget, self.n_candidates, self.screen = budget, candidates, screen
        self.workers, self.scheduler, self.seed = workers, scheduler, seed
        self.references = REFERENCES if references is None else references
        self.origin, self._say = origin, say or (lambda line: None)
        self.levers = list(levers or [])
        self.progress = Progress(progress, (5 if allow == "proved" else 4)
                                 + (1 if self.levers else 0))
        cores = 1 if scheduler is not None else workers or os.cpu_count() or 1
        # seconds of a verification and of one run of the tasks, for the estimates:
        # from the measured costs until measured here (verification.phases)
        self.seconds = {
            "verify": verify_seconds(budget, 2 * (CONFIRM + CROSS_CHECK), cores,
                                     space.recording is not None
                                     or space.robot.mode == "dynamic"),
            "tasks": sum(t.duration for t in tasks) / DRAKE_REAL_TIME
            / min(cores, max(1, len(tasks)))}
        self.kept: list[Kept] = []
        self.counts = {"screened": 0, "proofs": 0, "counterexample_replays": 0,
                       "task_runs": 0, "verifications": 0, "simulations": 0}
        self.control_period = 1.0 / space.robot.control_rate_hz

    def say(self, line: str) -> None:
        self.progress.write(line, self._say)

    # ------------------------------------------------------------------ the pieces

    def verify(self, cell: ResolvedCell, text: str, config_path: str, folder: Path,
               label: str) -> dict:
        """verify's report of the configuration resolved in ``cell`` (:meth:`cell_of`;
        its file text is ``text``), written to ``folder``; its confirmed counterexamples
        are kept."""
        from verification.report import write_report
        from verification.verify import verify

        folder.mkdir(parents=True, exist_ok=True)
        start = time.perf_counter()
        outcome = verify(cell.config, self.space, folder, budget=self.budget,
                         workers=self.workers, scheduler=self.scheduler, seed=self.seed,
                         config_text=text, properties="both", cell=cell)
        report = write_report(outcome, folder, config_path=config_path,
                              space_path=self.space_path, replay=False, origin=self.origin)
        self.counts["verifications"] += 1
        self.seconds["verify"] = time.perf_counter() - start  # the estimates' (latest)
        self.counts["simulations"] += report["simulations"]
        for name, p in report["properties"].items():
            for c in p["counterexamples"]:
                self.keep(c, label, name)
        return report

    def keep(self, entry: dict, label: str, name: str) -> None:
        target = self.out / "counterexamples" / f"{len(self.kept):03d}_{name}.yaml"
        target.parent.mkdir(exist_ok=True)
        shutil.copyfile(entry["scenario"], target)
        self.kept.append(Kept(load_scenario(target), label, name,
                              float(entry["drake_robustness"]), str(target)))

    def recheck(self, runner: Runner, candidates: list[Candidate]) -> None:
        """Replays, in the batched evaluator, the kept counterexamples each candidate
        has not met yet; a violation of either property rejects it."""
        jobs = [(c, k) for c in candidates if c.status == "screened"
                for k in self.kept[c.checked:]]
        if not jobs:
            return
        scenarios = [dataclasses.replace(k.scenario, controller=c.config) for c, k in jobs]
        # (each candidate's scenarios form their own batches: the evaluator resolves each
        # batch's configuration with its scenarios' operators, which are the kept files')
        figures = runner.evaluate(scenarios)
        self.counts["counterexample_replays"] += len(jobs)
        for (c, k), row in zip(jobs, figures):
            columns = property_columns(c.config)
            bad = [name for name, j in columns.items() if row[j] < 0.0]
            if bad and c.status == "screened":
                c.status = "counterexample"
                c.reason = (f"violates {bad[0]} ({row[columns[bad[0]]]:.4f}) in "
                            f"{k.file}, kept from {k.found_for}")
        for c in candidates:
            c.checked = len(self.kept)

    def prove(self, c: Candidate) -> None:
        proofs = proofs_of(c.cell, self.space)
        self.counts["proofs"] += len(proofs)
        c.proved = {name: p.proved for name, p in proofs.items()}
        if self.allow == "proved" and not all(c.proved.values()):
            name, p = next((n, p) for n, p in proofs.items() if not p.proved)
            failed = next((x.statement for x in p.premises if not x.holds), "")
            c.status, c.reason = "unproved", f"{name}: {failed}" + (
                f" (margin at the worst corner {p.margin_at_worst_corner:.4f} m)"
                if p.margin_at_worst_corner is not None else "")

    def run_tasks(self, runner: Runner, config: ControllerConfig, *, operators: bool = True
                  ) -> list[TaskRun]:
        self.counts["task_runs"] += len(self.tasks)
        start = time.perf_counter()
        runs = runner.map(_run_task, [(t, config, operators) for t in self.tasks])
        if operators:  # (the estimates': the runs with operators, which take longer)
            self.seconds["tasks"] = time.perf_counter() - start
        return runs

    # --------------------------------------------------------------------- the run

    def candidates(self) -> list[Candidate]:
        """The base configuration and the screen's Sobol points, validated."""
        wanted = max(1, self.screen * self.n_candidates)
        points = sweep_points("sobol", 1 << (wanted - 1).bit_length(),  # a power of two
                              len(self.block), seed=self.seed)
        base = {p.name: _get(self.config, p.name) for p in self.block}
        out = [Candidate(0, base, self.cell_of(self.config))]
        for i, u in enumerate(points, start=1):
            values = values_at(self.block, u)
            out.append(Candidate(i, values, None))
            try:
                out[-1].cell = self.build(values)
            except InputError as e:
                out[-1].status, out[-1].reason = "invalid", str(e)
        self.counts["screened"] = len(out)
        return out

    def cell_of(self, config: ControllerConfig) -> ResolvedCell:
        """What ``config`` means on the space's robot for its operators, resolved once:
        the value its proofs and its proxy take."""
        return space_cell(config, self.space)

    def build(self, values: dict) -> ResolvedCell:
        """The resolved cell of the configuration with these values, validated (raises
        InputError): its rules, and T_r not below the loop's own reaction time."""
        config = with_values(self.config, values)
        validate_controller(config)
        cell = self.cell_of(config)
        floor = cell.frame_timeout + self.control_period
        if any(p.name == REACTION_TIME for p in self.block) and \
                config.safety.reaction_time < floor - 1e-12:
            raise InputError(REACTION_TIME, config.safety.reaction_time,
                             f">= {floor:.4g} s, the loop's own reaction time")
        return cell

    def refine(self, c: Candidate, index: int) -> Candidate | None:
        """A proved candidate pushed, one parameter at a time, towards a lower proxy while
        both proofs still hold: a choice is taken if it proves and lowers the proxy; a
        number is bisected (REFINE_STEPS times) between its value and the end of its range
        that lowers the proxy. A number the proxy does not depend on (the frame timeout,
        the tracker's noise) goes instead towards the end where the proofs' least margin
        is larger, if it is: that margin is what the parameters after it in the block
        (T_r, Z_r) then spend. Proofs take milliseconds, so this costs no simulation (the
        proofs it runs are counted). None if nothing lowered the proxy."""
        values = dict(c.values)

        def assessed(trial: dict) -> tuple[bool, float, float] | None:
            """(both proved, proxy, the proofs' least margin); None if not valid."""
            try:
                cell = self.build(trial)
            except InputError:
                return None
            proofs = list(proofs_of(cell, self.space).values())
            self.counts["proofs"] += len(proofs)
            return (all(x.proved for x in proofs), round(proxy_distance(cell), 12),
                    min(x.margin_at_worst_corner for x in proofs))

        def judged(trial: dict) -> tuple | None:  # (proxy, -least margin) if both prove
            found = assessed(trial)
            return (found[1], -found[2]) if found is not None and found[0] else None

        def margin(trial: dict) -> float:  # the proofs' least margin, proved or not
            found = assessed(trial)
            return -math.inf if found is None else found[2]

        key = judged(values)
        if key is None:
            return None
        for p in self.block:
            if p.choices:
                for choice in p.choices:
                    trial = dict(values, **{p.name: choice})
                    found = judged(trial) if str(choice) != str(values[p.name]).lower() \
                        else None
                    if found is not None and found[0] < key[0]:
                        values, key = trial, found
                continue
            if isinstance(values[p.name], int):
                continue  # (a count: not bisected)
            ends = {end: round(proxy_distance(self.cell_of(with_values(
                self.config, dict(values, **{p.name: end})))), 12)
                for end in (p.min, p.max)}
            if min(ends.values()) < key[0]:
                target = min(ends, key=ends.get)
            elif all(v == key[0] for v in ends.values()):  # the proxy does not depend on it
                room = {end: margin(dict(values, **{p.name: end})) for end in ends}
                target = max(room, key=room.get)
                if not room[target] > -key[1]:
                    continue
            else:
                continue  # the proxy does not fall this way
            good, bad = values[p.name], target  # proved; not known
            for step in range(REFINE_STEPS + 1):
                x = bad if step == 0 else 0.5 * (good + bad)  # the end itself first
                trial = dict(values, **{p.name: x})
                found = judged(trial)
                if found is not None and found < key:
                    values, key, good = trial, found, x
                    if step == 0:
                        break
                else:
                    bad = x
        if not key[0] < round(c.proxy, 12):
            return None
        out = Candidate(index, values, self.build(values))
        out.proved = {name: True for name in mode_properties(out.config.safety.mode)}
        out.proxy = proxy_distance(out.cell)
        out.full_speed = full_speed_distance(out.cell)
        return out

    def run(self) -> dict:
        self.out.mkdir(parents=True, exist_ok=True)
        bar = self.progress
        with bar, Runner(workers=self.workers, scheduler=self.scheduler,
                         cache_path=self.out / "evaluations.jsonl") as runner:
            bar.phase(f"verifying and timing {len(self.references)} reference "
                      f"configurations ({', '.join(self.references)})",
                      len(self.references), left=self.left(len(self.references)))
            rows = []
            for label, path in self.references.items():
                rows.append(self.reference(runner, label, path))
                bar.step()
            pool = self.candidates()
            valid = [c for c in pool if c.status == "screened"]
            bar.phase(f"screening {len(valid)} candidates: the counterexamples kept, then "
                      "the proofs", len(valid) + 1, left=self.left(0))
            self.recheck(runner, valid)
            bar.step()
            for c in valid:
                if c.status == "screened":
                    self.prove(c)
                    c.proxy = proxy_distance(c.cell)
                    c.full_speed = full_speed_distance(c.cell)
                bar.step()
            if self.allow == "proved":  # the proofs are the constraint: descend on them
                seeds = sorted((c for c in pool if c.status == "screened"),
                               key=lambda c: (c.proxy, c.index))[:REFINE_SEEDS]
                bar.phase(f"refining the {len(seeds)} best proved candidates by their proofs",
                          len(seeds), left=self.left(0))
                for c in seeds:
                    refined = self.refine(c, len(pool))
                    if refined is not None:
                        refined.reason = f"refined from candidate {c.index}"
                        pool.append(refined)
                        self.recheck(runner, [refined])
                    bar.step()
                self.counts["refined"] = len(pool) - self.counts["screened"]
            order = [pool[0]] + sorted((c for c in pool[1:] if c.status == "screened"),
                                       key=lambda c: (c.proxy, c.index))
            queue = order[:self.n_candidates + 1]
            best, evaluated = None, []
            bar.phase(f"simulating the tasks of up to {len(queue)} candidates, verifying "
                      "each one faster than the best so far", len(queue),
                      left=self.left(0, len(queue)))
            for c in queue:
                if c.status == "screened":  # the base configuration may have failed its screen
                    evaluated.append(c)
                    best = self.evaluate(runner, c, best)
                bar.step()
            for c in pool:
                if c.status == "screened":
                    c.status = "not simulated"
                    c.reason = f"beyond the {self.n_candidates} candidates simulated"
            chosen_row = None
            if best is not None:
                bar.phase("timing the chosen configuration's tasks", 1,
                          left=self.left(0, 0))
                chosen_row = self.row(runner, "chosen", best.config, best.report_dict,
                                      best.tasks)
                chosen_row["held"] = self.held(best.config)
                bar.step()
            priced = []
            if best is not None and self.levers:
                bar.phase(f"pricing {len(self.levers)} levers for the chosen configuration",
                          len(self.levers), left=self.left(0, 0))
                iso = next((r for r in rows if r["configuration"] == "iso.yaml"), None)
                baselines: dict = {}
                for lever in self.levers:
                    row = price(best.config, lever, self.space, self.tasks, baselines)
                    self.counts["proofs"] += row.fitted.proofs_run
                    self.counts["task_runs"] += len(self.tasks)
                    priced.append(record(row, iso and iso["total_lost_time"]))
                    self.say(f"lever {lever.label}: "
                             f"{'proved' if row.fitted.proved else 'not proved'}, lost "
                             + ("unfinished" if row.total is None else f"{row.total:.2f} s"))
                    bar.step()
                self.counts["task_runs"] += len(baselines)
        result = self.result(pool, evaluated, rows, best, chosen_row)
        result["levers"] = priced
        return result

    def held(self, config: ControllerConfig) -> dict:
        """What held the robot on each task under ``config`` (``outputs.held.held_by``: the
        stop causes' seconds, and the segment that held it with the real body's clearance
        then), each task run once more in the Drake diagram for its duration (counted)."""
        from safety_systems.config.configuration import with_controller
        from safety_systems.diagrams.simulation import simulate
        from safety_systems.outputs.held import held_by
        from verification.search.evaluate_drake import collect_diagram_garbage

        out = {}
        for task in self.tasks:
            try:
                out[task.name] = held_by(simulate(with_controller(task, config)))
            finally:
                collect_diagram_garbage()
            self.counts["task_runs"] += 1
        return out

    def left(self, references: int, candidates: int | None = None) -> tuple[float, float]:
        """The least and the most time the rest of the run may take, from the start of
        a phase with ``references`` still to verify and time and ``candidates`` still to
        simulate (None: all of them; the screen and the refinement, proofs only, are
        left out): each candidate's tasks are run, and at most all of them, at least
        none, verified; the chosen one's run with no operator last."""
        candidates = self.n_candidates + 1 if candidates is None else candidates
        tasks, verify = self.seconds["tasks"], self.seconds["verify"]
        fixed = references * (verify + 2 * tasks) + candidates * tasks + tasks
        return fixed, fixed + candidates * verify

    def reference(self, runner: Runner, label: str, path: Path) -> dict:
        config = load_controller_config(path)
        report = self.verify(self.cell_of(config), read_text(path), str(path),
                             self.out / "references" / Path(label).stem, label)
        self.say(f"{label}: {report['verdict']}")
        return self.row(runner, label, config, report, None)

    def row(self, runner: Runner, label: str, config: ControllerConfig, report: dict,
            runs: list[TaskRun] | None) -> dict:
        """A row of the comparison: verdict, vacuous share, and per task the task time,
        the run with no operator's, the time lost and the time stopped."""
        runs = self.run_tasks(runner, config) if runs is None else runs
        baselines = self.run_tasks(runner, config, operators=False)
        tasks = {r.task: {"task_time": r.task_time, "no_operator": b.task_time,
                          "lost_time": lost_time(r, b), "stopped_time": r.stopped_time}
                 for r, b in zip(runs, baselines)}
        lost = [t["lost_time"] for t in tasks.values()]
        return {"configuration": label, "verdict": report["verdict"],
                "properties": {n: p["verdict"] for n, p in report["properties"].items()},
                "vacuous": {n: p["vacuous"]["evaluated"] for n, p in
                            report["properties"].items()},
                "tasks": tasks,
                "total_task_time": _finite(total([r.task_time for r in runs])),
                "total_lost_time": _finite(total(lost))}

    def evaluate(self, runner: Runner, c: Candidate, best: Candidate | None
                 ) -> Candidate | None:
        """Steps 2 and 3 of the module docstring for one candidate; the best so far."""
        self.recheck(runner, [c])
        if c.status != "screened":
            self.say(f"candidate {c.index}: {c.status}: {c.reason}")
            return best
        c.tasks = self.run_tasks(runner, c.config)
        c.objective = total([r.task_time for r in c.tasks])
        if math.isinf(c.objective):
            c.status, c.reason = "unfinished", "a task did not finish within its horizon"
        elif best is not None and c.objective >= best.objective:
            c.status = "slower"
            c.reason = f"{c.objective:.3f} s >= the best so far, {best.objective:.3f} s"
        if c.status != "screened":
            self.say(f"candidate {c.index}: {c.status}: {c.reason}")
            return best
        folder = self.out / "candidates" / f"{c.index:04d}"
        folder.mkdir(parents=True, exist_ok=True)
        text = config_text(c.config, [f"candidate {c.index} of safety-systems tune: "
                                      + ", ".join(f"{k}={v}" for k, v in c.values.items())])
        write_text(folder / "config.yaml", text)
        report = self.verify(c.cell, text, str(folder / "config.yaml"), folder,
                             f"candidate {c.index}")
        c.verdict, c.report = report["verdict"], str(folder / "report.json")
        c.report_dict = report
        acceptable = ALLOW[:ALLOW.index(self.allow) + 1]
        if c.verdict in acceptable:
            c.status = "accepted"
            c.reason = f"{c.verdict}; total task time {c.objective:.3f} s"
            if best is not None:
                best.status = "superseded"
            best = c
        else:
            c.status, c.reason = "rejected", f"verify: {c.verdict}"
        self.say(f"candidate {c.index}: {c.status}: {c.reason}")
        return best

    def result(self, pool: list[Candidate], evaluated: list[Candidate], rows: list[dict],
               best: Candidate | None, chosen_row: dict | None) -> dict:
        table = ([chosen_row] if chosen_row else []) + rows
        iso = next((r for r in rows if r["configuration"] == "iso.yaml"), None)
        reduction = None
        if chosen_row and iso and iso["total_lost_time"] and \
                chosen_row["total_lost_time"] is not None:
            reduction = 1.0 - chosen_row["total_lost_time"] / iso["total_lost_time"]
        chosen = None
        if best is not None:
            path = self.out / "chosen.yaml"
            write_text(path, read_text(Path(best.report).parent / "config.yaml"))
            chosen = {"index": best.index, "values": best.values, "verdict": best.verdict,
                      "config": str(path), "report": best.report,
                      "changed": {k: v for k, v in best.values.items()
                                  if v != _get(self.config, k)}}
        return {"allow": self.allow, "budget": self.budget, "seed": self.seed,
                "space": self.space_path, "tasks": [t.name for t in self.tasks],
                "parameters": [dataclasses.asdict(p) for p in self.block],
                "chosen": chosen, "table": table, "lost_time_reduction_vs_iso": reduction,
                "candidates": [c.record() for c in evaluated],
                "screen": {"points": len(pool), "outcomes": _tally(pool),
                           "base": pool[0].record()},
                "counterexamples": [{"file": k.file, "found_for": k.found_for,
                                     "property": k.property, "robustness": k.robustness}
                                    for k in self.kept],
                "counts": self.counts, "provenance": self.origin}


class Progress:
    """tune's progress on stderr: each phase named with its number and count, and the
    least and most time the run may still take (``verification.phases``), then a bar of
    its steps (a reference verified and timed, a candidate proved, refined or
    simulated); lines said meanwhile print above it. Off: nothing is drawn."""

    def __init__(self, on: bool, phases: int):
        self.on, self.bar = on, None
        self.phases = Phases("tune", phases, on)

    def phase(self, name: str, steps: int, left: tuple[float, float] | None = None) -> None:
        self.close()
        self.phases.start(name, left)
        if self.on:
            from tqdm import tqdm

            self.bar = tqdm(total=steps, unit="step", leave=False)

    def step(self) -> None:
        if self.bar is not None:
            self.bar.update(1)

    def write(self, line: str, say) -> None:
        if self.bar is None:
            say(line)
        else:
            from tqdm import tqdm

            with tqdm.external_write_mode():
                say(line)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _run_task(scenario: Scenario, config: ControllerConfig, operators: bool) -> TaskRun:
    """``run_task`` for the runner's workers."""
    return run_task(scenario, config, operators=operators)


def _get(config, name: str):
    for part in name.split("."):
        config = getattr(config, part)
    return config


def _finite(x: float) -> float | None:
    return None if math.isinf(x) else x


def _tally(pool: list[Candidate]) -> dict:
    counts: dict = {}
    for c in pool:
        counts[c.status] = counts.get(c.status, 0) + 1
    return counts
