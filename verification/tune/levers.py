"""Levers: what a cell could buy to win time back beside its people, each priced in the
time it wins and proved or not (issue 47, part 2).

A lever is a choice of the cell, not a setting of the controller: the sensor set its
operators wear (``safety_systems.cell.sensor_sets``), the capture rate and the latency
of its motion capture, and the stopping data it has measured (or a robot, payload or
speed limit that stops sooner). ``tune`` refuses these as parameters (``tunable.MEASURED``: they
are the sensor's measured properties); here they are what the integrator may buy, and
each is priced on the same tasks as ``tune``'s objective.

For a configuration and a lever, :func:`fit` gives the configuration as that sensing
allows it, by three rules that follow from the proofs (``verification.proof.theorems``),
never a search:

- the frame timeout tau: the lever's sensor period + latency + processing time, with
  the configuration's own headroom above its sensor's (the tracker's rule,
  ``scenario.validate_controller``: tau must exceed them);
- T_r: the configuration's, less what tau gained (the sensing's share of the reaction),
  never below the loop's own reaction time tau + one control tick (``tune``'s rule);
- Z_r: the least both proofs allow. Z_d + Z_r enters every level's margin of both
  theorems with slope 1 (M and M_S), so Z_r moves by exactly the least margin; the
  proofs are then run again on the fitted configuration and their verdict is the row's.

The space is the same box with the lever's tracked points and latency bound. The tasks
(``tune``'s: the seed's two, or the integrator's) run with their operators wearing the
lever's set (each added body at the operator's own posture point,
``scenario.operator_posture``) and their real sensor at the lever's rate and latency;
the time lost is the task time less the run with no operator (``tasks.lost_time``).
"""

import dataclasses
import math
import typing

from safety_systems.cell.human_body import POINTS
from safety_systems.cell.sensor_sets import SENSOR_SETS, points_of
from safety_systems.config.configuration import braking_table, frame_timeout, robot_model_of
from safety_systems.config.scenario import (
    MAX_STOPPING_DISTANCE,
    MAX_STOPPING_TIME,
    Body,
    BrakingConfig,
    ControllerConfig,
    Scenario,
    actual_sensor,
    operator_posture,
    validate_controller,
)
from safety_systems.files.input_error import InputError
from safety_systems.files.ranges import number
from verification.spaces.box import Range, ScenarioSpace
from verification.tune.tasks import lost_time, run_task

PADS = (1e-9, 1e-6, 1e-4)  # m added to Z_r over the exact fit, the least that proves


@dataclasses.dataclass
class Lever:
    """One choice of the cell's sensing (an entry of a tune file's ``levers:``):
    ``sensor_set`` (a name of ``safety_systems.cell.sensor_sets.SENSOR_SETS``), the
    capture ``rate_hz`` and ``latency`` (s, the largest the cell's capture has), and
    ``cost``, the integrator's own weight for it (any unit: money, effort; reported beside
    its lost time, never mixed into it; none: not given). ``braking``: stopping data of its
    own (rows by speed fraction, as a configuration's ``braking``: the stops measured on
    the cell, or another robot's, or a lower payload's), named ``stopping_name``; empty:
    the configuration's. Its T_s and B (``stopping_time``, ``stopping_distance``: the
    stop the monitor assumes at full speed) as given with the rows, else scaled by the
    rows' full-speed stop against the configuration's table's (:func:`stopped`)."""

    sensor_set: str = "gloves"
    rate_hz: float = number(20.0, ge=20.0, le=1000.0, unit="Hz")
    latency: float = number(0.02, ge=0.0, le=1.0, unit="s")
    cost: typing.Optional[float] = number(None, ge=0.0, le=1e9)
    braking: BrakingConfig = dataclasses.field(default_factory=BrakingConfig)
    stopping_name: str = ""
    stopping_time: typing.Optional[float] = number(None, gt=0.0, le=MAX_STOPPING_TIME,
                                                   unit="s")
    stopping_distance: typing.Optional[float] = number(None, gt=0.0,
                                                       le=MAX_STOPPING_DISTANCE, unit="m")

    @property
    def label(self) -> str:
        text = f"{self.sensor_set}, {self.rate_hz:g} Hz, {1000.0 * self.latency:g} ms"
        if self.braking.speed_fraction:
            text += f", stopping data {self.stopping_name or 'given'}"
        return text


def check_levers(levers: list[Lever]) -> None:
    """Raises InputError (naming ``levers[i]``'s field) for a sensor set that is not known,
    or stopping data the configuration's rules refuse."""
    for i, lever in enumerate(levers):
        if lever.sensor_set not in SENSOR_SETS:
            raise InputError(f"levers[{i}].sensor_set", lever.sensor_set,
                             "a sensor set: " + " | ".join(SENSOR_SETS))
        if lever.braking.speed_fraction or lever.braking.stopping_time or \
                lever.braking.stopping_distance:
            validate_controller(ControllerConfig(braking=lever.braking),
                                prefix=f"levers[{i}]")
        for name in ("stopping_time", "stopping_distance"):
            if getattr(lever, name) is not None and not lever.braking.speed_fraction:
                raise InputError(f"levers[{i}].{name}", getattr(lever, name),
                                 "a value only with the lever's own stopping data (braking)")


