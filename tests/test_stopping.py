"""The simulated robot's true stopping data (safety_systems.cell.stopping)."""

import dataclasses

import numpy as np
import pytest

from safety_systems.cell.braking import (
    default_braking_table,
    path_rate_step,
    tool_stopping_distance,
)
from safety_systems.config.configuration import contact_capsules
from safety_systems.cell.joint_path import joint_path_state
from safety_systems.cell.robot_geometry import capsule_ends
from safety_systems.config.scenario import load_scenario
from safety_systems.cell.stopping import true_stopping
from safety_systems.config.configuration import joint_path

SCENARIO = load_scenario("models/scenarios/inspection_seed.yaml")
PATH = joint_path(SCENARIO.robot)
TABLE = default_braking_table()
DT = 0.002


def _stepped_travel(capsules, scale, starts=60):
    """Independently: the stop stepped in time from ``starts`` points of a cycle, each
    capsule end's travel summed tick by tick; the farthest end's travel, and the ticks."""
    path = dataclasses.replace(PATH, cycles=2)
    s = np.linspace(0.0, PATH.cycle_time, starts, endpoint=False)
    rate = np.ones(starts)
    ends = capsule_ends(joint_path_state(path, s)[0], capsules)[0]
    travel = np.zeros(ends.shape[:-1])
    ticks = 0
    while np.any(rate > 0.0):
        new = path_rate_step(rate, 0.0, DT, table=TABLE, acceleration_limit=1.0,
                             time_scale=scale)
        s, rate, ticks = s + 0.5 * (rate + new) * DT, new, ticks + 1
        moved = capsule_ends(joint_path_state(path, s)[0], capsules)[0]
        travel += np.linalg.norm(moved - ends, axis=-1)
        ends = moved
    return float(travel.max()), ticks


@pytest.mark.parametrize("scale", [1.0, 1.7])
def test_stop_time_is_the_followers_ticks_and_distance_covers_every_end(scale):
    capsules = contact_capsules(SCENARIO.robot, "capsules")
    stop = true_stopping(PATH, capsules, TABLE, scale, DT)
    stepped, ticks = _stepped_travel(capsules, scale)
    assert stop.time == pytest.approx(ticks * DT, abs=1e-12)
    # The placeholder table stops from full speed in 0.53 s, scaled: in whole ticks, and
    # the tick on which the stop is commanded.
    table_time = 0.53 * scale
    assert table_time <= stop.time <= table_time + 2 * DT
    # Every end travels at most the stopping distance (the fastest end at each instant,
    # integrated), and not much less: it is a tight figure, not a loose bound.
    assert stepped <= stop.distance + 1e-6
    assert stop.distance <= 1.05 * stepped


def test_on_the_tool_point_it_is_the_tools_stopping_distance():
    stop = true_stopping(PATH, contact_capsules(SCENARIO.robot, "tool_point"), TABLE, 1.0, DT)
    assert stop.distance == pytest.approx(tool_stopping_distance(PATH, TABLE), rel=1e-4)


def test_bad_scale_is_refused():
    with pytest.raises(ValueError, match="braking_time_scale"):
        true_stopping(PATH, contact_capsules(SCENARIO.robot, "tool_point"), TABLE, 0.0, DT)
