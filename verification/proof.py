"""Proof that the robot is at rest whenever a body is within the contact distance.

Theorem (what ``prove`` checks). Take the kinematic workcell with a configuration whose
human-speed term is ``iso`` or ``estimated_with_floor`` (so every S_i uses at least a
constant speed v), over a space whose scenarios satisfy its assumptions (bodies seen
before their onset, at most one gap in each body's measurements, per-axis sensor noise
below ``noise_bound_sigmas`` standard deviations, hand speed below v_max). Let

    M = v (T_s + T_r) - V_R T_r + B + C + Z_d + Z_r          (the configured S, lower bound)
        - E                                                  (tracker position error)
        - v_max (tau + T_stop + h)                           (human travel)
        - V_R h - D                                          (robot travel)
        - c                                                  (contact distance)

where T_s, T_r, B, C, Z_d, Z_r are the configuration's, tau its frame timeout, h the
control period, V_R the largest tool speed on the path, T_stop and D the longest time
and tool travel of a stop from full speed under the real brakes, and E a bound on the
distance between a tracked body and its estimate at the estimate's capture time. If
M >= 0 over the whole box, no scenario in it has a body within c of a moving tool.

Proof sketch. Suppose the tool moves at tick t_c with a body i within c. The path rate
only rises after a command k > 0, so there is a last tick t' <= t_c with k(t') > 0;
after it every command is 0, so the robot rests within T_stop of t' + h and
t_c - t' <= T_stop (one more tick h is allowed for rounding). At t' there was no
sensor fault, so the newest frame was captured at t_f >= t' - tau; no track was lost;
and body i had a usable track (it was seen before its onset and no track expires
within the space's gaps), so d_i(t') >= S_max >= S_i. Then
    d_true(t_c) >= d_i(t') - E - v_max (t_c - t_f) - |p_R(t_c) - p_R(t')|,
the tool travels at most V_R h in the tick after t' and D while braking, and
S_i >= v (T_s + T_r) - V_R T_r + B + C + Z_d + Z_r (the Eq. 5 speed towards the body is
at least -V_R; a coasting body's occlusion margin covers its extra error when
``occlusion_speed`` >= v_max). Together d_true(t_c) >= M + c >= c: a contradiction.

The bounds V_R, D, T_stop and E are computed here, soundly: V_R and D by a Lipschitz
covering of the path (grid values plus the largest change between grid points, from a
bound on the tool's acceleration); T_stop by running the braking model from full speed;
E by running the filter's deterministic gain recursion for every gap pattern the space
allows and propagating worst-case error and velocity bounds (linear in noise and v_max).
M is then checked over the continuous box of (v_max, noise) by z3 (unsatisfiability of
M < 0), with the robot bounds taken at the largest braking time scale (stopping time
and distance grow with it).
"""

import dataclasses
import math

import numba
import numpy as np
import z3

from safety_systems import kalman
from safety_systems.braking import braking_deceleration, path_rate_step
from safety_systems.compiled_cache import drop_stale_builds
from safety_systems.joint_path import JointPath, joint_path_state
from safety_systems.kalman import axis_predict, axis_update
from safety_systems.scenario import ControllerConfig
from safety_systems.tracks import MIN_MEASUREMENT_STD
from safety_systems.ur5e import DH_A, DH_D, tool0_position_and_velocity
from safety_systems.workcell import assumed_stopping, braking_table, frame_timeout, joint_path
from verification.space import ScenarioSpace

# Its compiled functions inline kalman's (see compiled_cache).
drop_stale_builds(__file__, (kalman,))

# Longest distance from any joint axis to the tool flange, bounded by the link lengths.
REACH_BOUND = sum(abs(a) for a in DH_A) + sum(DH_D[1:])
_MAX_BLEND_ACCEL = 10.0 / math.sqrt(3.0)  # max |h''| of the minimum-jerk blend
_MAX_BLEND_RATE = 1.875


@dataclasses.dataclass(frozen=True)
class RobotBounds:
    """Sound bounds on the robot's motion (see the module docstring)."""

    tool_speed: float  # V_R, m/s at nominal path speed
    stop_time: float  # T_stop, s
    stop_travel: float  # D, m
    grid_spacing: float  # s of path parameter between covering points


@dataclasses.dataclass(frozen=True)
class Proof:
    """The outcome of ``prove``: ``proved`` only if every premise holds and z3 showed
    M >= 0 over the box."""

    proved: bool
    method: str
    box: dict
    premises: list  # (statement, holds)
    margin_at_worst_corner: float | None
    terms: dict


def tool_acceleration_bound(path: JointPath) -> float:
    """Bound on |d2p/ds2| of the tool at nominal speed, m/s^2 (revolute chain: the sum of
    joint accelerations plus twice the squared sum of joint speeds, times the reach)."""
    d = np.abs(path.deltas)
    rate = (_MAX_BLEND_RATE * d / path.durations[:, None]).sum(axis=1)
    accel = (_MAX_BLEND_ACCEL * d / path.durations[:, None] ** 2).sum(axis=1)
    return float(REACH_BOUND * np.max(accel + 2.0 * rate**2))


