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
import numpy as np
from scipy.stats import qmc

from safety_systems.braking import path_rate_step
from safety_systems.joint_path import joint_path_state
from safety_systems.operator_paths import stack_paths, stacked_position_velocity
from safety_systems.scenario import ControllerConfig, actual_sensor
from safety_systems.ssm import (
    directed_speeds,
    monitor_protective_distances,
    speed_override,
)
from safety_systems.ur5e import tool0_position_and_velocity
from safety_systems.workcell import (
    assumed_stopping,
    braking_table,
    frame_timeout,
    joint_path,
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


def _danger_scores(space: ScenarioSpace, config: ControllerConfig, scenarios: list,
                   step: float, horizon: tuple[float, int]) -> np.ndarray:
    """Danger score of each candidate scenario, m (lower is more dangerous; see module).

    A reduced model of the loop, every ``step`` seconds: the configured monitor is fed
    the first operator's hand as the sensor would show it (one period plus the latency
    late; while occluded, the ball around where it was last seen; for ``estimated`` speeds, the hand's
    directed speed ``ESTIMATE_LAG`` late) and commands k by Eqs. 9-12; k is 0 while the
    tracker's newest frame is older than the frame timeout (frames late beyond the
    configured latency, or dropped). The robot starts at rest and its path rate follows
    k through ``path_rate_step`` (acceleration limit and braking data). Controllers
    other than ``ssm_override`` are not modelled (k = 1 but for faults). The Kalman
    filter, noise and the other bodies are left out. ``horizon``: (duration, cycles)
    to run to.
    The score is the closest the hand comes to the tool while the tool still moves. It
    only orders candidates; verdicts rest on the full closed-loop simulations.
    """
    n = len(scenarios)
    duration, cycles = horizon
    path = joint_path(dataclasses.replace(space.robot, cycles=cycles))
    end = path.cycle_time * cycles
    dt = 1.0 / space.robot.control_rate_hz
    ticks = max(1, round(step / dt))
    table = braking_table(config)
    t = np.arange(0.0, duration + step, ticks * dt)
    stack = stack_paths([scripted_operators(sc)[0].path for sc in scenarios])
    f = config.safety
    sensors = [actual_sensor(sc) for sc in scenarios]
    latency = np.array([s.latency for s in sensors])
    delay = 1.0 / config.sensor.rate_hz + latency
    lag = np.where(f.human_speed == "iso", 0.0, ESTIMATE_LAG)
    occ = np.array([[o.start, o.end] if (o := next(iter(sc.sensor.occlusions), None)) else
                    [np.inf, np.inf] for sc in scenarios])
    drops = dropout_table(sensors)
    # The tracker's frames: it looks at offset + j P; the newest frame delivered by then
    # (captured at i P, delivered latency later, unless dropped) is processed.
    period = 1.0 / config.sensor.rate_hz
    offset = config.sensor.latency + config.tracker.processing_time
    timeout = frame_timeout(config)
    scale = np.array([sc.robot.braking_time_scale for sc in scenarios])

    @functools.lru_cache(maxsize=1)  # ticks between two tracker looks share the frame
    def frame_seen(j: int) -> np.ndarray:
        """Index of the frame the tracker's look j processes, per candidate."""
        return delivered_frames(np.full(n, offset + j * period), latency, period, drops)

    def fault(now: float) -> np.ndarray:
        j = math.floor((now - offset) / period + 1e-9)
        i = frame_seen(j)
        return (j < 0) | (i < 0) | (now - i * period > timeout)

    t_s, b = assumed_stopping(config)
    s_path, rate = np.zeros(n), np.zeros(n)
    closest = np.full(n, np.inf)
    for now in t:  # the monitor's view at each time, for every candidate
        q, dq, _ = joint_path_state(path, s_path)
        tool, tool_v = tool0_position_and_velocity(q, dq * rate[:, None])
        seen_at = np.maximum(now - delay, 0.0)
        hidden = (seen_at >= occ[:, 0]) & (seen_at < occ[:, 1])
        base = np.where(hidden, occ[:, 0], seen_at)
        p_m = stacked_position_velocity(stack, base)[0]  # frozen while hidden
        v_m = stacked_position_velocity(stack, np.maximum(base - lag, 0.0))[1]
        ball = f.occlusion_speed * np.where(hidden, seen_at - base, 0.0)
        d = np.linalg.norm(p_m - tool, axis=-1) - ball
        v_h, v_r = directed_speeds(tool, tool_v, p_m[:, None], v_m[:, None])
        S = monitor_protective_distances(
            v_h[:, 0], v_r[:, 0], mode=f.human_speed, reaction_time=f.reaction_time,
            stopping_time=t_s, stopping_distance=b, intrusion_distance=f.intrusion_distance,
            human_uncertainty=f.human_uncertainty,
            robot_uncertainty=f.robot_uncertainty, iso_speed=f.iso_human_speed,
            iso_reduced_speed=f.iso_reduced_human_speed)
        # Other controllers (seed 004's, zones) are not modelled: they keep full speed.
        k_ssm = (speed_override(d, S, delta_s=f.delta_s, d_min=f.d_min)
                 if config.type == "ssm_override" else np.ones(n))
        hand = stacked_position_velocity(stack, np.full(n, now))[0]
        moving = np.linalg.norm(tool_v, axis=-1) > MOVING_SPEED
        closest = np.where(moving, np.minimum(closest, np.linalg.norm(hand - tool, axis=-1)),
                           closest)
        for k in range(ticks):
            command = np.where(fault(now + k * dt), 0.0, k_ssm)
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
        return np.array([f[0] for f in self.figures])

    def first_violation(self) -> int | None:
        """Number of simulations up to and including the first violation (None if none)."""
        bad = np.flatnonzero(self.robustness < 0.0)
        return int(bad[0]) + 1 if bad.size else None


def evaluate_points(space: ScenarioSpace, config: ControllerConfig, runner: Runner,
                    points: np.ndarray, log: SearchLog) -> np.ndarray:
    """Simulates the scenarios of ``points``; appends to ``log``; returns robustness."""
    scenarios = [make_scenario(space, config, to_point(space, u)) for u in points]
    figures = runner.evaluate(scenarios)
    log.points.extend(np.asarray(points, dtype=float).tolist())
    log.figures.extend(figures.tolist())
    return figures[:, 0]


def falsify(space: ScenarioSpace, config: ControllerConfig, runner: Runner, *, budget: int,
            seed: int = 0, round_size: int = 5, candidates: int = 8192, explore: int = 10,
            stop_at_first: bool = False) -> SearchLog:
    """Searches for the smallest robustness with at most ``budget`` simulations: first up
    to ``explore`` candidates in danger order (four ranked for one plain Sobol point), in
    rounds of ``round_size``; then CMA-ES from the best point so far, restarted from the
    next candidates whenever it stops."""
    d = len(free_parameters(space))
    log = SearchLog()
    if d == 0:
        evaluate_points(space, config, runner, np.zeros((1, 0)), log)
        return log
    sobol = sweep_points("sobol", candidates, d, seed=seed)
    pool = np.vstack([corners(space) if d <= 10 else np.zeros((0, d)), sobol])
    ranked = pool[np.argsort(danger_scores(space, config, pool, runner=runner), kind="stable")]
    queue = _interleave(ranked, sobol, 4)

    def done() -> bool:
        return len(log.points) >= budget or (stop_at_first and log.first_violation() is not None)

    explore = min(explore, budget)
    while len(log.points) < explore and queue and not done():
        take = min(round_size, explore - len(log.points))
        batch, queue = np.array(queue[:take]), queue[take:]
        evaluate_points(space, config, runner, batch, log)
    restart = 0
    while not done():
        start = np.asarray(log.points[int(np.argmin(log.robustness))]) if restart == 0 \
            else np.asarray(queue.pop(0))
        if not _cma(space, config, runner, log, start, budget, seed + restart, stop_at_first):
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


def _cma(space, config, runner, log, start, budget, seed, stop_at_first) -> bool:
    """One CMA-ES run from ``start``; False when the budget leaves no room for it."""
    popsize = 6
    if budget - len(log.points) < popsize:
        return False
    options = {"bounds": [0.0, 1.0], "seed": seed + 1, "verbose": -9, "popsize": popsize,
               "tolfun": 1e-4, "tolx": 1e-4}
    es = cma.CMAEvolutionStrategy(np.clip(start, 0.0, 1.0).tolist(), 0.08, options)
    while not es.stop() and len(log.points) + popsize <= budget:
        xs = np.clip(np.array(es.ask()), 0.0, 1.0)
        values = evaluate_points(space, config, runner, xs, log)
        es.tell(list(xs), [float(v) if math.isfinite(v) else 1e3 for v in values])
        if stop_at_first and log.first_violation() is not None:
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
