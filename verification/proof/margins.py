"""The theorems' margins (``verification.proof.theorems`` states them): the speed levels
the robot's stop is taken from (one row under ``safety.stopping: full_speed``, one per
level under ``by_speed``), each level's margin as a function of the hand speed bound and
the noise, and z3's check that no row is below zero anywhere in the box."""

import dataclasses

import numpy as np
import z3

from safety_systems.cell.stopping import TRUTH_RATES, rate_index
from safety_systems.config.configuration import joint_path
from safety_systems.config.resolved_cell import ResolvedCell
from safety_systems.ssm.formulas import SPEED_LEVELS, level_at_or_above
from verification.proof.robot_bounds import (
    robot_acceleration_bound,
    robot_bounds_by_rate,
)
from verification.spaces.box import ScenarioSpace


def check_cell(cell: ResolvedCell, space: ScenarioSpace) -> None:
    """Raises ValueError unless ``cell`` was resolved for the space's robot station (its
    braking table, stops and capsules are that robot's: ``spaces.space.space_cell``): a
    proof never takes another robot's stops."""
    if cell.robot != space.robot:
        raise ValueError("the resolved cell is of another robot station than the space's; "
                         "resolve it with spaces.space.space_cell(config, space)")


def least_level_separation(cell: ResolvedCell, space: ScenarioSpace) -> float:
    """The least the monitor's S can be at any speed level g = 1..G (m): its human term
    at the least human speed, its robot term at the least it can be there
    (:func:`robot_speed_low`), B(g) + C + Z_d + Z_r (Z_d at its base)."""
    f = cell.config.safety
    lv = speed_levels(cell, space)
    v = {"iso": min(f.iso_human_speed, f.iso_reduced_human_speed),
         "estimated_with_floor": f.iso_human_speed}.get(f.human_speed, 0.0)
    s = (v * (lv.t_s + f.reaction_time) + robot_speed_low(cell, lv) * f.reaction_time
         + lv.b + f.intrusion_distance + f.human_uncertainty + f.robot_uncertainty)
    return float(s.min())


def unsat_below_zero(m: "Margin", space: ScenarioSpace) -> bool:
    """z3: some row of ``m`` (a speed level) is below 0 somewhere in the space's v_max
    range has no solution: one query, the rows' conditions in a disjunction
    (:class:`Margin`: fixed - k_speed v_max - v_true(v_max) t_true per row)."""
    p = space.parameters
    vm = z3.Real("v_max")
    solver = z3.Solver()
    solver.add(vm >= p.peak_speed.min, vm <= p.peak_speed.max)
    if m.floor:
        top = z3.If(vm > z3.RealVal(repr(m.v_true)), vm, z3.RealVal(repr(m.v_true)))
    else:
        top = z3.RealVal(repr(float(m.v_true)))
    below = []
    for fixed, k_speed, t_true in zip(m.fixed, m.k_speed, m.t_true):
        row = z3.RealVal(repr(float(fixed))) - z3.RealVal(repr(float(k_speed))) * vm
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
    docstring), the monitor's T_s(sigma_g) and B(sigma_g) (``ResolvedCell.level_stops``)
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


def speed_levels(cell: ResolvedCell, space: ScenarioSpace) -> Levels:
    """The :class:`Levels` of the cell's configuration on ``space``'s robot (the cell is
    resolved for it: ``spaces.space.space_cell``), the stops at the space's largest
    braking time scale (they grow with it). The rate over the tick before a decision
    exceeds the rate at it by at most one braking step, the table's fastest deceleration
    over the space's shortest braking time scale times the period."""
    check_cell(cell, space)
    f, p = cell.config.safety, space.parameters
    h = 1.0 / space.robot.control_rate_hz
    if f.stopping == "by_speed":
        level = np.arange(1, SPEED_LEVELS + 1)
        rate = np.array([level_rate(int(g)) for g in level])
        drop = float(np.max(cell.braking.deceleration)) / p.braking_time_scale.min * h
        previous = np.minimum(1.0, rate + drop)
        t_all, b_all = cell.level_stops
        t_s, b = np.asarray(t_all[1:], dtype=float), np.asarray(b_all[1:], dtype=float)
    else:
        level, rate, previous = np.array([SPEED_LEVELS]), np.ones(1), np.ones(1)
        t_s, b = (np.array([float(x)]) for x in cell.stopping)
    bounds = robot_bounds_by_rate(joint_path(space.robot), cell, period=h,
                                  braking_time_scale=p.braking_time_scale.max, rates=rate)
    return Levels(level, rate, previous, t_s, b, np.array([x.stop_time for x in bounds]),
                  np.array([x.stop_travel for x in bounds]), bounds[0].tool_speed,
                  f.stopping == "by_speed")


@dataclasses.dataclass(frozen=True)

