"""The robot's path from its own log: a recorded joint trajectory, checked, as a path.

A log is joint positions at time stamps, from one of:

- a UR RTDE CSV: ``ur_rtde``'s ``startFileRecording`` (comma-separated) or UR's RTDE
  ``record.py`` (space-separated), one header row of field names, ``timestamp`` (s,
  the controller's clock) and ``actual_q_0`` ... ``actual_q_{n-1}`` (rad); any other
  field (``target_q_*``, temperatures, voltages, ...) is ignored;
- a ROS bag's ``sensor_msgs/msg/JointState`` topic (``sensing.ros_bag``): header stamps,
  the joints found by name among the robot model's.

The checks (:func:`check_joint_log`, one line naming the file, the row, the field, the
value and what is allowed, as every bad input): time stamps finite and strictly
increasing (a repeated or decreasing stamp is refused), no spacing longer than
``max_gap`` (samples lost), joint positions finite and within the robot model's joint
limits (radians: a log in degrees falls outside them), and no joint faster between two
samples than its speed limit; and the path the robot runs through them
(:func:`check_path_speeds`) no faster than that limit anywhere.

The path (:func:`make_log_path`): a cubic spline through the samples (``SplinePath``,
the kind a Cartesian path already is, so the PathFollower, the batched evaluator and
the proofs' bounds take it unchanged), its parameter the log's time from its first
sample, so a path rate of 1 runs it as recorded and the override's k slows it like
any path. One pass (the robot stops at its last sample), or repeated: the log must then
end where it starts (the step from its last sample back to its first, over one median
spacing, within the joint speed limits), and the spline is periodic.
"""

import csv
import dataclasses
import functools
import hashlib
import math
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline

from safety_systems.cell.joint_path import SplinePath
from safety_systems.files.documents import read_input
from safety_systems.files.input_error import InputError

MAX_LOG_BYTES = 512 * 1024 * 1024
MAX_ROWS = 2_000_000  # an hour at 500 Hz
TIME = "timestamp"
BAG_SUFFIXES = (".mcap", ".db3", ".bag")


@dataclasses.dataclass(frozen=True, eq=False)
class JointLog:
    """Samples of a robot's joints: ``times`` (T,) s as logged, ``q`` (T, n) rad;
    ``rows`` (T,) where each sample is in the file (a CSV's line number, a bag's message
    index), ``fields`` (n,) what each joint is called there; ``sha256`` of the file(s)."""

    file: str
    times: np.ndarray
    q: np.ndarray
    rows: np.ndarray
    fields: tuple[str, ...]
    sha256: str
    row_name: str = "row"  # what a row is called in a message: a CSV's row, a bag's message


def is_bag(path: str | Path) -> bool:
    """Whether ``path`` is a ROS bag: a rosbag2 folder, or an .mcap, .db3 or .bag file."""
    path = Path(path)
    return path.is_dir() or path.suffix.lower() in BAG_SUFFIXES


