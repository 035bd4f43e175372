"""The live control loop, its watchdog and its log.

Every control period (the verified robot's control rate, 500 Hz for the UR5e) the loop
reads the robot's joint positions, decides k (``safety_loop.SafetyLoop``: the
simulator's tracker, monitor and override functions) and commands it; between ticks it
waits on the NatNet client's sockets, and a frame that arrives is processed at once
and a new k commanded then (not at the next tick).

**Watchdog.** k is 0, whatever the monitor says, while (in this order of naming):
- the robot is lost: its connection closed, or no new joint sample for its timeout
  (``robot_lost``; it does not come back within a run);
- a motion-capture packet could not be read, until a good frame follows (``bad_packet``);
- the loop ran late: a tick that starts more than ``max_overrun`` after its due time
  holds k at 0 for ``overrun_hold`` (``overrun``);
and, by the tracker's own rules, when no valid frame is newer than the frame timeout
(``stale_frame``) or a frame is faulty. Any exception ends the run at k = 0
(``exception``). Whenever the stop is for a fault (anything but ``separation``) the
robot link's protective stop is asked for (``robot_link``). On every exit, normal or
not, the last command is k = 0: the slider is never left where it was.

**Log.** ``trace.csv`` has simulate's columns for the SSM override
(``outputs.run_files.trace_table``): time, k, path_rate, robot_speed, stop_reason,
S_max, rejected_<cause>, and per operator ``<op>:d_true`` and ``<op>:nearest_true``
(empty: the truth is not known live), ``<op>:d_measured`` (the least of the monitor's d
over the operator's twelve segments, empty while none is monitored),
``<op>:nearest_measured`` (that segment, by name) and ``<op>:S`` (its S; under
``safety.stopping: by_speed`` at the level the override held it to: the larger of the
level at or above the rate bound and the commanded k's), then per tracked body of the
operator ``<op>/<body>:hidden`` (1 while its track is a hidden ball, or lost); and then
the runtime's: ``frame_time`` (the newest good frame's capture time on this clock),
``frames`` and ``bad_packets`` (counts so far) and ``tick_late`` (s the tick started
after its due time). ``time`` is seconds since the loop started; k is what was
commanded (with ``--robot none``, what would have been). ``summary.json`` holds the
run's counts, stops by cause, the time each tracked body spent hidden or lost
(``hidden_time``), timing figures and provenance.
"""

import dataclasses
import math
import select
import sys
import time

import numpy as np

from safety_systems.cell.human_body import NUM_SEGMENTS, SEGMENT_NAMES
from safety_systems.sensing import stops
from safety_systems.outputs.metrics import first_frame_wait, stops_by_cause
from safety_systems.runtime.mocap import BodyMap, FrameClock, NatNetSource
from safety_systems.runtime.robot_link import RobotLost
from safety_systems.runtime.safety_loop import SafetyLoop
from safety_systems.sensing.stops import REJECT_CAUSES
from safety_systems.sensing.tracks import TRACK_HIDDEN, TRACK_LOST
from safety_systems.ssm.formulas import held_level

MAX_OVERRUN = 0.005  # s: a tick may start this late before the watchdog stops the robot
OVERRUN_HOLD = 0.2  # s k stays 0 after an overrun
STATUS_PERIOD = 0.25  # s between status lines
EXTRA = ("frame_time", "frames", "bad_packets", "tick_late")


@dataclasses.dataclass
class LiveOptions:
    duration: float | None = None  # s; None: until interrupted
    max_overrun: float = MAX_OVERRUN
    overrun_hold: float = OVERRUN_HOLD
    status: bool = True


@dataclasses.dataclass
class LiveResult:
    header: list
    rows: np.ndarray
    summary: dict
    end: str  # "duration", "interrupted", "robot_lost: ...", "exception: ..."


class _Log:
    """Rows of floats, grown in chunks."""

    def __init__(self, width: int):
        self.data, self.n = np.empty((4096, width)), 0

    def add(self, row: np.ndarray) -> None:
        if self.n == len(self.data):
            self.data = np.concatenate([self.data, np.empty_like(self.data)])
        self.data[self.n] = row
        self.n += 1

    def rows(self) -> np.ndarray:
        return self.data[:self.n].copy()


OPERATOR_COLUMNS = ("d_true", "nearest_true", "d_measured", "nearest_measured", "S")


def trace_header(operators: list[tuple[str, list[str]]]) -> list[str]:
    """trace.csv's columns (see the module docstring) of ``operators``: (name, its
    tracked bodies' names) each."""
    header = ["time", "k", "path_rate", "robot_speed", "stop_reason", "S_max"]
    header += [f"rejected_{c}" for c in REJECT_CAUSES]
    for name, bodies in operators:
        header += [f"{name}:{c}" for c in OPERATOR_COLUMNS]
        header += [f"{body}:hidden" for body in bodies]
    return header + list(EXTRA)


