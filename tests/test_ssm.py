import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from safety_systems.ssm.formulas import (
    directed_speeds,
    human_speed_term,
    human_uncertainty,
    monitor_protective_distances,
    overall_speed_override,
    protective_separation_distance,
    separation_and_directed_speeds,
    separation_distances,
    speed_override,
    speed_override_command,
)


def test_separation_distance_eq8():
    d = separation_distances(np.array([0.0, 0.0, 0.0]), np.array([[3.0, 4.0, 0.0], [0, 0, 2]]))
    np.testing.assert_allclose(d, [5.0, 2.0])


def test_directed_speeds_eq6_eq7():
    # Body at +x 2 m moving towards the robot at 1.5 m/s; robot moving +x at 0.25 m/s.
    v_h, v_r = directed_speeds(
        np.zeros(3), np.array([0.25, 0.0, 0.0]), np.array([[2.0, 0, 0]]), np.array([[-1.5, 0, 0]])
    )
    np.testing.assert_allclose(v_h, [1.5])
    np.testing.assert_allclose(v_r, [0.25])
    # Moving away gives negative directed speeds; a perpendicular velocity gives 0.
    v_h, v_r = directed_speeds(
        np.zeros(3), np.array([0.0, 0.3, 0.0]), np.array([[2.0, 0, 0]]), np.array([[1.0, 0, 0]])
    )
    np.testing.assert_allclose(v_h, [-1.0])
    np.testing.assert_allclose(v_r, [0.0], atol=1e-15)


def test_directed_speeds_coincident_is_worst_case():
    v_h, v_r = directed_speeds(np.zeros(3), np.array([0, 0.4, 0.3]), np.zeros((1, 3)),
                               np.array([[0.0, 1.2, 1.6]]))
    np.testing.assert_allclose(v_h, [2.0])
    np.testing.assert_allclose(v_r, [0.5])


def test_protective_distance_by_hand():
    # S = vH (Ts + Tr) + vR Tr + B + C + Zd + Zr
    #   = 1.6 * (0.3 + 0.1) + 0.5 * 0.1 + 0.2 + 0.05 + 0.01 + 0.02 = 0.97
    s = protective_separation_distance(
        1.6, 0.5, reaction_time=0.1, stopping_time=0.3, stopping_distance=0.2,
        intrusion_distance=0.05, human_uncertainty=0.01, robot_uncertainty=0.02,
    )
    assert s == pytest.approx(0.97)


def test_human_speed_modes():
    v = np.array([-1.0, 0.5, 2.5])
    np.testing.assert_allclose(human_speed_term(v, "estimated"), v)
    np.testing.assert_allclose(human_speed_term(v, "iso"), [2.0, 2.0, 2.0])
    np.testing.assert_allclose(human_speed_term(v, "estimated_with_floor"), [2.0, 2.0, 2.5])
    with pytest.raises(ValueError, match="human_speed mode"):
        human_speed_term(v, "fast")


def test_iso_mode_uses_reduced_speed_above_half_metre():
    args = dict(reaction_time=0.1, stopping_time=0.3, stopping_distance=0.2)
    # 2.0 * 0.4 + 0 + 0.2 = 1.0 > 0.5 -> 1.6 * 0.4 + 0.2 = 0.84.
    s = monitor_protective_distances(np.array([0.0]), np.array([0.0]), mode="iso", **args)
    np.testing.assert_allclose(s, [0.84])
    # Small times: 2.0 * 0.1 + 0.05 = 0.25 <= 0.5 stays.
    s = monitor_protective_distances(np.array([0.0]), np.array([0.0]), mode="iso",
                                     reaction_time=0.05, stopping_time=0.05,
                                     stopping_distance=0.05)
    np.testing.assert_allclose(s, [0.25])
    # Reduced value is floored at 0.5: 2.0*0.15+0.21 = 0.51 > 0.5 -> max(1.6*0.15+0.21, 0.5).
    s = monitor_protective_distances(np.array([0.0]), np.array([0.0]), mode="iso",
                                     reaction_time=0.05, stopping_time=0.1,
                                     stopping_distance=0.21)
    np.testing.assert_allclose(s, [0.5])


