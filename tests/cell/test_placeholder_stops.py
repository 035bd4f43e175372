"""Placeholder stopping tables of every shipped robot: the UR5e's is the project's default,
the others follow their stated rule."""

import math

import numpy as np
import pytest

from safety_systems.cell import braking, ur_family
from safety_systems.cell.placeholder_stops import (
    PLACEHOLDER_STOPS,
    placeholder_braking_table,
    placeholder_warning,
)


def test_ur5e_table_is_the_default():
    a, b = placeholder_braking_table("ur5e"), braking.default_braking_table()
    for field in ("speed_fraction", "stopping_time", "stopping_distance"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))


def test_every_shipped_robot_has_a_table():
    assert set(PLACEHOLDER_STOPS) == set(ur_family.UR_ROBOTS) | {"panda"}
    for robot in PLACEHOLDER_STOPS:
        table = placeholder_braking_table(robot)
        assert "placeholder" in placeholder_warning(robot)
        assert table.stopping_time[-1] == PLACEHOLDER_STOPS[robot].stop_time


def test_scaled_rule():
    """UR10e: 530 ms, 0.70 rad x (120 / 183) over 1.3 m, from the rows' full-speed value."""
    table = placeholder_braking_table("ur10e")
    assert table.stopping_time[-1] == pytest.approx(0.530)
    assert table.stopping_distance[-1] == pytest.approx(0.70 * 120 / 183 * 1.3)
    assert table.stopping_distance[0] == pytest.approx(table.stopping_distance[-1] * 0.33**2)
    ur3e = placeholder_braking_table("ur3e")
    assert ur3e.stopping_distance[-1] == pytest.approx(0.20 * 0.5)
    with pytest.raises(ValueError, match="allowed: ur3e"):
        placeholder_braking_table("kuka")
    assert math.isclose(PLACEHOLDER_STOPS["panda"].stop_angle, 0.70 * 2.175 / math.radians(183))
