"""Speed and separation monitoring maths: distances, directed speeds, S and k.

Plain vectorised functions shared by the Drake systems and the batched verifier.
Shapes: robot quantities are ``(..., 3)``, body quantities ``(..., N, 3)``;
leading axes broadcast (a batch of scenarios, a time axis, or nothing).

Seed: Lettera, Costa, Callegari, "A Hybrid Architecture for Safe Human-Robot
Industrial Tasks", Appl. Sci. 2025 (``shared/seeds/000_*``), Eqs. 1 and 6-12.
"""

import math

import numba
import numpy as np

from safety_systems.sensing import stops
from safety_systems.sensing.tracks import tracker_stop, usable

HUMAN_SPEED_MODES = ("estimated", "iso", "estimated_with_floor")
# The robot's speed in S (SafetyConfig.robot_speed): Eq. 7's directed speed, or the speed
# of the capsule's fastest point (safety_systems.ssm.separation).
ROBOT_SPEED_TERMS = ("directed", "fastest_point")
# The robot's stop in S (SafetyConfig.stopping): the stop from full speed whatever the
# speed (``full_speed``), or the stop from the speed the robot may have until the next
# decision (``by_speed``, ISO/TS 15066's S_s from the current speed; :func:`by_speed_command`).
STOPPING_MODES = ("full_speed", "by_speed")
# by_speed: the commanded speed is one of SPEED_LEVELS + 1 levels g / SPEED_LEVELS.
SPEED_LEVELS = 64


# ISO/TS 15066 Eq. 1 (seed Section 2) after ISO 13855: 2000 mm/s, or 1600 mm/s where
# the resulting S exceeds 500 mm (and then S is not taken below 500 mm).
ISO_HUMAN_SPEED = 2.0
ISO_REDUCED_HUMAN_SPEED = 1.6
ISO_REDUCED_SPEED_THRESHOLD = 0.5


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def separation_pair(p_R, v_R, p_B, v_B):
    """(d, v_human_directed, v_robot_directed) of one body (Eqs. 6-8; 3-vectors), compiled
    and callable from other compiled code (see :func:`separation_and_directed_speeds`)."""
    x0, x1, x2 = p_R[0] - p_B[0], p_R[1] - p_B[1], p_R[2] - p_B[2]  # body -> robot
    dist = np.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
    h0, h1, h2 = v_B[0], v_B[1], v_B[2]
    r0, r1, r2 = -v_R[0], -v_R[1], -v_R[2]
    if dist > 1e-12:
        v_h, v_r = (h0 * x0 + h1 * x1 + h2 * x2) / dist, (r0 * x0 + r1 * x1 + r2 * x2) / dist
    elif not math.isnan(dist):  # coincident: the full magnitudes (worst case)
        v_h, v_r = np.sqrt(h0 * h0 + h1 * h1 + h2 * h2), np.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
    else:  # a NaN position
        v_h, v_r = np.nan, np.nan
    return dist, v_h, v_r


@numba.njit(cache=True)
def _separation_rows(p_R, v_R, p_B, v_B, out, speeds):
    """Eq. 8's d and (if ``speeds``) Eqs. 6-7's directed speeds of rows (L, 3) / (L, N, 3)
    into out[0], out[1], out[2] (L, N), compiled."""
    for row in range(p_B.shape[0]):
        for i in range(p_B.shape[1]):
            if speeds:
                out[0, row, i], out[1, row, i], out[2, row, i] = separation_pair(
                    p_R[row], v_R[row], p_B[row, i], v_B[row, i])
            else:
                x0 = p_R[row, 0] - p_B[row, i, 0]
                x1 = p_R[row, 1] - p_B[row, i, 1]
                x2 = p_R[row, 2] - p_B[row, i, 2]
                out[0, row, i] = np.sqrt(x0 * x0 + x1 * x1 + x2 * x2)


def _rows(robot: np.ndarray, bodies: np.ndarray, *more: np.ndarray):
    """Robot arrays (..., 3) and body arrays (..., N, 3) broadcast to one leading shape and
    flattened to rows (L, 3) and (L, N, 3); returns the leading shape and the arrays (views
    where no broadcasting is needed)."""
    arrays = [np.asarray(x, dtype=float) for x in (robot, bodies, *more)]
    leads = [x.shape[:x.ndim - 1 - (k % 2)] for k, x in enumerate(arrays)]
    lead = leads[0] if all(a == leads[0] for a in leads) else np.broadcast_shapes(*leads)
    rows = []
    for x, own in zip(arrays, leads):
        tail = x.shape[len(own):]
        if own != lead:
            x = np.broadcast_to(x, lead + tail)
        rows.append(x.reshape((-1,) + tail))
    return lead, rows