class _OperatorColumns:
    """The per-operator columns of a trace row from the loop's state (as simulate's
    ``operator_figures.operator_figures`` takes them from the logged signals)."""

    def __init__(self, loop: SafetyLoop, names: list[str]):
        slots = loop.recipe.slots
        K = self.K = slots.shape[0]
        if not np.array_equal(loop.recipe.operator, np.repeat(np.arange(K), NUM_SEGMENTS)):
            raise ValueError("the recipe's segments: 12 per operator, operator by operator")
        self.operators = [(loop.operator_names[k], [names[i] for i in slots[k] if i >= 0])
                          for k in range(K)]
        self.header = trace_header(self.operators)
        at = {name: j for j, name in enumerate(self.header)}
        self.at = {c: np.array([at[f"{o}:{c}"] for o, _ in self.operators], dtype=int)
                   for c in OPERATOR_COLUMNS}
        self.hidden_at = np.array([at[f"{names[i]}:hidden"] for i in range(loop.n)],
                                  dtype=int)
        self.which = np.array([SEGMENT_NAMES.index(n.rsplit("/", 1)[1])
                               for n in loop.segment_names], dtype=float).reshape(K, -1)
        self.rows = np.arange(K)
        self.levels = None if loop.levels is None else loop.levels[0].size - 1

    def fill(self, row: np.ndarray, loop: SafetyLoop, k: float, rate: float) -> None:
        """Writes the operators' columns of ``row`` at a tick that commanded k under the
        rate bound ``rate``."""
        d = loop.out[0].reshape(self.K, -1)
        none = np.isnan(d).all(axis=1)
        j = np.where(np.isnan(d), np.inf, d).argmin(axis=1)
        if self.levels is None:
            s = loop.out[1]
        else:
            g = held_level(rate, k, self.levels)
            s = loop.level_out[g]
        row[self.at["d_true"]] = math.nan
        row[self.at["nearest_true"]] = math.nan
        row[self.at["d_measured"]] = np.where(none, np.nan, d[self.rows, j])
        row[self.at["nearest_measured"]] = np.where(none, np.nan, self.which[self.rows, j])
        row[self.at["S"]] = np.where(none, np.nan, s.reshape(self.K, -1)[self.rows, j])
        row[self.hidden_at] = _hidden(loop.status)


