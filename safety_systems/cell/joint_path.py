"""The robot's pre-programmed cyclic path in joint space, as a function of a path parameter.

The path visits joint-space waypoints W_0 ... W_{M-1} and returns to W_0 (one cycle);
segment j goes from W_j to W_{j+1 mod M} in ``durations[j]`` seconds of nominal time
with a minimum-jerk (quintic) rest-to-rest profile, so the robot pauses at every
waypoint as a pick-and-place cycle does. The path parameter ``s`` is nominal time in
seconds, from 0 to ``cycles * cycle_time``; the PathFollower advances it at the rate
sigma = ds/dt (1 = nominal speed). All functions are vectorised over ``s``.
"""

import dataclasses
import math

import numba
import numpy as np
from numba.core import types
from numba.extending import overload
from scipy.interpolate import CubicSpline

from safety_systems.cell.ur5e import JOINT_VELOCITY_LIMIT

# Peak of the minimum-jerk blend's derivative h'(tau) = 30 tau^2 (1 - tau)^2, at tau = 1/2.
_PEAK_BLEND_RATE = 1.875

# Default pick-and-place cycle of the UR5e on its table (own choice): above the pick
# point on the operator's side of the table, down, up, across, down to the place
# point, up, back. Degrees and seconds.
DEFAULT_WAYPOINTS_DEG = (
    (140.0, -80.0, 100.0, -110.0, -90.0, 0.0),
    (140.0, -65.0, 110.0, -135.0, -90.0, 0.0),
    (140.0, -80.0, 100.0, -110.0, -90.0, 0.0),
    (220.0, -80.0, 100.0, -110.0, -90.0, 0.0),
    (220.0, -65.0, 110.0, -135.0, -90.0, 0.0),
    (220.0, -80.0, 100.0, -110.0, -90.0, 0.0),
)
DEFAULT_DURATIONS = (0.8, 0.8, 1.5, 0.8, 0.8, 1.5)


@dataclasses.dataclass(frozen=True, eq=False)
class JointPath:
    """A cyclic joint path; build it with :func:`make_joint_path`.

    Attributes:
        waypoints: (M, n) joint positions, radians.
        durations: (M,) nominal segment durations, seconds.
        starts: (M,) nominal start time of each segment within a cycle, seconds.
        cycle_time: nominal time of one cycle, seconds.
        cycles: number of cycles in the task.
        deltas: (M, n) joint displacement of each segment, radians.
    """

    waypoints: np.ndarray
    durations: np.ndarray
    starts: np.ndarray
    cycle_time: float
    cycles: int
    deltas: np.ndarray  # (M, n) joint displacement of each segment, radians

    @property
    def num_joints(self) -> int:
        return int(self.waypoints.shape[1])

    @property
    def end(self) -> float:
        """The path parameter at which the task is finished, seconds of nominal time."""
        return self.cycle_time * self.cycles

    @property
    def peak_joint_speeds(self) -> np.ndarray:
        """Each joint's largest speed at nominal speed (sigma = 1), radians per second."""
        return np.max(_PEAK_BLEND_RATE * np.abs(self.deltas) / self.durations[:, None], axis=0)

    @property
    def peak_joint_speed(self) -> float:
        """Largest joint speed at nominal speed (sigma = 1), radians per second."""
        return float(np.max(self.peak_joint_speeds))


