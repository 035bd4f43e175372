import math

import pytest

from safety_systems.files.input_error import InputError
from safety_systems.pfl.body_regions import REGION_NAMES, REGIONS, BodyRegion, body_region

# ISO/TS 15066:2016 Table A.2 (quasi-static force N, least pressure N/cm^2 of the region's
# locations) and Table A.3 (effective mass kg, spring constant N/mm), written out again.
TABLE = {
    "skull_forehead": (130, 110, 4.4, 150),
    "face": (65, 110, 4.4, 75),
    "neck": (150, 140, 1.2, 50),
    "back_shoulders": (210, 160, 40, 35),
    "chest": (140, 120, 40, 25),
    "abdomen": (110, 140, 40, 10),
    "pelvis": (180, 210, 40, 25),
    "upper_arms_elbows": (150, 190, 3, 30),
    "lower_arms_wrists": (160, 180, 2, 40),
    "hands_fingers": (140, 190, 0.6, 75),
    "thighs_knees": (220, 220, 75, 50),
    "lower_legs": (130, 210, 75, 60),
}
FORBIDDEN = {"skull_forehead", "face", "neck"}


def test_the_twelve_regions_in_the_tables_order():
    assert REGION_NAMES == tuple(TABLE)


@pytest.mark.parametrize("name", TABLE)
def test_figures_are_the_tables(name):
    r = body_region(name)
    force, pressure, mass, spring = TABLE[name]
    assert (r.force, r.pressure_n_per_cm2, r.effective_mass, r.spring_n_per_mm) == (
        force, pressure, mass, spring)
    assert r.pressure == pytest.approx(pressure * 1e4)  # Pa
    assert r.spring_constant == pytest.approx(spring * 1e3)  # N/m


@pytest.mark.parametrize("name", TABLE)
def test_transient_contact_at_twice_the_quasi_static_limits_or_none(name):
    r = body_region(name)
    if name in FORBIDDEN:
        assert not r.transient_contact
        assert r.transient_force == 0.0 and r.transient_pressure == 0.0
    else:
        assert r.transient_contact and r.transient_multiplier == 2.0
        assert r.transient_force == 2 * r.force
        assert r.transient_pressure == pytest.approx(2 * r.pressure)


def test_the_table_gives_no_transient_multiplier_for_skull_and_face():
    assert body_region("skull_forehead").transient_multiplier is None
    assert body_region("face").transient_multiplier is None
    assert body_region("neck").transient_multiplier == 2.0  # the table's; forbidden here


def test_an_unknown_region_is_one_line_naming_the_allowed():
    with pytest.raises(InputError) as error:
        body_region("elbow")
    text = str(error.value)
    assert "elbow" in text and "upper_arms_elbows" in text and "\n" not in text


@pytest.mark.parametrize("field, value", [("force", 0.0), ("effective_mass", -1.0),
                                          ("spring_n_per_mm", math.nan),
                                          ("transient_multiplier", 0.5)])
def test_a_bad_figure_fails_early(field, value):
    figures = dict(name="x", force=1.0, pressure_n_per_cm2=1.0, transient_multiplier=2.0,
                   effective_mass=1.0, spring_n_per_mm=1.0, transient_contact=True)
    figures[field] = value
    with pytest.raises(ValueError, match=field):
        BodyRegion(**figures)


def test_permitted_transient_contact_needs_a_multiplier():
    with pytest.raises(ValueError, match="transient_multiplier"):
        BodyRegion(name="x", force=1.0, pressure_n_per_cm2=1.0, transient_multiplier=None,
                   effective_mass=1.0, spring_n_per_mm=1.0, transient_contact=True)


def test_regions_are_frozen():
    with pytest.raises(AttributeError):
        REGIONS[0].force = 1.0
