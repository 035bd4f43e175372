"""Proofs that the robot is at rest whenever a body is within the contact distance of it,
and that it never moves with a body inside the protective distance of the true speeds.

Theorem 1 (what ``prove`` checks). Take the kinematic workcell (``robot.mode: kinematic``,
a checked premise: the theorem covers no other mode, ``Proof.robot_mode`` says which)
with the SSM speed override, a configuration whose human-speed term is a constant floor
v (``iso`` or ``estimated_with_floor``), whose monitor measures capsules containing the
property's (``configuration.monitor_capsules`` against ``contact_capsules``), whose
tracker keeps hidden bodies as balls growing at ``occlusion_speed`` >= v_max until they
are seen leaving (``hidden_bodies: hazard``, ``safety_systems.sensing.tracks``), and a space whose
scenarios satisfy the premises ``prove`` lists (each marked *checked*, against this
model, or *trusted*, taken from the files). Let

    M = v (T_s + T_r) + r_low T_r + B + C + Z_d + Z_r        (the configured S, lower bound)
        - E                                                  (tracker position error)
        - v_max (tau + T_stop + h)                           (human travel)
        - V_R h - D                                          (robot travel)
        - c                                                  (contact distance)

where T_s, T_r, B, C, Z_d, Z_r are the configuration's, tau its frame timeout, h the
control period, V_R the largest speed of any point of the monitor's capsule axes on
the path, r_low the least the monitor's robot speed term can be (-V_R for Eq. 7's
directed speed, 0 for ``robot_speed: fastest_point``), T_stop the longest stop from full
speed under the real brakes and D the longest travel of any capsule axis point in it
(plus one tick), and E a bound on the distance between a tracked body and its estimate
at the estimate's capture time. If
M >= 0 over the whole box, no scenario in it has a body within c of any capsule of the
moving robot, whatever the occlusions (of any length, of any bodies), dropped frames,
and outlier or corrupted frames.

Proof sketch. Suppose the robot moves at tick t_c with body i within c of capsule j.
The path rate only rises after a command k > 0, so there is a last tick t' <= t_c with
k(t') > 0; after it every command is 0, so the robot rests within T_stop of t' + h and
t_c - t' <= T_stop + h. At t' there was no fault: the newest good frame was captured at
t_f >= t' - tau, and it was clean (a rejected entry: a bad time, an unknown id, a
non-finite position or one outside the gate, stops the robot until a clean frame). Body
i had a usable track: it was seen before its onset and a track ends only where a body
leaves the cell, which the space's bodies never do. So d_i(t') >= S_max >= S_ij(t'),
with d_i the clearance from the estimate x (tracking) or the ball around it (hidden;
radius occlusion_speed (t_f - t_seen)) to the monitor's capsule j. The true position at
t_f lies within E + v_max (t_f - t_seen) of x: E bounds the error at the last accepted
measurement (the filter restarts after every gap, so E is the error of a track seen in
consecutive frames since its start, by the gain recursion, with every accepted frame
within the noise bound: frames inside the gate are trusted to be, and the space's
outliers are checked to fall outside it), and the ball covers the rest. Then
    clearance_ij(t_c) >= d_i(t') - E - v_max (t_c - t_f) - (V_R h + D),
the real capsules being inside the monitor's (a larger radius, a longer axis) and the
robot's axis points moving at most V_R h in the tick after t' and D while braking, and
S_ij >= v (T_s + T_r) + r_low T_r + B + C + Z_d + Z_r (Eq. 5's speed of any axis point
towards the body is at least -V_R). Together clearance_ij(t_c) >= M + c >= c.

Theorem 2 (what ``prove_separation`` checks): the separation invariant
(``verification.properties``): at every tick t where the override's k > 0, every body
i and every capsule j of the real robot have clearance_ij(t) >= S_true_ij(t), seed Eqs.
9-11 on the true directed speeds with T_r and C, and the simulated robot's stopping
time T* and distance B* (``safety_systems.cell.stopping``), without Z_d and Z_r. Under the
premises of Theorem 1 but the ordering of braking speeds (S_true uses the full-speed
stop), let

    M_S = v_lo (T_s + T_r) - v_hi (T_stop + T_r)     (the human terms)
          + g T_r                                   (the robot speed terms)
          + B - D + Z_d + Z_r                       (stopping distance, allowances)
          - E - v_max tau                           (what the monitor does not see)

with v_lo the monitor's least human speed (the 1.6 m/s rule's lower speed, or the
floor), v_hi the most S_true can use (the larger iso speed, or max(v_max, floor)), and
g = -2 V_R for the directed robot speed (the monitor's capsule point may move away from
the estimate at V_R while the true body's moves towards it at V_R) or -a h for
``fastest_point`` (the monitor's speed is the capsule's fastest end by Eq. 5, its ends
differenced over the last tick, at most a h short of the instant's speed of any of its
axis points, a: ``robot_acceleration_bound``). If M_S >= 0 over the box, the invariant
holds in every scenario of it. C cancels (it is in both S), so only Z_d + Z_r can buy
the margin; ``Proof.needed_allowance`` says how much is missing.

Proof sketch. At a tick t with k(t) > 0 there is no fault, the newest good frame is
at most tau old, every body's track is usable, and the closest d_i exceeds S_max. The
monitor's robot is the true robot at t (the same joint state). As in Theorem 1 the true
position is within E + v_max (t - t_f) of the estimate beyond its ball, so
clearance_ij(t) >= d_i(t) - E - v_max tau > S_max - E - v_max tau. S_max is at least
v_lo (T_s + T_r) + r T_r + B + C + Z_d + Z_r with r the monitor's robot speed term, and
S_true_ij at most v_hi (T* + T_r) + r* T_r + B* + C with T* <= T_stop, B* <= D and r*
the true directed speed: r* - r <= -g. So clearance_ij(t) - S_true_ij(t) > M_S >= 0.

Speed levels (``safety.stopping: by_speed``, ISO/TS 15066's S_s from the robot's
current speed). The override commands one of the levels sigma_g = g / G (G =
``ssm.SPEED_LEVELS``) by ``ssm.by_speed_command``; the monitor computes each body's S at
every level with T_s(sigma_g) and B(sigma_g) (``configuration.level_stops``), and
S_true takes T* and B* from the simulated robot's stop from its true rate at the tick
(``cell.stopping.stops_by_rate``: the grid rate at or above it). Both theorems then
hold with one margin per level g = 1..G, each checked over the box (one z3 query, the
levels' conditions in a disjunction); the proof reports the least, and at which level
(``Proof.terms``: ``speed_level``, ``level_margins``). Let rho_g (:func:`level_rate`)
bound every rate the override counts as level g or below and the grid rate S_true
takes for such a rate (g / G but for the rules' rounding), and rho'_g = min(1, rho_g +
a_b h) every rate over the tick before (a_b: the table's fastest deceleration at the
space's shortest braking time scale; the rate falls at most a_b h in a tick). Then

    M_g = v (T_s(sigma_g) + T_r) + r_g T_r + B(sigma_g) + C + Z_d + Z_r
          - E - v_max (tau + T_stop(rho_g) + h) - V_R rho_g h - D(rho_g) - c

    M_S,g = v_lo (T_s(sigma_g) + T_r) - v_hi (T_stop(rho_g) + T_r) + g_g T_r
            + B(sigma_g) - D(rho_g) + Z_d + Z_r - E - v_max tau

with T_stop(rho) and D(rho) the stop commanded at path rate rho (D over a path
window of that stop plus one tick at rho), r_g = -V_R rho'_g (directed) or 0
(fastest_point), and g_g = -V_R (rho_g + rho'_g) (directed) or -a(rho'_g) h
(fastest_point, a(rho) = |d2p/ds2| rho^2 + V_R |d sigma/dt|). At g = G every term is
the full-speed one (rho = rho' = 1, T_s(1) = T_s, B(1) = B): M_G = M and M_S,G = M_S.
Z_d + Z_r adds to every level's margin alike, so ``needed_allowance`` is the least
level's shortfall.

Proof sketch (what changes). Whenever k(t) > 0 the override found d(t) >= S_max(g_now)
(g_now the level at or above the rate now) and d(t) >= dS S_max(g_k) with k = g_k / G,
g_k >= 1 (the level 0 never permits motion, though g_now may be 0). So d(t) >=
S_max(g') with g' = max(g_now, g_k) in 1..G (for dS > 1 this needs S_max(g_k) >= 0: a
checked premise, the monitor's least S at any level is not negative). The rate now is
at most rho_{g'}, and so is k; one tick moves the rate from the rate now towards k
without passing it (``braking.rate_step_one``), so sigma(t + h) <= rho_{g'}.
Theorem 1: at the last tick t' with k > 0 before t_c the rate left is at most
rho_{g'}; every later command is 0, and a stop from a lower rate takes no longer and
travels no farther (a braking step preserves the order of rates: checked), so t_c - t'
<= T_stop(rho_{g'}) + h and the capsule axes travel at most V_R rho_{g'} h +
D(rho_{g'}) after t'. The monitor's capsule velocities at t' are differenced over the
tick before, at rates up to rho'_{g'}, so its directed robot term is at least -V_R
rho'_{g'}. The rest is as above, with the level's terms: clearance_ij(t_c) >= M_{g'} +
c. Theorem 2: at a tick t with k(t) > 0, S_true takes the stop from the grid rate at
or above sigma(t), at most rho_{g'}: T* <= T_stop(rho_{g'}) and B* <= D(rho_{g'})
(stops grow with the rate, checked there too); S_true's robot term is at most V_R
sigma(t) <= V_R rho_{g'}, the monitor's at least -V_R rho'_{g'} (directed), or within
a(rho'_{g'}) h of the instant's speed of any axis point (fastest_point). The rest is as
above: clearance_ij(t) - S_true_ij(t) > M_S,{g'}. As g' is one of 1..G, every level's
margin >= 0 proves the theorem.

The bounds V_R, D, T_stop and E are computed here, soundly: V_R and D by a Lipschitz
covering of the path (grid values of every capsule end's speed, whose maximum bounds
every axis point's, plus the largest change between grid points, from a bound on a
rigid point's acceleration); T_stop by running the braking model from full speed; E by
running the filter's deterministic gain recursion from a new track until it converges
and propagating worst-case error and velocity bounds (linear in noise and v_max). M is
then checked over the continuous box of (v_max, noise) by z3 (unsatisfiability of
M < 0, and of M_S < 0), with the robot bounds taken at the largest braking time scale
(stopping time and distance grow with it).

A space built around a recording (``verification.recording_space``) is declined: the
margins are checked over scripted approaches' parameters only (:func:`_declined` lists
what a proof over recorded motion would need, measured from the recording).
"""

