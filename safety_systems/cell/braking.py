"""Braking model: how fast the robot's path speed can fall, from stopping data by speed.

The robot follows its path at a rate sigma (fraction of nominal path speed). When the
safety controller asks for a lower speed, sigma cannot fall faster than the robot's
brakes allow. The stopping data is a table of rows (speed fraction sigma_j, stopping
time T_j in seconds, stopping distance D_j of the tool in metres). The deceleration of
sigma at speed sigma is interpolated from the rows' sigma_j / T_j (constant beyond the
ends), so a table measured with constant deceleration is reproduced exactly: a stop
from sigma_j takes T_j. Both stop categories are modelled as decelerations along the
path (category 1, a controlled stop, does this; for category 0 it is an approximation,
since removing power lets the arm leave its path).

Default data (used when a configuration gives no table): Universal Robots, UR5/CB3
User Manual v3.4.5, Appendix A, stop category 0 at 100 % speed (joint speed 183 deg/s),
full extension and 5 kg payload: base 0.31 rad in 244 ms, shoulder 0.70 rad in 530 ms,
elbow 0.22 rad in 164 ms. We take the slowest joint (shoulder, 530 ms), assume constant
deceleration for the 33 % and 66 % rows (time proportional to speed, distance to its
square) and convert the angle to a tool distance over the UR5's 0.85 m reach
(0.70 rad x 0.85 m = 0.595 m). UR publishes category 1 data only as graphs, so the same
rows serve both categories. THESE ARE PLACEHOLDERS: integrators must enter the stopping
time and distance measured on their own cell, tool and payload.
"""

import dataclasses
import math

import numba
import numpy as np

PLACEHOLDER_WARNING = ("The stopping data is the built-in placeholder derived from UR5/CB3 "
                       "figures, not data measured on this cell: enter the measured stopping "
                       "times and distances (controller.braking) before relying on this "
                       "result.")
UR5_SHOULDER_STOP_TIME = 0.530  # s, stop category 0, 100 % speed (UR5/CB3 manual, App. A)
UR5_SHOULDER_STOP_ANGLE = 0.70  # rad
UR5_REACH = 0.85  # m
DEFAULT_SPEED_FRACTIONS = (0.33, 0.66, 1.0)


@dataclasses.dataclass(frozen=True, eq=False)
class BrakingTable:
    """Stopping data by speed fraction (rows sorted by speed, all > 0)."""

    speed_fraction: np.ndarray
    stopping_time: np.ndarray  # s
    stopping_distance: np.ndarray  # m, of the tool

    def __post_init__(self) -> None:
        rows = [np.array(getattr(self, f), dtype=float) for f in
                ("speed_fraction", "stopping_time", "stopping_distance")]
        names = ("speed_fraction", "stopping_time", "stopping_distance")
        n = rows[0].size
        for name, r in zip(names, rows):
            if r.shape != (n,) or n == 0 or not np.all(np.isfinite(r) & (r > 0.0)):
                raise ValueError(f"braking.{name}={r.tolist()}: need {max(n, 1)} or more "
                                 "positive numbers, one per row")
        if np.any(np.diff(rows[0]) <= 0.0):
            raise ValueError(f"braking.speed_fraction={rows[0].tolist()}: must increase")
        for name, r in zip(names, rows):
            r.setflags(write=False)
            object.__setattr__(self, name, r)

    @property
    def deceleration(self) -> np.ndarray:
        """sigma_j / T_j for each row, fraction of nominal speed per second."""
        return self.speed_fraction / self.stopping_time


def default_braking_table() -> BrakingTable:
    """The placeholder table derived from UR's published UR5 stopping data (see module)."""
    f = np.array(DEFAULT_SPEED_FRACTIONS)
    return BrakingTable(
        speed_fraction=f,
        stopping_time=UR5_SHOULDER_STOP_TIME * f,
        stopping_distance=UR5_SHOULDER_STOP_ANGLE * UR5_REACH * f * f,
    )


def braking_deceleration(table: BrakingTable, speed: np.ndarray | float) -> np.ndarray:
    """Largest rate at which |sigma| can fall at path speed |sigma|, per second."""
    return np.interp(np.abs(speed), table.speed_fraction, table.deceleration)


def stopping_time(table: BrakingTable, speed: np.ndarray | float) -> np.ndarray:
    """Stopping time at speed fraction ``speed``, seconds (linear in the table; 0 at 0)."""
    return np.interp(np.abs(speed), np.r_[0.0, table.speed_fraction],
                     np.r_[0.0, table.stopping_time])


