"""Power and force limiting's caps in the override, the clamping rule and the permitted
contact figure (safety_systems/pfl/speed_caps.py, ssm/formulas.py)."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from safety_systems.cell.human_body import NUM_SEGMENTS
from safety_systems.pfl.segment_regions import SEGMENT_FORBIDDEN, permitted_speeds
from safety_systems.pfl.speed_caps import (
    CLAMP_GAP,
    between_links,
    capsule_box_gap,
    capsule_links,
    clamp_caps,
    clampable,
    contact_robustness,
    mounting_box,
    segment_caps,
)
from safety_systems.sensing.tracks import TRACK_HIDDEN, TRACK_LOST, TRACK_NONE, TRACK_TRACKING
from safety_systems.ssm.formulas import (
    by_speed_override_command,
    capped_by_speed_command,
    capped_override_command,
    speed_override_command,
)

STATUSES = [TRACK_NONE, TRACK_TRACKING, TRACK_HIDDEN, TRACK_LOST]
distances = st.floats(-0.5, 5.0, allow_nan=False) | st.just(math.nan) | st.just(math.inf)


@st.composite
def monitor_rows(draw, levels=0):
    n = draw(st.integers(1, 24))
    d = np.array(draw(st.lists(distances, min_size=n, max_size=n)))
    s = np.array(draw(st.lists(st.floats(-1.0, 4.0) | st.just(math.nan), min_size=n * (
        levels + 1), max_size=n * (levels + 1))))
    status = np.array(draw(st.lists(st.sampled_from(STATUSES), min_size=n, max_size=n)),
                      dtype=float)
    fault = draw(st.sampled_from([0.0, 0.0, 0.0, 1.0]))
    return d, s, status, fault


@settings(max_examples=300, deadline=None)
@given(monitor_rows(), st.floats(1.0, 3.0), st.floats(0.0, 0.6))
def test_zero_caps_give_eq12_bit_for_bit(row, delta_s, d_min):
    d, s, status, fault = row
    ours = capped_override_command(d, s, status, fault, np.zeros(d.size), delta_s=delta_s,
                                   d_min=d_min)
    eq12 = speed_override_command(d, s, status, fault, delta_s=delta_s, d_min=d_min)
    assert ours == eq12 or (np.isnan(ours[1]) and ours[0] == eq12[0] and ours[2] == eq12[2])


@settings(max_examples=200, deadline=None)
@given(monitor_rows(levels=8), st.floats(1.0, 3.0), st.floats(0.0, 0.6), st.floats(0.0, 1.0))
def test_zero_caps_give_the_speed_levels_bit_for_bit(row, delta_s, d_min, rate):
    d, s, status, fault = row
    levels = s.reshape(9, d.size)
    ours = capped_by_speed_command(d, levels, status, fault, rate, np.zeros(d.size),
                                   delta_s=delta_s, d_min=d_min)
    theirs = by_speed_override_command(d, levels, status, fault, rate, delta_s=delta_s,
                                       d_min=d_min)
    assert ours == theirs


@settings(max_examples=300, deadline=None)
@given(monitor_rows(), st.floats(1.0, 3.0), st.floats(0.0, 0.6), st.data())
def test_caps_hold_k_up_only_within_them_and_never_through_a_fault(row, delta_s, d_min, data):
    d, s, status, fault = row
    caps = np.array(data.draw(st.lists(st.floats(0.0, 1.0), min_size=d.size,
                                       max_size=d.size)))
    k, _, reason = capped_override_command(d, s, status, fault, caps, delta_s=delta_s,
                                           d_min=d_min)
    k0, _, reason0 = speed_override_command(d, s, status, fault, delta_s=delta_s, d_min=d_min)
    assert k0 <= k <= 1.0
    usable = (status == TRACK_TRACKING) | (status == TRACK_HIDDEN)
    if k > k0:  # held up: at most the closest usable segment's cap
        closest = np.flatnonzero(usable)[np.argmin(d[usable])]
        assert k <= max(caps[closest], k0)
        # never past a fault, a lost track or a bad measurement of a usable body
        assert fault == 0.0 and not np.any(status == TRACK_LOST)
        assert np.all(np.isfinite(d[usable])) and np.all(np.isfinite(s[usable]))
    if reason0 != 0 and reason != 0:
        assert k == 0.0


def test_a_forbidden_segment_near_stops_the_robot_whatever_the_others_caps():
    d = np.array([0.2, 0.05, 0.05])  # head at 0.2 m, two hands touching
    s = np.array([0.5, 0.5, 0.5])
    status = np.full(3, float(TRACK_TRACKING))
    k, _, reason = capped_override_command(d, s, status, 0.0, np.array([0.0, 0.8, 0.8]))
    assert k == 0.0 and reason != 0
    # the head far: the hands hold the robot at their least cap
    d[0] = 3.0
    k, _, reason = capped_override_command(d, s, status, 0.0, np.array([0.0, 0.8, 0.3]))
    assert k == 0.3 and reason == 0


def test_caps_follow_the_limits_and_the_configured_speed():
    limits = permitted_speeds(8.85)
    caps = segment_caps(limits, None, 0.9773)
    assert np.all(caps[SEGMENT_FORBIDDEN] == 0.0) and np.all(caps[~SEGMENT_FORBIDDEN] > 0.0)
    assert np.all(caps * 0.9773 <= limits * (1 + 1e-12))
    slow = segment_caps(limits, 0.25, 0.9773)
    assert np.allclose(slow[~SEGMENT_FORBIDDEN], 0.25 / 0.9773)
    assert np.all(segment_caps(limits, None, math.nan) == 0.0)  # no bound: pure SSM
    assert caps.size == NUM_SEGMENTS


points = st.tuples(*[st.floats(-2.0, 2.0)] * 3)


@settings(max_examples=300, deadline=None)
@given(points, points, st.floats(0.0, 0.2), points, points)
def test_the_gap_to_a_box_is_a_lower_bound(p, q, radius, a, b):
    box = np.array([np.minimum(a, b), np.maximum(a, b)])
    gap = capsule_box_gap(np.array(p), np.array(q), radius, box)
    t = np.linspace(0.0, 1.0, 2001)[:, None]
    axis = np.array(p) + t * (np.array(q) - np.array(p))
    outside = np.maximum(np.maximum(box[0] - axis, 0.0), axis - box[1])
    true_gap = np.linalg.norm(outside, axis=1).min() - radius
    assert gap <= true_gap + 1e-9


def test_clamping_zeroes_the_caps_near_a_surface_and_fails_safe():
    table = np.array([[[-1.0, -1.0, -0.5], [1.0, 1.0, 0.0]]])  # its top at z = 0
    ends = np.array([[[0.0, 0.0, 0.10], [0.3, 0.0, 0.10]],  # a forearm 0.10 m above it
                     [[0.0, 0.0, 0.60], [0.3, 0.0, 0.60]],  # one 0.60 m above
                     [[np.nan, 0.0, 0.0], [0.3, 0.0, 0.6]]])  # a bad envelope
    radii = np.array([0.04, 0.04, 0.04])
    caps = np.array([0.8, 0.8, 0.8])
    out = np.empty(3)
    no_robot = np.zeros((0, 2, 3))
    clamp_caps(ends, radii, caps, table, CLAMP_GAP + 0.1, no_robot, no_robot, np.zeros(0),
               np.zeros(0, dtype=np.int64), out)
    assert out.tolist() == [0.0, 0.8, 0.0]
    assert clampable(ends[0, 0], ends[0, 1], 0.04, table, CLAMP_GAP + 0.02)
    assert not clampable(ends[0, 0], ends[0, 1], 0.04, table, CLAMP_GAP)


def test_the_contact_figure():
    assert contact_robustness(1.2, 0.5, False) == 1.2 - 0.5
    assert contact_robustness(1.2, 1.5, False) < 0.0
    assert contact_robustness(0.0, 0.0, False) == -np.inf  # head, neck: whatever the speed
    assert contact_robustness(1.2, 0.1, True) == -np.inf  # clampable


def test_power_and_force_limiting_needs_the_robots_mass(monkeypatch):
    """A description without link masses (and no payload) gives no effective mass, so no
    permissible speed: ssm_pfl is refused (one line), ssm is not."""
    import dataclasses

    import pytest

    import safety_systems.config.configuration as configuration
    from safety_systems.config.scenario import ControllerConfig, RobotConfig
    from safety_systems.files.input_error import InputError

    monkeypatch.setattr(configuration, "effective_mass", lambda model, payload: 0.0)
    config = ControllerConfig()
    assert configuration.pfl_terms(RobotConfig(), config).limits.size == NUM_SEGMENTS
    pfl = dataclasses.replace(config, safety=dataclasses.replace(config.safety,
                                                                 mode="ssm_pfl"))
    with pytest.raises(InputError, match="effective mass"):
        configuration.pfl_terms(RobotConfig(), pfl)


# Two links of a robot folded about an elbow at the origin: one along +x, one along +y.
LINKS = np.array([[[0.0, 0.0, 0.0], [0.4, 0.0, 0.0]], [[0.0, 0.0, 0.0], [0.0, 0.4, 0.0]],
                  [[0.0, 0.4, 0.0], [0.0, 0.5, 0.0]]])
LINK_RADII = np.array([0.05, 0.05, 0.04])


def test_a_segment_within_reach_of_two_links_is_caught_between_them():
    """Issue 46: a forearm between two links (or a link and the base's) is clamped though
    no surface is declared; one link alone, or a link and the tool on its flange (the
    same link), is not."""
    links = np.array([0, 1, 1])  # the third capsule: a tool on the second link's flange
    v = np.zeros_like(LINKS)
    crease = (np.array([0.12, 0.12, 0.0]), np.array([0.2, 0.2, 0.0]), 0.05)  # in the fold
    assert between_links(*crease, LINKS, v, LINK_RADII, links, CLAMP_GAP)
    far_side = (np.array([0.2, -0.1, 0.0]), np.array([0.3, -0.1, 0.0]), 0.05)  # link 0 only
    assert not between_links(*far_side, LINKS, v, LINK_RADII, links, CLAMP_GAP)
    tip = (np.array([0.0, 0.5, 0.1]), np.array([0.0, 0.45, 0.1]), 0.03)  # at the tool only
    assert not between_links(*tip, LINKS, v, LINK_RADII, links, CLAMP_GAP)
    # the override drops its cap there, keeps it on the far side, and fails safe on NaN
    ends = np.array([[crease[0], crease[1]], [far_side[0], far_side[1]],
                     [[np.nan, 0.0, 0.0], [0.3, -0.1, 0.0]]])
    out = np.empty(3)
    clamp_caps(ends, np.full(3, 0.05), np.full(3, 0.5), np.zeros((0, 2, 3)), CLAMP_GAP, LINKS,
               v, LINK_RADII, links, out)
    assert out.tolist() == [0.0, 0.5, 0.0]


def test_the_tool_belongs_to_its_flanges_link():
    from safety_systems.cell.robot_geometry import robot_capsules, tool_point

    assert capsule_links(robot_capsules(payload_radius=0.05)).tolist() == [0, 1, 2, 3, 4, 5, 5]
    assert capsule_links(tool_point()).tolist() == [0]


def test_the_mounting_surface_covers_the_robots_reach_unless_sized():
    box = mounting_box([], 1.3)
    assert box.tolist() == [[[-1.3, -1.3, -0.05], [1.3, 1.3, 0.0]]]
    assert mounting_box([1.2, 0.8], 1.3).tolist() == [[[-0.6, -0.4, -0.05], [0.6, 0.4, 0.0]]]
