"""The stopping proof: its verdicts, and its bounds checked against sampling and simulation."""

import dataclasses as dc
import math
from pathlib import Path

import numpy as np
import pytest

from safety_systems.braking import BrakingTable, path_rate_step, tool_stopping_distance
from safety_systems.joint_path import joint_path_state
from safety_systems.kalman import axis_predict, process_noise, transition_matrix
from safety_systems.scenario import BrakingConfig, load_controller_config
from safety_systems.configuration import tracker_rules
from safety_systems.tracks import TRACK_SLOT, frame_update
from safety_systems.ur5e import tool0_position_and_velocity
from safety_systems.workcell import braking_table, frame_timeout, joint_path
from verification.proof import (
    braking_is_monotone,
    estimate_error_coefficients,
    prove,
    robot_bounds,
    tool_acceleration_bound,
)
from verification.space import Range, load_space

ROOT = Path(__file__).resolve().parents[2]
ISO = load_controller_config(ROOT / "models/configs/iso.yaml")
SEED = load_controller_config(ROOT / "models/configs/seed_estimated.yaml")
SPACE = load_space(ROOT / "models/spaces/default.yaml")
PATH = joint_path(SPACE.robot)
H = 1.0 / SPACE.robot.control_rate_hz
HUMAN_SPEED, OCCLUSION = 1, 4  # premise indices


def _safety(**kw):
    return dc.replace(ISO, safety=dc.replace(ISO.safety, **kw))


def _space(**ranges):
    return dc.replace(SPACE, parameters=dc.replace(SPACE.parameters, **ranges))


@pytest.fixture(scope="module")
def iso_proof():
    return prove(ISO, SPACE)


def test_iso_config_is_proved_with_a_positive_margin(iso_proof):
    assert iso_proof.proved
    assert iso_proof.margin_at_worst_corner > 0.0
    assert len(iso_proof.premises) == 7 and all(ok for _, ok in iso_proof.premises)


def test_margin_is_the_theorem_s_m_at_the_worst_corner(iso_proof):
    t, f, p = iso_proof.terms, ISO.safety, SPACE.parameters
    assert (t["T_s"], t["B"], t["T_r"]) == (0.54, 0.26, 0.20)
    assert t["tau"] == frame_timeout(ISO) and t["h"] == H
    v_max, n = p.peak_speed.max, SPACE.noise_bound_sigmas * p.noise_std.max
    e = t["E_per_axis"]
    m = (t["v"] * (t["T_s"] + t["T_r"]) - t["V_R"] * t["T_r"] + t["B"] + f.intrusion_distance
         - math.sqrt(3.0) * (e["alpha"] * n + e["beta"] * v_max)
         - v_max * (t["tau"] + t["T_stop"] + t["h"]) - t["V_R"] * t["h"] - t["D"]
         - SPACE.contact_distance)
    assert iso_proof.margin_at_worst_corner == pytest.approx(m, abs=1e-12)


def test_seed_config_fails_on_its_human_speed():
    proof = prove(SEED, SPACE)
    assert not proof.proved and proof.margin_at_worst_corner is None
    assert not proof.premises[HUMAN_SPEED][1]
    assert "human-speed" in proof.premises[HUMAN_SPEED][0]
    # Without occlusions (the seed has no occlusion margin) it is the only failing premise.
    proof = prove(SEED, _space(occlusion=Range(0.0, 0.0)))
    assert [ok for _, ok in proof.premises] == [True, False, True, True, True, True]


BROKEN = {
    "no reaction time": (_safety(reaction_time=0.0), SPACE),
    "short stopping time": (_safety(stopping_time=0.3), SPACE),
    "short stopping distance": (_safety(stopping_distance=0.1), SPACE),
    "slow brakes": (ISO, _space(braking_time_scale=Range(1.0, 1.5))),
    "long occlusion": (ISO, _space(occlusion=Range(0.0, ISO.tracker.max_coast_time + 0.1))),
}


@pytest.mark.parametrize("name", BROKEN)
def test_broken_iso_configs_are_not_proved(name):
    config, space = BROKEN[name]
    proof = prove(config, space)
    assert not proof.proved
    if name == "long occlusion":
        assert not proof.premises[OCCLUSION][1] and proof.margin_at_worst_corner is None
    else:  # every premise but z3's holds; the margin is negative
        assert [ok for _, ok in proof.premises] == [True] * 6 + [False]
        assert proof.margin_at_worst_corner < 0.0


