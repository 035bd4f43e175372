import dataclasses

import numpy as np
import pytest

from safety_systems.cell.cartesian_path import line_path
from safety_systems.speed_alteration.erga import ErgaParameters
from safety_systems.config.scenario import EllipsoidConfig, SpeedAlterationConfig
from safety_systems.speed_alteration.methods import (
    collision_trend,
    danger_grid,
    erga_speed,
    hwang_speed,
    operator_ellipsoids,
)
from safety_systems.systems.bimodal_speed_controller import BimodalSpeedController
from safety_systems.systems.erga_speed_controller import ErgaSpeedController
from safety_systems.systems.hwang_speed_controller import HwangSpeedController
from safety_systems.systems.preprogrammed_speed_controller import PreprogrammedSpeedController

CONTROLLERS = [ErgaSpeedController, HwangSpeedController, BimodalSpeedController,
               PreprogrammedSpeedController]
CONFIG = SpeedAlterationConfig(
    ellipsoids=EllipsoidConfig(human="hands", link_radii=[], tool_offset=-0.05))
S = 1.0  # path position of every decision, s: the tool sphere's centre is then at
TOOL = np.array([0.368, 0.05, 0.7185])  # (tool0 at y = 0.05 m, 5 cm above it), m
# The tool moves along +y at 0.05 m/s; in one 0.1 s step it reaches y = 0.055. A glove
# 0.102 m ahead is clear now (DI < 1) but is touched by 0.1 m of spheres unless the speed
# stays below 0.02 m/s.
AHEAD = TOOL + [0.0, 0.102, 0.0]


@pytest.fixture(scope="module")
def path():
    return line_path([0.368, 0, 0.6685], [0.368, 0.12, 0.6685], speed=0.05, rpy=[np.pi, 0, 0],
                     seed=np.radians([159, -103, 74, -61, -90, -111]))


def _decide(cls, path, hand, *, status=1.0, fault=0.0, config=CONFIG):
    """One decision at t = 0 by a controller with one glove; its outputs and the system."""
    system = cls(path=path, config=config, operator_of=[0], is_hand=[True])
    context = system.CreateDefaultContext()
    system.GetInputPort("positions_estimated").FixValue(context, np.asarray(hand, float))
    system.GetInputPort("velocities_estimated").FixValue(context, np.zeros(3))
    system.GetInputPort("track_status").FixValue(context, [status])
    system.GetInputPort("fault").FixValue(context, [fault])
    system.GetInputPort("path_state").FixValue(context, [S, 1.0, 0.0])
    context.SetDiscreteState(system.EvalUniquePeriodicDiscreteUpdate(context))
    out = {n: system.GetOutputPort(n).Eval(context)[0]
           for n in ("path_speed_commanded", "speed_selected", "danger_index")}
    return out, system


def _humans(hand, config=CONFIG):
    return operator_ellipsoids(np.asarray([hand], float), np.array([True]), np.array([0]),
                               np.array([True]), config.ellipsoids)


@pytest.mark.parametrize("cls", CONTROLLERS)
def test_no_tracked_operator_keeps_preprogrammed_speed(cls, path):
    for hand, status in ((AHEAD, 0.0), ([np.nan] * 3, 1.0)):
        out, system = _decide(cls, path, hand, status=status)
        assert system.preprogrammed_speed == pytest.approx(0.05, abs=1e-3)
        assert out["speed_selected"] == system.preprogrammed_speed
        assert out["path_speed_commanded"] == 1.0
        assert out["danger_index"] == 0.0


@pytest.mark.parametrize("cls", CONTROLLERS)
@pytest.mark.parametrize("hand", [TOOL + [0.0, 0.5, 0.0], AHEAD])
def test_fault_or_lost_track_stops(cls, path, hand):
    for kw in ({"fault": 1.0}, {"fault": float("nan")}, {"status": 3.0}):
        out, _ = _decide(cls, path, hand, **kw)
        assert out["speed_selected"] == 0.0, kw
        assert out["path_speed_commanded"] == 0.0, kw


@pytest.mark.parametrize("cls", CONTROLLERS)
def test_far_operator_keeps_preprogrammed_speed(cls, path):
    out, system = _decide(cls, path, TOOL + [0.0, 0.5, 0.0], status=2.0)  # coasting counts
    assert out["speed_selected"] == pytest.approx(system.preprogrammed_speed, abs=1e-3)
    assert out["path_speed_commanded"] == pytest.approx(
        out["speed_selected"] / system.preprogrammed_speed)
    assert 0.0 < out["danger_index"] < 1.0


