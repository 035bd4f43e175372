import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from safety_systems.cell.human_body import NUM_SEGMENTS, SEGMENT_NAMES
from safety_systems.pfl.body_regions import REGION_NAMES, body_region
from safety_systems.pfl.contact_speed import reduced_mass, transient_speed
from safety_systems.pfl.segment_regions import (
    SEGMENT_FORBIDDEN,
    SEGMENT_REGIONS,
    permitted_contact_robustness,
    permitted_speed,
    permitted_speeds,
    segment_regions,
)

FIXED = settings(derandomize=True, deadline=None, max_examples=100)
# Each segment's own region (the first of its regions).
OWN = {"head": "skull_forehead", "neck": "neck", "upper_trunk": "chest",
       "lower_trunk": "abdomen", "shoulder_left": "back_shoulders",
       "shoulder_right": "back_shoulders", "upper_arm_left": "upper_arms_elbows",
       "upper_arm_right": "upper_arms_elbows", "forearm_left": "lower_arms_wrists",
       "forearm_right": "lower_arms_wrists", "hand_left": "hands_fingers",
       "hand_right": "hands_fingers"}


def test_every_segment_has_its_regions():
    assert len(SEGMENT_REGIONS) == NUM_SEGMENTS == len(OWN)
    for name, regions in zip(SEGMENT_NAMES, SEGMENT_REGIONS):
        assert regions and set(regions) <= set(REGION_NAMES), name
        assert regions[0] == OWN[name]
    assert set(SEGMENT_REGIONS[SEGMENT_NAMES.index("head")]) == {"skull_forehead", "face"}


def test_only_the_head_and_neck_are_forbidden():
    forbidden = {name for name, f in zip(SEGMENT_NAMES, SEGMENT_FORBIDDEN) if f}
    assert forbidden == {"head", "neck"}


@pytest.mark.parametrize("segment", ["head", "neck"])
def test_a_forbidden_segment_permits_no_speed_and_any_contact_is_minus_infinity(segment):
    i = SEGMENT_NAMES.index(segment)
    for m_R in (0.5, 10.0, 200.0):
        assert permitted_speed(i, m_R) == 0.0
    limit = permitted_speed(i, 10.0)
    robustness = permitted_contact_robustness(limit, np.array([0.0, 0.01, 2.0]))
    assert np.all(np.isneginf(robustness))


def test_a_hand_contact_below_its_limit_is_permitted_above_it_is_not():
    i = SEGMENT_NAMES.index("hand_right")
    limit = permitted_speed(i, 10.0)
    # The hand's ball reaches the wrist: the lower arm's 320 N over 2 kg and 40 N/mm governs.
    wrist = 320.0 / math.sqrt(reduced_mass(2.0, 10.0) * 40_000.0)
    assert limit == pytest.approx(wrist) and limit < transient_speed(
        body_region("hands_fingers"), 10.0)
    assert permitted_contact_robustness(limit, limit - 0.1) == pytest.approx(0.1)
    assert permitted_contact_robustness(limit, limit) == 0.0  # at the limit: safe
    assert permitted_contact_robustness(limit, limit + 0.1) == pytest.approx(-0.1)


def test_a_segments_speed_is_the_least_of_its_regions():
    for i in range(NUM_SEGMENTS):
        speeds = [transient_speed(r, 12.0, contact_area=1e-4) for r in segment_regions(i)]
        assert permitted_speed(i, 12.0, contact_area=1e-4) == pytest.approx(min(speeds))


def test_permitted_speeds_are_aligned_with_the_segments():
    speeds = permitted_speeds(10.0)
    assert speeds.shape == (NUM_SEGMENTS,)
    np.testing.assert_allclose(speeds, [permitted_speed(i, 10.0) for i in range(NUM_SEGMENTS)])
    assert np.all((speeds == 0.0) == SEGMENT_FORBIDDEN)


@FIXED
@given(light=st.floats(0.5, 200.0), extra=st.floats(0.01, 200.0))
def test_a_heavier_robot_is_permitted_less_on_every_segment(light, extra):
    v_light, v_heavy = permitted_speeds(light), permitted_speeds(light + extra)
    allowed = ~SEGMENT_FORBIDDEN
    assert np.all(v_heavy[allowed] < v_light[allowed])
    assert np.all(v_heavy[~allowed] == 0.0)


def test_robustness_broadcasts_over_contacts():
    limits = permitted_speeds(10.0)
    r = permitted_contact_robustness(limits, np.full(NUM_SEGMENTS, 0.2))
    assert np.all(np.isneginf(r[SEGMENT_FORBIDDEN]))
    np.testing.assert_allclose(r[~SEGMENT_FORBIDDEN], limits[~SEGMENT_FORBIDDEN] - 0.2)


@pytest.mark.parametrize("segment", [-1, NUM_SEGMENTS])
def test_a_segment_out_of_range_fails_early(segment):
    with pytest.raises(ValueError, match="segment"):
        segment_regions(segment)