import dataclasses
import math

import numba
import numpy as np
import z3

from safety_systems.cell.braking import braking_deceleration
from safety_systems.config.configuration import contact_capsules, monitor_capsules
from safety_systems.cell.joint_path import JointPath, SplinePath, joint_path_state
from safety_systems.sensing.kalman import axis_predict, axis_update
from safety_systems.cell.robot_geometry import Capsules, capsule_ends
from safety_systems.config.scenario import ControllerConfig
from safety_systems.cell.stopping import rate_index, stop_from, TRUTH_RATES
from safety_systems.sensing.tracks import MIN_MEASUREMENT_STD
from safety_systems.cell.ur5e import DH_A, DH_D
from safety_systems.config.configuration import (
    assumed_stopping,
    braking_table,
    frame_timeout,
    joint_path,
    level_stops,
    placeholder_braking,
)
from safety_systems.ssm.formulas import SPEED_LEVELS, level_at_or_above
from verification.space import (
    HEAD_BACK,
    HEAD_UP,
    OTHER_HAND_OFFSET,
    ScenarioSpace,
    parameter_ranges,
)


# Longest distance from any joint axis to the tool flange, bounded by the link lengths.
REACH_BOUND = sum(abs(a) for a in DH_A) + sum(DH_D[1:])
_MAX_BLEND_ACCEL = 10.0 / math.sqrt(3.0)  # max |h''| of the minimum-jerk blend
_MAX_BLEND_RATE = 1.875
ERROR_HORIZON = 4000  # frames of the tracker's error recursion
CONVERGED = 1e-12  # m per unit of noise or speed: the recursion's last frames change less
COVERED_MODE = "kinematic"  # the theorem's robot follows its braked reference exactly


@dataclasses.dataclass(frozen=True)
class Premise:
    """One premise of the theorem: ``basis`` is ``checked`` (by ``prove``, against this
    model, the configuration and the space) or ``trusted`` (taken from the files and the
    real cell; ``holds`` is then what the files say, not a finding)."""

    statement: str
    holds: bool
    basis: str