@pytest.mark.parametrize(
    "d, expected",
    [(0.25, 0.0),  # d < d_min
     (1.0, 0.0),  # d = S_max: the ramp starts at 0
     (1.5, 0.5),  # d = 1.5 S_max with dS = 2
     (2.0, 1.0),  # d = dS * S_max
     (3.0, 1.0)],  # beyond
)
def test_speed_override_eq12_by_hand(d, expected):
    assert speed_override(np.array([d]), 1.0, delta_s=2.0, d_min=0.3)[0] == pytest.approx(expected)


def test_speed_override_dmin_beats_large_distance_band():
    # S_max tiny: d = 0.2 >= dS * S_max, but d < d_min must still stop.
    assert speed_override(np.array([0.2]), 0.05, delta_s=2.0, d_min=0.3)[0] == 0.0


def test_overall_override_uses_smax_over_bodies_and_fails_safe():
    d = np.array([1.5, 4.0, 0.1])
    s = np.array([0.4, 1.0, 5.0])
    inc = np.array([True, True, False])  # third body has no track: ignored
    k, s_max = overall_speed_override(d, s, inc)
    assert s_max == pytest.approx(1.0)
    assert k == pytest.approx(0.5)
    k, _ = overall_speed_override(d, np.array([np.nan, 1.0, 0.0]), inc)
    assert k == 0.0
    k, _ = overall_speed_override(d, s, np.zeros(3, bool))
    assert k == 1.0


finite = st.floats(min_value=0.0, max_value=10.0, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(d=finite, s_max=st.floats(-2.0, 5.0), delta_s=st.floats(1.0, 5.0), d_min=st.floats(0, 1))
def test_override_properties(d, s_max, delta_s, d_min):
    k = speed_override(np.array([d]), s_max, delta_s=delta_s, d_min=d_min)[0]
    assert 0.0 <= k <= 1.0
    if d < s_max or d < d_min:
        assert k == 0.0


@settings(max_examples=300, deadline=None)
@given(d1=finite, d2=finite, s_max=st.floats(-2.0, 5.0), delta_s=st.floats(1.0, 5.0),
       d_min=st.floats(0, 1))
def test_override_monotone_in_distance(d1, d2, s_max, delta_s, d_min):
    lo, hi = sorted((d1, d2))
    k = speed_override(np.array([lo, hi]), s_max, delta_s=delta_s, d_min=d_min)
    assert k[0] <= k[1]


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(finite, st.floats(0.0, 3.0)), min_size=1, max_size=10))
def test_overall_override_is_zero_when_any_body_inside_smax(pairs):
    d = np.array([p[0] for p in pairs])
    s = np.array([p[1] for p in pairs])
    k, s_max = overall_speed_override(d, s, np.ones(len(d), bool))
    assert 0.0 <= k <= 1.0
    if np.any(d < s_max) or np.any(d < 0.3):
        assert k == 0.0


def test_vectorised_over_batch_matches_loop():
    rng = np.random.default_rng(0)
    p_R = rng.normal(size=(7, 3))
    v_R = rng.normal(size=(7, 3))
    p_B = rng.normal(size=(7, 4, 3))
    v_B = rng.normal(size=(7, 4, 3))
    v_h, v_r = directed_speeds(p_R, v_R, p_B, v_B)
    for b in range(7):
        h1, r1 = directed_speeds(p_R[b], v_R[b], p_B[b], v_B[b])
        np.testing.assert_allclose(v_h[b], h1)
        np.testing.assert_allclose(v_r[b], r1)


body_value = st.one_of(st.floats(0.0, 4.0), st.sampled_from([np.inf, np.nan]))


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(body_value, st.one_of(st.floats(-2.0, 3.0),
                                                 st.sampled_from([np.inf, -np.inf, np.nan])),
                          st.booleans()), min_size=1, max_size=8),
       st.floats(1.0, 4.0), st.floats(0.0, 1.0))
