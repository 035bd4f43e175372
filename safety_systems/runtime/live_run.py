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

**Log.** ``trace.csv`` has simulate's columns (``outputs.trace_table``: time, k,
path_rate, robot_speed, stop_reason, S_max, rejected_<cause>, and per body d_true
(empty: the truth is not known live), d_measured, hidden and S) and then the runtime's:
``frame_time`` (the newest good frame's capture time on this clock), ``frames`` and
``bad_packets`` (counts so far) and ``tick_late`` (s the tick started after its due
time). ``time`` is seconds since the loop started; k is what was commanded (with
``--robot none``, what would have been). ``summary.json`` holds the run's counts, stops
by cause, timing figures and provenance.
"""

import dataclasses
import math
import select
import sys
import time

import numpy as np

from safety_systems.sensing import stops
from safety_systems.outputs.metrics import stops_by_cause
from safety_systems.runtime.mocap import BodyMap, FrameClock, NatNetSource
from safety_systems.runtime.robot_link import RobotLost
from safety_systems.runtime.safety_loop import SafetyLoop
from safety_systems.sensing.stops import REJECT_CAUSES
from safety_systems.sensing.tracks import TRACK_HIDDEN, TRACK_LOST

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


def trace_header(names: list[str]) -> list[str]:
    """trace.csv's columns (see the module docstring)."""
    header = ["time", "k", "path_rate", "robot_speed", "stop_reason", "S_max"]
    header += [f"rejected_{c}" for c in REJECT_CAUSES]
    for name in names:
        header += [f"{name}:d_true", f"{name}:d_measured", f"{name}:hidden", f"{name}:S"]
    return header + list(EXTRA)


def run_live(loop: SafetyLoop, bodies: BodyMap, names: list[str], mocap: NatNetSource,
             robot, *, latency: float, period: float, options: LiveOptions,
             now=time.monotonic) -> LiveResult:
    """Runs the control loop until ``options.duration`` has passed, an interrupt or an
    error (see the module docstring); returns the log."""
    header = trace_header(names)
    log = _Log(len(header))
    clock = FrameClock(latency)
    sockets = mocap.sockets()
    n = loop.n
    state = dict(bad=False, overrun_until=-math.inf, lost="", frames=0, good_frame=math.nan,
                 stop_asked=None)
    latencies, lateness = [], []
    status_due = 0.0

    def command(t: float) -> tuple[float, float, int]:
        k, s_max, reason = loop.decide(t, robot.rate_bound())
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
            per = row[10:10 + 4 * n].reshape(n, 4)
            per[:, 0] = math.nan
            per[:, 1] = loop.out[0]
            per[:, 2] = (loop.status == TRACK_HIDDEN) | (loop.status == TRACK_LOST)
            per[:, 3] = loop.out[1]
            row[10 + 4 * n:] = (state["good_frame"] - t_start, state["frames"],
                                mocap.bad_packets, late)
            log.add(row)
            if options.status and t >= status_due:
                status_due = t + STATUS_PERIOD
                _status(t - t_start, k, reason, loop, names, state["frames"])
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
    summary = _summary(rows, header, names, latencies, lateness, period, state, end, mocap)
    summary["clock_start"] = t_start  # the monotonic clock's reading at time 0
    return LiveResult(header, rows, summary, end)


def _status(t: float, k: float, reason: int, loop: SafetyLoop, names: list, frames: int
            ) -> None:
    d = loop.out[0]
    near = ""
    if np.any(np.isfinite(d)):
        i = int(np.nanargmin(d))
        near = f"  closest {names[i]} {d[i]:.2f} m (S {loop.out[1][i]:.2f} m)"
    print(f"\r{t:8.1f} s  k={k:4.2f}{near}  stop: {stops.STOP_REASONS[int(reason)]:<11}"
          f" frames {frames}   ", end="", file=sys.stderr, flush=True)


def _percentile(values: list, q: float) -> float | None:
    return float(np.percentile(values, q)) if values else None


def _summary(rows, header, names, latencies, lateness, period, state, end, mocap) -> dict:
    time_ = rows[:, 0]
    reasons = rows[:, header.index("stop_reason")]
    hidden = {name: float(np.sum(rows[:, header.index(f"{name}:hidden")] > 0.5) * period)
              for name in names}
    last = np.nanmax(rows, axis=0, initial=0.0) if len(rows) else np.zeros(len(header))
    return {
        "end": end,
        "duration": float(time_[-1]) if time_.size else 0.0,
        "ticks": int(len(rows)),
        "frames": int(state["frames"]),
        "bad_packets": int(mocap.bad_packets),
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
