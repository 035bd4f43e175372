"""Sweeps and falsification over a scenario space (robustness >= 0 safe; we minimise it).

Points live in the unit cube over the space's free parameters
(``verification.space.to_point`` maps them to values).

- Sweeps: ``grid``, ``sobol``, ``halton``, ``uniform`` and ``corners`` (every vertex).
- Falsification (:func:`falsify`): candidates from the corners and a Sobol set are
  ranked by a cheap *danger score* from a reduced model of the loop, all candidates at
  once (the hand as the sensor shows it, Eqs. 9-12 on it, sensor faults from late or
  dropped frames, the robot's path rate through its acceleration limit and braking
  data; no Kalman filter, no noise, one hand: :func:`danger_scores`), and
  simulated in that order interleaved with plain Sobol order; then CMA-ES (the ``cma``
  package) minimises the closed-loop robustness from the best point found, each
  population simulated as one batch. The score only orders candidates and is not
  counted as a simulation; every verdict and every count of simulations
  rests on closed-loop simulations.
"""

import dataclasses
import functools
import itertools
import math

import cma
import numba
import numpy as np
from scipy.stats import qmc

from safety_systems import robot_geometry, separation, ssm
from safety_systems.braking import path_rate_step
from safety_systems.compiled_cache import drop_stale_builds
from safety_systems.configuration import (
    contact_body_radii,
    contact_capsules,
    monitor_capsules,
    monitored_body_radii,
)
from safety_systems.joint_path import joint_path_state
from safety_systems.operator_paths import stack_paths, stacked_position_velocity
from safety_systems.robot_geometry import (
    NUM_POINTS,
    capsule_ends_one,
    robot_points_one,
    segment_pair,
)
from safety_systems.scenario import ControllerConfig, actual_sensor
from safety_systems.separation import body_separation, capsule_axis
from safety_systems.ssm import _eq12
from safety_systems.workcell import (
    braking_table,
    frame_timeout,
    joint_path,
    monitor_terms,
    scripted_operators,
)
from verification.evaluate_batch import delivered_frames, dropout_table
from verification.properties import MOVING_SPEED
from verification.runner import Runner
from verification.space import (
    ScenarioSpace,
    corners,
    free_parameters,
    make_scenario,
    to_point,
)

SWEEPS = ("grid", "sobol", "halton", "uniform", "corners")
ESTIMATE_LAG = 0.05  # s by which the score lets an estimated hand speed lag the truth

# Its compiled functions inline the product's (see compiled_cache).
drop_stale_builds(__file__, (robot_geometry, separation, ssm))


def sweep_points(method: str, n: int, d: int, *, seed: int = 0) -> np.ndarray:
    """(m, d) points of the unit cube; m = n except for ``grid`` (the largest full grid
    of at most n points, at least 2 per axis) and ``corners`` (all 2^d)."""
    if d == 0:
        return np.zeros((1, 0))
    if method == "sobol":
        return qmc.Sobol(d, scramble=True, seed=seed).random(n)
    if method == "halton":
        return qmc.Halton(d, scramble=True, seed=seed).random(n)
    if method == "uniform":
        return np.random.default_rng(seed).uniform(size=(n, d))
    if method == "corners":
        return np.array(list(itertools.product((0.0, 1.0), repeat=d)))
    if method == "grid":
        per_axis = max(2, int(math.floor(n ** (1.0 / d) + 1e-9)))
        axis = np.linspace(0.0, 1.0, per_axis)
        return np.array(list(itertools.product(axis, repeat=d)))
    raise ValueError(f"method: got {method!r}; allowed: {' | '.join(SWEEPS)}")