def test_overall_override_is_the_minimum_over_included_bodies(bodies, delta_s, d_min):
    # The definition, body by body: S_max over the included bodies (inf if any included
    # body has a non-finite d or S), then the smallest Eq. 12 k over them.
    d = np.array([b[0] for b in bodies])
    s = np.array([b[1] for b in bodies])
    inc = np.array([b[2] for b in bodies])
    faulty = inc & ~(np.isfinite(d) & np.isfinite(s))
    s_max = np.inf if faulty.any() else max(s[inc], default=-np.inf)
    expected = min((float(speed_override(np.array([d_i]), s_max, delta_s=delta_s,
                                         d_min=d_min)[0]) for d_i in d[inc]), default=1.0)
    with np.errstate(invalid="raise", over="raise", divide="raise"):  # no inf - inf inside
        k, got_s_max = overall_speed_override(d, s, inc, delta_s=delta_s, d_min=d_min)
    assert got_s_max == s_max
    assert float(k) == expected


def test_overall_override_batched_matches_one_robot_at_a_time():
    # The batched evaluator's path (2-D) against the Drake system's (one robot, 1-D).
    rng = np.random.default_rng(3)
    d = rng.uniform(0.0, 3.0, (400, 5))
    s = rng.uniform(-1.0, 2.0, (400, 5))
    inc = rng.random((400, 5)) < 0.7
    d[rng.random(d.shape) < 0.05] = np.inf
    d[rng.random(d.shape) < 0.05] = np.nan
    s[rng.random(s.shape) < 0.05] = np.nan
    s[rng.random(s.shape) < 0.03] = -np.inf
    k, s_max = overall_speed_override(d, s, inc, delta_s=1.7, d_min=0.25)
    for row in range(len(d)):
        k_one, s_one = overall_speed_override(d[row], s[row], inc[row], delta_s=1.7, d_min=0.25)
        assert k[row] == k_one
        assert s_max[row] == s_one


def test_separation_with_directed_speeds_gives_eq8_distances():
    rng = np.random.default_rng(5)
    p_R, v_R = rng.normal(size=(6, 3)), rng.normal(size=(6, 3))
    p_B, v_B = rng.normal(size=(6, 4, 3)), rng.normal(size=(6, 4, 3))
    p_B[0, 1] = p_R[0]  # coincident
    p_B[2, 3] = np.nan  # a bad frame
    d, v_h, v_r = separation_and_directed_speeds(p_R, v_R, p_B, v_B)
    np.testing.assert_array_equal(d, separation_distances(p_R, p_B))
    assert d[0, 1] == 0.0 and v_h[0, 1] == pytest.approx(np.linalg.norm(v_B[0, 1]))
    assert np.isnan(v_h[2, 3]) and np.isnan(v_r[2, 3]) and np.isfinite(v_h[2, :3]).all()


def test_human_uncertainty_adds_only_the_terms_switched_on():
    std = np.array([0.01, np.nan])  # the second body has no track
    assert human_uncertainty(0.05, 0.0, std) == 0.05  # the seed's constant
    np.testing.assert_allclose(human_uncertainty(0.05, 3.0, std)[0], 0.08)


def test_override_command_is_the_plain_override_then_fail_safe():
    rng = np.random.default_rng(8)
    for _ in range(200):
        d, s = rng.uniform(-0.5, 3, 5), rng.uniform(-1, 2, 5)
        status = rng.integers(0, 4, 5).astype(float)
        d[rng.uniform(size=5) < 0.1] = np.nan
        fault = float(rng.choice([0, 0, 0, 2, 5, 7, np.nan]))
        k, top, reason = speed_override_command(d, s, status, fault)
        usable = (status == 1) | (status == 2)
        k_ref, top_ref = overall_speed_override(d, s, usable)
        if fault != 0.0:  # incl. NaN
            assert k == 0.0 and reason == (2 if np.isnan(fault) else fault)
        elif np.any(status == 3):
            assert k == 0.0 and reason == 3
        else:
            assert k == k_ref and reason == (1 if k_ref <= 0 else 0)
        assert top == top_ref or (np.isnan(top) and np.isnan(top_ref))
