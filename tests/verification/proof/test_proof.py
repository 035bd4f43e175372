"""The stopping proof: its verdicts and premises, and its bounds checked against sampling
and simulation."""

import dataclasses as dc
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from safety_systems.cell.braking import BrakingTable, path_rate_step
from safety_systems.cell.joint_path import joint_path_state
from safety_systems.sensing.kalman import axis_predict, process_noise, transition_matrix
from safety_systems.cell.robot_geometry import capsule_ends
from safety_systems.cell.stopping import TRUTH_RATES, rate_index
from safety_systems.config.scenario import Box, BrakingConfig, load_controller_config
from safety_systems.sensing.tracks import TRACK_SLOT, frame_update
from safety_systems.config.configuration import joint_path
from safety_systems.config.resolved_cell import resolve
from safety_systems.ssm.formulas import SPEED_LEVELS, level_at_or_above
from verification.proof.tracking_error import ERROR_HORIZON, estimate_error_coefficients
from verification.proof.robot_bounds import (
    braking_is_monotone,
    capsule_reach,
    joint_rate_bounds,
    robot_acceleration_bound,
    robot_bounds,
    tool_acceleration_bound,
)
from verification.proof.margins import level_rate, margin, speed_levels
from verification.proof.premises import operators_reach
from verification.proof.theorems import prove, prove_separation
from verification.spaces.box import Range
from verification.spaces.space import load_space, space_cell

ROOT = Path(__file__).resolve().parents[3]
ISO = load_controller_config(ROOT / "models/configs/iso.yaml")
SEED = load_controller_config(ROOT / "models/configs/seed_estimated.yaml")
PREVIOUS = load_controller_config(ROOT / "models/configs/iso_previous.yaml")
# iso.yaml's terms for "stopped before contact" alone (without the Z_r the separation
# invariant asks for), where the contact margin is tight enough to break.
ISO_CONTACT = dc.replace(ISO, safety=dc.replace(ISO.safety, robot_uncertainty=0.0))
SPACE = load_space(ROOT / "models/spaces/default.yaml")
FLANGE = load_space(ROOT / "models/spaces/flange.yaml")
PATH = joint_path(SPACE.robot)
H = 1.0 / SPACE.robot.control_rate_hz


def _safety(config=ISO_CONTACT, **kw):
    return dc.replace(config, safety=dc.replace(config.safety, **kw))


def _tracker(config=ISO_CONTACT, **kw):
    return dc.replace(config, tracker=dc.replace(config.tracker, **kw))


def _space(space=SPACE, **ranges):
    return dc.replace(space, parameters=dc.replace(space.parameters, **ranges))


def _cell(config, space=SPACE):
    """What ``config`` means on the space's robot: the cell the proofs take."""
    return space_cell(config, space)


def _failed(proof):
    return [x.statement for x in proof.premises if not x.holds]


@pytest.fixture(scope="module")
def iso_proof():
    return prove(_cell(ISO), SPACE)


def test_iso_config_is_proved_over_the_whole_cell_space(iso_proof):
    assert iso_proof.proved and iso_proof.margin_at_worst_corner > 0.0
    assert all(x.holds for x in iso_proof.premises)
    bases = {x.basis for x in iso_proof.premises}
    assert bases == {"checked", "trusted"}
    assert iso_proof.premises[-1].statement.startswith("z3")
    # It states the robot mode it covers, and checks the space's is that one.
    assert iso_proof.robot_mode == "kinematic"
    assert any("robot.mode: kinematic" in x.statement for x in iso_proof.premises
               if x.basis == "checked")
    # The default stopping data is the placeholder, and the premises say so in words.
    assert iso_proof.placeholder_braking
    assert any("PLACEHOLDER" in x.statement for x in iso_proof.premises if x.basis == "trusted")
    # Over the previous envelope (the flange only) it is proved too.
    assert prove(_cell(ISO, FLANGE), FLANGE).proved


def test_margin_is_the_theorem_s_m_at_the_worst_corner(iso_proof):
    t, f, p = iso_proof.terms, ISO.safety, SPACE.parameters
    assert (t["T_s"], t["B"], t["T_r"]) == (0.54, 0.26, 0.20)
    assert t["tau"] == _cell(ISO).frame_timeout and t["h"] == H
    v_max = p.peak_speed.max
    m = (t["v"] * (t["T_s"] + t["T_r"]) - t["V_R"] * t["T_r"] + t["B"] + f.intrusion_distance
         + f.human_uncertainty + f.robot_uncertainty
         - v_max * (t["tau"] + t["T_stop"] + t["h"]) - t["V_R"] * t["h"] - t["D"]
         - SPACE.contact_distance)
    assert iso_proof.margin_at_worst_corner == pytest.approx(m, abs=1e-12)
    # The tracker's error E is not a term: the envelopes' allowance covers it (a premise).
    n = SPACE.noise_bound_sigmas * p.noise_std.max
    e = t["E_per_axis"]
    error = math.sqrt(3.0) * (e["alpha"] * n + e["beta"] * v_max)
    assert 0.0 < error <= t["tracking_allowance"] == ISO.body.tracking_allowance
    assert any(f"E {error:.4f} m" in x.statement for x in iso_proof.premises)