@dataclasses.dataclass(frozen=True)
class RobotBounds:
    """Sound bounds on the robot's motion (see the module docstring)."""

    tool_speed: float  # V_R, m/s at nominal path speed: the fastest capsule axis point
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
    premises: list  # Premise records
    margin_at_worst_corner: float | None
    terms: dict
    placeholder_braking: bool = False  # the built-in stopping data, not measured data
    property: str = "contact"  # the theorem: "contact" or "separation"
    # separation: how much larger Z_d + Z_r must be for M_S >= 0 over the box (0 when it
    # is; None when a premise fails)
    needed_allowance: float | None = None
    robot_mode: str = COVERED_MODE  # the robot mode the theorem covers


def joint_rate_bounds(path: JointPath | SplinePath) -> tuple[np.ndarray, np.ndarray]:
    """Per piece of the path, bounds on the sum over the joints of |dq/ds| and of
    |d2q/ds2| at nominal speed (rad/s, rad/s^2). A JointPath's segments are minimum-jerk
    blends (their peak rate and acceleration per unit of travel are constants); a
    SplinePath's pieces are cubics: q'' is linear on a piece (its largest size at an
    end) and q' quadratic (at an end or at its vertex). Running a spline backwards flips
    the signs only."""
    if isinstance(path, SplinePath):
        c, breaks = path.spline.c, path.spline.x  # c (4, pieces, 6): c0 x^3 + ... + c3
        h = np.diff(breaks)[:, None]
        accel = np.maximum(np.abs(2.0 * c[1]), np.abs(6.0 * c[0] * h + 2.0 * c[1]))
        rate = np.maximum(np.abs(c[2]), np.abs(3.0 * c[0] * h * h + 2.0 * c[1] * h + c[2]))
        with np.errstate(divide="ignore", invalid="ignore"):
            vertex = np.where(c[0] != 0.0, -c[1] / (3.0 * c[0]), -1.0)
        inside = (vertex > 0.0) & (vertex < h)
        rate = np.maximum(rate, np.where(inside, np.abs(c[2] - c[1] ** 2 / (3.0 * np.where(
            c[0] != 0.0, c[0], 1.0))), 0.0))
        return rate.sum(axis=1), accel.sum(axis=1)
    d = np.abs(path.deltas)
    return ((_MAX_BLEND_RATE * d / path.durations[:, None]).sum(axis=1),
            (_MAX_BLEND_ACCEL * d / path.durations[:, None] ** 2).sum(axis=1))


def tool_acceleration_bound(path: JointPath | SplinePath, reach: float = REACH_BOUND) -> float:
    """Bound on |d2p/ds2| at nominal speed of a rigid point of the arm within ``reach``
    of every joint axis, m/s^2 (revolute chain: the sum of joint accelerations plus twice
    the squared sum of joint speeds, times the reach; :func:`joint_rate_bounds`)."""
    rate, accel = joint_rate_bounds(path)
    return float(reach * np.max(accel + 2.0 * rate**2))


def capsule_reach(capsules: Capsules) -> float:
    """A bound on any capsule end's distance from any joint axis, m: the link lengths,
    the tool, and the longest extension of a link's axis past its joints."""
    lengths = np.hypot(np.r_[DH_A, 0.0], np.r_[DH_D, capsules.tool_length])  # P_k -> P_k+1
    length = lengths[np.minimum(capsules.a, 6)]
    overhang = np.maximum(np.maximum(-capsules.t0, capsules.t1 - 1.0), 0.0) * length
    return REACH_BOUND + capsules.tool_length + float(np.max(overhang, initial=0.0))


def robot_bounds(path: JointPath, config: ControllerConfig, *, period: float,
                 braking_time_scale: float, capsules: Capsules | None = None,
                 cells: int = 20000, rate: float = 1.0) -> RobotBounds:
    """V_R, T_stop and D for ``path`` under the configured table scaled by
    ``braking_time_scale``, over the axis ends of ``capsules`` (None: the configuration's
    monitor capsules; see the module docstring), the stop commanded at path rate
    ``rate`` (1: from full speed) and D over the tick before it at that rate."""
    return robot_bounds_by_rate(path, config, period=period,
                                braking_time_scale=braking_time_scale, capsules=capsules,
                                cells=cells, rates=(rate,))[0]


def robot_bounds_by_rate(path: JointPath, config: ControllerConfig, *, period: float,
                         braking_time_scale: float, rates, capsules: Capsules | None = None,
                         cells: int = 20000) -> list[RobotBounds]:
    """:func:`robot_bounds` at each path rate of ``rates``, the path covered once: V_R (at
    nominal rate, the same for all), T_stop the ticks of a stop commanded at the rate (as
    the PathFollower runs it) and D the largest travel of any capsule axis point over a
    window of path parameter as long as that stop's plus one tick at the rate."""
    capsules = monitor_capsules(config) if capsules is None else capsules
    table = braking_table(config)
    delta = path.cycle_time / cells
    s = np.arange(cells + 1) * delta
    q, dq, _ = joint_path_state(dataclasses.replace(path, cycles=2), s)
    _, end_v = capsule_ends(q, capsules, dq)
    speed = np.linalg.norm(end_v, axis=-1).reshape(len(s), -1).max(axis=1)
    slack = tool_acceleration_bound(path, capsule_reach(capsules)) * delta / 2.0
    cell_bound = np.maximum(speed[:-1], speed[1:]) + slack  # |p'| on each cell, any end
    tiled = np.tile(cell_bound, 2)
    out = []
    for rate in rates:
        # A stop commanded at ``rate``, as the PathFollower runs it.
        stop_time, travelled = stop_from(float(rate), table, braking_time_scale, period)
        window = int(math.ceil((travelled + rate * period) / delta)) + 1  # + the tick after t'
        arcs = np.convolve(tiled, np.ones(window), "valid")[:cells] * delta
        out.append(RobotBounds(float(cell_bound.max()), stop_time, float(arcs.max()), delta))
    return out


def robot_acceleration_bound(path: JointPath | SplinePath, config: ControllerConfig,
                             space: ScenarioSpace, tool_speed: float, *,
                             rate: float = 1.0) -> float:
    """A bound (m/s^2) on the acceleration of any point of the monitor's capsule axes:
    |d2p/ds2| sigma^2 + |dp/ds| |d sigma/dt| with sigma <= ``rate`` and the path rate changing
    no faster than the robot's acceleration limit or the brakes' fastest deceleration
    (at the space's shortest braking time scale); ``tool_speed`` bounds |dp/ds|."""
    capsules = monitor_capsules(config)
    rate_change = max(space.robot.acceleration_limit,
                      float(np.max(braking_table(config).deceleration))
                      / space.parameters.braking_time_scale.min)
    return (tool_acceleration_bound(path, capsule_reach(capsules)) * rate * rate
            + tool_speed * rate_change)


