"""Helpers of the tests of the shipped main-job scenarios (tests/test_main_job.py,
tests/test_inspection_banded.py): a scenario run through the command line, read back, and
the check that a scenario carries its configuration file's controller."""

import dataclasses
import json
from pathlib import Path

import numpy as np

from safety_systems.cell.sensor_sets import points_of
from safety_systems.cli import main


def simulated(folder: Path, scenario: Path) -> tuple[dict, np.ndarray]:
    """``simulate SCENARIO`` into ``folder``: its summary.json and trace.csv (columns by
    name, without the ':' genfromtxt drops)."""
    out = folder / "out"
    assert main(["simulate", str(scenario), "--out", str(out), "--quiet"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    return summary, np.genfromtxt(out / "trace.csv", delimiter=",", names=True)


def assert_carries(scenario, config, sensor_set: str) -> None:
    """``scenario``'s controller is ``config`` (with the cell's exits), and its first
    operator wears ``sensor_set``'s bodies."""
    c = scenario.controller
    assert (c.sensor, c.safety, c.body, c.braking) == (config.sensor, config.safety,
                                                        config.body, config.braking)
    assert dataclasses.replace(c.tracker, exits=[]) == config.tracker
    assert {b.point for b in scenario.operators[0].bodies} == set(points_of(sensor_set))
