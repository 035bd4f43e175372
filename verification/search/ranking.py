"""The falsifier's rankings: cheap models of the loop that score candidate scenarios all
at once, so that the search simulates the most dangerous first (robustness >= 0 safe;
a lower score is more dangerous). Each candidate scored by either is one evaluation of a
model of the loop: it is counted (``verification.search.counts``, kinds ``margins`` and
``dangers``) and priced (``counts.COST``).

:func:`bound_scores`, the falsifier's ranking: the proofs' margins
(``verification.proof.margins.margin``, one per property; under ``safety.stopping: by_speed``
the least over the speed levels' margins) evaluated pointwise, at each candidate's own
fastest speed, from its parameters alone (no scenario is built), less how far a hidden
hand can outrun its envelope where the configuration lets it (:func:`hidden_shortfall`):
microseconds per candidate, some thousand times cheaper than a
closed-loop simulation. It knows nothing of the geometry of an approach; it tells which
candidates' speeds come closest to breaking the theorem.

:func:`danger_scores`, the reduced model of the loop, steps the configured monitor and
the robot's braked path rate on the scenario as the sensor shows it (see
:func:`_danger_scores` for what it keeps and what it leaves out) and returns two scores
per candidate: the closest a body comes to the real robot while it moves ("stopped
before contact") and the smallest d_true - S_true while motion is permitted (the
separation invariant, on the true speeds and the simulated robot's own stopping data).
Under ``safety.stopping: by_speed`` it runs the by-speed override and S_true's stop from
the true rate, as the loop does. It sees the geometry of an approach, occlusions and
faults, and costs about as much as a batched closed-loop simulation of the same
candidate (it builds the scenario and steps it): the falsifier turns to it only after
the cheap ranking (``strategies.falsify``),
and ``sweep`` orders corners with it.
"""

import dataclasses
import functools
import math

import numba
import numpy as np

from safety_systems.cell.braking import path_follower_step
from safety_systems.cell.human_body import NUM_POINTS as BODY_POINTS
from safety_systems.cell.human_body import envelope_batch
from safety_systems.config.configuration import (
    contact_capsules,
    operator_postures,
    tracked_points,
)
from safety_systems.cell.joint_path import joint_path_state
from safety_systems.cell.operator_paths import stack_paths, stacked_position_velocity
from safety_systems.cell.model_points import model_arrays, model_points_one, model_work
from safety_systems.cell.robot_geometry import (
    capsule_ends_one,
    segments_pair,
)
from safety_systems.config.resolved_cell import ResolvedCell
from safety_systems.config.scenario import ControllerConfig, actual_sensor
from safety_systems.sensing.tracks import TRACK_HIDDEN, TRACK_NONE, TRACK_TRACKING, usable
from safety_systems.ssm.separation import (
    capsule_axis,
    segment_levels,
    segment_of,
    segment_separation,
)
from safety_systems.ssm.formulas import speed_scale_eq12, by_speed_command, level_at_or_above
from safety_systems.config.configuration import joint_path, scripted_operators
from verification.search.counts import Tally
from verification.search.evaluate_batch import (
    _truth_segments,
    delivered_frames,
    dropout_table,
    true_stopping_by_rate,
    true_stopping_terms,
)
from safety_systems.ssm.true_measures import is_moving, true_margin
from verification.spaces.box import NAMES, WHOLE, ScenarioSpace
from verification.spaces.space import (
    free_parameters,
    lower_upper,
    make_scenario,
    to_point,
)

ESTIMATE_LAG = 0.05  # s by which the score lets an estimated hand speed lag the truth



SCORES = ("contact", "separation")  # the columns of both rankings, by property


def unit_values(space: ScenarioSpace, points: np.ndarray, name: str) -> np.ndarray:
    """Parameter ``name``'s value at each of the (n, d) unit points, as
    ``space.to_point`` maps them (rounded where it rounds), without building dicts."""
    lo, hi = lower_upper(space)
    i = NAMES.index(name)
    free = free_parameters(space)
    if name not in free:
        values = np.full(len(points), lo[i])
    else:
        u = np.clip(np.asarray(points, dtype=float)[:, free.index(name)], 0.0, 1.0)
        values = lo[i] + u * (hi[i] - lo[i])
    return np.round(values) if name in WHOLE else values