class Margin:
    """A theorem's margin as a function of the body speed bound v_max, one row per speed
    level (:class:`Levels`; one row under ``full_speed``):
    M_g(v_max) = fixed_g - k_speed_g v_max - v_true(v_max) t_true_g, with v_true(v_max)
    the human speed of S_true (separation only: max(v_max, floor) under
    ``estimated_with_floor``, the constant ``v_true`` otherwise; 0 for contact). The
    margin is the least row. ``prove`` and ``prove_separation`` check every row over the
    box; the falsifier's cheapest ranking evaluates it pointwise
    (``verification.search.ranking.bound_scores``). The tracker's position error is not
    a term: the envelopes' tracking allowance covers it (a premise), as the sensor noise
    enters only there and through the gate."""

    fixed: np.ndarray
    k_speed: np.ndarray
    t_true: np.ndarray
    v_true: float = 0.0
    floor: bool = False  # v_true(v_max) = max(v_max, v_true)
    level: np.ndarray = dataclasses.field(default_factory=lambda: np.array([SPEED_LEVELS]))

    def human_speed(self, v_max):
        return np.maximum(v_max, self.v_true) if self.floor else self.v_true

    def rows_at(self, v_max) -> np.ndarray:
        """M_g at v_max (a number or an array), each row (level) along a new last axis."""
        v = np.asarray(v_max, dtype=float)[..., None]
        return self.fixed - self.k_speed * v - self.human_speed(v) * self.t_true

    def at(self, v_max):
        """M at v_max (a number or an array): the least row's."""
        return self.rows_at(v_max).min(axis=-1)


def margin(cell: ResolvedCell, space: ScenarioSpace, prop: str = "contact") -> Margin:
    """The margin of the ``prop`` theorem (``contact`` or ``separation``, see the
    module docstring) for the cell's configuration on ``space``'s robot and sensor
    bounds, whether or not its premises hold (without them it bounds nothing; it still
    orders scenarios by how close their body speed comes to breaking it)."""
    return margin_of_levels(cell, space, prop, speed_levels(cell, space))


def margin_of_levels(cell: ResolvedCell, space: ScenarioSpace, prop: str, lv: Levels
                     ) -> Margin:
    f = cell.config.safety
    h = 1.0 / space.robot.control_rate_hz
    tau = cell.frame_timeout
    if prop == "contact":
        v = {"iso": min(f.iso_human_speed, f.iso_reduced_human_speed),
             "estimated_with_floor": f.iso_human_speed}.get(f.human_speed, 0.0)
        fixed = (v * (lv.t_s + f.reaction_time) + robot_speed_low(cell, lv) * f.reaction_time
                 + lv.b + f.intrusion_distance + f.human_uncertainty + f.robot_uncertainty
                 - lv.tool_speed * lv.rate * h - lv.stop_travel - space.contact_distance)
        return Margin(fixed, tau + lv.stop_time + h, np.zeros(lv.level.size),
                      level=lv.level)
    if prop != "separation":
        raise ValueError(f"prop: got {prop!r}; allowed: contact | separation")
    floor = f.human_speed == "estimated_with_floor"
    v_lo = f.iso_human_speed if floor else min(f.iso_human_speed, f.iso_reduced_human_speed)
    fixed = (v_lo * (lv.t_s + f.reaction_time)
             + robot_speed_gap(cell, space, lv) * f.reaction_time
             + lv.b - lv.stop_travel + f.human_uncertainty + f.robot_uncertainty)
    v_true = f.iso_human_speed if floor else max(f.iso_human_speed, f.iso_reduced_human_speed)
    return Margin(fixed, np.full(lv.level.size, tau), lv.stop_time + f.reaction_time, v_true,
                  floor, lv.level)


def robot_speed_low(cell: ResolvedCell, lv: Levels) -> np.ndarray:
    """The least the monitor's robot speed term can be at each level, m/s: -V_R times the
    fastest rate over the tick its capsule velocities are differenced over for Eq. 7's
    directed speed (a robot moving away lowers S), 0 for ``fastest_point`` (a speed)."""
    if cell.config.safety.robot_speed == "fastest_point":
        return np.zeros(lv.level.size)
    return -lv.tool_speed * lv.previous_rate


def robot_speed_gap(cell: ResolvedCell, space: ScenarioSpace, lv: Levels) -> np.ndarray:
    """How far (m/s, negative) the monitor's robot speed term can fall short of S_true's
    at each level: directed, V_R (rho_g + the tick before's rate) (the monitor's capsule
    point may move away from the estimate while S_true's moves towards the body);
    fastest_point, a h (the monitor's speed is the capsule's fastest end by Eq. 5, its
    ends differenced over the last tick, at most a h short of the instant's, a:
    :func:`robot_acceleration_bound` at the tick's fastest rate; no axis point moves
    faster)."""
    if cell.config.safety.robot_speed == "fastest_point":
        h = 1.0 / space.robot.control_rate_hz
        path = joint_path(space.robot)
        return np.array([-robot_acceleration_bound(path, cell, space, lv.tool_speed,
                                                   rate=float(r)) * h
                         for r in lv.previous_rate])
    return -lv.tool_speed * (lv.rate + lv.previous_rate)
