"""Task time: how long the nominal task scenarios take under a configuration, and how
much of it is lost to the operators (the objective of ``safety-systems tune``).

A task scenario (``models/scenarios/inspection_seed.yaml``, ``co_kitting.yaml``: seed 000,
Section 7, with the operators' scripted motions) is run in the Drake diagram under the
configuration (``configuration.with_controller``: the scenario's cell, real sensor,
exits and walls stay) until the robot finishes its cycles, for at most ``HORIZON``
times the scenario's duration (capped at ``scenario.MAX_DURATION``): a cautious
configuration may need longer than the scenario's own duration, which was set for the
seed's. The baseline is the same run with no operator (every operator absent
throughout); the time lost to stops and slow-downs is the difference.
"""

import dataclasses
import math

import numpy as np

from safety_systems.config.configuration import with_controller
from safety_systems.config.scenario import MAX_DURATION, ControllerConfig, Scenario

HORIZON = 3.0  # the longest run, in multiples of the scenario's duration
STEP = 1.0  # s of simulated time between checks whether the task has finished


@dataclasses.dataclass(frozen=True)
class TaskRun:
    """One task scenario under one configuration: ``task_time`` (s to finish the cycles,
    None if not within ``ran``), ``stopped_time`` (s held at rest by the controller
    before finishing) and ``ran`` (s simulated)."""

    task: str
    task_time: float | None
    stopped_time: float
    ran: float


def absent_operators(scenario: Scenario) -> Scenario:
    """The scenario with every operator absent throughout (the run with no operator)."""
    late = [dataclasses.replace(o, enter_time=MAX_DURATION - 1.0, leave_time=MAX_DURATION)
            for o in scenario.operators]
    return dataclasses.replace(scenario, operators=late)


def run_task(scenario: Scenario, config: ControllerConfig, *, operators: bool = True
             ) -> TaskRun:
    """Runs ``scenario`` under ``config`` (without its operators when ``operators`` is
    False) until its cycles are done (see the module docstring)."""
    from verification.search.evaluate_drake import collect_diagram_garbage

    try:
        return _run_task(scenario, config, operators)
    finally:
        collect_diagram_garbage()


def _run_task(scenario: Scenario, config: ControllerConfig, operators: bool) -> TaskRun:
    from pydrake.systems.analysis import Simulator

    from safety_systems.diagrams.workcell import MakeWorkcell

    run = with_controller(scenario, config)
    if not operators:
        run = absent_operators(run)
    horizon = min(MAX_DURATION, HORIZON * scenario.duration)
    workcell = MakeWorkcell(run, logged=["follower.path_state"])
    simulator = Simulator(workcell.diagram)
    context = simulator.get_mutable_context()
    simulator.Initialize()
    follower = workcell.systems["follower"]
    state = follower.GetOutputPort("path_state")
    follower_context = follower.GetMyContextFromRoot(context)
    t = 0.0
    while t < horizon:
        t = min(t + STEP, horizon)
        simulator.AdvanceTo(t)
        if state.Eval(follower_context)[2] > 0.5:  # the path's end reached
            break
    log = workcell.logger.FindLog(context)
    time = log.sample_times()
    path_state = log.data().T[:, workcell.columns["follower.path_state"]]
    done = np.flatnonzero(path_state[:, 2] > 0.5)
    finished = float(time[done[0]]) if done.size else None
    dt = np.diff(time, append=time[-1])
    held = (path_state[:, 1] == 0.0) & (path_state[:, 2] < 0.5)
    return TaskRun(scenario.name, finished, float(np.sum(dt[held])), float(time[-1]))


def total(values: list[float | None]) -> float:
    """The sum of task times (inf when a task did not finish)."""
    return math.inf if any(v is None for v in values) else float(sum(values))


def lost_time(run: TaskRun, baseline: TaskRun) -> float | None:
    """Seconds lost to the operators: the task time minus the run with no operator's
    (None when either did not finish)."""
    if run.task_time is None or baseline.task_time is None:
        return None
    return run.task_time - baseline.task_time


def total_lost(tasks: list[Scenario], config: ControllerConfig) -> float:
    """Total seconds ``config`` loses on ``tasks`` against its own runs with no operator
    (as the tuner counts them), inf if a task did not finish."""
    return total([lost_time(run_task(task, config), run_task(task, config, operators=False))
                  for task in tasks])