def separation_distances(p_robot: np.ndarray, p_bodies: np.ndarray) -> np.ndarray:
    """Euclidean distance from the robot point to every body, seed Eq. 8.

    Returns shape ``(..., N)``.
    """
    lead, (p_R, p_B) = _rows(p_robot, p_bodies)
    d = np.empty((1,) + p_B.shape[:2])
    _separation_rows(p_R, p_R, p_B, p_B, d, False)
    return d[0].reshape(lead + d.shape[2:])


def directed_speeds(
    p_robot: np.ndarray,
    v_robot: np.ndarray,
    p_bodies: np.ndarray,
    v_bodies: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Speeds of each body towards the robot and of the robot towards each body.

    Seed Eq. 6: v^d_RB_i = v_RB_i . (p_R - p_RB_i)/||p_R - p_RB_i||, and Eq. 7:
    v^d_R = v_R . (p_RB_i - p_R)/||p_RB_i - p_R||. Positive means closing in.

    Interpretation: where a body coincides with the robot point the direction is
    undefined; there both speeds are taken as their full magnitudes (the worst case).

    Returns ``(v_human_directed, v_robot_directed)``, each shape ``(..., N)``.
    """
    return separation_and_directed_speeds(p_robot, v_robot, p_bodies, v_bodies)[1:]


def separation_and_directed_speeds(
    p_robot: np.ndarray,
    v_robot: np.ndarray,
    p_bodies: np.ndarray,
    v_bodies: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eq. 8's distances and Eqs. 6-7's directed speeds at once (they share the offsets):
    ``(d, v_human_directed, v_robot_directed)``, as :func:`separation_distances` and
    :func:`directed_speeds` give them; a NaN body position gives NaN everywhere. The
    pairs are looped over in compiled code (numba), any leading axes flattened."""
    p_R, v_R = np.asarray(p_robot, dtype=float), np.asarray(v_robot, dtype=float)
    p_B, v_B = np.asarray(p_bodies, dtype=float), np.asarray(v_bodies, dtype=float)
    if p_R.ndim == 1 and v_R.ndim == 1 and p_B.ndim == 2 and v_B.ndim == 2:
        out = np.empty((3, 1, p_B.shape[0]))  # one robot, the common case: no copies
        _separation_rows(p_R[None], v_R[None], p_B[None], v_B[None], out, True)
        return out[0, 0], out[1, 0], out[2, 0]
    lead, (p_R, p_B, v_R, v_B) = _rows(p_R, p_B, v_R, v_B)
    out = np.empty((3,) + p_B.shape[:2])
    _separation_rows(p_R, v_R, p_B, v_B, out, True)
    shape = lead + out.shape[2:]
    return out[0].reshape(shape), out[1].reshape(shape), out[2].reshape(shape)


_MODE_CODES = {mode: code for code, mode in enumerate(HUMAN_SPEED_MODES)}


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def human_speed(v_h, mode, iso):
    """The human speed v_H entering S (Eq. 10) by ``mode``, its index in
    ``HUMAN_SPEED_MODES``: ``estimated`` the directed speed as given (negative when the
    body moves away, which lowers S), ``iso`` the constant ``iso`` of ISO/TS 15066 Eq. 1,
    ``estimated_with_floor`` the larger of the two (a NaN stays NaN). The one statement
    of the modes: S and the numpy :func:`human_speed_term` use it."""
    if mode == 1 or (mode == 2 and v_h < iso):
        v_h = iso
    return v_h


@numba.njit(cache=True)
def _human_speed_rows(v, mode, iso, out):
    for i in range(v.size):
        out[i] = human_speed(v[i], mode, iso)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def body_protective_distance(v_h, v_r, z_d, mode, t_sr, t_r, const, iso, iso_reduced):
    """S of one body, compiled and callable from other compiled code:
    ((v_H (T_s + T_r) + v_R T_r) + (B + C + Z_r)) + Z_d with ``t_sr`` = T_s + T_r and
    ``const`` = B + C + Z_r, v_H by ``mode`` (its index in ``HUMAN_SPEED_MODES``) and
    ISO 13855's 1.6 m/s rule in ``iso`` mode (see :func:`monitor_protective_distances`)."""
    v_h = human_speed(v_h, mode, iso)
    s = v_h * t_sr + v_r * t_r + const + z_d
    if mode == 1 and s > ISO_REDUCED_SPEED_THRESHOLD:
        s = iso_reduced * t_sr + v_r * t_r + const + z_d
        if s < ISO_REDUCED_SPEED_THRESHOLD:  # noqa: PLR1730 (max() would drop a NaN)
            s = ISO_REDUCED_SPEED_THRESHOLD
    return s


@numba.njit(cache=True)
def _protective_kernel(v_h, v_r, z_d, mode, t_sr, t_r, const, iso, iso_reduced, out):
    """:func:`body_protective_distance` of every element (flat arrays; ``z_d`` of length 1 or of the
    outputs)."""
    one_z = z_d.size == 1
    for i in range(out.size):
        out[i] = body_protective_distance(v_h[i], v_r[i], z_d[0] if one_z else z_d[i], mode,
                                          t_sr, t_r, const, iso, iso_reduced)


def protective_separation_distance(
    v_human: np.ndarray,
    v_robot: np.ndarray,
    *,
    reaction_time: float,
    stopping_time: float,
    stopping_distance: float,
    intrusion_distance: float = 0.0,
    human_uncertainty: np.ndarray | float = 0.0,
    robot_uncertainty: float = 0.0,
) -> np.ndarray:
    """Protective separation distance S_i, seed Eqs. 9-11 (ISO/TS 15066 Eq. 1).

    S_i = v_H (T_s + T_r) + v_R T_r + B + C + Z_d + Z_r, where v_H is the human speed
    (Eq. 10) and v_R the robot's speed towards the body (Eq. 11). B is the stopping
    distance ``S_S`` (constant in the seed). :func:`monitor_protective_distances` with
    ``mode="estimated"``.
    """
    return monitor_protective_distances(
        v_human, v_robot, mode="estimated", reaction_time=reaction_time,
        stopping_time=stopping_time, stopping_distance=stopping_distance,
        intrusion_distance=intrusion_distance, human_uncertainty=human_uncertainty,
        robot_uncertainty=robot_uncertainty)


def human_speed_term(
    v_human_directed: np.ndarray,
    mode: str,
    *,
    iso_speed: float = ISO_HUMAN_SPEED,
) -> np.ndarray:
    """The human speed entering S, by ``mode`` (:func:`human_speed` of every element).

    - ``estimated``: the Kalman filter's directed speed, as the seed does (Eq. 10);
      negative when the body moves away, which lowers S.
    - ``iso``: the constant ``iso_speed`` of ISO/TS 15066 Eq. 1 (2.0 m/s); the 1.6 m/s
      reduction is applied by :func:`monitor_protective_distances`.
    - ``estimated_with_floor``: the larger of the two.
    """
    if mode not in HUMAN_SPEED_MODES:
        raise ValueError(f"human_speed mode {mode!r} is not one of {HUMAN_SPEED_MODES}")
    v = np.ascontiguousarray(v_human_directed, dtype=float)
    out = np.empty(v.shape)
    _human_speed_rows(v.reshape(-1), HUMAN_SPEED_MODES.index(mode), float(iso_speed),
                      out.reshape(-1))
    return out


def monitor_protective_distances(
    v_human_directed: np.ndarray,
    v_robot_directed: np.ndarray,
    *,
    mode: str,
    reaction_time: float,
    stopping_time: float,
    stopping_distance: float,
    intrusion_distance: float = 0.0,
    human_uncertainty: np.ndarray | float = 0.0,
    robot_uncertainty: float = 0.0,
    iso_speed: float = ISO_HUMAN_SPEED,
    iso_reduced_speed: float = ISO_REDUCED_HUMAN_SPEED,
) -> np.ndarray:
    """S_i (Eqs. 9-11) for every body under a human-speed ``mode`` (the speed
    :func:`human_speed_term` gives), in compiled code.

    In ``iso`` mode, ISO 13855's rule is applied: if S computed with 2.0 m/s exceeds
    0.5 m, S is recomputed with 1.6 m/s but not taken below 0.5 m.
    """
    code = _MODE_CODES.get(mode)
    if code is None:
        raise ValueError(f"human_speed mode {mode!r} is not one of {HUMAN_SPEED_MODES}")
    v_h = np.asarray(v_human_directed, dtype=float)
    v_r = np.asarray(v_robot_directed, dtype=float)
    z_d = np.asarray(human_uncertainty, dtype=float)
    shape = v_h.shape
    if v_r.shape != shape or (z_d.ndim and z_d.shape != shape):
        shape = np.broadcast_shapes(v_h.shape, v_r.shape, z_d.shape)
        v_h, v_r = (np.ascontiguousarray(np.broadcast_to(x, shape)) for x in (v_h, v_r))
        if z_d.size != 1:
            z_d = np.ascontiguousarray(np.broadcast_to(z_d, shape))
    out = np.empty(shape)
    _protective_kernel(v_h.ravel(), v_r.ravel(), z_d.ravel(), code,
                       stopping_time + reaction_time, reaction_time,
                       stopping_distance + intrusion_distance + robot_uncertainty,
                       iso_speed, iso_reduced_speed, out.ravel())
    return out


def human_uncertainty(base: float, sigmas: float,
                      position_std: np.ndarray) -> np.ndarray | float:
    """Z_d of each body, metres: the configured ``base`` plus ``sigmas`` standard
    deviations of the track's position (not computed when ``sigmas`` is 0, so the seed's
    constant Z_d stays the float ``base``). A hidden body's extra uncertainty is not in
    Z_d: it is the radius of its ball (:func:`hidden_ball_radius`), taken off its d."""
    if sigmas:
        return base + sigmas * np.asarray(position_std, dtype=float)
    return base


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def hidden_ball_radius(unseen_time, occlusion_speed):
    """Radius (m) of the ball a hidden body may be in, around its last accepted
    estimate: ``occlusion_speed`` (m/s) times the seconds since it was last seen. Not in
    the seed (its Z_d is constant); see ``safety_systems.sensing.tracks``."""
    return occlusion_speed * unseen_time


# Stand-ins for an infinite S_max (+-): beyond every finite distance, and (dS - 1) times
# them stays finite, so Eq. 12's arithmetic meets no inf - inf or 0 * inf.
_S_MAX_CAP = 1e100


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def speed_scale_eq12(d, s_max, delta_s, d_min):
    """Eq. 12 for one distance (see :func:`speed_override`), compiled. Nondecreasing in
    d and nonincreasing in s_max (a NaN s_max taken as the cap), which the batched
    evaluator's exact skips rely on."""
    s = _S_MAX_CAP if math.isnan(s_max) else min(max(s_max, -_S_MAX_CAP), _S_MAX_CAP)
    if not (d >= d_min and d < np.inf):  # also NaN
        return 0.0
    ramp = (d - s) / max((delta_s - 1.0) * s, 1e-12)  # an empty band: a step
    if math.isnan(ramp):
        return 0.0
    return min(max(ramp, 0.0), 1.0)


@numba.njit(cache=True)
def _speed_scale_eq12_elements(d, s_max, delta_s, d_min, out):
    one_s = s_max.size == 1
    for i in range(out.size):
        out[i] = speed_scale_eq12(d[i], s_max[0] if one_s else s_max[i], delta_s, d_min)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def override_row(d, s, inc, delta_s, d_min):
    """(k, S_max) of one robot from its bodies' d, S and included flags (N,), compiled and
    callable from other compiled code (see :func:`overall_speed_override`)."""
    included, faulty = False, False
    top, closest = -np.inf, np.inf
    for i in range(d.size):
        if not inc[i]:
            continue
        included = True
        if not (np.isfinite(d[i]) and np.isfinite(s[i])):
            faulty = True
        else:
            top = max(top, s[i])
            closest = min(closest, d[i])
    if not included:
        k, top = 1.0, -np.inf
    elif faulty:  # a non-finite d_i or S_i: stop
        k, top = 0.0, np.inf
    else:
        k = speed_scale_eq12(closest, top, delta_s, d_min)
    return k, top


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def held_by_tracker(k, status, fault):
    """(k, stop reason) after the SpeedOverride's fail-safe stops: the reason a k of 0
    has (the separation), and the tracker's stop rule (``tracks.tracker_stop``: its
    fault, else a lost track), which holds the robot whatever k."""
    reason = float(stops.STOP_SEPARATION if k <= 0.0 else stops.STOP_NONE)
    held = tracker_stop(status, fault)
    if held != stops.STOP_NONE:
        k, reason = 0.0, held
    return k, reason


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def level_top(s_levels, included, g):
    """S_max(g): the largest S at level g (``s_levels`` (G + 1, N)) of the included
    bodies, -inf with none."""
    top = -np.inf
    for i in range(included.size):
        if included[i]:
            top = max(top, s_levels[g, i])
    return top


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def level_inclusion(d, s_levels, status, included):
    """(any usable body, a usable body with a non-finite d or S at some level, the
    closest finite d) of the bodies' d (N,) and S at every level (G + 1, N); their
    usable flags (``tracks.usable``) into ``included``."""
    any_included, faulty, closest = False, False, np.inf
    for i in range(d.size):
        included[i] = usable(status[i])
        if not included[i]:
            continue
        any_included = True
        if not np.isfinite(d[i]):
            faulty = True
        else:
            closest = min(closest, d[i])
        for g in range(s_levels.shape[0]):
            if not np.isfinite(s_levels[g, i]):
                faulty = True
    return any_included, faulty, closest


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def override_row_caps(d, s, inc, caps, delta_s, d_min):
    """(k, S_max) of one robot under ``safety.mode: ssm_pfl``: the least over the
    included bodies i of max(Eq. 12(d_i, S_max), caps[i]), each body's Eq. 12 against
    the largest S of all (as :func:`override_row`), held up at its power and force
    limiting cap (``pfl.speed_caps``: a path rate, 0 for a body where no contact may
    happen while the robot moves). No included body: k = 1; a non-finite d_i or S_i of
    an included body: k = 0 whatever the caps (fail safe). With every cap 0 this is
    :func:`override_row`'s k bit for bit (Eq. 12 is nondecreasing in d)."""
    included, faulty = False, False
    top = -np.inf
    for i in range(d.size):
        if not inc[i]:
            continue
        included = True
        if not (np.isfinite(d[i]) and np.isfinite(s[i])):
            faulty = True
        else:
            top = max(top, s[i])
    if not included:
        return 1.0, -np.inf
    if faulty:
        return 0.0, np.inf
    k = 1.0
    for i in range(d.size):
        if inc[i]:
            k = min(k, max(speed_scale_eq12(d[i], top, delta_s, d_min), caps[i]))
    return k, top


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def override_command_caps(d, s, status, fault, delta_s, d_min, caps, included):
    """:func:`override_command` under ``safety.mode: ssm_pfl``: k by
    :func:`override_row_caps`, then the same fail-safe stops (the tracker's fault or a
    lost track hold the robot whatever the caps)."""
    for i in range(d.size):
        included[i] = usable(status[i])
    k, top = override_row_caps(d, s, included, caps, delta_s, d_min)
    k, reason = held_by_tracker(k, status, fault)
    return k, top, reason


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def override_command(d, s, status, fault, delta_s, d_min, included):
    """The SpeedOverride's (k, S_max, stop reason) of one robot, compiled: Eq. 12 over
    the bodies with a usable track (``tracks.usable``: tracking or hidden; their flags
    are written into ``included`` (N,)) by :func:`override_row`, then fail safe: the
    tracker's stop rule (``tracks.tracker_stop``: its fault, else a lost track) holds the
    robot with that reason."""
    for i in range(d.size):
        included[i] = usable(status[i])
    k, top = override_row(d, s, included, delta_s, d_min)
    k, reason = held_by_tracker(k, status, fault)
    return k, top, reason


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def level_at_or_above(rate, levels):
    """The speed level g (of ``levels`` + 1, g / levels) at or above the path rate
    ``rate`` (clipped to [0, 1]; a NaN counts as full speed). A rate at most 1e-9 above
    g / levels counts as level g: the tolerance is in units of the rate, not of the
    level, so that with power-of-two level counts (the override's SPEED_LEVELS, S_true's
    TRUTH_RATES) a level-g rate maps exactly to a grid rate at or below g / levels
    (``verification.proof.margins.level_rate``)."""
    if not rate < 1.0:
        return levels
    return max(0, min(levels, math.ceil((rate - 1e-9) * levels)))


def held_level(rate: float, k: float, levels: int) -> int:
    """The speed level whose S the override held the distances to at a tick under
    ``safety.stopping: by_speed`` (:func:`by_speed_command`), for the figures that report
    it (trace, plot, the live runtime's log): the larger of the level at or above the
    path rate then (:func:`level_at_or_above`) and the level it commanded (k = g /
    ``levels``). Fails towards the larger S: a rate that is not finite counts as full
    speed; a k that is not finite commanded a stop (level 0, so the rate's level)."""
    now = int(level_at_or_above(rate if math.isfinite(rate) else 1.0, levels))
    commanded = min(max(round(k * levels), 0), levels) if math.isfinite(k) else 0
    return max(now, commanded)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def by_speed_command(d, s_levels, status, fault, rate, delta_s, d_min, included):
    """The SpeedOverride's (k, S_max, stop reason) with S following the robot's speed
    (``safety.stopping: by_speed``), compiled. ``s_levels`` (G + 1, N): each body's S at
    the speed levels g / G (``separation.level_rows``: T_s and B of the stop from that
    speed, ``configuration.level_stops``); ``rate`` the path rate now.

    Over the bodies with a usable track (flags into ``included``), with d the closest
    clearance and S_max(g) the largest S at level g:

    - no usable body: k = 1; a non-finite d or S of a usable body: k = 0;
    - the robot keeps moving only while d >= S_max(g_now), g_now the level at or above
      the rate now (ISO/TS 15066: S from the current speed), and d >= d_min; else k = 0,
      a protective stop;
    - then k = g / G for the largest g with d >= dS S_max(g) (0 if none): the fastest
      level whose S, widened by the slow-down band dS, the operator is beyond. A k below
      the rate slows the robot within its brakes (``braking.rate_step_one``) before d
      can reach S_max(g_now).

    So whenever k > 0, d >= S_max(g') with g' = max(g_now, g_k): the S of a level at or
    above every rate the robot can have until the next decision (the rate moves from
    the rate now towards k). That is the premise ``verification.proof`` takes. Eq. 12's
    linear ramp is not used: the levels replace it. S_max returned is S_max(g').
    Then the tracker's stop rule holds the robot as in :func:`override_command`."""
    levels = s_levels.shape[0] - 1
    any_included, faulty, closest = level_inclusion(d, s_levels, status, included)
    g_now = level_at_or_above(rate, levels)
    if not any_included:
        k, top = 1.0, -np.inf
    elif faulty:
        k, top = 0.0, np.inf
    else:
        top_now = level_top(s_levels, included, g_now)
        k, top = 0.0, top_now
        if closest >= d_min and closest >= top_now:
            for g in range(levels, 0, -1):
                top_g = level_top(s_levels, included, g)
                if closest >= delta_s * top_g:
                    k = g / levels
                    if g > g_now:
                        top = top_g
                    break
    k, reason = held_by_tracker(k, status, fault)
    return k, top, reason


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def by_speed_command_caps(d, s_levels, status, fault, rate, delta_s, d_min, caps, included):
    """:func:`by_speed_command` under ``safety.mode: ssm_pfl``: each usable body i has its
    own level k_i (the largest g / G with d_i >= dS S_max(g), given d_i >= S_max(g_now)
    and d_i >= d_min; else 0), held up at its cap (``pfl.speed_caps``), and k is the
    least over the bodies of max(k_i, caps[i]); the same fail-safe stops. Each k_i is
    nondecreasing in d_i, so with every cap 0 the least is the closest body's: k and
    S_max as :func:`by_speed_command` gives them, bit for bit. Whenever k > caps[i],
    k_i >= k > 0, so d_i >= S_max(g') for g' = max(g_now, g_k) (the premise the proofs
    take, now per body). S_max returned is S_max(g') with g_k the level at or above k."""
    levels = s_levels.shape[0] - 1
    any_included, faulty, _ = level_inclusion(d, s_levels, status, included)
    g_now = level_at_or_above(rate, levels)
    if not any_included:
        k, top = 1.0, -np.inf
    elif faulty:
        k, top = 0.0, np.inf
    else:
        top_now = level_top(s_levels, included, g_now)
        tops = np.empty(levels + 1)  # S_max(g) over the included bodies
        for g in range(levels + 1):
            tops[g] = level_top(s_levels, included, g)
        k = 1.0
        for i in range(d.size):
            if not included[i]:
                continue
            k_i = 0.0
            if d[i] >= d_min and d[i] >= top_now:
                for g in range(levels, 0, -1):
                    if d[i] >= delta_s * tops[g]:
                        k_i = g / levels
                        break
            k = min(k, max(k_i, caps[i]))
        top = top_now
        g_k = level_at_or_above(k, levels)
        if g_k > g_now and k > 0.0:
            top = tops[g_k]
    k, reason = held_by_tracker(k, status, fault)
    return k, top, reason


@numba.njit(cache=True)
def _by_speed_command_caps(d, s_levels, status, fault, rate, delta_s, d_min, caps):
    return by_speed_command_caps(d, s_levels, status, fault, rate, delta_s, d_min, caps,
                                 np.empty(d.size, np.bool_))


def capped_by_speed_command(distances: np.ndarray, level_distances: np.ndarray,
                            status: np.ndarray, fault: float, rate: float, caps: np.ndarray,
                            *, delta_s: float = 1.0, d_min: float = 0.30
                            ) -> tuple[float, float, int]:
    """:func:`by_speed_command_caps` of one robot from Python: (k, S_max, stop reason)."""
    k, top, reason = _by_speed_command_caps(
        np.ascontiguousarray(distances, dtype=float),
        np.ascontiguousarray(level_distances, dtype=float),
        np.ascontiguousarray(status, dtype=float), float(fault), float(rate), float(delta_s),
        float(d_min), np.ascontiguousarray(caps, dtype=float))
    return float(k), float(top), int(reason)


@numba.njit(cache=True)
def _by_speed_command(d, s_levels, status, fault, rate, delta_s, d_min):
    return by_speed_command(d, s_levels, status, fault, rate, delta_s, d_min,
                            np.empty(d.size, np.bool_))


def by_speed_override_command(distances: np.ndarray, level_distances: np.ndarray,
                              status: np.ndarray, fault: float, rate: float, *,
                              delta_s: float = 1.0, d_min: float = 0.30
                              ) -> tuple[float, float, int]:
    """:func:`by_speed_command` of one robot from Python: (k, S_max, stop reason)."""
    k, top, reason = _by_speed_command(
        np.ascontiguousarray(distances, dtype=float),
        np.ascontiguousarray(level_distances, dtype=float),
        np.ascontiguousarray(status, dtype=float), float(fault), float(rate), float(delta_s),
        float(d_min))
    return float(k), float(top), int(reason)


@numba.njit(cache=True)
def _override_command(d, s, status, fault, delta_s, d_min):
    return override_command(d, s, status, fault, delta_s, d_min, np.empty(d.size, np.bool_))


@numba.njit(cache=True)
def _override_command_caps(d, s, status, fault, delta_s, d_min, caps):
    return override_command_caps(d, s, status, fault, delta_s, d_min, caps,
                                 np.empty(d.size, np.bool_))


def capped_override_command(distances: np.ndarray, protective_distances: np.ndarray,
                            status: np.ndarray, fault: float, caps: np.ndarray, *,
                            delta_s: float = 2.0, d_min: float = 0.30
                            ) -> tuple[float, float, int]:
    """:func:`override_command_caps` of one robot from Python: (k, S_max, stop reason)."""
    k, top, reason = _override_command_caps(
        np.ascontiguousarray(distances, dtype=float),
        np.ascontiguousarray(protective_distances, dtype=float),
        np.ascontiguousarray(status, dtype=float), float(fault), float(delta_s), float(d_min),
        np.ascontiguousarray(caps, dtype=float))
    return float(k), float(top), int(reason)


def speed_override_command(distances: np.ndarray, protective_distances: np.ndarray,
                           status: np.ndarray, fault: float, *, delta_s: float = 2.0,
                           d_min: float = 0.30) -> tuple[float, float, int]:
    """:func:`override_command` of one robot from Python: (k, S_max, stop reason)."""
    k, top, reason = _override_command(
        np.ascontiguousarray(distances, dtype=float),
        np.ascontiguousarray(protective_distances, dtype=float),
        np.ascontiguousarray(status, dtype=float), float(fault), float(delta_s), float(d_min))
    return float(k), float(top), int(reason)


def override_decision(distances: np.ndarray, protective: np.ndarray, status: np.ndarray,
                      fault: float, *, rate: float = 1.0, caps: np.ndarray | None = None,
                      delta_s: float = 2.0, d_min: float = 0.30) -> tuple[float, float, int]:
    """The SpeedOverride's (k, S_max, stop reason) of one robot from Python, by whichever
    rule its configuration asks for: ``protective`` (N,), Eq. 12
    (:func:`speed_override_command`); (G + 1, N), S at every speed level with ``rate``
    the path rate now (``safety.stopping: by_speed``, :func:`by_speed_override_command`);
    each with power and force limiting's ``caps`` (N,) under ``safety.mode: ssm_pfl``
    (:func:`capped_override_command`, :func:`capped_by_speed_command`), None under
    ``ssm``. The Drake SpeedOverride and the live runtime decide through it."""
    protective = np.asarray(protective, dtype=float)
    if protective.ndim == 2:
        if caps is not None:
            return capped_by_speed_command(distances, protective, status, fault, rate, caps,
                                           delta_s=delta_s, d_min=d_min)
        return by_speed_override_command(distances, protective, status, fault, rate,
                                         delta_s=delta_s, d_min=d_min)
    if caps is not None:
        return capped_override_command(distances, protective, status, fault, caps,
                                       delta_s=delta_s, d_min=d_min)
    return speed_override_command(distances, protective, status, fault, delta_s=delta_s,
                                  d_min=d_min)


@numba.njit(cache=True)
def _override_rows(d, s, inc, delta_s, d_min, k, s_max):
    """:func:`override_row` of every row (L, N)."""
    for row in range(d.shape[0]):
        k[row], s_max[row] = override_row(d[row], s[row], inc[row], delta_s, d_min)


def speed_override(
    distances: np.ndarray,
    s_max: np.ndarray | float,
    *,
    delta_s: float = 2.0,
    d_min: float = 0.30,
) -> np.ndarray:
    """Speed override k per body, seed Eq. 12; shape of ``distances``.

    k = 0 if d_i < S_max or d_i < d_min; else 1 if d_i >= dS * S_max; else
    (d_i - S_max) / (dS * S_max - S_max). Computed as the ramp (d_i - S_max) /
    ((dS - 1) S_max) clipped to [0, 1] (1 from d_i = dS * S_max, to rounding), then 0
    below d_min.

    Interpretations: the zero case is tested first (Eq. 12 lists its cases in the
    other order, but then d < d_min would not stop the robot whenever
    d >= dS * S_max, which the text rules out); with S_max <= 0 (every body moving
    away fast under ``estimated`` speeds) the linear band is empty and k = 1 for
    d >= d_min. Non-finite distances and an infinite or NaN S_max give k = 0 (fail
    safe).
    """
    d = np.asarray(distances, dtype=float)
    s = np.asarray(s_max, dtype=float)
    shape = np.broadcast_shapes(d.shape, s.shape)
    d = np.ascontiguousarray(np.broadcast_to(d, shape)).reshape(-1)
    s = s.reshape(1) if s.size == 1 else np.ascontiguousarray(np.broadcast_to(s, shape)).reshape(-1)
    out = np.empty(shape)
    _speed_scale_eq12_elements(d, s, float(delta_s), float(d_min), out.reshape(-1))
    return out


def overall_speed_override(
    distances: np.ndarray,
    protective_distances: np.ndarray,
    included: np.ndarray,
    *,
    delta_s: float = 2.0,
    d_min: float = 0.30,
) -> tuple[np.ndarray, np.ndarray]:
    """The robot's k from every included body: min over bodies of Eq. 12.

    S_max is the largest S_i of the included bodies (Eq. 12 compares each d_i with
    S_max, not with its own S_i). Bodies not included (no track) are ignored; with no
    included body k = 1. An included body with a non-finite d_i or S_i gives k = 0
    (S_max is then infinite).

    With one S_max for all bodies Eq. 12 is non-decreasing in d_i, so the minimum over
    the bodies is k of the closest included body, which is what is computed (in
    compiled code, row by row over any leading axes).

    Returns ``(k, s_max)`` with the body axis (last) reduced.
    """
    d = np.asarray(distances, dtype=float)
    s = np.asarray(protective_distances, dtype=float)
    inc = np.asarray(included, dtype=bool)
    if d.ndim == 1 and s.shape == d.shape and inc.shape == d.shape:  # one robot
        k, s_max = override_row(d, s, inc, float(delta_s), float(d_min))
        return np.float64(k), np.float64(s_max)
    shape = d.shape
    if s.shape != shape or inc.shape != shape:
        shape = np.broadcast_shapes(d.shape, s.shape, inc.shape)
        d, s, inc = (np.ascontiguousarray(np.broadcast_to(x, shape)) for x in (d, s, inc))
    lead = shape[:-1]
    k, s_max = np.empty((2, math.prod(lead)))
    _override_rows(d.reshape(-1, shape[-1]), s.reshape(-1, shape[-1]),
                   inc.reshape(-1, shape[-1]), float(delta_s), float(d_min), k, s_max)
    return k.reshape(lead)[()], s_max.reshape(lead)[()]  # one robot: scalars