def braking_is_monotone(config: ControllerConfig, period: float, scale: float) -> bool:
    """One braking step preserves the order of path speeds (so a stop from a lower
    speed takes no longer and travels no farther than one from full speed)."""
    sigma = np.linspace(0.0, 1.0, 10001)
    after = np.maximum(sigma - braking_deceleration(braking_table(config), sigma)
                       / scale * period, 0.0)
    return bool(np.all(np.diff(after) >= -1e-15))


@numba.njit(cache=True)
def _error_run(R, q2, v0, period, horizon, out):
    """The error coefficients after each frame of a new track seen in consecutive frames
    (per axis; ``out`` (horizon, 2): E . (n, v_max) bounds |estimate - true position| at
    that frame's capture time, for noise bounded by n and speed by v_max), compiled.

    One axis of the tracker's filter: covariance P = [[p, c], [c, w]] of (position,
    velocity), predicted and updated by ``kalman.axis_predict`` and ``axis_update`` (the
    tracker's own equations; gain (k_p, k_v) = P[:, 0] / (p + R)). With error e and
    velocity estimate m bounded by E . (n, v_max) and M . (n, v_max): the prior error is
    at most e + (m + v_max) dt (the body moves at most v_max dt), the posterior
    (1 - k_p) prior + k_p n (the measurement is within n), and the new velocity estimate
    |1 - k_v dt| m + |k_v| (e + v_max dt + n)."""
    p, c, w = R, 0.0, v0 * v0  # after the first measurement: x = [z, 0]
    e_n, e_v = 1.0, 0.0
    m_n, m_v = 0.0, 0.0
    out[0, 0], out[0, 1] = e_n, e_v
    dt = period
    for j in range(1, horizon):
        p, c, w = axis_predict(p, c, w, dt, q2)
        prior_n, prior_v = e_n + m_n * dt, e_v + (m_v + 1.0) * dt
        k_p, k_v, p, c, w = axis_update(p, c, w, R)
        m_n = abs(1.0 - k_v * dt) * m_n + abs(k_v) * (e_n + 1.0)
        m_v = abs(1.0 - k_v * dt) * m_v + abs(k_v) * (e_v + dt)
        e_n = (1.0 - k_p) * prior_n + k_p * 1.0
        e_v = (1.0 - k_p) * prior_v + k_p * 0.0
        out[j, 0], out[j, 1] = e_n, e_v


