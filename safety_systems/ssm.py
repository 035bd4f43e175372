"""Speed and separation monitoring maths: distances, directed speeds, S and k.

Plain vectorised functions shared by the Drake systems and the batched verifier.
Shapes: robot quantities are ``(..., 3)``, body quantities ``(..., N, 3)``;
leading axes broadcast (a batch of scenarios, a time axis, or nothing).

Seed: Lettera, Costa, Callegari, "A Hybrid Architecture for Safe Human-Robot
Industrial Tasks", Appl. Sci. 2025 (``shared/seeds/000_*``), Eqs. 1 and 6-12.
"""

import math

import numpy as np

HUMAN_SPEED_MODES = ("estimated", "iso", "estimated_with_floor")

# ISO/TS 15066 Eq. 1 (seed Section 2) after ISO 13855: 2000 mm/s, or 1600 mm/s where
# the resulting S exceeds 500 mm (and then S is not taken below 500 mm).
ISO_HUMAN_SPEED = 2.0
ISO_REDUCED_HUMAN_SPEED = 1.6
ISO_REDUCED_SPEED_THRESHOLD = 0.5


def separation_distances(p_robot: np.ndarray, p_bodies: np.ndarray) -> np.ndarray:
    """Euclidean distance from the robot point to every body, seed Eq. 8.

    Returns shape ``(..., N)``.
    """
    diff = np.asarray(p_bodies, dtype=float) - np.asarray(p_robot, dtype=float)[..., None, :]
    return np.sqrt(np.vecdot(diff, diff))


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
    :func:`directed_speeds` give them."""
    v_away = np.negative(v_robot, dtype=float)[..., None, :]  # -v_R
    v_bodies = np.asarray(v_bodies, dtype=float)
    diff = np.asarray(p_robot, dtype=float)[..., None, :] - np.asarray(p_bodies, dtype=float)
    dist = np.sqrt(np.vecdot(diff, diff))
    # Projections onto body -> robot, divided by the distance where it is defined.
    if np.minimum.reduce(dist, axis=None, initial=np.inf) > 1e-12:  # False with a NaN
        return dist, np.vecdot(v_bodies, diff) / dist, np.vecdot(v_away, diff) / dist
    apart = dist > 1e-12
    v_h = np.divide(np.vecdot(v_bodies, diff), dist,
                    out=np.zeros_like(dist), where=apart)
    v_r = np.divide(np.vecdot(v_away, diff), dist,
                    out=np.zeros_like(dist), where=apart)
    coincident = ~apart & np.isfinite(dist)
    v_h = np.where(coincident, np.linalg.norm(v_bodies, axis=-1), v_h)
    v_r = np.where(coincident, np.linalg.norm(v_away, axis=-1), v_r)
    v_h[np.isnan(dist)] = np.nan
    v_r[np.isnan(dist)] = np.nan
    return dist, v_h, v_r


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
    term chosen by :func:`human_speed_term` (Eq. 10) and v_R the robot's speed towards
    the body (Eq. 11). B is the stopping distance ``S_S`` (constant in the seed).
    """
    s = np.asarray(v_human, dtype=float) * (stopping_time + reaction_time)
    s = s + np.asarray(v_robot, dtype=float) * reaction_time
    s += stopping_distance + intrusion_distance + robot_uncertainty  # B + C + Z_r
    if isinstance(human_uncertainty, float | int) and human_uncertainty == 0:
        return s
    return s + human_uncertainty  # Z_d, possibly per body


def human_speed_term(
    v_human_directed: np.ndarray,
    mode: str,
    *,
    iso_speed: float = ISO_HUMAN_SPEED,
) -> np.ndarray:
    """The human speed entering S, by ``mode``.

    - ``estimated``: the Kalman filter's directed speed, as the seed does (Eq. 10);
      negative when the body moves away, which lowers S.
    - ``iso``: the constant ``iso_speed`` of ISO/TS 15066 Eq. 1 (2.0 m/s); the 1.6 m/s
      reduction is applied by :func:`iso_protective_separation_distance`.
    - ``estimated_with_floor``: the larger of the two.
    """
    v = np.asarray(v_human_directed, dtype=float)
    if mode == "estimated":
        return v
    if mode == "iso":
        return np.full_like(v, iso_speed)
    if mode == "estimated_with_floor":
        return np.maximum(v, iso_speed)
    raise ValueError(f"human_speed mode {mode!r} is not one of {HUMAN_SPEED_MODES}")


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
    """S_i for every body under a human-speed ``mode`` (see :func:`human_speed_term`).

    In ``iso`` mode, ISO 13855's rule is applied: if S computed with 2.0 m/s exceeds
    0.5 m, S is recomputed with 1.6 m/s but not taken below 0.5 m.
    """
    if mode == "estimated":  # the seed's (Eq. 10), the common case: S straight away
        return protective_separation_distance(
            v_human_directed, v_robot_directed, reaction_time=reaction_time,
            stopping_time=stopping_time, stopping_distance=stopping_distance,
            intrusion_distance=intrusion_distance, human_uncertainty=human_uncertainty,
            robot_uncertainty=robot_uncertainty)
    kwargs = {"reaction_time": reaction_time, "stopping_time": stopping_time,
              "stopping_distance": stopping_distance, "intrusion_distance": intrusion_distance,
              "human_uncertainty": human_uncertainty, "robot_uncertainty": robot_uncertainty}
    v_h = human_speed_term(v_human_directed, mode, iso_speed=iso_speed)
    s = protective_separation_distance(v_h, v_robot_directed, **kwargs)
    if mode == "iso":
        s_reduced = protective_separation_distance(
            np.full_like(v_h, iso_reduced_speed), v_robot_directed, **kwargs
        )
        s = np.where(
            s > ISO_REDUCED_SPEED_THRESHOLD,
            np.maximum(s_reduced, ISO_REDUCED_SPEED_THRESHOLD),
            s,
        )
    return s