def test_seed_and_previous_configs_fail_on_their_premises():
    failed = _failed(prove(_cell(SEED), SPACE))
    assert any("human-speed" in s for s in failed)
    assert any("tool_point against capsules" in s for s in failed)
    assert any("hidden bodies stay hazards" in s for s in failed)
    failed = _failed(prove(_cell(PREVIOUS), SPACE))
    assert len(failed) == 3 and prove(_cell(PREVIOUS), SPACE).margin_at_worst_corner is None
    assert any("tool_point against capsules" in s for s in failed)
    assert any("hidden_bodies: expire" in s for s in failed)
    assert any("outlier frames all fall outside the gate" in s for s in failed)


NOT_PROVED = {  # name: (config, space, words of the failing premise or None: the margin)
    "no reaction time": (_safety(reaction_time=0.0), SPACE, None),
    "short stopping time": (_safety(stopping_time=0.3), SPACE, None),
    "short stopping distance": (_safety(stopping_distance=0.1), SPACE, None),
    "slow brakes": (ISO_CONTACT, _space(braking_time_scale=Range(1.0, 1.5)), None),
    "tracks expire": (_tracker(hidden_bodies="expire"), SPACE, "hidden bodies stay"),
    "slow ball": (_safety(occlusion_speed=1.5), SPACE, "hidden bodies stay"),
    "no gate": (_tracker(gate=False), SPACE, "outside the gate"),
    "outliers inside the gate": (ISO_CONTACT, _space(outlier_offset=Range(0.5, 2.0)),
                                 "outside the gate"),
    "gate too narrow": (_tracker(gate_width=0.001), SPACE, "pass the gate"),
    "capsules too small": (_safety(link_radii=[0.03] * 6), SPACE, "contains the one"),
    "payload too small": (_safety(payload_radius=0.04), SPACE, "contains the one"),
    "tool point against capsules": (_safety(robot_geometry="tool_point"), SPACE,
                                    "contains the one"),
    "dynamic robot": (ISO, dc.replace(SPACE, robot=dc.replace(SPACE.robot, mode="dynamic")),
                      "robot.mode: dynamic"),
    "exit within reach": (_tracker(exits=[Box([1.0, -1.0, -1.0], [2.0, 1.0, 2.0])]), SPACE,
                          "exit region"),
    "walls within reach": (_tracker(cell=Box([-3.0, -3.0, -1.0], [3.0, 3.0, 3.0])), SPACE,
                           "exit region"),
    # The whole operator: the monitor's body model must allow the space's postures, its
    # radii cover the measured segments', its allowance the tracker's error.
    "forearm shorter than a posture's": (dc.replace(ISO_CONTACT, body=dc.replace(
        ISO_CONTACT.body, forearm=0.30)), SPACE, "bodies the monitor's model allows"),
    "trunk lean below the leaning posture's": (dc.replace(ISO_CONTACT, body=dc.replace(
        ISO_CONTACT.body, trunk_lean_deg=30.0)), SPACE, "bodies the monitor's model allows"),
    "hands smaller than the measured": (dc.replace(ISO_CONTACT, body=dc.replace(
        ISO_CONTACT.body, hand_radius=0.05)), SPACE, "bodies the monitor's model allows"),
    "no tracking allowance": (dc.replace(ISO_CONTACT, body=dc.replace(
        ISO_CONTACT.body, tracking_allowance=0.0)), SPACE, "tracking allowance covers"),
}


@pytest.mark.parametrize("name", NOT_PROVED)
def test_broken_configs_are_not_proved(name):
    config, space, words = NOT_PROVED[name]
    proof = prove(_cell(config, space), space)
    assert not proof.proved
    if words is None:  # every premise but z3's holds; the margin is negative
        assert _failed(proof) == ["z3: M >= 0 for every v_max in the box"]
        assert proof.margin_at_worst_corner < 0.0
    else:
        assert len(_failed(proof)) == 1 and words in _failed(proof)[0]
        assert proof.margin_at_worst_corner is None