def hand_speeds(space: ScenarioSpace, points: np.ndarray) -> np.ndarray:
    """The fastest each candidate's approaching hand moves: its last leg (the retreat,
    the start distance and the overshoot) run rest to rest at its peak speed and
    acceleration (``operator_paths.segment_profile``'s peak)."""
    return np.minimum(unit_values(space, points, "peak_speed"),
                      np.sqrt(last_leg(space, points) * unit_values(space, points,
                                                                     "acceleration")))


def last_leg(space: ScenarioSpace, points: np.ndarray) -> np.ndarray:
    """(n,) m: the approaching hand's last leg, towards the robot: the retreat walked back,
    the start distance and the overshoot."""
    return sum(unit_values(space, points, x) for x in ("retreat_distance", "start_distance",
                                                       "overshoot"))


def bound_scores(space: ScenarioSpace, cell: ResolvedCell, points: np.ndarray, *,
                 tally: Tally | None = None) -> np.ndarray:
    """(n, 2) the proofs' margins (columns ``SCORES``; ``proof.margins.margin``) at each
    candidate's own v_max (:func:`hand_speeds`; the margins no longer depend on the noise,
    which the envelopes' allowance covers): our reading of "the proof's margin evaluated
    pointwise", for the configuration resolved in ``cell`` (``spaces.space.space_cell``).
    It orders candidates; it proves nothing (where a premise fails it bounds nothing).
    Counted in ``tally``."""
    from verification.proof.margins import margin  # (z3 and the proofs' bounds, on first use)

    points = np.asarray(points, dtype=float).reshape(len(points), -1)
    if tally is not None:
        tally.add("margins", len(points))
    v = hand_speeds(space, points)
    scores = np.stack([margin(cell, space, prop).at(v) for prop in SCORES], axis=1)
    return scores - hidden_shortfall(space, cell.config, points, v)[:, None]


def hidden_shortfall(space: ScenarioSpace, config: ControllerConfig, points: np.ndarray,
                     v: np.ndarray) -> np.ndarray:
    """(n,) how far, m, a candidate's hidden hand can get out of its envelope: the
    margins assume a hidden body's ball grows at least as fast as the body moves (a
    premise of the proofs). Where the configuration's ``occlusion_speed`` is slower than
    the candidate's hand speed v and the occlusion hides every tracked body of the
    operator (else the seen ones bound the hand within an arm's reach), the hand gains
    (v - occlusion_speed) per second for as long as it is hidden (its occlusion and
    dropout, from the onset) while it comes towards the robot (after the walk away of a
    retreat, then over the retreat, the start distance and the overshoot, at v), and
    the margin is that much smaller. Zero where the premise holds; our reading, for
    ranking only (it proves nothing)."""
    gain = np.maximum(0.0, v - config.safety.occlusion_speed)
    everyone = (unit_values(space, points, "occluded_bodies")
                >= 2.0 + unit_values(space, points, "heads"))
    gain = np.where(everyone, gain, 0.0)
    if not gain.any():
        return gain
    hidden = unit_values(space, points, "occlusion") + unit_values(space, points, "dropout")
    retreat = unit_values(space, points, "retreat_distance")
    speed = np.maximum(v, 1e-9)
    return gain * np.clip(hidden - retreat / speed, 0.0, last_leg(space, points) / speed)


