"""bench_tune's what-if (its fourth part): every permitted segment uncapped, head and neck
still 0, and the caps restored after."""

import dataclasses
import sys
from pathlib import Path

import numpy as np

from safety_systems.config import configuration
from safety_systems.config.scenario import ControllerConfig, RobotConfig

sys.path.insert(0, str(Path(__file__).parents[2] / "benchmarks"))
import bench_tune  # noqa: E402


def test_uncapped_permitted_segments_is_a_what_if_that_ends():
    config = ControllerConfig()
    # a robot force limit whose detection lets the arms and hands keep a cap (issue 46)
    pfl = dataclasses.replace(config, safety=dataclasses.replace(
        config.safety, mode="ssm_pfl", contact_stop_force=50.0))
    before = configuration.pfl_terms(RobotConfig(), pfl)
    assert 0.0 < before.caps.max() <= 1.0 and before.caps.min() == 0.0
    with bench_tune.uncapped_permitted_segments():
        during = configuration.pfl_terms(RobotConfig(), pfl)
    np.testing.assert_array_equal(during.caps, np.where(before.caps > 0.0, 1.0, 0.0))
    assert during.caps[:2].tolist() == [0.0, 0.0]  # the head and the neck
    after = configuration.pfl_terms(RobotConfig(), pfl)
    np.testing.assert_array_equal(after.caps, before.caps)