def run_live(loop: SafetyLoop, bodies: BodyMap, names: list[str], mocap: NatNetSource,
             robot, *, latency: float, period: float, options: LiveOptions,
             now=time.monotonic) -> LiveResult:
    """Runs the control loop until ``options.duration`` has passed, an interrupt or an
    error (see the module docstring); returns the log. ``names``: the tracked bodies'
    (``operator/body``), in slot order."""
    columns = _OperatorColumns(loop, names)
    header = columns.header
    width = len(header) - len(EXTRA)
    log = _Log(len(header))
    clock = FrameClock(latency)
    sockets = mocap.sockets()
    hidden_ticks = np.zeros(loop.n)  # ticks each body spent hidden or lost
    state = dict(bad=False, overrun_until=-math.inf, lost="", frames=0, good_frame=math.nan,
                 stop_asked=None, rate=math.nan)
    latencies, lateness = [], []
    status_due = 0.0

    def command(t: float) -> tuple[float, float, int]:
        state["rate"] = robot.rate_bound()
        k, s_max, reason = loop.decide(t, state["rate"])
        cause = (stops.STOP_ROBOT_LOST if state["lost"] else stops.STOP_BAD_PACKET
                 if state["bad"] else stops.STOP_OVERRUN if t < state["overrun_until"]
                 else None)
        if cause is not None:
            k, reason = 0.0, cause
        robot.command(k)
        fault = reason >= stops.STOP_STALE_FRAME
        if fault != state["stop_asked"]:
            robot.protective_stop(fault)
            state["stop_asked"] = fault
        return k, s_max, reason

    def frames_in() -> None:
        before = mocap.bad_packets
        frames = mocap.poll()
        if mocap.bad_packets > before:
            state["bad"] = True
        for arrival, frame in frames:
            t_capture = clock.capture_time(frame.suffix.timestamp, arrival)
            z, valid, ids = bodies.entries(frame.rigid_bodies)
            loop.frame(t_capture, z, valid, ids)
            state["frames"] += 1
        if frames and mocap.bad_packets == before:
            state["bad"] = False
        if frames or state["bad"]:  # a new k at once, not at the next tick
            state["good_frame"] = loop.t_good[0]
            command(now())
        if frames:
            latencies.append(now() - frames[-1][0])

    mocap.poll()  # frames queued while connecting are old: the loop starts afresh
    mocap.frames.clear()
    t_start = now()
    end_at = math.inf if options.duration is None else t_start + options.duration
    next_tick, end = t_start, "duration"
    k, reason = 0.0, stops.STOP_STALE_FRAME
    robot.command(0.0)
    try:
        while True:
            t = now()
            if t >= end_at:
                break
            wait = min(next_tick, end_at) - t
            if wait > 0.0:
                ready, _, _ = select.select(sockets, [], [], wait)
                if ready:
                    frames_in()
                continue
            late = t - next_tick
            lateness.append(late)
            if late > options.max_overrun:
                state["overrun_until"] = t + options.overrun_hold
            robot.advance_to(next_tick - t_start)  # a model robot's time: the tick's
            try:
                q, t_q = robot.read()
                loop.robot(q, t_q)
            except RobotLost as e:
                if not state["lost"]:
                    state["lost"] = str(e)
            k, s_max, reason = command(t)
            row = np.empty(len(header))
            row[:10] = (t - t_start, k, getattr(robot, "rate", math.nan),
                        float(np.nanmax(np.linalg.norm(loop.end_velocities, axis=-1),
                                        initial=0.0)),
                        reason, s_max, *loop.rejected)
            columns.fill(row, loop, k, state["rate"])
            row[width:] = (state["good_frame"] - t_start, state["frames"],
                           mocap.bad_packets, late)
            log.add(row)
            hidden_ticks += _hidden(loop.status)
            if options.status and t >= status_due:
                status_due = t + STATUS_PERIOD
                _status(t - t_start, k, reason, loop, state["frames"])
            next_tick += period
            if next_tick < t - period:  # fell more than a period behind: skip, and say so
                next_tick += period * math.floor((t - next_tick) / period + 1.0)
    except KeyboardInterrupt:
        end = "interrupted"
    except Exception as e:  # noqa: BLE001 - any error ends the run at k = 0
        end = f"exception: {type(e).__name__}: {e}"
        reason = stops.STOP_EXCEPTION
    finally:
        robot.command(0.0)  # never left where it was
        robot.protective_stop(reason >= stops.STOP_STALE_FRAME)
        robot.close()
        mocap.close()
    if state["lost"] and end == "duration":
        end = f"robot_lost: {state['lost']}"
    if end.startswith("exception"):  # the last row says why the robot was stopped
        row = np.full(len(header), math.nan)
        row[:5] = (now() - t_start, 0.0, math.nan, math.nan, stops.STOP_EXCEPTION)
        log.add(row)
    if options.status:
        print(file=sys.stderr)
    rows = log.rows()
    hidden = {name: float(ticks * period) for name, ticks in zip(names, hidden_ticks)}
    summary = _summary(rows, header, hidden, latencies, lateness, period, state, end, mocap)
    summary["clock_start"] = t_start  # the monotonic clock's reading at time 0
    return LiveResult(header, rows, summary, end)


def _hidden(status: np.ndarray) -> np.ndarray:
    """Whether each status is hidden or lost."""
    return (status == TRACK_HIDDEN) | (status == TRACK_LOST)


def _status(t: float, k: float, reason: int, loop: SafetyLoop, frames: int) -> None:
    d = loop.out[0]
    near = ""
    if np.any(np.isfinite(d)):
        i = int(np.nanargmin(d))
        near = f"  closest {loop.segment_names[i]} {d[i]:.2f} m (S {loop.out[1][i]:.2f} m)"
    print(f"\r{t:8.1f} s  k={k:4.2f}{near}  stop: {stops.STOP_REASONS[int(reason)]:<11}"
          f" frames {frames}   ", end="", file=sys.stderr, flush=True)


def _percentile(values: list, q: float) -> float | None:
    return float(np.percentile(values, q)) if values else None


def _summary(rows, header, hidden, latencies, lateness, period, state, end, mocap) -> dict:
    time_ = rows[:, 0]
    reasons = rows[:, header.index("stop_reason")]
    last = np.nanmax(rows, axis=0, initial=0.0) if len(rows) else np.zeros(len(header))
    return {
        "end": end,
        "duration": float(time_[-1]) if time_.size else 0.0,
        "ticks": int(len(rows)),
        "frames": int(state["frames"]),
        "bad_packets": int(mocap.bad_packets),
        "first_frame_wait": first_frame_wait(reasons, time_),
        "protective_stops": stops_by_cause(reasons, time_),
        "rejected_frames": {c: int(last[header.index(f"rejected_{c}")]) for c in REJECT_CAUSES},
        "hidden_time": hidden,
        "timing": {
            "control_period": period,
            "tick_late_p50": _percentile(lateness, 50), "tick_late_p99": _percentile(lateness, 99),
            "tick_late_max": max(lateness, default=None),
            "frame_to_k_p50": _percentile(latencies, 50),
            "frame_to_k_p99": _percentile(latencies, 99),
        },
    }