def margin_corner(space: ScenarioSpace, cell: ResolvedCell, columns, *,
                  sweeps: int = 3, tally: Tally | None = None) -> dict:
    """Where the proofs' margins are least, found by coordinate search on
    :func:`bound_scores` (every candidate scored is counted in ``tally``): from the
    centre of the unit cube, each sweep scores the points that move one parameter to
    either end of its range; every parameter whose two ends score apart goes to the
    lower, and the sweeps repeat from there until nothing moves. Returns, for each
    score column in ``columns`` (``SCORES``), ``(corner, moves)``: the unit point and
    which parameters move that margin (none where its premises give no finite margin:
    then it orders nothing). Both columns are read from the same scorings."""
    d = len(free_parameters(space))
    found = {c: (np.full(d, 0.5), np.zeros(d, dtype=bool)) for c in columns}
    for _ in range(sweeps):
        probes = []
        for c in columns:
            base = found[c][0]
            for i in range(d):
                for end in (0.0, 1.0):
                    p = base.copy()
                    p[i] = end
                    probes.append(p)
        unique, back = np.unique(np.array(probes).reshape(-1, d), axis=0,
                                 return_inverse=True)
        scores = bound_scores(space, cell, unique, tally=tally)[back.ravel()]
        moved = False
        for n, c in enumerate(columns):
            base, moves = found[c]
            ends = scores[n * 2 * d:(n + 1) * 2 * d, c].reshape(d, 2)
            apart = np.isfinite(ends).all(axis=1) & (np.abs(ends[:, 0] - ends[:, 1]) > 1e-9)
            lower = np.where(ends[:, 1] < ends[:, 0], 1.0, 0.0)
            new = np.where(apart, lower, base)
            moved |= bool(np.any(new != base))
            found[c] = (new, moves | apart)
        if not moved:
            break
    return found