def test_what_is_not_a_fault_is_proved():
    # The tool point measured against the tool point (the previous envelope), exits and
    # walls far from every approach, no outliers without a gate.
    assert prove(_cell(_safety(robot_geometry="tool_point"), FLANGE), FLANGE).proved
    far = _tracker(exits=[Box([8.0, -1.0, -1.0], [9.0, 1.0, 2.0])],
                   cell=Box([-9.0, -9.0, -9.0], [9.0, 9.0, 9.0]))
    assert operators_reach(SPACE) < 8.0 and prove(_cell(far), SPACE).proved
    clean = _space(outlier_frames=Range(0.0, 0.0))
    assert prove(_cell(_tracker(gate=False), clean), clean).proved


def _longest_stop_travel(capsules, table, rate):
    """The longest path any capsule end travels in a stop from ``rate`` under ``table``,
    from 300 points of the cycle, stepped as the PathFollower steps it."""
    path = dc.replace(PATH, cycles=2)
    s = np.linspace(0.0, PATH.cycle_time, 300, endpoint=False)
    sigma, travelled = np.full(s.size, rate), np.zeros((s.size,) + capsules.radius.shape + (2,))
    ends = capsule_ends(joint_path_state(path, s)[0], capsules)[0]
    while np.any(sigma > 0.0):
        new = path_rate_step(sigma, 0.0, H, table=table, acceleration_limit=1.0)
        s = s + 0.5 * (sigma + new) * H
        sigma = new
        moved = capsule_ends(joint_path_state(path, s)[0], capsules)[0]
        travelled += np.linalg.norm(moved - ends, axis=-1)
        ends = moved
    return travelled.max()


@pytest.mark.parametrize("scale", [1.0, 2.0])
def test_robot_bounds_cover_every_capsule_point(scale):
    cell = resolve(ISO)
    rb = robot_bounds(PATH, cell, period=H, braking_time_scale=scale)
    capsules = cell.capsules
    # V_R: above every capsule end's speed sampled 10x more densely than the covering grid
    # (every axis point moves slower than the faster of its capsule's ends).
    s = np.linspace(0.0, PATH.cycle_time, 200_001)
    q, dq, _ = joint_path_state(PATH, s)
    speed = np.linalg.norm(capsule_ends(q, capsules, dq)[1], axis=-1).max(axis=(1, 2))
    assert speed.max() <= rb.tool_speed <= 1.05 * speed.max()
    # D: above the longest travel of any capsule end in a stop under brakes slowed by scale.
    table = cell.braking
    slowed = BrakingTable(table.speed_fraction, table.stopping_time * scale,
                          table.stopping_distance)
    travelled = _longest_stop_travel(capsules, slowed, 1.0)
    assert rb.stop_travel >= travelled > 0.5 * rb.stop_travel
    # T_stop: the ticks a stop from full speed takes, as the PathFollower steps it.
    rate, ticks = 1.0, 0
    while rate > 0.0:
        rate = float(path_rate_step(rate, 0.0, H, table=table, acceleration_limit=2.0,
                                    time_scale=scale))
        ticks += 1
    assert rb.stop_time == pytest.approx(ticks * H, abs=1e-12)
    assert scale * 0.53 <= rb.stop_time <= scale * 0.53 + H  # the table's 0.53 s, scaled


def test_a_longer_tool_moves_faster_and_farther():
    long_tool = _safety(tool_length=0.3)
    iso, long_cell = resolve(ISO), resolve(long_tool)
    short = robot_bounds(PATH, iso, period=H, braking_time_scale=1.0)
    longer = robot_bounds(PATH, long_cell, period=H, braking_time_scale=1.0)
    assert longer.tool_speed > short.tool_speed and longer.stop_travel > short.stop_travel
    assert capsule_reach(long_cell.capsules) > capsule_reach(iso.capsules)


def test_acceleration_bound_covers_finite_differences_of_every_capsule_end():
    capsules = resolve(_safety(tool_length=0.3)).capsules
    bound = tool_acceleration_bound(PATH, capsule_reach(capsules))
    step = 1e-4  # s of path parameter
    s = np.arange(0.0, PATH.cycle_time, step)
    q, dq, _ = joint_path_state(PATH, s)
    v = capsule_ends(q, capsules, dq)[1]
    # |dv|/ds over an interval is an average of |p''|, so it cannot exceed sup |p''|.
    accel = np.linalg.norm(np.diff(v, axis=0), axis=-1) / step
    assert 0.5 < accel.max() <= bound


EWASTE = load_space(ROOT / "models/spaces/ewaste.yaml")