def stopping_distance(table: BrakingTable, speed: np.ndarray | float) -> np.ndarray:
    """Tool stopping distance at speed fraction ``speed``, metres (0 at 0)."""
    return np.interp(np.abs(speed), np.r_[0.0, table.speed_fraction],
                     np.r_[0.0, table.stopping_distance])


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def _interp_one(x, xp, fp):
    """``np.interp`` of one x (same arithmetic: slope (x - xp_j) + fp_j, the end values
    beyond the ends); numba's own is several times slower for one value."""
    n = xp.size
    if math.isnan(x):
        y = np.nan
    elif x <= xp[0]:
        y = fp[0]
    elif x >= xp[n - 1]:
        y = fp[n - 1]
    else:
        j = 0
        while xp[j + 1] <= x:  # the cell xp[j] <= x < xp[j + 1] (tables are short)
            j += 1
        y = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j]) * (x - xp[j]) + fp[j]
    return y


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def rate_step_one(r, c, time_scale, dt, fractions, deceleration, acceleration_limit,
                  max_rate):
    """:func:`path_rate_step` of one rate r and command c (the braking table as its
    ``speed_fraction`` and ``deceleration`` arrays), compiled and callable from other
    compiled code."""
    c = min(max(c, -max_rate), max_rate) if math.isfinite(c) else 0.0
    if abs(c) < abs(r) or c * r < 0.0:  # slowing: within the brakes
        bound = _interp_one(abs(r), fractions, deceleration) / time_scale * dt
    else:
        bound = acceleration_limit * dt
    step = c - r  # clipped to [-bound, bound]; a NaN stays NaN (min/max would drop it)
    if step < -bound:  # noqa: PLR1730
        step = -bound
    if step > bound:  # noqa: PLR1730
        step = bound
    new = r + step
    return 0.0 if r * new < 0.0 else new


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def path_follower_step(s, rate, cmd, end, time_scale, dt, fractions, deceleration,
                  acceleration_limit, max_rate):
    """One tick of the PathFollower: the new path parameter and rate (s, sigma) from
    (s, sigma) and the command: sigma by :func:`rate_step_one`, s by the trapezoid rule,
    both held at the ends (s in [0, end], sigma 0 there). Compiled; shared by the
    PathFollower system and the batched evaluator."""
    if s >= end:
        s_new, new = end, 0.0
    else:
        new = rate_step_one(rate, cmd, time_scale, dt, fractions, deceleration,
                            acceleration_limit, max_rate)
        s_new = s + 0.5 * (rate + new) * dt
        if s_new >= end or s_new <= 0.0:
            s_new, new = min(max(s_new, 0.0), end), 0.0
    return s_new, new


@numba.njit(cache=True)
def _path_rate_kernel(rate, cmd, time_scale, dt, fractions, deceleration, acceleration_limit,
                      max_rate, out):
    """:func:`rate_step_one` element by element (``cmd``, ``time_scale`` of length 1 or of
    the output)."""
    one_cmd, one_scale = cmd.size == 1, time_scale.size == 1
    for i in range(out.size):
        out[i] = rate_step_one(rate[i], cmd[0] if one_cmd else cmd[i],
                               time_scale[0] if one_scale else time_scale[i], dt, fractions,
                               deceleration, acceleration_limit, max_rate)


def path_rate_step(
    rate: np.ndarray | float,
    commanded: np.ndarray | float,
    dt: float,
    *,
    table: BrakingTable,
    acceleration_limit: float,
    time_scale: np.ndarray | float = 1.0,
    max_rate: float = 1.0,
) -> np.ndarray:
    """The path rate sigma one control tick later, moving towards the commanded rate.

    Falling magnitude (towards zero) is bounded by :func:`braking_deceleration`
    divided by ``time_scale`` (the real brakes' stopping times relative to the table's);
    rising magnitude by ``acceleration_limit`` (fraction of nominal speed per second).
    A command of the other sign first brings sigma to rest (it never crosses zero
    within one tick). Commands are clipped to [-max_rate, max_rate] (1: the nominal
    speed; speed alteration controllers may go faster). Non-finite commands count as 0
    (fail safe). Compiled; shape of ``rate`` (a float for floats: the PathFollower's tick).
    """
    one = isinstance(rate, float)
    r = np.asarray(rate, dtype=float)
    c = np.asarray(commanded, dtype=float)
    scale = np.asarray(time_scale, dtype=float)
    shape = np.broadcast_shapes(r.shape, c.shape, scale.shape)
    if r.shape != shape:
        r = np.broadcast_to(r, shape)
    if c.size != 1 and c.shape != shape:
        c = np.broadcast_to(c, shape)
    if scale.size != 1 and scale.shape != shape:
        scale = np.broadcast_to(scale, shape)
    out = np.empty(shape)
    _path_rate_kernel(r.reshape(-1), c.reshape(-1), scale.reshape(-1), float(dt),
                      table.speed_fraction, table.deceleration, float(acceleration_limit),
                      float(max_rate), out.reshape(-1))
    return float(out[()]) if one and not shape else out


def tool_stopping_distance(
    path, table: BrakingTable, *, rate: float = 1.0, period: float = 0.002,
    starts: int = 400, tool_position=None,
) -> float:
    """Worst tool travel while braking from path rate ``rate`` on ``path``, metres.

    Runs the braking model (a command of 0 from ``rate``) from ``starts`` evenly spaced
    points of one cycle at once and returns the longest distance the tool flange
    travels before it rests. It tells an integrator what stopping distance B the
    braking table implies on their own path; it does not replace measurement. The tool
    flange's position is ``tool_position(q)`` (q (..., n) -> (..., 3); None: the UR5e's
    tool0, ``model_points.tool0_position`` gives any robot's).
    """
    from safety_systems.cell.joint_path import joint_path_state

    if tool_position is None:
        from safety_systems.cell.ur5e import tool0_position as tool_position

    ends = joint_path_state(path, np.array([0.0, path.cycle_time]))[0]
    if np.allclose(ends[0], ends[1], rtol=0.0, atol=1e-9):  # a cycle that closes:
        path = dataclasses.replace(path, cycles=2)  # a stop may run on into the next one
    # (a path run once, a robot log's, rests at its end; it does not jump to its start)
    s = np.linspace(0.0, path.cycle_time, starts, endpoint=False)
    sigma = np.full(starts, float(rate))
    p = tool_position(joint_path_state(path, s)[0])
    travelled = np.zeros(starts)
    while np.any(sigma != 0.0):
        new = path_rate_step(sigma, 0.0, period, table=table, acceleration_limit=1.0)
        s = s + 0.5 * (sigma + new) * period
        sigma = new
        p_new = tool_position(joint_path_state(path, s)[0])
        travelled += np.linalg.norm(p_new - p, axis=-1)
        p = p_new
    return float(travelled.max())
