"""What held the robot (``outputs.held``), on the main job (as the README runs it): the technician at the desk
holds the robot by the lower trunk's envelope (bounded from the gloves alone) while the
real body stands well clear of it; the seconds add up to the separation stops', and
simulate's summary.json and console line carry them, with the monitor's measure and the
points whose tracking would release the robot."""

import json
from pathlib import Path

import numpy as np
import pytest

from safety_systems.cli import main
from safety_systems.outputs.held_terms import held_words

MODELS = Path(__file__).parents[2] / "models"


@pytest.fixture(scope="module")
def summary(tmp_path_factory) -> dict:
    folder = tmp_path_factory.mktemp("held")
    assert main(["simulate", str(MODELS / "scenarios" / "inspection_seed.yaml"), "--out",
                 str(folder / "out"), "--quiet"]) == 0
    return json.loads((folder / "out" / "summary.json").read_text())


def test_the_separation_stops_are_told_by_the_segment_that_held_them(summary):
    held = summary["held"]
    separation = held["separation"]
    assert separation["time"] > 5.0  # the robot is held while the technician works
    assert held["causes"]["separation"] == pytest.approx(separation["time"], abs=0.01)
    assert sum(separation["by_segment"].values()) == pytest.approx(separation["time"])
    first = next(iter(separation["by_segment"]))
    # gloves only: the trunk's envelope, not a tracked hand, holds the robot, while the
    # real body is farther than any d_min from it
    assert first == "lower_trunk", separation["by_segment"]
    assert separation["true_clearance_median"] > 0.5
    # the monitor measures the envelope, nearer than the real body: tracking the trunk's
    # points (chest, pelvis: gloves track neither) is what would release the robot
    assert separation["measured_clearance_median"] < separation["true_clearance_median"] - 0.5
    assert separation["untracked_points"] == ["chest", "pelvis"]
    times = list(separation["by_segment"].values())
    assert times == sorted(times, reverse=True)


def test_the_console_line_says_it(summary):
    words = held_words(summary["held"])
    assert words.startswith("held on separation stops") and "lower_trunk" in words
    assert "tracking chest and pelvis would bound lower_trunk by its own points" in words
    assert held_words({"causes": {}}) == ""
    assert np.isfinite(summary["held"]["separation"]["true_clearance_median"])


def test_a_constant_floor_says_what_the_lowest_speed_asks_and_the_seeds_does_not(summary):
    # the seed's controller takes the tracker's speeds in S: no bound to state
    assert summary["held"]["separation"]["lowest_speed"] is None