def estimate_error_coefficients(config: ControllerConfig, horizon: int = ERROR_HORIZON
                                ) -> tuple[float, float, bool]:
    """(alpha, beta, converged): per axis, |estimate - true position| <= alpha n +
    beta v_max at every accepted measurement, for noise bound n and speed bound v_max.

    Under ``hidden_bodies: hazard`` a track's filter restarts after every gap (an
    occlusion, a rejected entry, a dropped or bad frame: ``safety_systems.sensing.tracks``), so
    every accepted measurement is the j-th of a run of consecutive frames since a new
    track, and the bound is the largest over j of :func:`_error_run`. It is taken over
    ``horizon`` frames; ``converged`` says the coefficients' last tenth changed by less
    than ``CONVERGED`` (the gains and the linear recursion have reached their fixed
    point, so later frames add nothing)."""
    period = 1.0 / config.sensor.rate_hz
    m_std = config.sensor.noise_std if config.tracker.measurement_std is None \
        else config.tracker.measurement_std
    R = max(m_std, MIN_MEASUREMENT_STD) ** 2
    out = np.empty((horizon, 2))
    _error_run(R, config.tracker.velocity_process_noise, config.tracker.initial_velocity_std,
               period, horizon, out)
    tail = out[horizon - max(horizon // 10, 2):]
    converged = bool(horizon >= 20 and np.all(np.ptp(tail, axis=0) < CONVERGED))
    alpha, beta = out.max(axis=0)
    return float(alpha), float(beta), converged


def operators_reach(space: ScenarioSpace) -> float:
    """A bound on how far from the robot base any body of the space's scenarios gets, m:
    the farthest point of the robot, then the start distance, a retreat and the body's
    offset from the hand (a recording space's: ``recording_space.recorded_reach``)."""
    if space.recording is not None:
        from verification.recording_space import recorded_reach

        return recorded_reach(space)
    p = space.parameters
    robot = REACH_BOUND + DH_D[0] + space.robot.tool_length
    body = max(OTHER_HAND_OFFSET, math.hypot(HEAD_BACK, HEAD_UP))
    return robot + p.start_distance.max + p.retreat_distance.max + p.overshoot.max + body


def _tracks_never_end(config: ControllerConfig, space: ScenarioSpace) -> bool:
    """No body of the space comes into an exit region or beyond the cell's walls (where
    its track would end): every region lies beyond ``operators_reach`` of the base."""
    reach, t = operators_reach(space), config.tracker

    def inside_ball(box) -> bool:  # the box meets the ball of radius reach about the base
        nearest = np.clip(0.0, box.min, box.max)
        return float(np.linalg.norm(nearest)) <= reach

    walls_far = t.cell is None or (np.all(np.array(t.cell.min) <= -reach)
                                   and np.all(np.array(t.cell.max) >= reach))
    return bool(walls_far and not any(inside_ball(box) for box in t.exits))


def _monitor_covers_contact(config: ControllerConfig, space: ScenarioSpace) -> bool:
    """The monitor's robot contains the property's: capsules against capsules (same axes,
    radii and tool at least as large), capsules against the tool point (the flange lies on
    the tool capsule's axis), or the tool point against the tool point."""
    f, robot = config.safety, space.robot
    if space.contact_geometry == "tool_point":
        return True
    if f.robot_geometry == "tool_point":
        return False
    mine = monitor_capsules(config)
    real = contact_capsules(robot, space.contact_geometry)
    return bool(np.all(mine.radius >= real.radius) and mine.tool_length >= real.tool_length)


def least_level_separation(config: ControllerConfig, space: ScenarioSpace) -> float:
    """The least the monitor's S can be at any speed level g = 1..G (m): its human term
    at the least human speed, its robot term at the least it can be there
    (:func:`robot_speed_low`), B(g) + C + Z_d + Z_r (Z_d at its base)."""
    f = config.safety
    lv = speed_levels(config, space)
    v = {"iso": min(f.iso_human_speed, f.iso_reduced_human_speed),
         "estimated_with_floor": f.iso_human_speed}.get(f.human_speed, 0.0)
    s = (v * (lv.t_s + f.reaction_time) + robot_speed_low(config, lv) * f.reaction_time
         + lv.b + f.intrusion_distance + f.human_uncertainty + f.robot_uncertainty)
    return float(s.min())


def _setting(config: ControllerConfig, space: ScenarioSpace, prop: str):
    """What both theorems share: the box's extremes, the tracker's error coefficients and
    the premises, checked and trusted (``prop``: ``contact`` or ``separation``, which
    needs no ordering of braking speeds and no contact distance)."""
    f, t, p = config.safety, config.tracker, space.parameters
    h = 1.0 / space.robot.control_rate_hz
    period = 1.0 / config.sensor.rate_hz
    scale = p.braking_time_scale.max
    v_max, noise = p.peak_speed.max, space.noise_bound_sigmas * p.noise_std.max
    alpha, beta, converged = estimate_error_coefficients(config)
    e_worst = math.sqrt(3.0) * (alpha * noise + beta * v_max)  # m, Euclidean
    outliers = p.outlier_frames.max >= 1
    gate_widest = ((t.gate_speed + v_max) * p.outlier_frames.max * period + t.gate_width
                   + f.human_uncertainty + e_worst + math.sqrt(3.0) * noise)
    placeholder = placeholder_braking(config)
    checked = _model_premises(config, space) + [
        (f"hidden bodies stay hazards: tracks end only where bodies leave "
         f"(hidden_bodies: {t.hidden_bodies}) and a hidden body's ball grows at least as "
         f"fast as a hand (occlusion_speed {f.occlusion_speed:g} >= v_max {v_max:g} m/s)",
         t.hidden_bodies == "hazard" and f.occlusion_speed >= v_max),
        ("no body of the space reaches an exit region or the cell's walls (where its track "
         f"would end): all within {operators_reach(space):.2f} m of the base",
         _tracks_never_end(config, space)),
        (f"frames within the noise bound pass the gate (gate_speed {t.gate_speed:g} >= "
         f"v_max and gate_width {t.gate_width:g} m >= E + sqrt(3) noise "
         f"{e_worst + math.sqrt(3.0) * noise:.4f} m)",
         not t.gate or (t.gate_speed >= v_max
                        and t.gate_width >= e_worst + math.sqrt(3.0) * noise)),
        ((f"the space's outlier frames all fall outside the gate: offset "
          f"{p.outlier_offset.min:g} m > the widest gate an outlier of a run of "
          f"{int(p.outlier_frames.max)} frames can meet, {gate_widest:.3f} m")
         if outliers else "the space has no outlier frames",
         not outliers or (t.gate and p.outlier_offset.min > gate_widest)),
        ("every body is seen before its onset (settle time > frame timeout)",
         space.settle_time > frame_timeout(config)),
    ]
    by_speed = f.stopping == "by_speed"
    if prop == "contact" or by_speed:
        checked.append(("a braking step preserves the order of speeds"
                        + (" (so a stop from a lower speed level takes no longer and travels "
                           "no farther)" if by_speed else ""),
                        braking_is_monotone(config, h, scale)))
    if by_speed:
        least = least_level_separation(config, space)
        checked.append((f"d >= dS S_max(g) gives d >= S_max(g) at every speed level: dS = 1 "
                        f"or the monitor's S is never negative (dS {f.delta_s:g}; the least S "
                        f"at any level {least:.4f} m)", f.delta_s == 1.0 or least >= 0.0))
    checked.append((f"the tracker's error recursion converged within {ERROR_HORIZON} frames",
                    converged))
    trusted = [
        ("the stopping data describes the real robot's stops"
         + (" from every speed (S by speed uses its rows below full speed)"
            if by_speed else "") + ", times within "
         f"{p.braking_time_scale.min:g} to {scale:g} of it"
         + (" (THE BUILT-IN PLACEHOLDER DERIVED FROM UR5/CB3 DATA, NOT MEASURED ON THIS "
            "CELL)" if placeholder else " (the configuration's braking table)")),
        f"no hand or head moves faster than v_max = {v_max:g} m/s (ISO 13855: 2.0 m/s)",
        f"sensor noise stays below {space.noise_bound_sigmas:g} sigma per axis "
        f"({noise:g} m) in every frame the gate accepts: no marker swap or reflection "
        "passes it",
        "the real robot follows its braked reference as exactly as the kinematic model "
        "does (its tracking error is not covered)",
        "the UR5e model's capsules contain the real arm (they contain its collision "
        "geometry: tests/test_robot_geometry.py), the tool fits its payload capsule and "
        "every body fits its sphere",
        "bodies come into the cell only through its exits and are tracked before they "
        "come near the robot (the space's operators stand still for the settle time)",
    ]
    premises = ([Premise(x, bool(ok), "checked") for x, ok in checked]
                + [Premise(x, True, "trusted") for x in trusted])
    box = {"peak_speed": [p.peak_speed.min, p.peak_speed.max],
           "noise_std": [p.noise_std.min, p.noise_std.max],
           "braking_time_scale": [p.braking_time_scale.min, p.braking_time_scale.max],
           "latency": [p.latency.min, p.latency.max], "dropout": [p.dropout.min, p.dropout.max],
           "occlusion": [p.occlusion.min, p.occlusion.max],
           "outlier_frames": [p.outlier_frames.min, p.outlier_frames.max],
           "start_distance": [p.start_distance.min, p.start_distance.max],
           "acceleration": [p.acceleration.min, p.acceleration.max]}
    return premises, box, placeholder, (alpha, beta), scale


def _model_premises(config: ControllerConfig, space: ScenarioSpace) -> list[tuple]:
    """The premises on the controller and the robot that both theorems share, as
    (statement, holds) pairs."""
    f = config.safety
    return [
        ("the controller is the SSM speed override (seed 000, Eq. 12)"
         if f.stopping != "by_speed" else
         f"the controller is the SSM speed override with S by speed (ssm.by_speed_command: "
         f"{SPEED_LEVELS} levels, S from the stop at the level of the rate now and of the "
         "command)", config.type == "ssm_override"),
        (f"the space's robot is in {COVERED_MODE} mode, the one this theorem covers "
         f"(robot.mode: {space.robot.mode}; a dynamic robot's tracking error is not in "
         "the margin)", space.robot.mode == COVERED_MODE),
        ("the human-speed term is a constant floor (iso or estimated_with_floor)",
         f.human_speed in ("iso", "estimated_with_floor")),
        ("the monitor's robot contains the one contact is measured against "
         f"({f.robot_geometry} against {space.contact_geometry})",
         _monitor_covers_contact(config, space)),
    ]


def _declined(config: ControllerConfig, space: ScenarioSpace, prop: str, method: str
              ) -> Proof:
    """A recording space's proof, declined: the theorems' margins are checked over the
    box of a scripted space's parameters, where the peak speed bounds every body's
    speed and every body is seen standing still for the settle time before it moves.
    Recorded motion has neither parameter. The premises a proof over it would need (the
    speed bound, every body seen from the start, no exit reached) are measured from the
    recording and listed, but no margin is checked over it, so the verdict over a
    recording space is ``passed`` or ``falsified``, never ``proved``."""
    from verification.recording_space import recorded_speed, tracked_from_start

    f, t = config.safety, config.tracker
    p = space.recording.parameters
    v_max = recorded_speed(space.recording) * p.time_scale.max
    checked = _model_premises(config, space) + [
        (f"hidden bodies stay hazards (hidden_bodies: {t.hidden_bodies}) and a hidden "
         f"body's ball grows at least as fast as the recorded bodies move (occlusion_speed "
         f"{f.occlusion_speed:g} >= {v_max:.3f} m/s: the recording's fastest segment at the "
         f"largest time scale, {p.time_scale.max:g})",
         t.hidden_bodies == "hazard" and f.occlusion_speed >= v_max),
        (f"the gate admits the recorded bodies' speeds (gate_speed {t.gate_speed:g} >= "
         f"{v_max:.3f} m/s)", not t.gate or t.gate_speed >= v_max),
        ("every body is tracked from t = 0 at every point of the box (seen before the "
         "robot first moves)", tracked_from_start(space)),
        ("no body reaches an exit region or the cell's walls (where its track would end): "
         f"all within {operators_reach(space):.2f} m of the base",
         _tracks_never_end(config, space)),
        ("the operators are the scripted approaches the theorem's margin is checked over "
         "(a speed bound from their peak speed, every body seen standing still before it "
         "moves): a recording space's operators move as recorded, and no margin is "
         "checked over recorded motion, so this space is searched, never proved", False),
    ]
    trusted = [
        "the recording is the operators' true motion, linear between its samples, and "
        "the mapping puts it in the cell frame",
        "the stopping data describes the real robot's stops, times within "
        f"{p.braking_time_scale.min:g} to {p.braking_time_scale.max:g} of it",
    ]
    premises = ([Premise(x, bool(ok), "checked") for x, ok in checked]
                + [Premise(x, True, "trusted") for x in trusted])
    box = {name: [r.min, r.max] for name, r in parameter_ranges(space).items()}
    return Proof(False, method, box, premises, None, {}, placeholder_braking(config), prop)


def _unsat_below_zero(m: "Margin", space: ScenarioSpace) -> bool:
    """z3: some row of ``m`` (a speed level) is below 0 somewhere in the space's
    (v_max, noise) box has no solution: one query, the rows' conditions in a
    disjunction (:class:`Margin`: fixed - k_noise noise - k_speed v_max - v_true(v_max)
    t_true per row)."""
    p = space.parameters
    vm, nz = z3.Reals("v_max noise")
    solver = z3.Solver()
    solver.add(vm >= p.peak_speed.min, vm <= p.peak_speed.max,
               nz >= p.noise_std.min, nz <= p.noise_std.max)
    if m.floor:
        top = z3.If(vm > z3.RealVal(repr(m.v_true)), vm, z3.RealVal(repr(m.v_true)))
    else:
        top = z3.RealVal(repr(float(m.v_true)))
    below = []
    for fixed, k_speed, t_true in zip(m.fixed, m.k_speed, m.t_true):
        row = (z3.RealVal(repr(float(fixed))) - z3.RealVal(repr(float(m.k_noise))) * nz
               - z3.RealVal(repr(float(k_speed))) * vm)
        if t_true != 0.0:
            row = row - top * z3.RealVal(repr(float(t_true)))
        below.append(row < 0)
    solver.add(z3.Or(*below))
    return solver.check() == z3.unsat


@dataclasses.dataclass(frozen=True)
class Levels:
    """The speeds the theorems take the robot's stop from, one row each: under
    ``safety.stopping: full_speed`` one row, the stop from full speed with the
    configuration's T_s and B; under ``by_speed`` one per speed level g = 1..G (the level
    g' = max(g_now, g_k) whose S the override checked whenever k > 0, see the module
    docstring), the monitor's T_s(sigma_g) and B(sigma_g) (``configuration.level_stops``)
    and the robot bounds of a stop commanded at ``rate`` (:func:`level_rate`)."""

    level: np.ndarray  # g of each row (full_speed: G alone)
    rate: np.ndarray  # rho_g: no path rate until the next decision exceeds it
    previous_rate: np.ndarray  # no path rate over the tick before the decision exceeds it
    t_s: np.ndarray  # s, the monitor's T_s at the level
    b: np.ndarray  # m, the monitor's B at the level
    stop_time: np.ndarray  # s, T_stop(rho_g)
    stop_travel: np.ndarray  # m, D(rho_g)
    tool_speed: float  # V_R at nominal path rate
    by_speed: bool


def level_rate(g: int, levels: int = SPEED_LEVELS) -> float:
    """rho_g: a bound on every path rate the override counts as level g or below
    (``ssm.formulas.level_at_or_above``), and on the grid rate S_true takes the simulated
    robot's stop from for such a rate (``cell.stopping.rate_index``): the largest float
    rate r with level_at_or_above(r) <= g, found by bisection on the rule itself (both
    rules are non-decreasing in the rate, so every rate of level g or below is at most
    r, and its grid index at most rate_index(r)), raised to that grid rate if it is
    higher; 1 for g = G. Interpretation: the rules' rounding tolerance (1e-9 in units of
    their own step) lets a level cover rates a hair above g / G; the bound keeps them."""
    if g >= levels:
        return 1.0
    lo, hi = g / levels, (g + 1) / levels
    if not (level_at_or_above(lo, levels) <= g < level_at_or_above(hi, levels)):
        raise ValueError(f"level_at_or_above does not put {lo!r} at level {g} or below and "
                         f"{hi!r} above it")
    while True:
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if level_at_or_above(mid, levels) <= g:
            lo = mid
        else:
            hi = mid
    return min(1.0, max(lo, rate_index(lo) / TRUTH_RATES))


def speed_levels(config: ControllerConfig, space: ScenarioSpace) -> Levels:
    """The :class:`Levels` of ``config`` on ``space``'s robot, the stops at the space's
    largest braking time scale (they grow with it). The rate over the tick before a
    decision exceeds the rate at it by at most one braking step, the table's fastest
    deceleration over the space's shortest braking time scale times the period."""
    f, p = config.safety, space.parameters
    h = 1.0 / space.robot.control_rate_hz
    if f.stopping == "by_speed":
        level = np.arange(1, SPEED_LEVELS + 1)
        rate = np.array([level_rate(int(g)) for g in level])
        drop = float(np.max(braking_table(config).deceleration)) \
            / p.braking_time_scale.min * h
        previous = np.minimum(1.0, rate + drop)
        t_all, b_all = level_stops(config)
        t_s, b = np.asarray(t_all[1:], dtype=float), np.asarray(b_all[1:], dtype=float)
    else:
        level, rate, previous = np.array([SPEED_LEVELS]), np.ones(1), np.ones(1)
        t_s, b = (np.array([float(x)]) for x in assumed_stopping(config))
    bounds = robot_bounds_by_rate(joint_path(space.robot), config, period=h,
                                  braking_time_scale=p.braking_time_scale.max, rates=rate)
    return Levels(level, rate, previous, t_s, b, np.array([x.stop_time for x in bounds]),
                  np.array([x.stop_travel for x in bounds]), bounds[0].tool_speed,
                  f.stopping == "by_speed")


@dataclasses.dataclass(frozen=True)
class Margin:
    """A theorem's margin as a function of the hand speed bound v_max and the noise, one
    row per speed level (:class:`Levels`; one row under ``full_speed``):
    M_g(v_max, noise) = fixed_g - k_noise noise - k_speed_g v_max - v_true(v_max) t_true_g,
    with v_true(v_max) the human speed of S_true (separation only: max(v_max, floor)
    under ``estimated_with_floor``, the constant ``v_true`` otherwise; 0 for contact).
    The margin is the least row. ``prove`` and ``prove_separation`` check every row over
    the box; the falsifier's cheapest ranking evaluates it pointwise
    (``verification.ranking.bound_scores``)."""

    fixed: np.ndarray
    k_noise: float
    k_speed: np.ndarray
    t_true: np.ndarray
    v_true: float = 0.0
    floor: bool = False  # v_true(v_max) = max(v_max, v_true)
    level: np.ndarray = dataclasses.field(default_factory=lambda: np.array([SPEED_LEVELS]))

    def human_speed(self, v_max):
        return np.maximum(v_max, self.v_true) if self.floor else self.v_true

    def rows_at(self, v_max, noise) -> np.ndarray:
        """M_g at (v_max, noise) (numbers or arrays of one shape), each row (level) along
        a new last axis."""
        v = np.asarray(v_max, dtype=float)[..., None]
        n = np.asarray(noise, dtype=float)[..., None]
        return (self.fixed - self.k_noise * n - self.k_speed * v
                - self.human_speed(v) * self.t_true)

    def at(self, v_max, noise):
        """M at (v_max, noise) (numbers or arrays of one shape): the least row's."""
        return self.rows_at(v_max, noise).min(axis=-1)


def margin(config: ControllerConfig, space: ScenarioSpace, prop: str = "contact") -> Margin:
    """The margin of the ``prop`` theorem (``contact`` or ``separation``, see the
    module docstring) for ``config`` on ``space``'s robot and sensor bounds, whether or
    not its premises hold (without them it bounds nothing; it still orders scenarios by
    how close their hand speed and noise come to breaking it)."""
    return _margin(config, space, prop, speed_levels(config, space))


def _margin(config: ControllerConfig, space: ScenarioSpace, prop: str, lv: Levels) -> Margin:
    f = config.safety
    h = 1.0 / space.robot.control_rate_hz
    alpha, beta, _ = estimate_error_coefficients(config)
    tau = frame_timeout(config)
    k_noise = math.sqrt(3.0) * alpha * space.noise_bound_sigmas
    if prop == "contact":
        v = {"iso": min(f.iso_human_speed, f.iso_reduced_human_speed),
             "estimated_with_floor": f.iso_human_speed}.get(f.human_speed, 0.0)
        fixed = (v * (lv.t_s + f.reaction_time) + robot_speed_low(config, lv) * f.reaction_time
                 + lv.b + f.intrusion_distance + f.human_uncertainty + f.robot_uncertainty
                 - lv.tool_speed * lv.rate * h - lv.stop_travel - space.contact_distance)
        return Margin(fixed, k_noise, math.sqrt(3.0) * beta + tau + lv.stop_time + h,
                      np.zeros(lv.level.size), level=lv.level)
    if prop != "separation":
        raise ValueError(f"prop: got {prop!r}; allowed: contact | separation")
    floor = f.human_speed == "estimated_with_floor"
    v_lo = f.iso_human_speed if floor else min(f.iso_human_speed, f.iso_reduced_human_speed)
    fixed = (v_lo * (lv.t_s + f.reaction_time)
             + robot_speed_gap(config, space, lv) * f.reaction_time
             + lv.b - lv.stop_travel + f.human_uncertainty + f.robot_uncertainty)
    v_true = f.iso_human_speed if floor else max(f.iso_human_speed, f.iso_reduced_human_speed)
    return Margin(fixed, k_noise, np.full(lv.level.size, math.sqrt(3.0) * beta + tau),
                  lv.stop_time + f.reaction_time, v_true, floor, lv.level)


def robot_speed_low(config: ControllerConfig, lv: Levels) -> np.ndarray:
    """The least the monitor's robot speed term can be at each level, m/s: -V_R times the
    fastest rate over the tick its capsule velocities are differenced over for Eq. 7's
    directed speed (a robot moving away lowers S), 0 for ``fastest_point`` (a speed)."""
    if config.safety.robot_speed == "fastest_point":
        return np.zeros(lv.level.size)
    return -lv.tool_speed * lv.previous_rate


def robot_speed_gap(config: ControllerConfig, space: ScenarioSpace, lv: Levels) -> np.ndarray:
    """How far (m/s, negative) the monitor's robot speed term can fall short of S_true's
    at each level: directed, V_R (rho_g + the tick before's rate) (the monitor's capsule
    point may move away from the estimate while S_true's moves towards the body);
    fastest_point, a h (the monitor's speed is the capsule's fastest end by Eq. 5, its
    ends differenced over the last tick, at most a h short of the instant's, a:
    :func:`robot_acceleration_bound` at the tick's fastest rate; no axis point moves
    faster)."""
    if config.safety.robot_speed == "fastest_point":
        h = 1.0 / space.robot.control_rate_hz
        path = joint_path(space.robot)
        return np.array([-robot_acceleration_bound(path, config, space, lv.tool_speed,
                                                   rate=float(r)) * h
                         for r in lv.previous_rate])
    return -lv.tool_speed * (lv.rate + lv.previous_rate)


def _worst(m: Margin, space: ScenarioSpace) -> tuple[float, int]:
    """The margin at the box's worst corner (the largest v_max and noise: every row falls
    in both) and the row it is least in."""
    p = space.parameters
    rows = m.rows_at(p.peak_speed.max, p.noise_std.max)
    i = int(np.argmin(rows))
    return float(rows[i]), i


def _z3_premise(name: str, lv: Levels, holds: bool, worst: float, i: int
                ) -> Premise:
    if not lv.by_speed:
        return Premise(f"z3: {name} >= 0 for every (v_max, noise) in the box", holds, "checked")
    return Premise(f"z3: {name}(g) >= 0 at every speed level g = 1..{SPEED_LEVELS} for every "
                   f"(v_max, noise) in the box (least at level {int(lv.level[i])}, rate "
                   f"{lv.rate[i]:.4f}: {worst:.4f} m at the worst corner)", holds, "checked")


def _level_terms(lv: Levels, m: Margin, space: ScenarioSpace, i: int) -> dict:
    """The terms that say which speed level the margin is least at (by_speed)."""
    f = {"stopping": "by_speed" if lv.by_speed else "full_speed"}
    if lv.by_speed:
        p = space.parameters
        rows = m.rows_at(p.peak_speed.max, p.noise_std.max)
        f |= {"speed_level": int(lv.level[i]), "level_rate": float(lv.rate[i]),
              "previous_rate": float(lv.previous_rate[i]),
              "level_margins": {str(int(g)): float(x) for g, x in zip(lv.level, rows)}}
    return f


def _method(theorem: str, stopping: str) -> str:
    """The ``method`` a proof of ``theorem`` (``stopping`` or ``separation``) states."""
    return (f"SSM {theorem} theorem over the robot's capsules (verification.proof); "
            "margin checked over the box by z3"
            + (", at every speed level" if stopping == "by_speed" else "")
            + "; robot bounds by Lipschitz covering; tracker error by gain recursion")


def prove(config: ControllerConfig, space: ScenarioSpace) -> Proof:
    """Tries to prove "stopped before contact" for ``config`` over ``space`` (under
    ``safety.stopping: by_speed`` at every speed level)."""
    f = config.safety
    h = 1.0 / space.robot.control_rate_hz
    v = {"iso": min(f.iso_human_speed, f.iso_reduced_human_speed),
         "estimated_with_floor": f.iso_human_speed}.get(f.human_speed, 0.0)
    method = _method("stopping", f.stopping)
    if space.recording is not None:
        return _declined(config, space, "contact", method)
    premises, box, placeholder, (alpha, beta), _ = _setting(config, space, "contact")
    if not all(x.holds for x in premises):
        return Proof(False, method, box, premises, None, {}, placeholder)
    lv = speed_levels(config, space)
    tau = frame_timeout(config)
    m = _margin(config, space, "contact", lv)
    holds = _unsat_below_zero(m, space)
    worst, i = _worst(m, space)
    terms = {"v": v, "T_s": float(lv.t_s[i]), "T_r": f.reaction_time, "B": float(lv.b[i]),
             "tau": tau, "h": h, "V_R": lv.tool_speed, "robot_speed": f.robot_speed,
             "T_stop": float(lv.stop_time[i]), "D": float(lv.stop_travel[i]),
             "E_per_axis": {"alpha": alpha, "beta": beta},
             "C+Z_d+Z_r": f.intrusion_distance + f.human_uncertainty + f.robot_uncertainty,
             "contact_distance": space.contact_distance} | _level_terms(lv, m, space, i)
    premises = premises + [_z3_premise("M", lv, holds, worst, i)]
    return Proof(holds, method, box, premises, worst, terms, placeholder)


def prove_separation(config: ControllerConfig, space: ScenarioSpace) -> Proof:
    """Tries to prove the separation invariant for ``config`` over ``space`` (the second
    theorem of the module docstring; under ``safety.stopping: by_speed`` at every speed
    level); when the margin falls short, says by how much Z_d + Z_r would have to grow
    (``Proof.needed_allowance``: every level's margin gains what Z_d + Z_r gains)."""
    f = config.safety
    p = space.parameters
    floor = f.human_speed == "estimated_with_floor"
    v_lo = f.iso_human_speed if floor else min(f.iso_human_speed, f.iso_reduced_human_speed)
    method = _method("separation", f.stopping)
    if space.recording is not None:
        return _declined(config, space, "separation", method)
    premises, box, placeholder, (alpha, beta), _ = _setting(config, space, "separation")
    if not all(x.holds for x in premises):
        return Proof(False, method, box, premises, None, {}, placeholder, "separation")
    lv = speed_levels(config, space)
    tau = frame_timeout(config)
    m = _margin(config, space, "separation", lv)
    holds = _unsat_below_zero(m, space)
    worst, i = _worst(m, space)
    v_hi = float(m.human_speed(p.peak_speed.max))  # S_true's human speed, at most
    t_s, t_true = float(lv.t_s[i]), float(m.t_true[i])  # T_stop + T_r of S_true
    terms = {"v_lo": v_lo, "v_hi": v_hi, "T_s": t_s,
             "T_r": f.reaction_time, "B": float(lv.b[i]), "tau": tau, "V_R": lv.tool_speed,
             "T_stop": float(lv.stop_time[i]), "D": float(lv.stop_travel[i]),
             "E_per_axis": {"alpha": alpha, "beta": beta},
             "Z_d+Z_r": f.human_uncertainty + f.robot_uncertainty,
             "human_speed_term": v_lo * (t_s + f.reaction_time) - v_hi * t_true,
             "robot_speed": f.robot_speed,
             "robot_speed_term": float(robot_speed_gap(config, space, lv)[i])
             * f.reaction_time,
             "stopping_distance_term": float(lv.b[i] - lv.stop_travel[i]),
             "sensing_term": -float(m.k_noise * p.noise_std.max + m.k_speed[i]
                                    * p.peak_speed.max)} | _level_terms(lv, m, space, i)
    premises = premises + [_z3_premise("M_S", lv, holds, worst, i)]
    return Proof(holds, method, box, premises, worst, terms, placeholder, "separation",
                 0.0 if holds else max(-worst, 0.0))