def test_acceleration_bound_covers_a_spline_path():
    # The e-waste cell's planned task path (a SplinePath, there and back): the bound
    # covers every capsule end too, and each piece's joint rate sums cover their samples.
    path = joint_path(EWASTE.robot)
    capsules = resolve(ISO).capsules
    bound = tool_acceleration_bound(path, capsule_reach(capsules))
    step = 1e-4
    s = np.arange(0.0, path.cycle_time, step)
    q, dq, ddq = joint_path_state(path, s)
    v = capsule_ends(q, capsules, dq)[1]
    accel = np.linalg.norm(np.diff(v, axis=0), axis=-1) / step
    assert 0.1 < accel.max() <= bound
    rate, joint_accel = joint_rate_bounds(path)
    u = np.where(s > path.duration, 2.0 * path.duration - s, s)  # the way back mirrored
    piece = np.clip(np.searchsorted(path.spline.x, u, side="right") - 1, 0, len(rate) - 1)
    assert np.all(np.abs(dq).sum(axis=1) <= rate[piece] + 1e-9)
    assert np.all(np.abs(ddq).sum(axis=1) <= joint_accel[piece] + 1e-9)


def test_a_spline_path_cell_can_be_proved():
    assert prove(_cell(ISO, EWASTE), EWASTE).proved


def test_braking_is_monotone_for_the_default_table():
    assert ISO.braking.speed_fraction == []  # the default (UR5 placeholder) table
    for scale in (0.5, 1.0, 2.0):
        assert braking_is_monotone(resolve(ISO).braking, H, scale)
    # A table whose deceleration jumps within one tick's worth of speed is not.
    jumpy = dc.replace(ISO, braking=BrakingConfig(speed_fraction=[0.5, 1.0],
                                                  stopping_time=[10.0, 0.001],
                                                  stopping_distance=[0.1, 0.2]))
    assert not braking_is_monotone(resolve(jumpy).braking, H, 1.0)
    assert not prove(_cell(dc.replace(jumpy)), SPACE).proved


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


SETUPS = {  # the iso config, and a smoother, lagging filter
    "iso": ISO,
    "lagging": _tracker(measurement_std=0.01),
}


@pytest.fixture(scope="module", params=list(SETUPS))
def coefficients(request):
    config = SETUPS[request.param]
    alpha, beta, converged = estimate_error_coefficients(config)
    assert converged
    return config, (alpha, beta)


@pytest.mark.parametrize("gaps", ["none", "dropout", "occlusion", "many"])
@pytest.mark.parametrize("seed", range(3))
def test_tracker_error_stays_within_the_bound(coefficients, gaps, seed):
    # The tracker under the hazard rule (its filter restarts after every gap), gaps of any
    # length and number: at every accepted measurement the error is within the bound.
    config, (alpha, beta) = coefficients
    rng = np.random.default_rng(seed)
    period, p = 1.0 / config.sensor.rate_hz, SPACE.parameters
    v_max, n = p.peak_speed.max, SPACE.noise_bound_sigmas * p.noise_std.max
    settle, rows = int(round(SPACE.settle_time / period)), 64
    frames = settle + 120
    truth = _motions(rng, rows, frames, settle, period, v_max, p.acceleration.max)
    # Noise bounded by n per axis: uniform, or at the bound with a random sign.
    noise = n * np.where(rng.random((frames, rows, 1)) < 0.5,
                         rng.uniform(-1.0, 1.0, truth.shape), rng.choice([-1.0, 1.0], truth.shape))
    hidden = np.zeros((frames, rows), dtype=bool)
    dropped = np.zeros(frames, dtype=bool)
    start = settle + int(rng.integers(0, 20))
    if gaps == "dropout":
        dropped[start:start + int(rng.integers(1, 10))] = True
    elif gaps == "occlusion":
        hidden[start:start + int(rng.integers(1, 60))] = True  # up to 3 s
    elif gaps == "many":
        hidden[settle:] = rng.random((frames - settle, rows)) < 0.2
    rules = resolve(_tracker(config, gate=False)).tracker_rules
    tracks, worst, updates, t_good = np.zeros((rows, TRACK_SLOT)), 0.0, 0, -np.inf
    for k in range(frames):
        if dropped[k]:
            continue  # no frame at all
        tracks, _, _, t_good = frame_update(tracks, k * period, truth[k] + noise[k],
                                            ~hidden[k], rules=rules, t_good=t_good)
        seen = ~hidden[k]  # posteriors: compare with the true position at capture time
        if seen.any():
            worst = max(worst, float(np.max(np.abs(tracks[seen, :3] - truth[k, seen]))))
            updates += int(seen.sum())
    assert updates > 0
    assert worst <= alpha * n + beta * v_max
    assert worst > 0.5 * n  # the noise reached the estimate: the check is not vacuous