@pytest.mark.parametrize("scale", [1.0, 2.0])
def test_robot_bounds_cover_sampled_motion(scale):
    rb = robot_bounds(PATH, ISO, period=H, braking_time_scale=scale)
    # V_R: above the tool speed sampled 10x more densely than the covering grid.
    s = np.linspace(0.0, PATH.cycle_time, 200_001)
    q, dq, _ = joint_path_state(PATH, s)
    speed = np.linalg.norm(tool0_position_and_velocity(q, dq)[1], axis=-1)
    assert speed.max() <= rb.tool_speed <= 1.05 * speed.max()
    # D: above the tool's worst stopping travel under brakes slowed by ``scale``.
    table = braking_table(ISO)
    slowed = BrakingTable(table.speed_fraction, table.stopping_time * scale,
                          table.stopping_distance)
    assert rb.stop_travel >= tool_stopping_distance(PATH, slowed, period=H)
    # T_stop: the ticks a stop from full speed takes, as the PathFollower steps it.
    rate, ticks = 1.0, 0
    while rate > 0.0:
        rate = float(path_rate_step(rate, 0.0, H, table=table, acceleration_limit=2.0,
                                    time_scale=scale))
        ticks += 1
    assert rb.stop_time == pytest.approx(ticks * H, abs=1e-12)
    assert scale * 0.53 <= rb.stop_time <= scale * 0.53 + H  # the table's 0.53 s, scaled


def test_slower_brakes_double_stop_time_and_travel():
    nominal = robot_bounds(PATH, ISO, period=H, braking_time_scale=1.0)
    slow = robot_bounds(PATH, ISO, period=H, braking_time_scale=2.0)
    assert slow.tool_speed == nominal.tool_speed
    assert slow.stop_time / nominal.stop_time == pytest.approx(2.0, rel=0.01)
    assert 1.7 <= slow.stop_travel / nominal.stop_travel <= 2.1


def test_tool_acceleration_bound_covers_finite_differences():
    bound = tool_acceleration_bound(PATH)
    step = 1e-4  # s of path parameter
    s = np.arange(0.0, PATH.cycle_time, step)
    q, dq, _ = joint_path_state(PATH, s)
    v = tool0_position_and_velocity(q, dq)[1]
    # |dv|/ds over an interval is an average of |p''|, so it cannot exceed sup |p''|.
    accel = np.linalg.norm(np.diff(v, axis=0), axis=-1) / step
    assert 0.5 < accel.max() <= bound


def test_braking_is_monotone_for_the_default_table():
    assert ISO.braking.speed_fraction == []  # the default (UR5 placeholder) table
    for scale in (0.5, 1.0, 2.0):
        assert braking_is_monotone(ISO, H, scale)
    # A table whose deceleration jumps within one tick's worth of speed is not.
    jumpy = dc.replace(ISO, braking=BrakingConfig(speed_fraction=[0.5, 1.0],
                                                  stopping_time=[10.0, 0.001],
                                                  stopping_distance=[0.1, 0.2]))
    assert not braking_is_monotone(jumpy, H, 1.0)


def _motions(rng, rows, frames, settle, period, v_max, a_max, substeps=10):
    """True positions (frames, rows, 3) at the frame times: at rest for ``settle`` frames,
    then piecewise-constant accelerations up to ``a_max`` with the speed capped at
    ``v_max``; even rows move along x only, odd rows in 3-D."""
    dt = period / substeps
    axes = np.where(np.arange(rows)[:, None] % 2 == 0, np.eye(3)[0], 1.0)
    p = rng.uniform(-1.0, 1.0, (rows, 3))
    v, a = np.zeros((rows, 3)), np.zeros((rows, 3))
    out = np.empty((frames, rows, 3))
    for k in range(frames):
        out[k] = p
        for _ in range(substeps if k >= settle else 0):
            change = rng.random(rows) < dt / 0.2  # new acceleration every ~0.2 s
            new = rng.normal(size=(rows, 3)) * axes
            size = a_max * rng.choice([0.0, 1.0, rng.random()], size=rows)
            new *= (size / np.linalg.norm(new, axis=1))[:, None]
            a = np.where(change[:, None], new, a)
            v_new = v + a * dt
            speed = np.linalg.norm(v_new, axis=1, keepdims=True)
            v_new *= np.minimum(1.0, v_max / np.maximum(speed, 1e-300))
            p = p + 0.5 * (v + v_new) * dt
            v = v_new
    return out


