"""The moving masses of the shipped robots against their makers' published masses: UR's
e-Series datasheets give the whole robot (base included) as 20.6 kg (UR5e) and 33.5 kg
(UR10e), Franka's Panda datasheet about 18 kg. The URDFs' moving links come to 17.7 kg
(UR5e, UR's dynamics table: 86% of the datasheet), 29.1 kg (UR10e, 87%) and 16.8 kg (the
Panda's seven links, hand and fingers, 93%): the rest is the fixed base, which does not
move (and the Panda's base link in its URDF, 0.63 kg, is lighter than the real one)."""

import pytest

from safety_systems.cell import ur5e
from safety_systems.cell.robot_model import robot_model
from safety_systems.cell.ur_family import UR10E
from safety_systems.pfl.robot_masses import effective_mass, link_masses, moving_mass

DATASHEET = {"ur5e": 20.6, "ur10e": 33.5, "panda": 18.0}  # kg, the whole robot


@pytest.mark.parametrize("name", DATASHEET)
def test_moving_mass_near_the_datasheet_and_below_it(name):
    model = robot_model(name)
    M = moving_mass(model)
    assert 0.8 * DATASHEET[name] < M < DATASHEET[name]  # the base is fixed: not counted
    assert link_masses(model).shape == (model.n,)


def test_the_urs_moving_mass_is_their_published_link_masses():
    assert moving_mass(robot_model("ur5e")) == pytest.approx(sum(ur5e.LINK_MASSES))
    assert moving_mass(robot_model("ur5e")) == pytest.approx(17.7)
    assert moving_mass(robot_model("ur10e")) == pytest.approx(sum(UR10E.link_masses))


def test_the_pandas_fingers_move_with_it():
    model = robot_model("panda")
    # Links 1-7 and the hand (welded to link 7) on the chain; the fingers (15 g each) off it.
    assert link_masses(model)[-1] == pytest.approx(0.735522 + 0.73)
    assert moving_mass(model) == pytest.approx(link_masses(model).sum() + 0.03)


def test_effective_mass_is_half_the_moving_mass_plus_the_payload():
    model = robot_model("ur5e")
    assert effective_mass(model, 0.0) == pytest.approx(17.7 / 2)
    assert effective_mass(model, 2.5) == pytest.approx(17.7 / 2 + 2.5)
    with pytest.raises(ValueError, match="payload"):
        effective_mass(model, -0.1)