def test_error_recursion_converges_and_an_unconverged_one_is_not_proved():
    alpha, beta, converged = estimate_error_coefficients(ISO)
    assert converged and 1.0 <= alpha < 1.01 and 0.0 <= beta < 1e-3
    assert not estimate_error_coefficients(ISO, horizon=3)[2]
    assert ERROR_HORIZON >= 1000


def test_speed_alteration_controllers_are_not_proved():
    proof = prove(_cell(dc.replace(ISO, type="erga")), SPACE)
    assert not proof.proved and not proof.premises[0].holds
    assert "speed override" in proof.premises[0].statement


# --- the separation theorem -----------------------------------------------------------

def test_separation_margin_is_the_theorem_s_at_the_worst_corner():
    proof = prove_separation(_cell(ISO), SPACE)
    t, f, p = proof.terms, ISO.safety, SPACE.parameters
    assert proof.proved and proof.property == "separation"
    v_max = p.peak_speed.max
    m = (t["v_lo"] * (t["T_s"] + t["T_r"]) - t["v_hi"] * (t["T_stop"] + t["T_r"])
         - 2.0 * t["V_R"] * t["T_r"] + t["B"] - t["D"]
         + f.human_uncertainty + f.robot_uncertainty - v_max * t["tau"])
    assert proof.margin_at_worst_corner == pytest.approx(m, abs=1e-12)
    # C is on both sides (the monitor's S and S_true): it cannot buy the invariant.
    more_c = prove_separation(_cell(_safety(ISO, intrusion_distance=0.5)), SPACE)
    assert more_c.margin_at_worst_corner == pytest.approx(proof.margin_at_worst_corner,
                                                          abs=1e-12)


def test_a_floor_below_the_hands_speed_costs_the_difference():
    # estimated_with_floor at 1.0 m/s: the monitor may use 1.0, S_true the true 2.0 m/s.
    floor = _safety(ISO, human_speed="estimated_with_floor", iso_human_speed=1.0)
    proof = prove_separation(_cell(floor), SPACE)
    base = prove_separation(_cell(ISO), SPACE)
    t = proof.terms
    assert (t["v_lo"], t["v_hi"]) == (1.0, SPACE.parameters.peak_speed.max)
    assert not proof.proved
    expected = base.margin_at_worst_corner - (2.0 - 1.0) * (t["T_s"] + t["T_r"]) \
        - (2.0 - 2.0) * (t["T_stop"] + t["T_r"])
    assert proof.margin_at_worst_corner == pytest.approx(expected, abs=1e-12)
    assert proof.needed_allowance == pytest.approx(-expected, abs=1e-12)


@pytest.mark.parametrize("config, space, words", [
    (SEED, SPACE, "human-speed"),
    (_safety(ISO, robot_geometry="tool_point"), SPACE, "contains the one"),
    (_tracker(ISO, hidden_bodies="expire"), SPACE, "hidden bodies stay"),
    (_tracker(ISO, gate=False), SPACE, "outside the gate"),
], ids=["seed", "tool point", "expire", "no gate"])
def test_the_separation_proof_names_the_missing_premise(config, space, words):
    proof = prove_separation(_cell(config, space), space)
    assert not proof.proved and proof.needed_allowance is None
    assert any(words in s for s in _failed(proof))


@pytest.mark.parametrize("config, space", [
    (_safety(ISO, stopping_time=0.3), SPACE),
    (_safety(ISO, stopping_distance=0.05), SPACE),
    (ISO, _space(braking_time_scale=Range(1.0, 1.5))),
], ids=["short stopping time", "short stopping distance", "slow brakes"])
def test_the_separation_proof_fails_on_the_margin_when_a_term_is_short(config, space):
    proof = prove_separation(_cell(config, space), space)
    assert _failed(proof) == ["z3: M_S >= 0 for every v_max in the box"]
    assert proof.margin_at_worst_corner < 0.0 < proof.needed_allowance


def test_the_tightest_proved_configuration_breaks_the_invariant_in_no_simulation():
    # Soundness against the closed loop: iso.yaml with just the allowance its proof asks
    # for, over 1024 Sobol scenarios of the default space (most of them vacuous: its S
    # keeps the robot at rest while a body is near).
    from verification.search.evaluate_batch import evaluate_many
    from verification.search.strategies import sweep_points
    from verification.spaces.space import free_parameters, make_scenario, to_point

    needed = prove_separation(_cell(ISO_CONTACT), SPACE).needed_allowance
    tight = _safety(ISO_CONTACT, robot_uncertainty=needed + 1e-6)
    assert prove_separation(_cell(tight), SPACE).proved
    points = sweep_points("sobol", 1024, len(free_parameters(SPACE)), seed=5)
    result = evaluate_many([make_scenario(SPACE, tight, to_point(SPACE, u)) for u in points])
    assert np.isfinite(result.separation).sum() > 20  # the robot was let move near someone
    assert result.separation.min() >= 0.0


