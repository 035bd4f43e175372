"""The safety and efficiency metric of seed 001 (Tables IX-X), on hand-computed traces."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from safety_systems.planning.evaluation import (
    A,
    B,
    EFFICIENCY_WEIGHTS,
    SAFETY_WEIGHTS,
    Thresholds,
    acceleration_variation,
    combine,
    evaluate,
    joint_smoothness,
    obstacle_proximity,
    power_efficiency,
    safe_navigation,
    task_completion,
    time_to_collision,
    trajectory_smoothness,
)

FIXED = settings(derandomize=True, deadline=None, max_examples=60)
INF = math.inf


def _six(*columns):
    """(T, 6) array from up to six joint columns (the rest zero)."""
    out = np.zeros((len(columns[0]), 6))
    for i, c in enumerate(columns):
        out[:, i] = c
    return out


def test_task_completion():
    assert task_completion(3.0, 4.0) == pytest.approx(75.0)  # 3 s of path in 4 s
    assert task_completion(4.0, 4.0) == 100.0
    assert task_completion(5.0, 4.0) == 100.0  # capped
    assert task_completion(1.0, 0.0) == 0.0


def test_power_efficiency():
    tau = _six([2, 1, 0], [0, 1, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, -4])
    omega = _six([1, 2, 0], [5, -2, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 1])
    # TW per instant: |2*1| + |0*5| = 2; |1*2| + |1*(-2)| = 4 (no cancelling); |-4*1| = 4.
    # mean 10/3, max 4 -> 100 * 10/12.
    assert power_efficiency(tau, omega) == pytest.approx(100.0 * 10.0 / 12.0)
    assert power_efficiency(tau, np.zeros_like(omega)) == 0.0


A_RUN = _six([0, 1, 3, 2], [1, 1, 1, 1], [0, -2, 0, -2])   # S = 1+2+1 = 4, 0, 2+2+2 = 6
A_IDEAL = _six([0, 1, 2, 2], [0, 1, 0, 1], [0, -3, 0, -3])  # S = 1+1+0 = 2, 3, 9


def test_acceleration_variation_and_trajectory_smoothness():
    assert acceleration_variation(A_RUN).tolist() == [4, 0, 6, 0, 0, 0]
    assert acceleration_variation(A_IDEAL).tolist() == [2, 3, 9, 0, 0, 0]
    # Ratios min(1, S_ideal / S): 2/4; S = 0 -> 1; min(1, 9/6) = 1; three idle joints 1.
    assert trajectory_smoothness(A_RUN, A_IDEAL) == pytest.approx(100.0 * 5.5 / 6.0)
    assert trajectory_smoothness(A_IDEAL, A_IDEAL) == 100.0


def test_joint_smoothness():
    q = _six([0, 1, 3], [0, -1, 0])        # travelled 3 and 2 rad: mean 5/6 over 2 s -> 5/12
    ideal = _six([0, 2, 4], [0, 0, 0])     # travelled 4 rad: mean 4/6 over 1 s -> 2/3
    assert joint_smoothness(q, 2.0, ideal, 1.0) == pytest.approx(100.0 * (5 / 12) / (2 / 3))
    assert joint_smoothness(ideal, 0.5, ideal, 1.0) == 100.0  # faster than ideal: capped
    assert joint_smoothness(q, 2.0, np.zeros((3, 6)), 1.0) == 100.0  # no ideal motion


def test_safe_navigation():
    closest = np.array([0.2, 0.6, INF, 0.49, 0.5])
    # Closer than 0.5 m at 2 of 5 instants (0.5 itself is not closer; absent is safe).
    assert safe_navigation(closest, 0.5) == pytest.approx(60.0)
    assert safe_navigation(np.full(3, INF), 0.5) == 100.0


def test_obstacle_proximity():
    # Present at 0.5 and 0.7 m: mean 0.6 of a comfortable 1 m.
    assert obstacle_proximity(np.array([0.5, INF, 0.7, INF]), 1.0) == pytest.approx(60.0)
    assert obstacle_proximity(np.array([1.5, 2.5]), 1.0) == 100.0  # capped
    assert obstacle_proximity(np.full(4, INF), 1.0) == 100.0  # nobody there


def test_time_to_collision():
    d = np.array([1.0, 2.0, 0.5, INF, 3.0])
    closing = np.array([1.0, 0.5, -1.0, 2.0, 0.0])
    # CRM: 1 s -> 1/2; 4 s -> 1 (capped); opening -> inf -> 1; absent -> 1; not closing -> 1.
    assert time_to_collision(d, closing, 2.0) == pytest.approx(100.0 * 4.5 / 5.0)
    # CRM 0.2 s and 1 s of a 2 s horizon: (0.1 + 0.5) / 2.
    assert time_to_collision(np.array([0.2, 1.0]), np.array([1.0, 1.0]), 2.0) == \
        pytest.approx(30.0)


def test_combine_with_seed_weights_reproduces_table_x():
    assert tuple(SAFETY_WEIGHTS.values()) == (0.4, 0.3, 0.3)  # Table IX order
    assert tuple(EFFICIENCY_WEIGHTS.values()) == (0.3, 0.3, 0.1, 0.3)
    assert (A, B) == (0.8, 0.2)
    def scores(sne, opm, crm, tct, pe, ts, js):
        return combine(
            {"safe_navigation_efficiency": sne, "obstacle_proximity": opm,
             "time_to_collision": crm},
            {"task_completion": tct, "power_efficiency": pe, "trajectory_smoothness": ts,
             "joint_smoothness": js})
    zone = scores(73.51, 61.20, 44.04, 67.66, 48.43, 47.31, 53.14)
    # Safety 0.4*73.51 + 0.3*61.20 + 0.3*44.04 = 29.404 + 18.36 + 13.212 = 60.976 ("61 %");
    # efficiency 0.3*67.66 + 0.3*48.43 + 0.1*47.31 + 0.3*53.14 = 55.5 ("55 %");
    # overall 0.8*60.976 + 0.2*55.5 = 59.8808.
    assert zone["safety_score"] == pytest.approx(60.976)
    assert zone["efficiency_score"] == pytest.approx(55.5)
    assert zone["overall_score"] == pytest.approx(59.8808)
    none = scores(100, 69.07, 40.18, 100, 50.67, 47.41, 53.14)
    # Safety 40 + 20.721 + 12.054 = 72.775; efficiency 30 + 15.201 + 4.741 + 15.942 = 65.884;
    # overall 58.22 + 13.1768 = 71.3968; the seed's 83.87 % is zone / no zone.
    assert none["overall_score"] == pytest.approx(71.3968)
    assert 100 * zone["overall_score"] / none["overall_score"] == pytest.approx(83.87, abs=0.01)


def test_combine_uses_the_metric_names_not_their_order():
    safety = {"safe_navigation_efficiency": 100.0, "obstacle_proximity": 0.0,
              "time_to_collision": 0.0}
    efficiency = {"task_completion": 100.0, "power_efficiency": 0.0,
                  "trajectory_smoothness": 0.0, "joint_smoothness": 0.0}
    reordered = dict(reversed(list(safety.items())))
    assert combine(reordered, efficiency) == combine(safety, efficiency)


KEYS = {"task_completion", "power_efficiency", "trajectory_smoothness", "joint_smoothness",
        "safe_navigation_efficiency", "obstacle_proximity", "time_to_collision",
        "contact_free", "safety_score", "efficiency_score", "overall_score"}


def test_evaluate_on_the_hand_trace():
    time = np.array([0.0, 1.0, 2.0])
    q = _six([0, 1, 3], [0, -1, 0])
    closest = np.array([0.2, INF, 0.8])
    r = evaluate(time=time, q=q, v=q, a=A_RUN[:3], torques=np.ones((3, 6)), progress=1.5,
                 elapsed=2.0, closest=closest, closing_speed=np.array([0.4, 1.0, -1.0]),
                 ideal_q=_six([0, 2, 4]), ideal_a=A_IDEAL[:3], ideal_duration=1.0)
    assert set(r) == KEYS
    assert r["task_completion"] == pytest.approx(75.0)
    assert r["joint_smoothness"] == pytest.approx(62.5)  # duration from time: 2 s
    # TW = |tau . v| summed: 0, |1| + |-1| = 2, 3 -> mean 5/3 of max 3.
    assert r["power_efficiency"] == pytest.approx(100 * 5 / 9)
    # S = 3, 0, 4 against ideal 2, 2, 6: ratios 2/3, 1, 1 and three idle joints.
    assert r["trajectory_smoothness"] == pytest.approx(100 * (5 + 2 / 3) / 6)
    # Unsafe (< 0.5 m) at 1 of 3 instants; mean present distance 0.5 of 1 m;
    # CRM 0.2/0.4 = 0.5 s -> 0.25, absent -> 1, opening -> 1.
    assert r["safe_navigation_efficiency"] == pytest.approx(100 * 2 / 3)
    assert r["obstacle_proximity"] == pytest.approx(50.0)
    assert r["time_to_collision"] == pytest.approx(100 * 2.25 / 3)
    expected = combine({k: r[k] for k in ("safe_navigation_efficiency", "obstacle_proximity",
                                          "time_to_collision")},
                       {k: r[k] for k in ("task_completion", "power_efficiency",
                                          "trajectory_smoothness", "joint_smoothness")})
    assert {k: r[k] for k in expected} == pytest.approx(expected)
    strict = evaluate(time=time, q=q, v=q, a=A_RUN[:3], torques=np.ones((3, 6)), progress=1.5,
                      elapsed=2.0, closest=closest, closing_speed=np.array([0.4, 1.0, -1.0]),
                      ideal_q=_six([0, 2, 4]), ideal_a=A_IDEAL[:3], ideal_duration=1.0,
                      thresholds=Thresholds(unsafe=0.1, comfortable=0.25, horizon=0.5))
    assert r["contact_free"] == 100.0
    touched = evaluate(time=time, q=q, v=q, a=A_RUN[:3], torques=np.ones((3, 6)), progress=1.5,
                       elapsed=2.0, closest=closest, closing_speed=np.array([0.4, 1.0, -1.0]),
                       ideal_q=_six([0, 2, 4]), ideal_a=A_IDEAL[:3], ideal_duration=1.0,
                       contact=True)
    # Our contact gate: the same run with a contact scores 0 on safety; the Table IX
    # metrics and the efficiency are unchanged.
    assert touched["contact_free"] == 0.0 and touched["safety_score"] == 0.0
    assert {k: v for k, v in touched.items() if k not in ("contact_free", "safety_score",
                                                          "overall_score")} == \
        {k: v for k, v in r.items() if k not in ("contact_free", "safety_score",
                                                 "overall_score")}
    assert touched["overall_score"] == pytest.approx(B * r["efficiency_score"])
    assert strict["safe_navigation_efficiency"] == 100.0
    assert strict["obstacle_proximity"] == 100.0
    assert strict["time_to_collision"] == pytest.approx(100.0)


def _arrays(t, lo=-5.0, hi=5.0):
    return hnp.arrays(float, (t, 6), elements=st.floats(lo, hi))


@st.composite
def runs(draw):
    t = draw(st.integers(2, 8))
    closest = draw(hnp.arrays(float, t, elements=st.one_of(st.floats(0.0, 3.0), st.just(INF))))
    closing = st.integers(-200, 200).map(lambda c: c / 100)  # m/s, no overflowing divisions
    return dict(
        time=np.cumsum(draw(hnp.arrays(float, t, elements=st.floats(0.01, 1.0)))),
        q=draw(_arrays(t)), v=draw(_arrays(t)), a=draw(_arrays(t)), torques=draw(_arrays(t)),
        progress=draw(st.floats(0.0, 20.0)), elapsed=draw(st.floats(0.0, 20.0)),
        closest=closest, closing_speed=draw(hnp.arrays(float, t, elements=closing)),
        ideal_q=draw(_arrays(t)), ideal_a=draw(_arrays(t)),
        ideal_duration=draw(st.floats(0.1, 10.0)))


@FIXED
@given(runs())
def test_evaluate_scores_in_range(run):
    r = evaluate(**run)
    assert set(r) == KEYS
    for key, value in r.items():
        assert 0.0 <= value <= 100.0 + 1e-9, key


@FIXED
@given(runs())
def test_a_contact_scores_lower_on_safety(run):
    clear, hit = evaluate(**run), evaluate(**run, contact=True)
    assert hit["safety_score"] == 0.0 <= clear["safety_score"]
    if np.all(run["closest"] > 1e-9):  # apart everywhere: time to collision is positive
        assert hit["safety_score"] < clear["safety_score"]
        assert hit["overall_score"] < clear["overall_score"]


def test_the_contact_gate_leaves_table_x_alone():
    safety = {"safe_navigation_efficiency": 73.51, "obstacle_proximity": 61.20,
              "time_to_collision": 44.04}
    efficiency = {"task_completion": 67.66, "power_efficiency": 48.43,
                  "trajectory_smoothness": 47.31, "joint_smoothness": 53.14}
    assert combine(safety, efficiency) == combine(safety, efficiency, contact=False)
    assert combine(safety, efficiency, contact=True)["safety_score"] == 0.0