def robot_bounds(path: JointPath, config: ControllerConfig, *, period: float,
                 braking_time_scale: float, cells: int = 20000) -> RobotBounds:
    """V_R, T_stop and D for ``path`` under the configured table scaled by
    ``braking_time_scale`` (see the module docstring)."""
    table = braking_table(config)
    delta = path.cycle_time / cells
    s = np.arange(cells + 1) * delta
    q, dq, _ = joint_path_state(dataclasses.replace(path, cycles=2), s)
    speed = np.linalg.norm(tool0_position_and_velocity(q, dq)[1], axis=-1)
    slack = tool_acceleration_bound(path) * delta / 2.0
    cell_bound = np.maximum(speed[:-1], speed[1:]) + slack  # |p'| on each cell
    # A stop from full speed, as the PathFollower runs it.
    rate, travelled, ticks = 1.0, 0.0, 0
    while rate > 0.0:
        new = float(path_rate_step(rate, 0.0, period, table=table, acceleration_limit=1.0,
                                   time_scale=braking_time_scale))
        travelled += 0.5 * (rate + new) * period
        rate, ticks = new, ticks + 1
    window = int(math.ceil((travelled + period) / delta)) + 1  # + the tick after t'
    arcs = np.convolve(np.tile(cell_bound, 2), np.ones(window), "valid")[:cells] * delta
    return RobotBounds(float(cell_bound.max()), ticks * period, float(arcs.max()), delta)


def braking_is_monotone(config: ControllerConfig, period: float, scale: float) -> bool:
    """One braking step preserves the order of path speeds (so a stop from a lower
    speed takes no longer and travels no farther than one from full speed)."""
    sigma = np.linspace(0.0, 1.0, 10001)
    after = np.maximum(sigma - braking_deceleration(braking_table(config), sigma)
                       / scale * period, 0.0)
    return bool(np.all(np.diff(after) >= -1e-15))


def estimate_error_coefficients(config: ControllerConfig, space: ScenarioSpace,
                                *, settle_frames: int = 60) -> tuple[float, float]:
    """(alpha, beta): per axis, |estimate - true position| <= alpha n + beta v_max at every
    update, for noise bound n and speed bound v_max, over every gap pattern the space
    allows (one run of g missing frames, as a dropout or an occlusion, after the track's
    first frames). The gains settle within ``settle_frames`` frames, so gaps starting
    later and frames after that add nothing new; the runs cover both."""
    period = 1.0 / config.sensor.rate_hz
    m_std = config.sensor.noise_std if config.tracker.measurement_std is None \
        else config.tracker.measurement_std
    R = max(m_std, MIN_MEASUREMENT_STD) ** 2
    q2, v0 = config.tracker.velocity_process_noise, config.tracker.initial_velocity_std
    p = space.parameters
    gap = int(math.ceil(max(p.dropout.max, p.occlusion.max) / period)) + 1
    settle = max(1, int(math.floor(space.settle_time / period)))
    alpha = beta = 0.0
    for g in range(0, gap + 1):
        for kind in ("dropout", "occlusion"):
            for start in range(settle, settle + settle_frames):
                a, b = _error_run(R, q2, v0, period, g, kind == "occlusion", start,
                                  start + g + settle_frames)
                alpha, beta = max(alpha, a), max(beta, b)
            if g == 0:
                break
    return alpha, beta


@numba.njit(cache=True)
def _error_run(R, q2, v0, period, gap, occlusion, start, horizon):
    """Worst error coefficients along one frame pattern (per axis; see above), compiled.

    One axis of the tracker's filter: covariance P = [[p, c], [c, w]] of (position,
    velocity), predicted and updated by ``kalman.axis_predict`` and ``axis_update`` (the
    tracker's own equations; gain (k_p, k_v) = P[:, 0] / (p + R)); E bounds the position
    error by E . (n, v_max), V the velocity estimate's magnitude the same way."""
    p, c, w = R, 0.0, v0 * v0  # after the first measurement: x = [z, 0]
    e_n, e_v = 1.0, 0.0  # error bound = E . (n, v_max)
    m_n, m_v = 0.0, 0.0  # |v estimate| bound (the body starts at rest)
    worst_n, worst_v = e_n, e_v
    j, pending = 1, 0.0
    while j < horizon:
        if start <= j < start + gap:
            if occlusion:  # coast: predict only
                p, c, w = axis_predict(p, c, w, period, q2)
                e_n, e_v = e_n + (m_n + 0.0) * period, e_v + (m_v + 1.0) * period
            else:
                pending += period  # dropout: no frame, no step
            j += 1
            continue
        dt = period + pending
        pending = 0.0
        p, c, w = axis_predict(p, c, w, dt, q2)
        prior_n, prior_v = e_n + (m_n + 0.0) * dt, e_v + (m_v + 1.0) * dt
        k_p, k_v, p, c, w = axis_update(p, c, w, R)
        m_n = abs(1.0 - k_v * dt) * m_n + abs(k_v) * (e_n + 1.0)
        m_v = abs(1.0 - k_v * dt) * m_v + abs(k_v) * (e_v + dt)
        e_n = (1.0 - k_p) * prior_n + k_p * 1.0
        e_v = (1.0 - k_p) * prior_v + k_p * 0.0
        worst_n, worst_v = max(worst_n, e_n), max(worst_v, e_v)
        j += 1
    return worst_n, worst_v