def test_the_fastest_point_robot_speed_needs_a_small_allowance():
    # S from the capsule's fastest point never credits a robot moving away: the robot
    # term of M_S shrinks from -2 V_R T_r to -a h T_r, and contact gains V_R T_r.
    fast = _safety(ISO_CONTACT, robot_speed="fastest_point")
    directed_sep = prove_separation(_cell(ISO_CONTACT), SPACE)
    fast_sep = prove_separation(_cell(fast), SPACE)
    t = fast_sep.terms
    assert fast_sep.terms["robot_speed_term"] == pytest.approx(
        -robot_acceleration_bound(PATH, _cell(fast), SPACE, t["V_R"]) * H * t["T_r"], abs=1e-15)
    assert 0.0 < fast_sep.needed_allowance < directed_sep.needed_allowance - 2 * t["V_R"] * t[
        "T_r"] + 0.05
    assert prove(_cell(fast), SPACE).margin_at_worst_corner == pytest.approx(
        prove(_cell(ISO_CONTACT), SPACE).margin_at_worst_corner + t["V_R"] * t["T_r"], abs=1e-12)
    tight = _safety(fast, robot_uncertainty=fast_sep.needed_allowance + 1e-6)
    assert prove_separation(_cell(tight), SPACE).proved and prove(_cell(tight), SPACE).proved
    # Soundness against the closed loop, over 1024 Sobol scenarios of the default space.
    from verification.search.evaluate_batch import evaluate_many
    from verification.search.strategies import sweep_points
    from verification.spaces.space import free_parameters, make_scenario, to_point

    points = sweep_points("sobol", 1024, len(free_parameters(SPACE)), seed=6)
    result = evaluate_many([make_scenario(SPACE, tight, to_point(SPACE, u)) for u in points])
    assert np.isfinite(result.separation).sum() > 50
    assert result.separation.min() >= 0.0 and result.robustness.min() >= 0.0


# --- safety.stopping: by_speed (one margin per speed level) ----------------------------

# iso.yaml with S from the stop at the robot's speed, the robot's fastest point in S, a
# shorter T_r, no C, and the least round Z_r that proves both theorems on the default
# space (the separation theorem asks for 0.1779 m, at level 43 of 64: every level's T_s
# keeps the configured 0.01 s over the stopping data, so the levels' margins are within
# a centimetre of each other).
BY_SPEED = _safety(ISO, stopping="by_speed", robot_speed="fastest_point", reaction_time=0.1,
                   intrusion_distance=0.0, robot_uncertainty=0.18)
BY_SPEED_DIRECTED = _safety(BY_SPEED, robot_speed="directed", robot_uncertainty=0.40)
SEPARATION_Z3 = f"z3: M_S(g) >= 0 at every speed level g = 1..{SPEED_LEVELS}"


def _worst_corner(space=SPACE):
    return space.parameters.peak_speed.max, space.parameters.noise_std.max


def test_by_speed_proves_both_theorems_and_names_the_least_level():
    for proof in (prove(_cell(BY_SPEED), SPACE), prove_separation(_cell(BY_SPEED), SPACE)):
        assert proof.proved and all(x.holds for x in proof.premises)
        t = proof.terms
        assert t["stopping"] == "by_speed" and len(t["level_margins"]) == SPEED_LEVELS
        assert min(t["level_margins"].values()) == proof.margin_at_worst_corner >= 0.0
        assert t["level_margins"][str(t["speed_level"])] == proof.margin_at_worst_corner
        assert f"least at level {t['speed_level']}," in proof.premises[-1].statement
        assert any("S by speed" in x.statement for x in proof.premises)
    sep = prove_separation(_cell(BY_SPEED), SPACE)
    assert sep.needed_allowance == 0.0 and sep.margin_at_worst_corner < 0.01
    assert 1 < sep.terms["speed_level"] < SPEED_LEVELS  # neither end is the tightest here


