"""Sweeps and falsification over a scenario space (robustness >= 0 safe; we minimise it).

Points live in the unit cube over the space's free parameters
(``verification.space.to_point`` maps them to values).

- Sweeps: ``grid``, ``sobol``, ``halton``, ``uniform`` and ``corners`` (every vertex).
- Falsification (:func:`falsify`): candidates from the corners and a Sobol set are
  ranked by a cheap open-loop *danger score* (no closed-loop simulation: how close the
  hand's scripted path comes to the tool if the robot kept full speed until the
  configured monitor, fed the hand as the sensor shows it, would first stop it, and
  then braked as its stopping data allows; :func:`danger_scores`), and
  simulated in that order interleaved with plain Sobol order; then CMA-ES (the ``cma``
  package) minimises the closed-loop robustness from the best point found, each
  population simulated as one batch. The score only orders candidates; every verdict
  rests on closed-loop simulations.
"""

import dataclasses
import itertools
import math

import cma
import numpy as np
from scipy.stats import qmc

from safety_systems.braking import path_rate_step
from safety_systems.joint_path import joint_path_state
from safety_systems.operator_paths import stack_paths, stacked_position_velocity
from safety_systems.scenario import ControllerConfig, actual_sensor
from safety_systems.ssm import directed_speeds, monitor_protective_distances, occlusion_margin
from safety_systems.ur5e import tool0_position, tool0_position_and_velocity
from safety_systems.workcell import (
    assumed_stopping,
    braking_table,
    joint_path,
    scripted_operators,
)
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
                  *, step: float = 0.02) -> np.ndarray:
    """Open-loop danger score of each point, m (lower is more dangerous; see module).

    The robot runs its path at full speed until the configured monitor, fed with the
    first operator's hand as the sensor would show it (one period plus the latency late,
    frozen and coasting while occluded; for ``estimated`` speeds, the hand's directed
    speed ``ESTIMATE_LAG`` late), finds it closer than S (Eqs. 9-11) or d_min; then it
    brakes from full speed. The score is the closest the hand comes to the tool while
    the tool still moves. Nothing here feeds back: it only orders candidates.
    """
    scenarios = [make_scenario(space, config, to_point(space, u)) for u in points]
    n = len(scenarios)
    path = joint_path(space.robot)
    dt = 1.0 / space.robot.control_rate_hz
    table = braking_table(config)
    rate, travelled = [1.0], [0.0]  # a stop from full speed, tick by tick
    while rate[-1] > 0.0:
        new = float(path_rate_step(rate[-1], 0.0, dt, table=table, acceleration_limit=1.0))
        travelled.append(travelled[-1] + 0.5 * (rate[-1] + new) * dt)
        rate.append(new)
    stop_time = (len(rate) - 1) * dt
    t = np.arange(0.0, max(s.duration for s in scenarios) + step, step)
    q, dq, _ = joint_path_state(path, t)
    tool, tool_v = tool0_position_and_velocity(q, dq)  # full speed: s = t
    stack = stack_paths([scripted_operators(sc)[0].path for sc in scenarios])
    f = config.safety
    delay = 1.0 / config.sensor.rate_hz + np.array([actual_sensor(sc).latency for sc in scenarios])
    lag = np.where(f.human_speed == "iso", 0.0, ESTIMATE_LAG)
    occ = np.array([[o.start, o.end] if (o := next(iter(sc.sensor.occlusions), None)) else
                    [np.inf, np.inf] for sc in scenarios])
    t_s, b = assumed_stopping(config)
    trigger = np.full(n, np.inf)
    for k, now in enumerate(t):  # the monitor's view at each time, for every candidate
        seen_at = np.maximum(now - delay, 0.0)
        hidden = (seen_at >= occ[:, 0]) & (seen_at < occ[:, 1])
        base = np.where(hidden, occ[:, 0], seen_at)
        p_b, v_b = stacked_position_velocity(stack, base)
        p_m = p_b + v_b * np.where(hidden, seen_at - base, 0.0)[:, None]
        v_m = stacked_position_velocity(stack, np.maximum(base - lag, 0.0))[1]
        d = np.linalg.norm(p_m - tool[k], axis=-1)
        v_h, v_r = directed_speeds(tool[k], tool_v[k], p_m[:, None], v_m[:, None])
        margin = occlusion_margin(np.where(hidden, seen_at - base, 0.0), v_m, f.occlusion_speed)
        S = monitor_protective_distances(
            v_h[:, 0], v_r[:, 0], mode=f.human_speed, reaction_time=f.reaction_time,
            stopping_time=t_s, stopping_distance=b, intrusion_distance=f.intrusion_distance,
            human_uncertainty=f.human_uncertainty + margin,
            robot_uncertainty=f.robot_uncertainty, iso_speed=f.iso_human_speed,
            iso_reduced_speed=f.iso_reduced_human_speed)
        hit = np.isinf(trigger) & ((d < S) | (d < f.d_min))
        trigger[hit] = now
    brake = np.minimum(trigger, t[-1])[:, None]
    after = np.maximum(t[None] - brake, 0.0)
    scale = np.array([sc.robot.braking_time_scale for sc in scenarios])[:, None]
    # Slower brakes stretch the stop in time and (at constant deceleration) in distance.
    s = np.minimum(t[None], brake) + scale * np.interp(after / scale, np.arange(len(rate)) * dt,
                                                       travelled)
    tool_actual = tool0_position(joint_path_state(path, s)[0])
    hand = np.stack([stacked_position_velocity(stack, now)[0] for now in t], axis=1)
    d_true = np.linalg.norm(hand - tool_actual, axis=-1)
    return np.min(np.where(after < stop_time * scale, d_true, np.inf), axis=1)


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
    ranked = pool[np.argsort(danger_scores(space, config, pool), kind="stable")]
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