def test_erga_slows_for_a_hand_ahead(path):
    out, system = _decide(ErgaSpeedController, path, AHEAD)
    v_pre = system.preprogrammed_speed
    assert out["speed_selected"] < v_pre
    assert 0.0 < out["speed_selected"] < 0.02  # as fast as it can while staying clear
    assert out["danger_index"] < 1.0
    assert out["path_speed_commanded"] == pytest.approx(out["speed_selected"] / v_pre)
    # The reported DI is the exact one at the pose the chosen speed reaches.
    reached = danger_grid(path, S, np.array([out["speed_selected"]]), 0.1, v_pre,
                          _humans(AHEAD), CONFIG.ellipsoids)
    assert out["danger_index"] == pytest.approx(reached.max())


def test_erga_backs_away_from_an_overlapping_hand(path):
    # 0.08 m ahead the spheres already overlap: only backing off 2 cm (v <= -0.2 m/s over
    # 0.1 s) clears them, which Eq. 11 prices at (0.25 / 0.05)^2 * (P + D) = 50. A penalty
    # R = 1000 makes that worth it.
    config = dataclasses.replace(CONFIG, R=1000.0)
    out, _ = _decide(ErgaSpeedController, path, TOOL + [0.0, 0.08, 0.0], config=config)
    assert -CONFIG.speed_limit <= out["speed_selected"] < -0.19
    assert out["danger_index"] < 1.0


def test_erga_with_seed_penalty_accepts_overlap_over_a_large_speed_change(path):
    # Seed behaviour, not a bug: with R = 10 the penalty of staying (10 DI^2 ~ 15-25) is
    # cheaper than backing off, so the finite penalty lets DI >= 1 through (cf. Fig. 6).
    out, system = _decide(ErgaSpeedController, path, TOOL + [0.0, 0.08, 0.0])
    assert -0.19 < out["speed_selected"] < system.preprogrammed_speed
    assert out["danger_index"] >= 1.0


def test_erga_matches_the_plain_function(path):
    out, system = _decide(ErgaSpeedController, path, AHEAD)
    v_pre, c = system.preprogrammed_speed, CONFIG
    grid = np.linspace(-c.speed_limit, c.speed_limit, system.grid_size)
    danger = danger_grid(path, S, grid, 1 / c.rate_hz, v_pre, _humans(AHEAD), c.ellipsoids)
    v, _ = erga_speed(grid_speeds=grid, danger=danger, v_pre=v_pre, v_prev=v_pre,
                      limit=c.speed_limit, rng=np.random.default_rng([c.seed, 0]),
                      params=ErgaParameters(), P=c.P, D=c.D, R=c.R)
    assert out["speed_selected"] == v


def test_erga_same_seed_same_decision(path):
    a, _ = _decide(ErgaSpeedController, path, AHEAD)
    b, _ = _decide(ErgaSpeedController, path, AHEAD)
    assert a == b
    others = {_decide(ErgaSpeedController, path, AHEAD,
                      config=dataclasses.replace(CONFIG, seed=seed))[0]["speed_selected"]
              for seed in (1, 2, 3)}
    assert len(others | {a["speed_selected"]}) > 1  # the seed is used


def test_preprogrammed_ignores_the_hand_but_reports_the_danger(path):
    out, system = _decide(PreprogrammedSpeedController, path, AHEAD)
    assert out["speed_selected"] == system.preprogrammed_speed
    assert out["path_speed_commanded"] == 1.0
    assert out["danger_index"] >= 1.0


@pytest.mark.parametrize("threshold, stops", [(0.1, True), (0.06, True), (0.04, False),
                                              (0.0, False)])
def test_bimodal_stops_within_its_clearance(path, threshold, stops):
    # Centres 0.15 m apart, radii 0.05 + 0.05: a clearance of 0.05 m.
    config = dataclasses.replace(CONFIG, bimodal_clearance=threshold)
    out, system = _decide(BimodalSpeedController, path, TOOL + [0.0, 0.15, 0.0], config=config)
    assert out["speed_selected"] == (0.0 if stops else system.preprogrammed_speed)


def test_bimodal_stops_on_overlap_at_zero_threshold(path):
    out, _ = _decide(BimodalSpeedController, path, TOOL + [0.0, 0.08, 0.0])
    assert out["speed_selected"] == 0.0
    assert out["danger_index"] >= 1.0