def test_by_speed_fails_at_a_named_level_when_z_r_or_t_s_is_short():
    short = prove_separation(_cell(_safety(BY_SPEED, robot_uncertainty=0.15)), SPACE)
    assert not short.proved and len(_failed(short)) == 1
    level = short.terms["speed_level"]
    assert short.terms["level_margins"][str(level)] == min(short.terms["level_margins"].values())
    assert _failed(short)[0].startswith(SEPARATION_Z3 + " for every v_max in the "
                                        f"box (least at level {level},")
    assert short.margin_at_worst_corner < 0.0
    assert short.needed_allowance == pytest.approx(-short.margin_at_worst_corner, abs=1e-15)
    # needed_allowance is what makes the least level prove, and no less.
    z = 0.15 + short.needed_allowance
    assert prove_separation(_cell(_safety(BY_SPEED, robot_uncertainty=z + 1e-9)), SPACE).proved
    assert not prove_separation(_cell(_safety(BY_SPEED, robot_uncertainty=z - 1e-6)), SPACE).proved
    # A short T_s costs most where the robot is fastest: contact fails at full speed.
    fast = prove(_cell(_safety(BY_SPEED, stopping_time=0.3)), SPACE)
    assert not fast.proved and fast.terms["speed_level"] == SPEED_LEVELS
    assert fast.terms["level_margins"]["1"] > 0.0 > fast.margin_at_worst_corner
    assert f"least at level {SPEED_LEVELS}," in _failed(fast)[0]


def test_low_levels_can_fail_where_the_full_speed_stop_proves():
    # The levels below full speed are checked, not only the full-speed one: with the
    # monitor's T_s at level 1 a little short (here in a cell whose stops by level are
    # changed there), the full-speed S still proves, S by speed fails at level 1 only,
    # and says so.
    cell = _cell(BY_SPEED)
    t_s, b = cell.level_stops
    t_s = t_s.copy()
    t_s[1] -= 0.02
    proof = prove_separation(dc.replace(cell, level_stops=(t_s, b)), SPACE)
    rows = proof.terms["level_margins"]
    assert not proof.proved and rows["1"] < 0.0 < min(v for g, v in rows.items() if g != "1")
    assert proof.terms["speed_level"] == 1 and "least at level 1," in _failed(proof)[0]


@pytest.mark.parametrize("config", [BY_SPEED, BY_SPEED_DIRECTED], ids=["fastest", "directed"])
def test_the_top_level_is_the_full_speed_margin(config):
    full = _safety(config, stopping="full_speed")
    for prover in (prove, prove_separation):
        by_level, at_full = prover(_cell(config), SPACE), prover(_cell(full), SPACE)
        assert by_level.terms["level_margins"][str(SPEED_LEVELS)] == pytest.approx(
            at_full.margin_at_worst_corner, abs=1e-12)
    lv, one = speed_levels(_cell(config), SPACE), speed_levels(_cell(full), SPACE)
    assert (lv.rate[-1], lv.previous_rate[-1], lv.t_s[-1], lv.b[-1]) == (1.0, 1.0, 0.54, 0.26)
    assert (lv.stop_time[-1], lv.stop_travel[-1]) == (one.stop_time[0], one.stop_travel[0])
    assert one.level.size == 1 and not one.by_speed


@pytest.mark.parametrize("config", [BY_SPEED, BY_SPEED_DIRECTED], ids=["fastest", "directed"])
def test_each_level_s_margin_is_the_theorem_s(config):
    # Every level's margin from its own terms: the monitor's T_s(sigma_g) and B(sigma_g),
    # the stop commanded at rho_g (its ticks counted here), the robot's speed scaled by
    # the level's rate (and by the tick before's where the monitor differences it).
    f, p = config.safety, SPACE.parameters
    cell = _cell(config)
    lv = speed_levels(cell, SPACE)
    t_s, b = cell.level_stops
    np.testing.assert_array_equal(lv.t_s, t_s[1:])
    np.testing.assert_array_equal(lv.b, b[1:])
    assert np.all(np.diff(lv.rate) > 0.0) and lv.rate[0] < 0.1
    table = cell.braking
    for rate, stop_time in zip(lv.rate, lv.stop_time):
        sigma, ticks = rate, 0
        while sigma > 0.0:
            sigma = float(path_rate_step(sigma, 0.0, H, table=table, acceleration_limit=2.0,
                                         time_scale=p.braking_time_scale.max))
            ticks += 1
        assert stop_time == pytest.approx(ticks * H, abs=1e-12)
    drop = float(np.max(table.deceleration)) / p.braking_time_scale.min * H
    previous = np.minimum(1.0, lv.rate + drop)
    np.testing.assert_allclose(lv.previous_rate, previous, rtol=0, atol=1e-15)
    v_max = _worst_corner()[0]
    v_r, tau = lv.tool_speed, cell.frame_timeout
    fastest = f.robot_speed == "fastest_point"
    low = 0.0 if fastest else -v_r * previous
    contact = (2.0 * (lv.t_s + f.reaction_time) + low * f.reaction_time + lv.b
               + f.human_uncertainty + f.robot_uncertainty
               - v_max * (tau + lv.stop_time + H) - v_r * lv.rate * H - lv.stop_travel)
    np.testing.assert_allclose(margin(cell, SPACE, "contact").rows_at(v_max), contact,
                               rtol=0, atol=1e-12)
    if fastest:
        gap = -np.array([robot_acceleration_bound(PATH, cell, SPACE, v_r, rate=r)
                         for r in previous]) * H
        a = tool_acceleration_bound(PATH, capsule_reach(cell.capsules))
        np.testing.assert_allclose(gap, -(a * previous**2 + v_r * max(
            SPACE.robot.acceleration_limit, float(np.max(table.deceleration)))) * H,
            rtol=1e-12)
    else:
        gap = -v_r * (lv.rate + previous)
    separation = (2.0 * (lv.t_s + f.reaction_time) - 2.0 * (lv.stop_time + f.reaction_time)
                  + gap * f.reaction_time + lv.b - lv.stop_travel + f.human_uncertainty
                  + f.robot_uncertainty - v_max * tau)
    np.testing.assert_allclose(margin(cell, SPACE, "separation").rows_at(v_max),
                               separation, rtol=0, atol=1e-12)