def _due(rate_hz: float, latency: float, config: ControllerConfig) -> float:
    """The least a frame's age may reach before the next is due: one sensor period, the
    latency and the tracker's processing time."""
    return 1.0 / rate_hz + latency + config.tracker.processing_time


def stopped(config: ControllerConfig, lever: Lever, model=None) -> ControllerConfig:
    """``config`` with the lever's stopping data, if it gives any: its rows, and T_s and B
    as the lever gives them, else scaled by the ratio of its full-speed stop to the
    configuration's table's (T_s and B are the configuration's stop on its cell's path;
    the rows' shape is the robot's)."""
    if not lever.braking.speed_fraction:
        return config
    old = braking_table(config, model)
    out = dataclasses.replace(config, braking=lever.braking)
    new = braking_table(out, model)
    time_ratio = new.stopping_time[-1] / old.stopping_time[-1]
    distance_ratio = new.stopping_distance[-1] / old.stopping_distance[-1]
    safety = out.safety
    return dataclasses.replace(out, safety=dataclasses.replace(
        safety,
        stopping_time=lever.stopping_time if lever.stopping_time is not None
        else None if safety.stopping_time is None else safety.stopping_time * time_ratio,
        stopping_distance=lever.stopping_distance if lever.stopping_distance is not None
        else None if safety.stopping_distance is None
        else safety.stopping_distance * distance_ratio))


PATH_STOPS = "the paths' (derived)"  # the stopping_name of :func:`with_path_stops`


def with_path_stops(lever: Lever, paths: list) -> Lever:
    """``lever`` with the stops ``paths`` allow (``path_stops.rounded_path_stops``: rows,
    T_s and B derived from the robot's published per-joint stops, not measured), named
    ``PATH_STOPS``."""
    from safety_systems.cell.path_stops import rounded_path_stops

    table, t_s, b = rounded_path_stops(paths)
    rows = BrakingConfig(speed_fraction=table.speed_fraction.tolist(),
                         stopping_time=table.stopping_time.tolist(),
                         stopping_distance=table.stopping_distance.tolist())
    return dataclasses.replace(lever, braking=rows, stopping_name=PATH_STOPS,
                               stopping_time=t_s, stopping_distance=b)


def sensed(config: ControllerConfig, lever: Lever, control_period: float) -> ControllerConfig:
    """``config`` with the lever's sensor (rate and latency) and the frame timeout and T_r
    that follow (the module's first two rules); Z_r as it was."""
    tau = frame_timeout(config)
    headroom = tau - _due(config.sensor.rate_hz, config.sensor.latency, config)
    if not headroom > 0.0:
        headroom = 0.5 / config.sensor.rate_hz  # (the default rule's half period)
    sensor = dataclasses.replace(config.sensor, rate_hz=lever.rate_hz, latency=lever.latency)
    out = dataclasses.replace(config, sensor=sensor)
    new_tau = _due(lever.rate_hz, lever.latency, out) + headroom
    reaction = max(config.safety.reaction_time - (tau - new_tau), new_tau + control_period)
    return dataclasses.replace(
        out, tracker=dataclasses.replace(out.tracker, frame_timeout=new_tau),
        safety=dataclasses.replace(out.safety, reaction_time=reaction))


def lever_space(space: ScenarioSpace, lever: Lever) -> ScenarioSpace:
    """The same box with the lever's tracked points and its latency as the bound."""
    old = space.parameters.latency
    latency = Range(min(old.min, lever.latency), lever.latency)
    return dataclasses.replace(space, tracked=list(points_of(lever.sensor_set)),
                               parameters=dataclasses.replace(space.parameters,
                                                              latency=latency))


@dataclasses.dataclass
class Fitted:
    """A configuration fitted to a lever: ``config``, its ``proofs`` (property -> Proof
    on the lever's space) and ``proved`` (every one)."""

    config: ControllerConfig
    proofs: dict
    proved: bool
    proofs_run: int = 0  # every proof the fit ran (its cost)


def fit(config: ControllerConfig, lever: Lever, space: ScenarioSpace) -> Fitted:
    """``config`` as the lever's sensing allows it (the module's three rules), proved or
    not on ``space`` with the lever's points and latency."""
    from verification.spaces.space import space_cell
    from verification.verify import proofs_of

    h = 1.0 / space.robot.control_rate_hz
    out = sensed(stopped(config, lever, robot_model_of(space.robot)), lever, h)
    box = lever_space(space, lever)
    proofs = proofs_of(space_cell(out, box), box)
    run = len(proofs)
    margins = [p.margin_at_worst_corner for p in proofs.values()
               if p.margin_at_worst_corner is not None and p.property != "permitted_contact"]
    if margins and all(math.isfinite(m) for m in margins):
        for pad in PADS:  # (z3 decides the margin's sign exactly: 0 to rounding is not)
            z_r = max(0.0, out.safety.robot_uncertainty - min(margins) + pad)
            trial = dataclasses.replace(out, safety=dataclasses.replace(
                out.safety, robot_uncertainty=z_r))
            trial_proofs = proofs_of(space_cell(trial, box), box)
            run += len(trial_proofs)
            if all(p.proved for p in trial_proofs.values()):
                out, proofs = trial, trial_proofs  # (else the sensed one stands)
                break
    return Fitted(out, proofs, all(p.proved for p in proofs.values()), run)