def make_joint_path(
    waypoints_rad: np.ndarray,
    durations: np.ndarray,
    *,
    cycles: int = 1,
    joint_speed_limit: float | np.ndarray = JOINT_VELOCITY_LIMIT,
    num_joints: int = 6,
) -> JointPath:
    """Checks and precomputes a cyclic joint path.

    Args:
        waypoints_rad: (M, n) joint positions in radians, M >= 2 (n: the robot's joints).
        durations: (M,) positive nominal durations in seconds; the last one closes the
            cycle from W_{M-1} back to W_0.
        cycles: how many cycles make the task (>= 1).
        joint_speed_limit: radians per second, one for every joint or one per joint (n,);
            no joint may exceed its own at nominal speed.
        num_joints: n, the robot's joint count (6: a UR arm's).

    Raises:
        ValueError: naming the bad value (a segment too fast for the joint limit names
            its index and the shortest duration allowed).
    """
    w = np.array(waypoints_rad, dtype=float)
    d = np.array(durations, dtype=float)
    if (w.ndim != 2 or w.shape[0] < 2 or w.shape[1] != num_joints
            or not np.all(np.isfinite(w))):
        raise ValueError(f"waypoints has shape {w.shape}: need (M >= 2, {num_joints}) finite "
                         "radians")
    if d.shape != (w.shape[0],) or not np.all(np.isfinite(d) & (d > 0.0)):
        raise ValueError(f"durations={d.tolist()}: need {w.shape[0]} positive seconds")
    if not (isinstance(cycles, int) and cycles >= 1):
        raise ValueError(f"cycles={cycles!r}: need an integer >= 1")
    deltas = np.roll(w, -1, axis=0) - w
    if np.ndim(joint_speed_limit) == 0:
        shortest = _PEAK_BLEND_RATE * np.abs(deltas).max(axis=1) / joint_speed_limit
        limit = f"{math.degrees(joint_speed_limit):.0f} deg/s"
    else:
        limits = np.asarray(joint_speed_limit, dtype=float)
        if limits.shape != (w.shape[1],):
            raise ValueError(f"joint_speed_limit has shape {limits.shape}: need one limit or "
                             f"({w.shape[1]},), one per joint")
        shortest = (_PEAK_BLEND_RATE * np.abs(deltas) / limits).max(axis=1)
        limit = "its joint's speed limit (" + ", ".join(
            f"{math.degrees(x):.0f}" for x in limits) + " deg/s)"
    for j in np.flatnonzero(d < shortest - 1e-12):
        raise ValueError(
            f"segment_durations[{j}]={d[j]}: the joint speed would exceed "
            f"{limit}; allowed >= {shortest[j]:.4f} s"
        )
    starts = np.concatenate([[0.0], np.cumsum(d)[:-1]])
    for a in (w, d, starts, deltas):
        a.setflags(write=False)
    return JointPath(w, d, starts, float(d.sum()), cycles, deltas)


def default_joint_path(cycles: int = 1) -> JointPath:
    """The default pick-and-place cycle (``DEFAULT_WAYPOINTS_DEG``)."""
    return make_joint_path(np.radians(DEFAULT_WAYPOINTS_DEG), DEFAULT_DURATIONS, cycles=cycles)