@pytest.mark.parametrize("rate", [0.3, 0.0625 + 1e-11])
def test_robot_bounds_cover_a_stop_from_below_full_speed(rate):
    cell = resolve(ISO)
    rb = robot_bounds(PATH, cell, period=H, braking_time_scale=1.0, rate=rate)
    full = robot_bounds(PATH, cell, period=H, braking_time_scale=1.0)
    travelled = _longest_stop_travel(cell.capsules, cell.braking, rate)
    assert rb.stop_travel >= travelled > 0.3 * rb.stop_travel
    assert rb.stop_travel < full.stop_travel and rb.stop_time < full.stop_time
    assert rb.tool_speed == full.tool_speed


@settings(max_examples=300, deadline=None)
@given(st.integers(0, SPEED_LEVELS), st.floats(-3e-9, 3e-9), st.floats(0.0, 1.0))
def test_level_rate_bounds_every_rate_of_its_level(g, nudge, anywhere):
    # rho_g is at least every path rate the override counts as level g (near the levels'
    # boundaries too, where the rules' rounding tolerance decides) and the grid rate
    # S_true takes its stop from for it.
    for rate in (min(max(g / SPEED_LEVELS + nudge, 0.0), 1.0), anywhere):
        level = int(level_at_or_above(rate, SPEED_LEVELS))
        if level == 0:
            continue
        bound = level_rate(level)
        assert rate <= bound and rate_index(rate) / TRUTH_RATES <= bound <= 1.0
        assert bound < (level + 1) / SPEED_LEVELS
        # and no looser than the rounding asks: S_true's grid rate for a level-g rate is
        # g / G itself (the two rules round alike), not the grid rate above it.
        assert bound <= level / SPEED_LEVELS + 2e-9


def test_the_tightest_by_speed_configuration_breaks_neither_property_in_simulation():
    # Soundness against the closed loop (the by-speed override, S_true from the stop at
    # the true rate): BY_SPEED with just the allowance its proof asks for, over 1024 Sobol
    # scenarios of the default space.
    from verification.search.evaluate_batch import evaluate_many
    from verification.search.strategies import sweep_points
    from verification.spaces.space import free_parameters, make_scenario, to_point

    bare = _safety(BY_SPEED, robot_uncertainty=0.0)
    needed = prove_separation(_cell(bare), SPACE).needed_allowance
    assert 0.17 < needed < 0.18
    tight = _safety(bare, robot_uncertainty=needed + 1e-6)
    assert prove_separation(_cell(tight), SPACE).proved and prove(_cell(tight), SPACE).proved
    points = sweep_points("sobol", 1024, len(free_parameters(SPACE)), seed=6)
    result = evaluate_many([make_scenario(SPACE, tight, to_point(SPACE, u)) for u in points])
    assert np.isfinite(result.separation).sum() > 500  # let move near someone, often
    assert result.separation.min() >= 0.0 and result.robustness.min() >= 0.0


def test_the_stopping_data_premise_says_what_the_spaces_time_scale_means():
    """A space that does not scale the stops says so, not "times within 1 to 1 of it"."""
    def premise(space):
        (found,) = [p.statement for p in prove(_cell(ISO, space), space).premises
                    if p.statement.startswith("the stopping data describes")]
        return found

    assert "their times the data's own (the space does not scale them)" in premise(SPACE)
    scaled = dc.replace(SPACE, parameters=dc.replace(
        SPACE.parameters, braking_time_scale=Range(0.9, 1.2)))
    assert "their times 0.9 to 1.2 times the data's" in premise(scaled)
    assert "1 to 1" not in premise(SPACE)