def danger_scores(space: ScenarioSpace, cell: ResolvedCell, points: np.ndarray,
                  *, step: float = 0.02, runner=None, tally: Tally | None = None
                  ) -> np.ndarray:
    """(n, 2) ``_danger_scores`` of the n points (columns ``SCORES``) for the
    configuration resolved in ``cell`` (``spaces.space.space_cell``), split over the
    runner's workers if given (the same scores: every part runs to the horizon of the
    whole set, and no candidate's score depends on another's; each part takes the cell
    with its scenarios). Every candidate scored is counted in ``tally`` (default: the
    runner's, if any)."""
    tally = runner.tally if tally is None and runner is not None else tally
    robot_path = joint_path(space.robot)
    scenarios = [make_scenario(space, cell.config, to_point(space, u), path=robot_path,
                               validate=False) for u in points]
    if not scenarios:
        return np.zeros((0, len(SCORES)))
    cell.check_scenario(scenarios[0], "danger_scores")
    if tally is not None:
        tally.add("dangers", len(scenarios))
    horizon = (max(s.duration for s in scenarios), max(s.robot.cycles for s in scenarios))
    parts = 1 if runner is None else max(1, min(runner.workers, len(points) // 256))
    if parts == 1:
        return _danger_scores(space, cell, scenarios, step, horizon)
    cuts = np.array_split(np.arange(len(scenarios)), parts)
    return np.concatenate(runner.map(_danger_scores, [
        (space, cell, scenarios[c[0]:c[-1] + 1], step, horizon) for c in cuts]))


@numba.njit(cache=True)
def _score_rows(q, v_joint, mine, real, h_ends, h_vel, h_radius, h_status, truth, truth_v,
                present, r_real, monitor, truth_t, truth_b, z_d, delta_s, d_min, free,
                levels, rate, truth_rates, k_out, gap_out, margin_out, moving_out, robot,
                work):
    """The reduced model's monitor and measure at one time for every candidate c,
    compiled, through the product's compiled functions: the robot's capsules
    (``robot_geometry``; ``mine`` the monitor's, ``real`` the contact geometry's, each
    (a, b, t0, t1, radius, tool length)) at q, v_joint (n, joints), its points by
    ``model_points.model_points_one`` (``robot`` its ``model_arrays``, ``work`` its work
    arrays, the points and their velocities); k (Eq. 12 by
    ``ssm.speed_scale_eq12`` over the usable segments (``h_status``), the monitor's
    envelopes h_ends, h_vel (n, M, 2, 3), radii h_radius, Z_d ``z_d``, d and S of each by
    ``separation.segment_separation``; 1 with no usable segment, 0 on a NaN or a lost
    operator); the smallest clearance of the ``present`` true segments ``truth`` (ends
    (n, T, 2, 3), radii r_real (T,)) to the real capsules; the smallest d_true - S_true
    over them (S_true: Eqs. 9-11 by ``true_measures.true_margin`` on the true directed
    speeds (``truth_v`` (n, T, 3) each segment's velocity), no Z_d or Z_r, the robot's
    own stopping time ``truth_t`` and distance ``truth_b`` (n,) with T_r and C folded in,
    as ``evaluate_batch`` measures it);
    whether the robot moves (its fastest capsule end). The two figures are computed
    only where they count: the clearance while the robot moves, the margin where
    ``free`` (no fault, no lost track, within the candidate's time; the row's k, if it
    is its command (``free`` of 2), > 0); inf elsewhere.

    ``safety.stopping: by_speed`` (``levels`` = the cell's ``level_terms``, empty
    otherwise): k by ``ssm.by_speed_command`` from every tracked body's S at each level
    (``separation.segment_levels``) and the path rate now ``rate`` (n,), and S_true's stop
    from the grid rate at or above it, ``truth_rates`` ((n, G_true + 1) times and
    distances, T_r and C folded in), as the batched evaluator runs them."""
    mode, iso, iso_reduced, t_r = monitor[0], monitor[4], monitor[5], monitor[2]
    ma, mb, mt0, mt1, m_radius, m_tool = mine
    ca, cb, ct0, ct1, c_radius, c_tool = real
    level_t_sr, level_const = levels
    by_speed = level_t_sr.size > 0
    truth_rt, truth_rb = truth_rates
    n_bodies = h_radius.shape[1]
    s_levels = np.empty((max(level_t_sr.size, 1), n_bodies))
    d_row = np.empty(n_bodies)
    included = np.empty(n_bodies, np.bool_)
    memo, poses, twists, points, point_v = work
    m_ends, m_vel = np.empty((ma.size, 2, 3)), np.empty((ma.size, 2, 3))
    c_ends, c_vel = np.empty((ca.size, 2, 3)), np.empty((ca.size, 2, 3))
    for c in range(q.shape[0]):
        memo[:] = np.nan  # (a UR's trigonometry: each candidate's own q)
        model_points_one(robot, m_tool, q[c], v_joint[c], memo, poses, twists, points, point_v)
        capsule_ends_one(points, point_v, ma, mb, mt0, mt1, m_ends, m_vel)
        d, top, any_tracked, faulty = np.inf, -np.inf, False, False
        for i in range(n_bodies):
            if usable(h_status[c, i]):
                any_tracked = True
                segment = segment_of(h_ends[c], h_vel[c], i)
                d_i, s_i, _, _, _ = segment_separation(segment, h_radius[c, i], z_d, m_ends,
                                                       m_vel, m_radius, monitor)
                d_row[i] = d_i
                if by_speed:
                    segment_levels(segment, h_radius[c, i], z_d, m_ends, m_vel, m_radius,
                                   monitor, level_t_sr, level_const, s_levels, i)
                if math.isnan(d_i) or math.isnan(s_i):
                    faulty = True
                else:
                    d, top = min(d, d_i), max(top, s_i)
            elif h_status[c, i] != TRACK_NONE:  # a lost operator (or one seen in part)
                faulty = True
        k = 1.0
        if by_speed:
            k = by_speed_command(d_row, s_levels, h_status[c], 0.0, rate[c], delta_s, d_min,
                                 included)[0]
        elif faulty:
            k = 0.0
        elif any_tracked:
            k = speed_scale_eq12(d, top, delta_s, d_min)
        stop_t, stop_b = truth_t[c], truth_b[c]
        if by_speed:  # the stop from the rate now (metrics.true_protective_distances)
            g = level_at_or_above(rate[c], truth_rt.shape[1] - 1)
            stop_t, stop_b = truth_rt[c, g], truth_rb[c, g]
        if c_tool != m_tool:
            model_points_one(robot, c_tool, q[c], v_joint[c], memo, poses, twists, points,
                             point_v)
        capsule_ends_one(points, point_v, ca, cb, ct0, ct1, c_ends, c_vel)
        speed, gap, margin = 0.0, np.inf, np.inf
        for j in range(ca.size):
            for e in range(2):
                w0, w1, w2 = c_vel[j, e, 0], c_vel[j, e, 1], c_vel[j, e, 2]
                speed = max(speed, math.sqrt(w0 * w0 + w1 * w1 + w2 * w2))
        moving = is_moving(speed)
        allowed = free[c] == 1 or (free[c] == 2 and k > 0.0)
        for i in range(truth.shape[1]):
            if present[c, i] and (moving or allowed):
                P = (truth[c, i, 0, 0], truth[c, i, 0, 1], truth[c, i, 0, 2])
                Q = (truth[c, i, 1, 0], truth[c, i, 1, 1], truth[c, i, 1, 2])
                v = (truth_v[c, i, 0], truth_v[c, i, 1], truth_v[c, i, 2])
                for j in range(ca.size):
                    end_a, end_b, vel_a, vel_b = capsule_axis(c_ends, c_vel, j)
                    axis, vh, vr = segments_pair(P, Q, v, v, end_a, end_b, vel_a, vel_b)
                    clearance = axis - c_radius[j] - r_real[i]
                    if moving:
                        gap = min(gap, clearance)
                    if allowed:
                        margin = min(margin, true_margin(
                            clearance, vh, vr, mode, stop_t, t_r, stop_b, iso, iso_reduced))
        k_out[c], gap_out[c], margin_out[c], moving_out[c] = k, gap, margin, moving


@numba.njit(cache=True)
def _follow(s, rate, command, stale, end, scale, dt, fractions, deceleration, acceleration):
    """The PathFollower's ticks (``braking.path_follower_step``) of every candidate c over
    one step of the reduced model, in place: command[c], or 0 at the ticks where
    ``stale`` (ticks, n) holds."""
    for c in range(s.size):
        for k in range(stale.shape[0]):
            s[c], rate[c] = path_follower_step(s[c], rate[c], 0.0 if stale[k, c] else command[c],
                                          end, scale[c], dt, fractions, deceleration,
                                          acceleration, 1.0)


def _danger_scores(space: ScenarioSpace, cell: ResolvedCell, scenarios: list,
                   step: float, horizon: tuple[float, int]) -> np.ndarray:
    """(n, 2) danger scores of the candidate scenarios of the configuration resolved in
    ``cell``, m (lower is more dangerous; the columns ``SCORES``).

    A reduced model of the loop, every ``step`` seconds: the configured monitor (its
    capsules, or the tool point) is fed every body as the sensor would show it (one
    period plus the latency late; while occluded, the ball around where it was last
    seen, or, under the ``expire`` rule, nothing once it has been unseen for the coast
    time beyond the exit radius (a lost track nearer stops the robot); in outlier
    frames, displaced, unless the gate rejects them, which stops the robot; for
    ``estimated`` speeds, its directed speed ``ESTIMATE_LAG`` late) and commands k by
    Eqs. 9-12 over every capsule (``safety.stopping: by_speed``: one of the speed levels
    by ``ssm.by_speed_command`` at the path rate now, and S_true from the stop at the
    true rate; see :func:`_score_rows`); k is 0 while the tracker's newest frame is older than
    the frame timeout (frames late beyond the configured latency, or dropped). The robot
    starts at rest and its path rate follows k through ``path_follower_step`` (acceleration
    limit and braking data). Controllers other than ``ssm_override`` are not modelled
    (k = 1 but for faults). The Kalman filter and noise are left out. ``horizon``:
    (duration, cycles) to run to.
    The robot follows its braked reference exactly, as in the kinematic mode, whatever
    the space's ``robot.mode`` (a dynamic robot tracks it within millimetres,
    ``tests/test_simulation.py``; its simulations run in the diagram, in its mode).
    The contact score is the closest a body comes to the real robot (the contact
    geometry) while the robot still moves; the separation score the smallest d_true -
    S_true (see :func:`_score_rows`) while k > 0 and no fault holds; each within the
    candidate's own duration. They only order candidates; verdicts rest on the full
    closed-loop simulations.
    """
    n = len(scenarios)
    duration, cycles = horizon
    path = joint_path(dataclasses.replace(space.robot, cycles=cycles))
    end = path.end  # its cycles, or one for a one-way path
    dt = 1.0 / space.robot.control_rate_hz
    ticks = max(1, round(step / dt))
    config, model, table = cell.config, cell.model, cell.braking
    t = np.arange(0.0, duration + step, ticks * dt)
    f, tr = config.safety, config.tracker
    # Every candidate's operators (padded to the most by repeating its first, absent) and
    # bodies (padded likewise).
    ops = [scripted_operators(sc) for sc in scenarios]
    K = max(len(o) for o in ops)
    stack = stack_paths([o[min(j, len(o) - 1)].path for o in ops for j in range(K)])
    names = [[f"{op.name}/{b.name}" for op in sc.operators for b in op.bodies]
             for sc in scenarios]
    N = max(len(x) for x in names)
    body_op = np.zeros((n, N), dtype=int)
    offsets = np.zeros((n, N, 3))
    present = np.zeros((n, N), dtype=bool)
    occ = np.full((n, N, 2), np.inf)
    outlier = np.full((n, N, 5), np.inf)
    outlier[:, :, 2:] = 0.0
    for c, (sc, cand) in enumerate(zip(scenarios, names)):
        rows = [(j, b) for j, op in enumerate(sc.operators) for b in op.bodies]
        for i, (j, body) in enumerate(rows):
            body_op[c, i], offsets[c, i], present[c, i] = j, body.offset, True
        for o in sc.sensor.occlusions:
            occ[c, cand.index(o.body)] = (o.start, o.end)
        for o in sc.sensor.faults:
            if o.kind == "outlier":
                outlier[c, cand.index(o.body)] = (o.start, o.end, *o.offset)
    sensors = [actual_sensor(sc) for sc in scenarios]
    latency = np.array([s.latency for s in sensors])
    delay = (1.0 / config.sensor.rate_hz + latency)[:, None]
    lag = 0.0 if f.human_speed == "iso" else ESTIMATE_LAG
    drops = dropout_table(sensors)
    mine = cell.capsules
    real = contact_capsules(space.robot, space.contact_geometry)
    # The monitor's envelopes, by the candidates' tracked points (a recipe per kind), and
    # each operator's true segments (the same for every candidate: 12 per operator).
    groups: dict = {}
    for c, sc in enumerate(scenarios):
        groups.setdefault(tuple(map(tuple, tracked_points(sc))), []).append(c)
    recipes = {key: cell.recipe_for(key) for key in groups}
    M = max(r.radius.size for r in recipes.values())
    seg_a, seg_b, r_segment = _truth_segments(scenarios[:1])
    per = seg_a.size  # true segments per operator
    r_real = np.tile(r_segment, K)
    postures = np.zeros((n, K, BODY_POINTS, 3))
    for c, sc in enumerate(scenarios):
        own = operator_postures(sc)
        postures[c] = own[np.minimum(np.arange(K), len(own) - 1)]
    op_present = np.array([[j < len(sc.operators) for j in range(K)] for sc in scenarios])
    seg_present = np.repeat(op_present, per, axis=1)
    # The tracker's frames: it looks at offset + j P; the newest frame delivered by then
    # (captured at i P, delivered latency later, unless dropped) is processed.
    period = 1.0 / config.sensor.rate_hz
    offset = config.sensor.latency + tr.processing_time
    timeout = cell.frame_timeout
    scale = np.array([sc.robot.braking_time_scale for sc in scenarios])
    expire = tr.hidden_bodies == "expire"

    rows = np.arange(n)[:, None] * K + body_op  # each body's operator in the stack

    def operators_at(when: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions and velocities (n, K, 3) of every operator at times when (n,)."""
        p, v = stacked_position_velocity(stack, np.repeat(when, K))
        return p.reshape(n, K, 3), v.reshape(n, K, 3)

    def bodies(points: np.ndarray) -> np.ndarray:
        """(n, N, 3) each body's row of (n, K, 3) operator figures."""
        return points.reshape(n * K, 3)[rows]

    # Hidden bodies are frozen where their occlusion began: once, up front.
    frozen = np.where(np.isfinite(occ[:, :, 0]), occ[:, :, 0], 0.0)
    p_frozen = stacked_position_velocity(stack, frozen.ravel(), rows.ravel())[0].reshape(
        n, N, 3) + offsets
    v_frozen = stacked_position_velocity(stack, np.maximum(frozen - lag, 0.0).ravel(),
                                         rows.ravel())[1].reshape(n, N, 3)

    @functools.lru_cache(maxsize=4)  # ticks between two tracker looks share the frame
    def frame_seen(j: int) -> tuple[np.ndarray, np.ndarray]:
        """Index of the frame the tracker's look j processes, per candidate, and whether
        the gate rejects it (an outlier frame of any body)."""
        i = delivered_frames(np.full(n, offset + j * period), latency, period, drops)
        capture = (i * period)[:, None]
        rejected = tr.gate & present & (outlier[:, :, 0] <= capture) & (capture < outlier[:, :, 1])
        return i, np.any(rejected, axis=1)

    def faults(now: float) -> np.ndarray:
        """(ticks, n): whether each candidate's tracker is in fault at the ticks of the
        step from ``now`` (the look in force: its frame too old, none yet, or rejected)."""
        when = now + dt * np.arange(ticks)
        looks = np.floor((when - offset) / period + 1e-9).astype(int)
        out = np.empty((ticks, n), dtype=np.bool_)
        for j in np.unique(looks):
            rows = looks == j
            i, rejected = frame_seen(int(j))
            out[rows] = ((j < 0) | (i < 0)[None, :]
                         | (when[rows, None] - (i * period)[None, :] > timeout)
                         | rejected[None, :])
        return out

    monitor = cell.monitor_terms
    robot_arrays = model_arrays(model)
    work = (*model_work(model), np.empty((model.num_points, 3)),
            np.empty((model.num_points, 3)))  # (memo, poses, twists, points, velocities)
    mine_arrays = (mine.a, mine.b, mine.t0, mine.t1, mine.radius, mine.tool_length)
    real_arrays = (real.a, real.b, real.t0, real.t1, real.radius, real.tool_length)
    truth_t, truth_b = true_stopping_terms(scenarios, cell)
    by_speed = f.stopping == "by_speed"
    levels = cell.level_terms if by_speed else (np.empty(0), np.empty(0))
    truth_rates = true_stopping_by_rate(scenarios, cell) if by_speed \
        else (np.empty((n, 1)), np.empty((n, 1)))
    ends = np.array([sc.duration for sc in scenarios])
    k_ssm, gap, margin = np.empty(n), np.empty(n), np.empty(n)
    moving = np.empty(n, dtype=np.bool_)
    s_path, rate = np.zeros(n), np.zeros(n)
    closest, smallest = np.full(n, np.inf), np.full(n, np.inf)
    ssm_only = config.type == "ssm_override"
    for now in t:  # the monitor's view at each time, for every candidate
        q, dq, _ = joint_path_state(path, s_path)
        v_joint = dq * rate[:, None]
        seen = np.maximum(now - delay[:, 0], 0.0)  # (n,): when the shown frame was captured
        seen_at = np.broadcast_to(seen[:, None], (n, N))
        hidden = (seen_at >= occ[:, :, 0]) & (seen_at < occ[:, :, 1])
        p_seen, v_seen = operators_at(seen)
        p_m = np.where(hidden[:, :, None], p_frozen, bodies(p_seen) + offsets)
        if lag:
            v_seen = operators_at(np.maximum(seen - lag, 0.0))[1]
        v_m = np.where(hidden[:, :, None], v_frozen, bodies(v_seen))
        if not tr.gate:  # outlier frames taken as truth
            ghost = (outlier[:, :, 0] <= seen_at) & (seen_at < outlier[:, :, 1]) & ~hidden
            p_m = p_m + np.where(ghost[:, :, None], outlier[:, :, 2:], 0.0)
        unseen = np.where(hidden, seen_at - occ[:, :, 0], 0.0)
        tracked, lost = present.copy(), np.zeros(n, dtype=bool)
        if expire:  # the previous rule: ended beyond the exit radius, else lost
            gone = hidden & (unseen > tr.max_coast_time)
            outside = np.hypot(p_m[:, :, 0], p_m[:, :, 1]) > tr.exit_radius
            tracked &= ~(gone & outside)
            lost = np.any(gone & ~outside & present, axis=1)
        status = np.where(tracked, np.where(hidden, TRACK_HIDDEN, TRACK_TRACKING),
                          TRACK_NONE).astype(float)
        h_ends, h_vel = np.full((n, M, 2, 3), np.nan), np.full((n, M, 2, 3), np.nan)
        h_radius, h_status = np.full((n, M), np.nan), np.full((n, M), float(TRACK_NONE))
        for key, rows_g in groups.items():
            r, idx = recipes[key], np.array(rows_g)
            m = r.radius.size
            out = (np.empty((idx.size, m, 2, 3)), np.empty((idx.size, m, 2, 3)),
                   np.empty((idx.size, m)), np.empty((idx.size, m)), np.empty((idx.size, m)))
            envelope_batch(r.regions, r.candidates, r.radius, r.operator, r.slots,
                           np.ascontiguousarray(p_m[idx]), np.ascontiguousarray(v_m[idx]),
                           status[idx], np.zeros((idx.size, N)), unseen[idx],
                           float(config.body.tracking_allowance), float(f.occlusion_speed),
                           *out)
            h_ends[idx, :m], h_vel[idx, :m], h_radius[idx, :m], h_status[idx, :m] = out[:4]
        p_now, v_now = operators_at(np.full(n, now))
        points_now = p_now[:, :, None, :] + postures  # (n, K, 10, 3)
        truth = np.stack([points_now[:, :, seg_a], points_now[:, :, seg_b]], axis=3).reshape(
            n, K * per, 2, 3)
        truth_v = np.repeat(v_now, per, axis=1)
        stale = faults(now)
        inside = now <= ends + 1e-9  # (each candidate only over its own duration)
        # Motion is permitted at this tick (free 1), or if its k > 0 (free 2): the
        # separation score counts only then. Other controllers (seed 004's, zones) are
        # not modelled: they keep full speed; a lost track stops the robot.
        free = np.where(inside & ~stale[0] & ~lost, 2 if ssm_only else 1, 0).astype(np.int64)
        _score_rows(q, v_joint, mine_arrays, real_arrays, h_ends, h_vel, h_radius, h_status,
                    truth, truth_v, seg_present, r_real, monitor, truth_t, truth_b,
                    float(f.human_uncertainty), f.delta_s, f.d_min, free, levels, rate,
                    truth_rates, k_ssm, gap, margin, moving, robot_arrays, work)
        command_now = np.where(lost, 0.0, k_ssm if ssm_only else 1.0)
        closest = np.where(moving & inside, np.minimum(closest, gap), closest)
        smallest = np.minimum(smallest, margin)
        _follow(s_path, rate, command_now, stale, end, scale, dt, table.speed_fraction,
                table.deceleration, space.robot.acceleration_limit)
    return np.stack([closest, smallest], axis=1)