def read_rtde_csv(path: str | Path, num_joints: int = 6) -> JointLog:
    """A UR RTDE CSV's ``timestamp`` and ``actual_q_0..`` columns (see the module
    docstring); raises InputError naming the file, the row and the field."""
    data = read_input(path, max_bytes=MAX_LOG_BYTES)
    file = str(path)
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise InputError("<file>", f"byte {e.start}", "a UTF-8 text file", file=file) from None
    lines = text.splitlines()
    if not lines or not lines[0].strip():
        raise InputError("<header>", "empty", f"a header row naming {TIME} and actual_q_0 ...",
                         file=file)
    comma = "," in lines[0]
    header = [x.strip() for x in (lines[0].split(",") if comma else lines[0].split())]
    wanted = [TIME] + [f"actual_q_{j}" for j in range(num_joints)]
    missing = [x for x in wanted if x not in header]
    if missing:
        raise InputError("<header>", missing[0], f"a column named {missing[0]} (an RTDE log "
                         f"of {TIME} and actual_q_0 ... actual_q_{num_joints - 1}; found "
                         f"{header[:8]}{' ...' if len(header) > 8 else ''})", file=file)
    if len(lines) - 1 > MAX_ROWS:
        raise InputError("<rows>", len(lines) - 1, f"at most {MAX_ROWS:,} rows", file=file)
    index = [header.index(x) for x in wanted]
    rows = csv.reader(lines[1:]) if comma else (x.split() for x in lines[1:])
    values, numbers = [], []
    for r, cells in enumerate(rows, start=2):
        if not cells or all(not c.strip() for c in cells):
            continue  # a blank line (a file's last one)
        if len(cells) != len(header):
            raise InputError(f"row {r}", f"{len(cells)} fields", f"{len(header)} fields, one "
                             "per header column", file=file)
        try:
            values.append([float(cells[i]) for i in index])
        except ValueError:
            bad = next(k for k, i in enumerate(index) if not _is_number(cells[i]))
            raise InputError(f"row {r}: {wanted[bad]}", cells[index[bad]], "a number ("
                             + ("s" if bad == 0 else "rad") + ")", file=file) from None
        numbers.append(r)
    if len(values) < 2:
        raise InputError("<rows>", len(values), "2 or more samples", file=file)
    a = np.array(values, dtype=float)
    return JointLog(file, a[:, 0], a[:, 1:], np.array(numbers), tuple(wanted[1:]),
                    hashlib.sha256(data).hexdigest())


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def check_joint_log(log: JointLog, *, lower: np.ndarray, upper: np.ndarray,
                    speed_limit: np.ndarray, robot: str, max_gap: float) -> None:
    """The checks of the module docstring on ``log`` against a robot's joint limits
    (``lower``, ``upper`` rad; ``speed_limit`` rad/s, each (n,)) named ``robot``; raises
    InputError naming the file, the row, the field, the value and what is allowed."""
    t, q, rows, f = log.times, log.q, log.rows, log.fields
    where = log.row_name
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise InputError(f"{where} {rows[bad[0]]}: timestamp", t[bad[0]], "a finite time in s",
                         file=log.file)
    dt = np.diff(t)
    bad = np.flatnonzero(dt <= 0.0)
    if bad.size:
        i = bad[0] + 1
        raise InputError(f"{where} {rows[i]}: timestamp", float(t[i]), "later than the "
                         f"previous sample's ({float(t[i - 1])!r} s): a repeated or decreasing stamp",
                         file=log.file)
    bad = np.flatnonzero(dt > max_gap)
    if bad.size:
        i = bad[0] + 1
        raise InputError(f"{where} {rows[i]}: timestamp", float(t[i]), f"within max_gap "
                         f"{max_gap:g} s of the previous sample's ({float(t[i - 1])!r} s); a gap of "
                         f"{dt[i - 1]:.4g} s is samples lost (the median spacing is "
                         f"{float(np.median(dt)):.4g} s)", file=log.file)
    finite = np.isfinite(q)
    inside = finite & (q >= lower - 1e-12) & (q <= upper + 1e-12)
    if not inside.all():
        i, j = np.argwhere(~inside)[0]
        alone = np.delete(inside, j, axis=1).all()  # the other joints within theirs
        turns = _turns(q[:, j], q[i, j], dt, lower[j], upper[j],
                       speed_limit[j]) if alone else ""
        raise InputError(f"{where} {rows[i]}: {f[j]}", float(q[i, j]), f"a finite angle in "
                         f"rad within the {robot}'s joint limits ({lower[j]:.4g} ... "
                         f"{upper[j]:.4g} rad; a log in degrees falls outside them{turns})",
                         file=log.file)
    speed = np.abs(np.diff(q, axis=0)) / dt[:, None]
    fast = speed > speed_limit[None, :]
    if fast.any():
        i, j = np.argwhere(fast)[0]
        raise InputError(f"{where} {rows[i + 1]}: {f[j]}", float(q[i + 1, j]),
                         f"a step from the previous sample at most the {robot}'s joint speed "
                         f"limit ({math.degrees(speed_limit[j]):.0f} deg/s; this one is "
                         f"{math.degrees(speed[i, j]):.1f} deg/s)", file=log.file)


def _turns(column: np.ndarray, angle: float, dt: np.ndarray, lower: float, upper: float,
           speed: float) -> str:
    """What to say of a joint's samples ``column`` (T,) rad, ``angle`` among them outside
    [lower, upper], where the same whole turns bring them all within and each step
    keeps within ``speed`` (a wrist that turns without end has turned): "" otherwise (a
    sample out of line, or a log in degrees)."""
    if not np.all(np.isfinite(column)):
        return ""
    k = (math.ceil((angle - upper) / math.tau) if angle > upper
         else -math.ceil((lower - angle) / math.tau))
    back = column - k * math.tau
    steady = np.all(np.abs(np.diff(column)) <= speed * dt)
    if not (steady and np.all(back >= lower) and np.all(back <= upper)):
        return ""
    return (f"; {angle:.4g} rad is {abs(k)} whole turn{'s' if abs(k) > 1 else ''} from "
            f"{angle - k * math.tau:.4g} rad, within them: a joint that turns without end "
            "has turned so; take its turns out of the log")


def window_index(log: JointLog, start: float, end: float | None) -> np.ndarray:
    """Which samples (T,) bool lie from log time ``start`` (s after the first sample) to
    ``end`` (None: the last); raises InputError when fewer than 2 do."""
    t = log.times - log.times[0]
    keep = (t >= start - 1e-9) & (t <= (math.inf if end is None else end + 1e-9))
    if keep.sum() < 2:
        raise InputError("path.log.start", [start, end], f"a window of 2 or more samples of "
                         f"the log's {t[-1]:.4g} s", file=log.file)
    return keep


def window(log: JointLog, start: float, end: float | None) -> tuple[np.ndarray, np.ndarray]:
    """(s, q): the samples of :func:`window_index`, s from 0."""
    keep = window_index(log, start, end)
    t = log.times[keep] - log.times[keep][0]
    return t, log.q[keep]


