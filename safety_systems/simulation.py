"""Run a workcell and collect its logged signals as plain arrays."""

import dataclasses

import numpy as np
from pydrake.systems.analysis import Simulator
from tqdm import tqdm

from safety_systems.joint_path import joint_path_state
from safety_systems.scenario import Scenario
from safety_systems.workcell import MakeWorkcell, Workcell

# Progress bars appear only on runs that take longer than this (wall-clock seconds).
PROGRESS_DELAY_SEC = 2.0


@dataclasses.dataclass
class Run:
    """Logged signals of one simulation, one row per control tick.

    ``signals`` maps ``"system.port"`` (and ``"q"``, ``"v"``: the robot's actual joint
    positions and velocities) to arrays of shape (T, size); ``time`` has shape (T,).
    """

    scenario: Scenario
    body_names: list[str]
    time: np.ndarray
    signals: dict[str, np.ndarray]

    def __getitem__(self, key: str) -> np.ndarray:
        return self.signals[key]

    def bodies(self, key: str) -> np.ndarray:
        """A 3N-wide signal reshaped to (T, N, 3)."""
        return self.signals[key].reshape(len(self.time), -1, 3)


def simulate_workcell(workcell: Workcell, *, duration: float | None = None,
                      progress: bool = False) -> Run:
    """Simulates ``workcell`` from rest at the path's start for ``duration`` seconds
    (default: the scenario's) and returns its logs."""
    scenario = workcell.scenario
    duration = scenario.duration if duration is None else duration
    simulator = Simulator(workcell.diagram)
    context = simulator.get_mutable_context()
    if workcell.plant is not None:
        q0 = joint_path_state(workcell.path, 0.0)[0]
        workcell.plant.SetPositions(workcell.plant.GetMyMutableContextFromRoot(context), q0)
    simulator.Initialize()
    step = max(1.0, duration / 100.0)
    with tqdm(total=round(duration, 3), unit="s sim", delay=PROGRESS_DELAY_SEC,
              disable=not progress, leave=False) as bar:
        t = 0.0
        while t < duration:
            t = min(t + step, duration)
            simulator.AdvanceTo(t)
            bar.update(round(t, 3) - bar.n)
    if workcell.logger is None:
        time, data = np.zeros(0), np.zeros((0, 0))
    else:
        log = workcell.logger.FindLog(context)
        time, data = log.sample_times().copy(), log.data().T
    signals = {key: data[:, cols].copy() if data.size else np.zeros((time.size, 0))
               for key, cols in workcell.columns.items()}
    return Run(scenario, workcell.body_names, time, signals)


def simulate(scenario: Scenario, *, duration: float | None = None,
             progress: bool = False) -> Run:
    """Builds the workcell of ``scenario`` and simulates it (see ``simulate_workcell``)."""
    return simulate_workcell(MakeWorkcell(scenario), duration=duration, progress=progress)
