"""Run a workcell and collect its logged signals as plain arrays."""

import dataclasses

import numpy as np
from pydrake.systems.analysis import Simulator
from tqdm import tqdm

from safety_systems.cell.joint_path import joint_path_state
from safety_systems.config.resolved_cell import ResolvedCell
from safety_systems.config.scenario import Scenario
from safety_systems.diagrams.workcell import MakeWorkcell, Workcell

# Progress bars appear only on runs that take longer than this (wall-clock seconds).
PROGRESS_DELAY_SEC = 2.0
OVERLAP = 10  # ticks of logs before the last check that ``until`` sees again


@dataclasses.dataclass
class Run:
    """Logged signals of one simulation, one row per control tick.

    ``signals`` maps ``"system.port"`` (and ``"q"``, ``"v"``: the robot's actual joint
    positions and velocities) to arrays of shape (T, size); ``time`` has shape (T,).
    ``cell``: the resolved cell the run was simulated with (what its configuration
    means; what the run's figures read).
    """

    scenario: Scenario
    body_names: list[str]
    time: np.ndarray
    signals: dict[str, np.ndarray]
    cell: ResolvedCell

    def __getitem__(self, key: str) -> np.ndarray:
        return self.signals[key]

    def bodies(self, key: str) -> np.ndarray:
        """A 3N-wide signal reshaped to (T, N, 3)."""
        return self.signals[key].reshape(len(self.time), -1, 3)


def simulate_workcell(workcell: Workcell, *, duration: float | None = None,
                      progress: bool = False, until=None, check_every: float = 0.25,
                      margin: float = 0.25) -> Run:
    """Simulates ``workcell`` from rest at the path's start for ``duration`` seconds
    (default: the scenario's) and returns its logs.

    ``until``: a function of logs (a Run) checked every ``check_every`` simulated
    seconds on the logs since the last check (and ``OVERLAP`` ticks before it); once it
    returns True the run goes on for ``margin`` seconds and stops there if ``until``
    also holds for the whole run so far (else it runs on to the end): a run cut short
    on purpose, e.g. a confirmation that needs only the run up to a contact. None runs
    the whole duration."""
    scenario = workcell.scenario
    duration = scenario.duration if duration is None else duration
    simulator = Simulator(workcell.diagram)
    context = simulator.get_mutable_context()
    if workcell.plant is not None:
        q0 = joint_path_state(workcell.path, 0.0)[0]
        workcell.plant.SetPositions(workcell.plant.GetMyMutableContextFromRoot(context), q0)
    simulator.Initialize()
    step = max(1.0, duration / 100.0) if until is None else check_every
    end, checked, seen = duration, until is None, 0
    with tqdm(total=round(duration, 3), unit="s sim", delay=PROGRESS_DELAY_SEC,
              disable=not progress, leave=False) as bar:
        t = 0.0
        while t < end:
            t = min(t + step, end)
            simulator.AdvanceTo(t)
            bar.update(round(t, 3) - bar.n)
            if not checked:
                run = _logs(workcell, context, max(0, seen - OVERLAP))
                seen += run.time.size - min(seen, OVERLAP)
                if until(run):
                    checked, end = True, min(duration, t + margin)
        if until is not None and end < duration and not until(_logs(workcell, context)):
            simulator.AdvanceTo(duration)  # (the whole run does not show it: run it all)
    return _logs(workcell, context)


def _logs(workcell: Workcell, context, first: int = 0) -> Run:
    """The workcell's logs so far from sample ``first`` on, as a Run."""
    if workcell.logger is None:
        time, data = np.zeros(0), np.zeros((0, 0))
    else:
        log = workcell.logger.FindLog(context)
        time, data = log.sample_times()[first:].copy(), log.data()[:, first:].T
    signals = {key: data[:, cols].copy() if data.size else np.zeros((time.size, 0))
               for key, cols in workcell.columns.items()}
    return Run(workcell.scenario, workcell.body_names, time, signals, workcell.cell)


def simulate(scenario: Scenario, *, duration: float | None = None,
             progress: bool = False, cell: ResolvedCell | None = None) -> Run:
    """Builds the workcell of ``scenario`` from its resolved ``cell`` (None: resolved
    from the scenario, ``MakeWorkcell``) and simulates it (see ``simulate_workcell``)."""
    return simulate_workcell(MakeWorkcell(scenario, cell=cell), duration=duration,
                             progress=progress)