@numba.njit(cache=True)
def _blend(tau: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Minimum-jerk blend h, h', h'' on tau in [0, 1] (arrays or one float); compiled."""
    t2 = tau * tau
    rest = 1.0 - tau
    h = t2 * tau * (10.0 - 15.0 * tau + 6.0 * t2)
    dh = 30.0 * t2 * (rest * rest)  # a product, not ** 2: the same for floats and arrays
    ddh = 60.0 * tau * rest * (1.0 - 2.0 * tau)
    return h, dh, ddh


@dataclasses.dataclass(frozen=True, eq=False)
class SplinePath:
    """A joint path through joint samples: a cubic spline over ``duration`` seconds of
    nominal time, run one way (``cycles`` 1) or there and back (a cycle is the way out
    and the way back, ``cycles`` >= 1).

    Built by :func:`make_spline_path` (e.g. from inverse kinematics of a Cartesian
    path, ``safety_systems.cell.cartesian_path``).
    """

    spline: CubicSpline  # u in [0, duration] -> q, shape (n,)
    duration: float
    cycles: int = 1
    there_and_back: bool = False

    @property
    def num_joints(self) -> int:
        return int(self.spline.c.shape[2])

    @property
    def cycle_time(self) -> float:
        return self.duration * (2.0 if self.there_and_back else 1.0)

    @property
    def end(self) -> float:
        return self.cycle_time * self.cycles

    @property
    def peak_joint_speed(self) -> float:
        u = np.linspace(0.0, self.duration, 2001)
        return float(np.max(np.abs(self.spline(u, 1))))

    def state(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, dq/ds, d2q/ds2 at path parameters s (clipped to [0, end])."""
        s = np.minimum(np.maximum(np.asarray(s, dtype=float), 0.0), self.end)
        phase = s - self.cycle_time * np.minimum(np.floor(s / self.cycle_time), self.cycles - 1)
        back = phase > self.duration
        u = np.where(back, 2.0 * self.duration - phase, phase)
        sign = np.where(back, -1.0, 1.0)[..., None]
        return self.spline(u), sign * self.spline(u, 1), self.spline(u, 2)


def make_spline_path(s_samples: np.ndarray, q_samples: np.ndarray, *, rest_to_rest: bool = False,
                     cycles: int = 1, there_and_back: bool = False,
                     joint_speed_limit: float = JOINT_VELOCITY_LIMIT) -> SplinePath:
    """A spline path through (s, q) samples (s in seconds of nominal time, increasing from
    0; q (K, n) radians). ``rest_to_rest``: zero joint speeds at both ends (clamped
    spline; needed there and back), else not-a-knot ends, so evenly spaced samples of a
    uniform motion give a uniform speed (the PathFollower starts and ends the motion)."""
    s = np.asarray(s_samples, dtype=float)
    q = np.asarray(q_samples, dtype=float)
    if s.ndim != 1 or s.size < 2 or s[0] != 0.0 or np.any(np.diff(s) <= 0.0):
        raise ValueError(f"s_samples: need an increasing sequence from 0, got {s.tolist()}")
    if q.ndim != 2 or q.shape[0] != s.size or not np.all(np.isfinite(q)):
        raise ValueError(f"q_samples has shape {q.shape}: need ({s.size}, n) finite radians")
    if there_and_back and not rest_to_rest:
        raise ValueError("there_and_back: needs rest_to_rest (the path turns round at rest)")
    if not (isinstance(cycles, int) and cycles >= 1 and (cycles == 1 or there_and_back)):
        raise ValueError(f"cycles={cycles!r}: 1, or more for a there-and-back path")
    spline = CubicSpline(s, q, bc_type="clamped" if rest_to_rest else "not-a-knot", axis=0)
    path = SplinePath(spline, float(s[-1]), cycles, there_and_back)
    if path.peak_joint_speed > joint_speed_limit:
        raise ValueError(f"the path needs {math.degrees(path.peak_joint_speed):.0f} deg/s at "
                         f"nominal speed; allowed <= {math.degrees(joint_speed_limit):.0f}")
    return path


def path_arrays(path: JointPath | SplinePath) -> tuple:
    """What compiled code reads a path from (see :func:`path_state_one`): a JointPath as
    (cycle_time, cycles, starts, durations, waypoints, deltas), a SplinePath as
    (cycle_time, cycles, breakpoints, coefficients (4, m, n), one-way duration,
    there-and-back). Made once per path."""
    arrays = path.__dict__.get("_compiled_arrays")
    if arrays is None:
        if isinstance(path, SplinePath):
            arrays = (float(path.cycle_time), float(path.cycles),
                      np.ascontiguousarray(path.spline.x, dtype=float),
                      np.ascontiguousarray(path.spline.c, dtype=float), float(path.duration),
                      bool(path.there_and_back))
        else:
            arrays = (float(path.cycle_time), float(path.cycles), path.starts, path.durations,
                      path.waypoints, path.deltas)
        path.__dict__["_compiled_arrays"] = arrays  # a cache beside the frozen fields
    return arrays


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def _spline_piece(c, i, j, u):
    """Value, first and second derivative of the cubic piece i, joint j, at offset u from
    its breakpoint, with scipy's PPoly arithmetic (terms c_k u^k times a falling factorial
    summed from the constant up, the powers of u accumulated term by term), so the
    values equal ``CubicSpline``'s bit for bit. Written out: loops here made every
    compiled caller several times slower, even where the spline is not used."""
    u2 = u * u
    value = ((0.0 + c[3, i, j]) + c[2, i, j] * u) + c[1, i, j] * u2 + c[0, i, j] * (u2 * u)
    slope = (0.0 + c[2, i, j]) + c[1, i, j] * u * 2.0 + c[0, i, j] * u2 * 3.0
    curvature = (0.0 + c[1, i, j] * 2.0) + c[0, i, j] * u * 6.0
    return value, slope, curvature


def path_state_one(s, arrays, q, dq, ddq):
    """q(s), dq/ds and d2q/ds2 at one path parameter s (clipped to [0, end]) into q, dq,
    ddq (n,); compiled code only, ``arrays`` from :func:`path_arrays`.

    A JointPath: its segment's minimum-jerk blend. A SplinePath: its cubic piece, the way
    back running the spline backwards (dq/ds negated), as ``SplinePath.state``. The kind
    is chosen when compiling (by the arrays' types), not at run time: a run-time branch
    between the two made every compiled caller several times slower (numba then keeps
    reference counting of the arrays in the hot loop). Called from Python, it runs the
    same compiled code.
    """
    _path_state_from_python(s, arrays, q, dq, ddq)


@numba.njit(cache=True)
def _path_state_from_python(s, arrays, q, dq, ddq):
    path_state_one(s, arrays, q, dq, ddq)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def _phase(s, cycle_time, cycles):
    """The path parameter s clipped to [0, end], as the time into its cycle."""
    x = min(max(s, 0.0), cycle_time * cycles)
    return x - cycle_time * min(math.floor(x / cycle_time), cycles - 1)


@overload(path_state_one, inline="always")  # no call (and array refcounts) per element
def _path_state_one(s, arrays, q, dq, ddq):
    if isinstance(arrays[3], types.Array) and arrays[3].ndim == 3:  # a SplinePath
        def spline(s, arrays, q, dq, ddq):
            cycle_time, cycles, breaks, coeffs, duration, there_and_back = arrays
            phase = _phase(s, cycle_time, cycles)
            back = there_and_back and phase > duration
            u = 2.0 * duration - phase if back else phase
            # The piece breaks[i] <= u < breaks[i + 1]; the last one at the far end.
            i = min(max(np.searchsorted(breaks, u, side="right") - 1, 0), breaks.size - 2)
            offset = u - breaks[i]
            for j in range(coeffs.shape[2]):
                q[j], slope, ddq[j] = _spline_piece(coeffs, i, j, offset)
                dq[j] = -slope if back else slope
        return spline

    def joint(s, arrays, q, dq, ddq):
        cycle_time, cycles, starts, durations, waypoints, deltas = arrays
        phase = _phase(s, cycle_time, cycles)
        j = np.searchsorted(starts, phase, side="right") - 1
        T = durations[j]
        h, dh, ddh = _blend(min((phase - starts[j]) / T, 1.0))
        dh, ddh = dh / T, ddh / (T * T)
        for i in range(waypoints.shape[1]):
            q[i] = waypoints[j, i] + h * deltas[j, i]
            dq[i] = dh * deltas[j, i]
            ddq[i] = ddh * deltas[j, i]
    return joint


@numba.njit(cache=True)
def _joint_path_kernel(s, arrays, out):
    """:func:`path_state_one` at every s (flat) into out (3, len(s), n)."""
    for r in range(s.size):
        path_state_one(s[r], arrays, out[0, r], out[1, r], out[2, r])


def joint_path_state(
    path: JointPath | SplinePath, s: float | np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q(s), dq/ds and d2q/ds2 at path parameter(s) s (clipped to [0, end]).

    ``s`` of shape ``S`` gives three arrays of shape ``S + (n,)``: radians, radians per
    second of nominal time, and radians per second squared. Compiled (either kind of
    path; :func:`path_state_one`).
    """
    s = np.asarray(s, dtype=float)
    n = path.num_joints
    out = np.empty((3, s.size, n))
    _joint_path_kernel(s.reshape(-1), path_arrays(path), out)
    shape = s.shape + (n,)
    return out[0].reshape(shape), out[1].reshape(shape), out[2].reshape(shape)