def prove(config: ControllerConfig, space: ScenarioSpace) -> Proof:
    """Tries to prove "stopped before contact" for ``config`` over ``space``."""
    f, p = config.safety, space.parameters
    robot = space.robot
    h = 1.0 / robot.control_rate_hz
    path = joint_path(robot)
    scale = p.braking_time_scale.max
    v = {"iso": min(f.iso_human_speed, f.iso_reduced_human_speed),
         "estimated_with_floor": f.iso_human_speed}.get(f.human_speed, 0.0)
    occl_ok = p.occlusion.max == 0.0 or (
        f.occlusion_speed >= p.peak_speed.max
        and p.occlusion.max + 1.0 / config.sensor.rate_hz <= config.tracker.max_coast_time)
    premises = [
        ("the controller is the SSM speed override (seed 000, Eq. 12)",
         config.type == "ssm_override"),
        ("the human-speed term is a constant floor (iso or estimated_with_floor)",
         f.human_speed in ("iso", "estimated_with_floor")),
        ("the robot is kinematic (joints follow the braked reference)",
         robot.mode == "kinematic"),
        ("every body is seen before its onset (settle time > frame timeout)",
         space.settle_time > frame_timeout(config)),
        ("occluded bodies are covered: none, or occlusion_speed >= v_max and no track "
         "expires during an occlusion", occl_ok),
        ("a braking step preserves the order of speeds",
         braking_is_monotone(config, h, scale)),
    ]
    box = {"peak_speed": [p.peak_speed.min, p.peak_speed.max],
           "noise_std": [p.noise_std.min, p.noise_std.max],
           "braking_time_scale": [p.braking_time_scale.min, p.braking_time_scale.max],
           "latency": [p.latency.min, p.latency.max], "dropout": [p.dropout.min, p.dropout.max],
           "occlusion": [p.occlusion.min, p.occlusion.max],
           "start_distance": [p.start_distance.min, p.start_distance.max],
           "acceleration": [p.acceleration.min, p.acceleration.max]}
    method = ("SSM stopping theorem (verification/proof.py); margin checked over the box "
              "by z3; robot bounds by Lipschitz covering; tracker error by gain recursion")
    if not all(ok for _, ok in premises):
        return Proof(False, method, box, premises, None, {})
    rb = robot_bounds(path, config, period=h, braking_time_scale=scale)
    alpha, beta = estimate_error_coefficients(config, space)
    t_s, b = assumed_stopping(config)
    tau = frame_timeout(config)
    fixed = (v * (t_s + f.reaction_time) - rb.tool_speed * f.reaction_time + b
             + f.intrusion_distance + f.human_uncertainty + f.robot_uncertainty
             - rb.tool_speed * h - rb.stop_travel - space.contact_distance)
    k_noise = math.sqrt(3.0) * alpha * space.noise_bound_sigmas
    k_speed = math.sqrt(3.0) * beta + tau + rb.stop_time + h

    def margin(v_max, noise):
        return fixed - k_noise * noise - k_speed * v_max

    vm, nz = z3.Reals("v_max noise")
    solver = z3.Solver()
    solver.add(vm >= p.peak_speed.min, vm <= p.peak_speed.max,
               nz >= p.noise_std.min, nz <= p.noise_std.max)
    solver.add(z3.RealVal(repr(fixed)) - z3.RealVal(repr(k_noise)) * nz
               - z3.RealVal(repr(k_speed)) * vm < 0)
    holds = solver.check() == z3.unsat
    worst = margin(p.peak_speed.max, p.noise_std.max)
    terms = {"v": v, "T_s": t_s, "T_r": f.reaction_time, "B": b, "tau": tau, "h": h,
             "V_R": rb.tool_speed, "T_stop": rb.stop_time, "D": rb.stop_travel,
             "E_per_axis": {"alpha": alpha, "beta": beta},
             "C+Z_d+Z_r": f.intrusion_distance + f.human_uncertainty + f.robot_uncertainty,
             "contact_distance": space.contact_distance}
    premises = premises + [("z3: M >= 0 for every (v_max, noise) in the box", holds)]
    return Proof(holds, method, box, premises, worst, terms)