def wearing(scenario: Scenario, lever: Lever) -> Scenario:
    """``scenario`` with every operator wearing the lever's set (a body added at each of
    its points no body marks yet, at the operator's posture: the truth it marks) and its
    real sensor at the lever's rate and latency."""
    operators = []
    for o in scenario.operators:
        posture = dict(zip(POINTS, operator_posture(o)))
        marked = {b.point for b in o.bodies if b.point}
        added = [Body(name=f"{o.name}_{q}", point=q, offset=[float(x) for x in posture[q]])
                 for q in points_of(lever.sensor_set) if q not in marked]
        operators.append(dataclasses.replace(o, bodies=list(o.bodies) + added,
                                             posture=[p for p in o.posture
                                                      if p.point not in
                                                      {b.point for b in added}]))
    sensor = dataclasses.replace(actual_sensor(scenario), rate_hz=lever.rate_hz,
                                 latency=lever.latency)
    return dataclasses.replace(scenario, operators=operators, sensor=sensor)


@dataclasses.dataclass
class Row:
    """One lever's price: the fitted configuration's verdict and its time lost on each
    task (None: unfinished), with ``total`` (None if any is)."""

    lever: Lever
    fitted: Fitted
    runs: dict  # task name -> (TaskRun with operators, TaskRun without)

    @property
    def lost(self) -> dict:
        return {name: lost_time(run, base) for name, (run, base) in self.runs.items()}

    @property
    def total(self) -> float | None:
        values = list(self.lost.values())
        return None if any(v is None for v in values) else float(sum(values))

    @property
    def held(self) -> float:
        return float(sum(run.stopped_time for run, _ in self.runs.values()))


def price(config: ControllerConfig, lever: Lever, space: ScenarioSpace,
          tasks: list[Scenario], baselines: dict | None = None) -> Row:
    """The lever's row for ``config`` on ``tasks``: fitted, proved or not, and run.
    ``baselines`` (task name -> TaskRun with no operator) is filled and reused: a run
    with no operator does not depend on the sensing."""
    fitted = fit(config, lever, space)
    baselines = {} if baselines is None else baselines
    runs = {}
    for task in tasks:
        worn = wearing(task, lever)
        if task.name not in baselines:
            baselines[task.name] = run_task(task, fitted.config, operators=False)
        runs[task.name] = (run_task(worn, fitted.config), baselines[task.name])
    return Row(lever, fitted, runs)



def record(row: Row, iso_lost: float | None) -> dict:
    """A row as tune.json and the benchmark keep it: the lever, the fitted terms, the
    proofs' verdicts, the time lost by task and in all, the seconds held at rest, and the
    reduction against iso.yaml's ``iso_lost`` (None: not known or unfinished)."""
    c = row.fitted.config
    total = row.total
    return {"lever": dataclasses.asdict(row.lever), "label": row.lever.label,
            "proved": row.fitted.proved,
            "proofs": {name: p.proved for name, p in row.fitted.proofs.items()},
            "frame_timeout": c.tracker.frame_timeout,
            "reaction_time": c.safety.reaction_time,
            "robot_uncertainty": c.safety.robot_uncertainty,
            "lost": row.lost, "total_lost": total, "held": row.held,
            "reduction": None if total is None or not iso_lost else 1.0 - total / iso_lost}


def under(config: ControllerConfig, block: list, lever: Lever) -> tuple[ControllerConfig, list]:
    """A tune's base configuration and block under a lever's sensing: the configuration's
    sensor at the lever's rate and latency, and the bounds of the frame timeout and of
    T_r moved by what the sensor's due time (period + latency + processing) gains, so the
    tune searches the same headroom above the faster loop (for a tune run under the lever,
    ``benchmarks/bench_tune.py --lever``)."""
    gain = _due(config.sensor.rate_hz, config.sensor.latency, config) - _due(
        lever.rate_hz, lever.latency, config)
    sensor = dataclasses.replace(config.sensor, rate_hz=lever.rate_hz, latency=lever.latency)
    moved = []
    for p in block:
        if p.name in ("tracker.frame_timeout", "safety.reaction_time") and p.min is not None:
            p = dataclasses.replace(p, min=p.min - gain, max=p.max - gain)
        moved.append(p)
    return dataclasses.replace(config, sensor=sensor), moved