def closing_step(s: np.ndarray, q: np.ndarray) -> tuple[float, np.ndarray]:
    """(time, speeds): the spacing a repeated log closes with (its median) and each
    joint's speed from its last sample back to its first over it, rad/s."""
    h = float(np.median(np.diff(s)))
    return h, np.abs(q[0] - q[-1]) / h


def make_log_path(s: np.ndarray, q: np.ndarray, *, repeat: bool = False,
                  cycles: int = 1) -> SplinePath:
    """The path through the samples (s from 0, strictly increasing; q (K, n) rad; see
    the module docstring): one pass, or ``cycles`` passes of a periodic spline closed by
    one median spacing back to the first sample (``repeat``)."""
    s, q = np.asarray(s, dtype=float), np.asarray(q, dtype=float)
    if not repeat:
        return SplinePath(CubicSpline(s, q, bc_type="not-a-knot", axis=0), float(s[-1]), 1)
    h, _ = closing_step(s, q)
    s, q = np.r_[s, s[-1] + h], np.vstack([q, q[:1]])
    return SplinePath(CubicSpline(s, q, bc_type="periodic", axis=0), float(s[-1]),
                      int(cycles))


@functools.lru_cache(maxsize=8)
def _cached_csv(path: str, num_joints: int, digest: str) -> JointLog:
    return read_rtde_csv(path, num_joints)


def read_joint_log(path: str | Path, joint_names: tuple[str, ...], topic: str = "") -> JointLog:
    """The joint log in ``path`` (an RTDE CSV, or a bag's JointState ``topic`` with the
    joints ``joint_names`` in the robot model's order), kept while its bytes do not
    change (each call still reads the file, so that it is named among the inputs)."""
    if is_bag(path):
        from safety_systems.sensing.ros_bag import read_joint_states

        times, q, rows, digest = read_joint_states(path, joint_names, topic)
        return JointLog(str(path), times, q, rows, tuple(joint_names), digest, "message")
    if topic:
        raise InputError("path.log.topic", topic, "empty for an RTDE CSV (a bag's JointState "
                         "topic only)", file=str(path))
    digest = hashlib.sha256(read_input(path, max_bytes=MAX_LOG_BYTES)).hexdigest()
    return _cached_csv(str(path), len(joint_names), digest)


def piece_speeds(path: SplinePath) -> np.ndarray:
    """Each joint's largest |dq/ds| on each cubic piece of a log's path (pieces, n),
    rad/s at path rate 1: on a piece the slope's largest size is at an end or at its
    vertex."""
    c, h = path.spline.c, np.diff(path.spline.x)[:, None]  # c (4, pieces, n)
    ends = np.maximum(np.abs(c[2]), np.abs(3.0 * c[0] * h * h + 2.0 * c[1] * h + c[2]))
    with np.errstate(divide="ignore", invalid="ignore"):
        vertex = np.where(c[0] != 0.0, -c[1] / (3.0 * c[0]), -1.0)
        at = np.abs(c[2] - c[1] ** 2 / (3.0 * np.where(c[0] != 0.0, c[0], 1.0)))
    inside = (vertex > 0.0) & (vertex < h)
    return np.maximum(ends, np.where(inside, at, 0.0))


def peak_joint_speeds(path: SplinePath) -> np.ndarray:
    """Each joint's largest |dq/ds| anywhere on a log's path (n,), rad/s at path rate 1."""
    return piece_speeds(path).max(axis=0)


def check_path_speeds(log: JointLog, path: SplinePath, keep: np.ndarray | None = None,
                      *, speed_limit: np.ndarray, robot: str) -> None:
    """The path the robot runs (``path``, :func:`make_log_path` of the samples ``keep``
    (T,) bool of ``log``; None: all) within the joint speed limits ``speed_limit`` (n,)
    rad/s of ``robot`` at path rate 1. A spline may overshoot its samples' steps (a
    sudden start or stop), so samples within the limit do not make a path within it.
    Raises InputError naming the file, the row its fastest piece ends at, the joint,
    the figure and the limit."""
    speeds = piece_speeds(path)
    over = speeds / speed_limit[None, :]
    if np.all(over <= 1.0):
        return
    i, j = np.unravel_index(int(np.argmax(over)), over.shape)
    rows, q = (log.rows, log.q) if keep is None else (log.rows[keep], log.q[keep])
    closing = i + 1 >= len(rows)  # a repeated log's step back to its first sample
    k = len(rows) - 1 if closing else i + 1
    between = ("this sample and the log's first (its step back, repeat: true)" if closing
               else "the previous sample and this one")
    raise InputError(f"{log.row_name} {rows[k]}: {log.fields[j]}", float(q[k, j]),
                     f"a path the robot runs within the {robot}'s joint speed limit "
                     f"({math.degrees(speed_limit[j]):.0f} deg/s): the spline through the "
                     f"samples peaks at {math.degrees(speeds[i, j]):.1f} deg/s between "
                     f"{between} (a sudden start or stop makes the spline overshoot the "
                     "samples' own steps)", file=log.file)