@pytest.mark.parametrize("offset", [0.08, 0.102, 0.3])
def test_hwang_picks_among_v_pre_and_the_limits(path, offset):
    hand = TOOL + [0.0, offset, 0.0]
    out, system = _decide(HwangSpeedController, path, hand)
    v_pre, e = system.preprogrammed_speed, CONFIG.ellipsoids
    speeds = np.array([-CONFIG.speed_limit, v_pre, CONFIG.speed_limit])
    assert out["speed_selected"] in speeds
    # The same choice as Eq. 13 on the controller's own inputs (first decision: the
    # previous speed is V_pre).
    humans = _humans(hand)
    danger = danger_grid(path, S, speeds, 0.1, v_pre, humans, e)
    now = danger_grid(path, S, np.zeros(1), 0.1, v_pre, humans, e)[0]
    assert out["speed_selected"] == hwang_speed(speeds=speeds, danger=danger, danger_now=now,
                                                v_pre=v_pre, v_prev=v_pre)


def test_collision_trend_is_the_one_sigma_gaussian():
    # DI = 1 / F: P = exp(-F / 2); absent bodies (DI 0) give 0, coincident centres 1.
    di = np.array([0.0, 0.25, 1.0, 4.0, np.inf])
    np.testing.assert_allclose(collision_trend(di), [0.0, np.exp(-2.0), np.exp(-0.5),
                                                     np.exp(-0.125), 1.0])
    assert np.all(np.diff(collision_trend(np.linspace(0.01, 10.0, 50))) > 0)


def test_hwang_jumps_to_the_retreat_limit_for_a_hand_ahead_where_none_keeps_going(path):
    # The glove 0.102 m ahead: the pre-programmed speed would touch it, and so would the
    # advance at the limit; Hwang's alteration is the other limit, a retreat (ERGA slows
    # to below 0.02 m/s instead, test above).
    out, system = _decide(HwangSpeedController, path, AHEAD)
    plain, _ = _decide(PreprogrammedSpeedController, path, AHEAD)
    assert plain["speed_selected"] == system.preprogrammed_speed and plain["danger_index"] >= 1
    assert out["speed_selected"] == -CONFIG.speed_limit
    assert out["danger_index"] < 1.0
    assert out["path_speed_commanded"] == pytest.approx(
        out["speed_selected"] / system.preprogrammed_speed)
    advance = danger_grid(path, S, np.array([CONFIG.speed_limit]), 0.1,
                          system.preprogrammed_speed, _humans(AHEAD), CONFIG.ellipsoids)
    assert advance.max() >= 1.0


def test_hwang_backs_away_when_only_backing_away_is_clear(path):
    # 0.08 m ahead the spheres overlap now: only backing off 2 cm in 0.1 s clears them.
    # The penalty index comes first, whatever it costs in Eq. 13 (ERGA with the seed's
    # R = 10 accepts the overlap instead, test above).
    out, _ = _decide(HwangSpeedController, path, TOOL + [0.0, 0.08, 0.0])
    assert -CONFIG.speed_limit <= out["speed_selected"] < -0.19
    assert out["danger_index"] < 1.0


GRID_SPEEDS = np.linspace(-0.25, 0.25, 101)


def _pairs_ahead(n, d0, rho=0.1, dt=0.1):
    """DI of n identical sphere pairs d0 ahead along the path, at each grid speed."""
    d = d0 - GRID_SPEEDS * dt
    return np.repeat(((rho / d) ** 2)[:, None], n, axis=1)


def test_hwang_collision_trend_cannot_leave_a_collision_free_v_pre_for_one_pair():
    # Why Hwang chooses among V_pre and the limits (hwang_speed): over a continuous range,
    # with pairs 0.14 m ahead (contact at 0.1 m, every speed collision-free), one pair's
    # collision trend cannot outweigh |V - V_pre| / V_pre: V_pre. Only some thirty such
    # pairs make Eq. 13 alone leave it for a limit.
    v_pre = 0.05
    for n, expected in ((1, v_pre), (30, -0.25)):
        danger = _pairs_ahead(n, 0.14)
        assert danger.max() < 1.0
        v = hwang_speed(speeds=GRID_SPEEDS, danger=danger, danger_now=danger[50],
                        v_pre=v_pre, v_prev=v_pre)
        assert v == pytest.approx(expected), n


def test_hwang_takes_the_least_colliding_speed_when_all_collide():
    danger = _pairs_ahead(2, 0.05)  # overlapping at every reachable pose
    assert danger.min() >= 1.0
    v = hwang_speed(speeds=GRID_SPEEDS, danger=danger, danger_now=danger[50], v_pre=0.05,
                    v_prev=0.05)
    assert v == -0.25