def occlusion_margin(
    unseen_time: np.ndarray,
    velocity_estimate: np.ndarray,
    occlusion_speed: float,
) -> np.ndarray:
    """Extra uncertainty of bodies not measured for ``unseen_time`` seconds, metres.

    Not in the seed (its Z_d is constant). While a body is unseen its track coasts at
    the estimated velocity; the body itself may have moved anywhere within
    ``occlusion_speed`` (m/s) of where it was last measured. The estimate is then off by
    at most (occlusion_speed + |v_estimate|) * unseen_time, which this returns (0 when
    ``occlusion_speed`` is 0: the seed's behaviour). Shapes: (..., N) and (..., N, 3).
    """
    if occlusion_speed <= 0.0:
        return np.zeros(np.shape(unseen_time))
    v = np.asarray(velocity_estimate, dtype=float)
    speed = np.fmax(np.sqrt((v * v).sum(axis=-1)), 0.0)  # no estimate (NaN): 0
    return (occlusion_speed + speed) * np.asarray(unseen_time, dtype=float)


def human_uncertainty(
    base: float,
    sigmas: float,
    position_std: np.ndarray,
    unseen_time: np.ndarray,
    velocity_estimate: np.ndarray,
    occlusion_speed: float,
) -> np.ndarray | float:
    """Z_d of each body, metres: the configured ``base``, plus ``sigmas`` standard
    deviations of the track's position, plus :func:`occlusion_margin`. Terms that are
    switched off (``sigmas`` 0, ``occlusion_speed`` 0) are not computed, so the seed's
    constant Z_d stays the float ``base``."""
    z_d = base
    if sigmas:
        z_d = z_d + sigmas * np.asarray(position_std, dtype=float)
    if occlusion_speed > 0.0:
        z_d = z_d + occlusion_margin(unseen_time, velocity_estimate, occlusion_speed)
    return z_d


# Stand-ins for an infinite S_max (+-): beyond every finite distance, and (dS - 1) times
# them stays finite, so Eq. 12's arithmetic meets no inf - inf or 0 * inf.
_S_MAX_CAP = 1e100
# Where an untracked body is put when the closest body is looked for: beyond every real
# distance, but short of the cap, so that a faulty body's S_max still stops the robot.
_NOWHERE = 1e50


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
    s = np.fmax(np.fmin(s_max, _S_MAX_CAP), -_S_MAX_CAP)  # NaN and inf: +cap (stop)
    ramp = (d - s) / np.maximum((delta_s - 1.0) * s, 1e-12)  # an empty band: a step
    k = np.minimum(np.maximum(ramp, 0.0), 1.0)
    return np.where((d >= d_min) & (d < np.inf), k, 0.0)


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
    the bodies is k of the closest included body, which is what is computed.

    Returns ``(k, s_max)`` with the body axis (last) reduced.
    """
    d = np.asarray(distances, dtype=float)
    s = np.asarray(protective_distances, dtype=float)
    inc = np.asarray(included, dtype=bool)
    if d.ndim == 1 and s.ndim == 1 and inc.ndim == 1:  # one robot: plain floats are faster
        return _overall_speed_override_one(d, s, inc, delta_s, d_min)
    s_inc = np.where(inc, np.where(np.isfinite(d) & np.isfinite(s), s, np.inf), -np.inf)
    s_max = s_inc.max(axis=-1, initial=-np.inf)
    closest = np.where(inc, d, _NOWHERE).min(axis=-1)
    return speed_override(closest, s_max, delta_s=delta_s, d_min=d_min), s_max


def _overall_speed_override_one(d: np.ndarray, s: np.ndarray, inc: np.ndarray,
                                delta_s: float, d_min: float) -> tuple[np.float64, np.float64]:
    """``overall_speed_override`` for one robot (1-D arrays), in Python floats: the same
    rules (the tests hold the two to each other), several times faster for a few bodies."""
    d_inc, s_inc = d[inc].tolist(), s[inc].tolist()
    if not d_inc:  # nothing included
        return np.float64(1.0), np.float64(-math.inf)
    if not math.isfinite(sum(d_inc) + sum(s_inc)):  # a non-finite d_i or S_i: stop
        return np.float64(0.0), np.float64(math.inf)
    s_max, closest = max(s_inc), min(d_inc)
    if closest < d_min:
        return np.float64(0.0), np.float64(s_max)
    ramp = (closest - s_max) / max((delta_s - 1.0) * s_max, 1e-12)
    return np.float64(min(max(ramp, 0.0), 1.0)), np.float64(s_max)