@pytest.mark.parametrize("dt, q2", [(0.05, 0.05), (0.35, 2.0), (1e-3, 0.0)])
def test_one_axis_prediction_is_the_filters(dt, q2):
    # The per-axis prediction (the tracker's and the proof's) equals the (x, v_x) block of
    # Eqs. 2 and 4 in 6-D.
    rng = np.random.default_rng(1)
    a = rng.normal(size=(6, 6))
    P = a @ a.T
    F, Q = transition_matrix(dt), process_noise(dt, q2)
    want = (F @ P @ F.T + Q)[np.ix_([0, 3], [0, 3])]
    p, c, w = axis_predict(P[0, 0], P[0, 3], P[3, 3], dt, q2)
    np.testing.assert_allclose([[p, c], [c, w]], want, rtol=1e-12, atol=1e-15)


SETUPS = {  # (config, settle_frames): the iso config, and a smoother, lagging filter
    "iso": (ISO, 60),
    "lagging": (dc.replace(ISO, tracker=dc.replace(ISO.tracker, measurement_std=0.01)), 20),
}


@pytest.fixture(scope="module", params=list(SETUPS))
def coefficients(request, iso_proof):
    config, settle_frames = SETUPS[request.param]
    if request.param == "iso":  # prove() already ran the recursion for this pair
        e = iso_proof.terms["E_per_axis"]
        return config, (e["alpha"], e["beta"])
    return config, estimate_error_coefficients(config, SPACE, settle_frames=settle_frames)


@pytest.mark.parametrize("hidden_bodies", ["hazard", "expire"])
@pytest.mark.parametrize("kind", ["none", "dropout", "occlusion"])
@pytest.mark.parametrize("seed", range(3))
def test_tracker_error_stays_within_the_bound(coefficients, kind, seed, hidden_bodies):
    config, (alpha, beta) = coefficients
    rng = np.random.default_rng(seed)
    period, p = 1.0 / config.sensor.rate_hz, SPACE.parameters
    v_max, n = p.peak_speed.max, SPACE.noise_bound_sigmas * p.noise_std.max
    settle, rows = int(round(SPACE.settle_time / period)), 64
    frames = settle + 60
    truth = _motions(rng, rows, frames, settle, period, v_max, p.acceleration.max)
    # Noise bounded by n per axis: uniform, or at the bound with a random sign.
    noise = n * np.where(rng.random((frames, rows, 1)) < 0.5,
                         rng.uniform(-1.0, 1.0, truth.shape), rng.choice([-1.0, 1.0], truth.shape))
    longest = math.ceil(max(p.dropout.max, p.occlusion.max) / period) + 1
    gap = 0 if kind == "none" else int(rng.integers(1, longest + 1))
    start = settle + int(rng.integers(0, 20))  # the gap starts at the onset
    rules = tracker_rules(dc.replace(config, tracker=dc.replace(
        config.tracker, hidden_bodies=hidden_bodies, gate=False, max_coast_time=10.0)))
    tracks, worst, updates, t_good = np.zeros((rows, TRACK_SLOT)), 0.0, 0, -np.inf
    for k in range(frames):
        hidden = start <= k < start + gap
        if hidden and kind == "dropout":
            continue  # no frame at all
        tracks, _, _, t_good = frame_update(tracks, k * period, truth[k] + noise[k],
                                            np.full(rows, not hidden), rules=rules,
                                            t_good=t_good)
        if not hidden:  # a posterior: compare with the true position at capture time
            worst = max(worst, float(np.max(np.abs(tracks[:, :3] - truth[k]))))
            updates += 1
    assert updates == frames - gap
    assert worst <= alpha * n + beta * v_max
    assert worst > 0.5 * n  # the noise reached the estimate: the check is not vacuous


def test_speed_alteration_controllers_are_not_proved():
    proof = prove(dc.replace(ISO, type="erga"), SPACE)
    assert not proof.proved and not proof.premises[0][1]
    assert "speed override" in proof.premises[0][0]