def danger_scores(space: ScenarioSpace, config: ControllerConfig, points: np.ndarray,
                  *, step: float = 0.02, runner: Runner | None = None) -> np.ndarray:
    """``_danger_scores`` of the points, split over the runner's workers if given (the
    same scores: every part runs to the horizon of the whole set)."""
    robot_path = joint_path(space.robot)
    scenarios = [make_scenario(space, config, to_point(space, u), path=robot_path,
                               validate=False) for u in points]
    horizon = (max(s.duration for s in scenarios), max(s.robot.cycles for s in scenarios))
    parts = 1 if runner is None else max(1, min(runner.workers, len(points) // 256))
    if parts == 1:
        return _danger_scores(space, config, scenarios, step, horizon)
    cuts = np.array_split(np.arange(len(scenarios)), parts)
    return np.concatenate(runner.map(_danger_scores, [
        (space, config, scenarios[c[0]:c[-1] + 1], step, horizon) for c in cuts]))


@numba.njit(cache=True)
def _score_rows(q, v_joint, mine, real, p_m, v_m, tracked, ball, r_mine, truth, present,
                r_real, monitor, z_d, delta_s, d_min, k_out, gap_out, moving_out):
    """The reduced model's monitor and measure at one time for every candidate c,
    compiled, through the product's compiled functions: the robot's capsules
    (``robot_geometry``; ``mine`` the monitor's, ``real`` the contact geometry's, each
    (a, b, t0, t1, radius, tool length)) at q, v_joint (n, 6); k (Eq. 12 by ``ssm._eq12``
    over the ``tracked`` bodies p_m, v_m (n, N, 3), radii r_mine, Z_d ``z_d``, hidden
    balls ``ball``, d and S of each by ``separation.body_separation``; 1 with no tracked
    body, 0 on a NaN); the smallest clearance of the ``present`` true bodies ``truth`` to
    the real capsules; whether the robot moves (its fastest capsule end)."""
    ma, mb, mt0, mt1, m_radius, m_tool = mine
    ca, cb, ct0, ct1, c_radius, c_tool = real
    points, point_v = np.empty((NUM_POINTS, 3)), np.empty((NUM_POINTS, 3))
    m_ends, m_vel = np.empty((ma.size, 2, 3)), np.empty((ma.size, 2, 3))
    c_ends, c_vel = np.empty((ca.size, 2, 3)), np.empty((ca.size, 2, 3))
    still = (0.0, 0.0, 0.0)
    for c in range(q.shape[0]):
        robot_points_one(q[c], v_joint[c], m_tool, points, point_v)
        capsule_ends_one(points, point_v, ma, mb, mt0, mt1, m_ends, m_vel)
        d, top, any_tracked, faulty = np.inf, -np.inf, False, False
        for i in range(p_m.shape[1]):
            if tracked[c, i]:
                any_tracked = True
                d_i, s_i, _, _, _ = body_separation(p_m[c, i], v_m[c, i], r_mine[c, i], z_d,
                                                    ball[c, i], m_ends, m_vel, m_radius,
                                                    monitor)
                if math.isnan(d_i) or math.isnan(s_i):
                    faulty = True
                else:
                    d, top = min(d, d_i), max(top, s_i)
        k = 1.0
        if faulty:
            k = 0.0
        elif any_tracked:
            k = _eq12(d, top, delta_s, d_min)
        if c_tool != m_tool:
            robot_points_one(q[c], v_joint[c], c_tool, points, point_v)
        capsule_ends_one(points, point_v, ca, cb, ct0, ct1, c_ends, c_vel)
        speed, gap = 0.0, np.inf
        for j in range(ca.size):
            for e in range(2):
                w0, w1, w2 = c_vel[j, e, 0], c_vel[j, e, 1], c_vel[j, e, 2]
                speed = max(speed, math.sqrt(w0 * w0 + w1 * w1 + w2 * w2))
        for i in range(truth.shape[1]):
            if present[c, i] and speed > MOVING_SPEED:  # (it counts only then)
                p = (truth[c, i, 0], truth[c, i, 1], truth[c, i, 2])
                for j in range(ca.size):
                    end_a, end_b, vel_a, vel_b = capsule_axis(c_ends, c_vel, j)
                    axis = segment_pair(p, still, end_a, end_b, vel_a, vel_b)[0]
                    gap = min(gap, axis - c_radius[j] - r_real[c, i])
        k_out[c], gap_out[c], moving_out[c] = k, gap, speed > MOVING_SPEED


def _danger_scores(space: ScenarioSpace, config: ControllerConfig, scenarios: list,
                   step: float, horizon: tuple[float, int]) -> np.ndarray:
    """Danger score of each candidate scenario, m (lower is more dangerous; see module).

    A reduced model of the loop, every ``step`` seconds: the configured monitor (its
    capsules, or the tool point) is fed every body as the sensor would show it (one
    period plus the latency late; while occluded, the ball around where it was last
    seen, or, under the ``expire`` rule, nothing once it has been unseen for the coast
    time beyond the exit radius (a lost track nearer stops the robot); in outlier
    frames, displaced, unless the gate rejects them, which stops the robot; for
    ``estimated`` speeds, its directed speed ``ESTIMATE_LAG`` late) and commands k by
    Eqs. 9-12 over every capsule; k is 0 while the tracker's newest frame is older than
    the frame timeout (frames late beyond the configured latency, or dropped). The robot
    starts at rest and its path rate follows k through ``path_rate_step`` (acceleration
    limit and braking data). Controllers other than ``ssm_override`` are not modelled
    (k = 1 but for faults). The Kalman filter and noise are left out. ``horizon``:
    (duration, cycles) to run to.
    The robot follows its braked reference exactly, as in the kinematic mode, whatever
    the space's ``robot.mode`` (a dynamic robot tracks it within millimetres,
    ``tests/test_simulation.py``; its simulations run in the diagram, in its mode).
    The score is the closest a body comes to the real robot (the contact geometry)
    while the robot still moves. It only orders candidates; verdicts rest on the full
    closed-loop simulations.
    """
    n = len(scenarios)
    duration, cycles = horizon
    path = joint_path(dataclasses.replace(space.robot, cycles=cycles))
    end = path.cycle_time * cycles
    dt = 1.0 / space.robot.control_rate_hz
    ticks = max(1, round(step / dt))
    table = braking_table(config)
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
    mine, real = monitor_capsules(config), contact_capsules(space.robot, space.contact_geometry)
    r_mine = np.array([np.pad(monitored_body_radii(sc), (0, N - len(x)))
                       for sc, x in zip(scenarios, names)])
    r_real = np.array([np.pad(contact_body_radii(sc), (0, N - len(x)))
                       for sc, x in zip(scenarios, names)])
    # The tracker's frames: it looks at offset + j P; the newest frame delivered by then
    # (captured at i P, delivered latency later, unless dropped) is processed.
    period = 1.0 / config.sensor.rate_hz
    offset = config.sensor.latency + tr.processing_time
    timeout = frame_timeout(config)
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

    @functools.lru_cache(maxsize=1)  # ticks between two tracker looks share the frame
    def frame_seen(j: int) -> tuple[np.ndarray, np.ndarray]:
        """Index of the frame the tracker's look j processes, per candidate, and whether
        the gate rejects it (an outlier frame of any body)."""
        i = delivered_frames(np.full(n, offset + j * period), latency, period, drops)
        capture = (i * period)[:, None]
        rejected = tr.gate & present & (outlier[:, :, 0] <= capture) & (capture < outlier[:, :, 1])
        return i, np.any(rejected, axis=1)

    def fault(now: float) -> np.ndarray:
        j = math.floor((now - offset) / period + 1e-9)
        i, rejected = frame_seen(j)
        return (j < 0) | (i < 0) | (now - i * period > timeout) | rejected

    monitor = monitor_terms(config)
    mine_arrays = (mine.a, mine.b, mine.t0, mine.t1, mine.radius, mine.tool_length)
    real_arrays = (real.a, real.b, real.t0, real.t1, real.radius, real.tool_length)
    k_ssm, gap, moving = np.empty(n), np.empty(n), np.empty(n, dtype=np.bool_)
    s_path, rate = np.zeros(n), np.zeros(n)
    closest = np.full(n, np.inf)
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
        ball = f.occlusion_speed * unseen
        tracked, lost = present.copy(), np.zeros(n, dtype=bool)
        if expire:  # the previous rule: ended beyond the exit radius, else lost
            gone = hidden & (unseen > tr.max_coast_time)
            outside = np.hypot(p_m[:, :, 0], p_m[:, :, 1]) > tr.exit_radius
            tracked &= ~(gone & outside)
            lost = np.any(gone & ~outside & present, axis=1)
        truth = bodies(operators_at(np.full(n, now))[0]) + offsets
        _score_rows(q, v_joint, mine_arrays, real_arrays, p_m, v_m, tracked, ball, r_mine,
                    truth, present, r_real, monitor, float(f.human_uncertainty), f.delta_s,
                    f.d_min, k_ssm, gap, moving)
        # Other controllers (seed 004's, zones) are not modelled: they keep full speed;
        # a lost track stops the robot.
        command_now = np.where(lost, 0.0, k_ssm if config.type == "ssm_override" else 1.0)
        closest = np.where(moving, np.minimum(closest, gap), closest)
        for k in range(ticks):
            command = np.where(fault(now + k * dt), 0.0, command_now)
            new = path_rate_step(rate, command, dt, table=table,
                                 acceleration_limit=space.robot.acceleration_limit,
                                 time_scale=scale)
            s_path = np.clip(s_path + 0.5 * (rate + new) * dt, 0.0, end)
            rate = np.where(s_path >= end, 0.0, new)
    return closest


@dataclasses.dataclass
class SearchLog:
    """Every closed-loop evaluation of a search, in order."""

    points: list = dataclasses.field(default_factory=list)  # unit points
    figures: list = dataclasses.field(default_factory=list)  # FIELDS of runner

    @property
    def robustness(self) -> np.ndarray:
        """"Stopped before contact" of every simulation."""
        return self.column(0)

    def column(self, j: int) -> np.ndarray:
        """Figure ``j`` (a column of the runner's ``FIELDS``) of every simulation."""
        return np.array([f[j] for f in self.figures])

    def first_violation(self, j: int = 0) -> int | None:
        """Number of simulations up to and including the first violation of the property
        in column ``j`` (None if none)."""
        bad = np.flatnonzero(self.column(j) < 0.0)
        return int(bad[0]) + 1 if bad.size else None


def evaluate_points(space: ScenarioSpace, config: ControllerConfig, runner: Runner,
                    points: np.ndarray, log: SearchLog, objective: int = 0) -> np.ndarray:
    """Simulates the scenarios of ``points``; appends to ``log``; returns the figure in
    column ``objective`` (0: "stopped before contact")."""
    scenarios = [make_scenario(space, config, to_point(space, u)) for u in points]
    figures = runner.evaluate(scenarios)
    log.points.extend(np.asarray(points, dtype=float).tolist())
    log.figures.extend(figures.tolist())
    return figures[:, objective]


def falsify(space: ScenarioSpace, config: ControllerConfig, runner: Runner, *, budget: int,
            seed: int = 0, round_size: int = 5, candidates: int = 8192, explore: int = 10,
            stop_at_first: bool = False, objectives: tuple | list = (0,)) -> SearchLog:
    """Searches for the smallest robustness of each property in ``objectives`` (columns
    of the runner's figures; every simulation measures them all) with at most ``budget``
    simulations: first up to ``explore`` candidates in danger order (four ranked for one
    plain Sobol point), in rounds of ``round_size``; then, property by property, each
    with an even share of what is left, CMA-ES from the best point so far for it,
    restarted from the next candidates whenever it stops. ``stop_at_first`` ends a
    property's part at its first violation."""
    d = len(free_parameters(space))
    log = SearchLog()
    if d == 0:
        evaluate_points(space, config, runner, np.zeros((1, 0)), log)
        return log
    sobol = sweep_points("sobol", candidates, d, seed=seed)
    pool = np.vstack([corners(space) if d <= 10 else np.zeros((0, d)), sobol])
    ranked = pool[np.argsort(danger_scores(space, config, pool, runner=runner), kind="stable")]
    queue = _interleave(ranked, sobol, 4)

    def found(objective: int) -> bool:
        return stop_at_first and log.first_violation(objective) is not None

    explore = min(explore, budget)
    while (len(log.points) < explore and queue
           and not all(found(j) for j in objectives)):
        take = min(round_size, explore - len(log.points))
        batch, queue = np.array(queue[:take]), queue[take:]
        evaluate_points(space, config, runner, batch, log)
    for n, objective in enumerate(objectives):
        share = len(log.points) + (budget - len(log.points)) // (len(objectives) - n)
        restart = 0
        while len(log.points) < share and not found(objective) and (restart == 0 or queue):
            start = (np.asarray(log.points[int(np.argmin(log.column(objective)))])
                     if restart == 0 else np.asarray(queue.pop(0)))
            if not _cma(space, config, runner, log, start, share, seed + restart,
                        stop_at_first, objective):
                break
            restart += 1
    return log


def _interleave(ranked: np.ndarray, plain: np.ndarray, ratio: int) -> list:
    """``ratio`` ranked points for each plain one, without repeats."""
    out, seen = [], set()
    for i, p in enumerate(ranked):
        extra = [plain[i // ratio]] if i % ratio == ratio - 1 and i // ratio < len(plain) else []
        for q in [p] + extra:
            key = tuple(np.round(q, 12))
            if key not in seen:
                seen.add(key)
                out.append(q)
    return out


def _cma(space, config, runner, log, start, budget, seed, stop_at_first, objective=0) -> bool:
    """One CMA-ES run from ``start`` on the figure in column ``objective``; False when
    the budget leaves no room for it."""
    popsize = 6
    if budget - len(log.points) < popsize:
        return False
    options = {"bounds": [0.0, 1.0], "seed": seed + 1, "verbose": -9, "popsize": popsize,
               "tolfun": 1e-4, "tolx": 1e-4}
    es = cma.CMAEvolutionStrategy(np.clip(start, 0.0, 1.0).tolist(), 0.08, options)
    while not es.stop() and len(log.points) + popsize <= budget:
        xs = np.clip(np.array(es.ask()), 0.0, 1.0)
        values = evaluate_points(space, config, runner, xs, log, objective)
        es.tell(list(xs), [float(v) if math.isfinite(v) else 1e3 for v in values])
        if stop_at_first and log.first_violation(objective) is not None:
            break
    return True


def sweep(space: ScenarioSpace, config: ControllerConfig, runner: Runner, *, method: str,
          budget: int, seed: int = 0) -> SearchLog:
    """Evaluates a sweep of at most ``budget`` points (corners in danger order)."""
    d = len(free_parameters(space))
    points = sweep_points(method, budget, d, seed=seed)
    if method == "corners" and len(points) > 1:
        points = points[np.argsort(danger_scores(space, config, points), kind="stable")]
    log = SearchLog()
    evaluate_points(space, config, runner, points[:budget], log)
    return log
