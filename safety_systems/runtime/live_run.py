"""The live control loop, its watchdog and its log.

Every control period (the verified robot's control rate, 500 Hz for the UR5e) the loop
reads the robot's joint positions, decides k (``safety_loop.SafetyLoop``: the
simulator's tracker, monitor and override functions) and commands it; between ticks it
waits on the NatNet client's sockets, and a frame that arrives is processed at once
and a new k commanded then (not at the next tick), unless the next tick is due before
that work would end (the longest a frame's work took lately, at most a quarter of a
period): then the tick takes the frame first and commands its k, so that no tick starts
late for a frame (measured: frames were what made nearly every late tick; issue 49).

**Watchdog.** k is 0, whatever the monitor says, while (in this order of naming):
- the robot is lost: its connection closed, or no new joint sample for its timeout
  (``robot_lost``; it does not come back within a run);
- a motion-capture packet could not be read, until a good frame follows (``bad_packet``);
- the loop ran late: a tick that starts more than ``max_overrun`` after its due time
  holds k at 0 for ``overrun_hold`` (``overrun``);
and, by the tracker's own rules, when no valid frame is newer than the frame timeout
(``stale_frame``) or a frame is faulty. Any exception ends the run at k = 0
(``exception``), and so does Ctrl-C. Whenever the stop is for a fault (anything but
``separation``) the robot link's protective stop is asked for (``robot_link``). On
every exit, normal or not, the last command is k = 0: the slider is never left where
it was (a second Ctrl-C while the loop ends is held until that command is sent).

**Log** (``run_log_pipe``, written by its own process; the format:
``sensing.run_log_format``). Each tick's row: simulate's columns for the SSM override
(``outputs.run_files.trace_table``): time, k, path_rate, robot_speed, stop_reason,
S_max, rejected_<cause>, and per operator ``<op>:d_true`` and ``<op>:nearest_true``
(NaN: the truth is not known live), ``<op>:d_measured`` (the least of the monitor's d
over the operator's twelve segments, NaN while none is monitored),
``<op>:nearest_measured`` (that segment) and ``<op>:S`` (its S; under
``safety.stopping: by_speed`` at the level the override held it to: the larger of the
level at or above the rate bound and the commanded k's), then per tracked body of the
operator ``<op>/<body>:hidden`` (1 while its track is a hidden ball, or lost); and then
the runtime's: ``frame_time`` (the newest good frame's capture time on this clock),
``frames`` and ``bad_packets`` (counts so far) and ``tick_late`` (s the tick started
after its due time); then ``log_dropped`` (records the log could not take so far) and
the robot's joints as read (``robot_time``, ``q_0``...). ``time`` is seconds since the
loop started; k is what was commanded (with ``--robot none``, what would have been).
Each frame is logged as received, with the time from its arrival to the k commanded
for it. The summary's counts, stops by cause, the time each tracked body spent hidden
or lost (``hidden_time``) and timing figures are kept as the run goes (``run_tally``):
nothing in the loop grows with the run's length.
"""

import contextlib
import dataclasses
import math
import select
import signal
import threading
import time

import numpy as np

from safety_systems.cell.human_body import NUM_SEGMENTS, SEGMENT_NAMES
from safety_systems.runtime.mocap import BodyMap, FrameClock, NatNetSource
from safety_systems.runtime.robot_link import RobotLost
from safety_systems.runtime.run_log_pipe import RunLogPipe
from safety_systems.runtime.run_tally import BAD_PACKETS, FRAMES
from safety_systems.runtime.safety_loop import SafetyLoop
from safety_systems.sensing import stops
from safety_systems.sensing.run_log_format import MAX_FRAME_BODIES, tick_columns
from safety_systems.sensing.stops import REJECT_CAUSES
from safety_systems.sensing.tracks import TRACK_HIDDEN, TRACK_LOST
from safety_systems.ssm.formulas import held_level

MAX_OVERRUN = 0.005  # s: a tick may start this late before the watchdog stops the robot
OVERRUN_HOLD = 0.2  # s k stays 0 after an overrun
EXTRA = ("frame_time", "frames", "bad_packets", "tick_late")
FRAME_WORK = 0.3e-3  # s: a frame's work (tracker, monitor, k) as first assumed
WORK_DECAY = 0.99  # per frame: the estimate is the largest recent one, forgotten in ~1 s
WORK_MOST = 0.25  # of a control period: the most a frame waits for a tick (frame to k)


@dataclasses.dataclass
class LiveOptions:
    duration: float | None = None  # s; None: until interrupted
    max_overrun: float = MAX_OVERRUN
    overrun_hold: float = OVERRUN_HOLD


@dataclasses.dataclass
class LiveResult:
    header: list  # the trace's columns (a /tick row's first ones)
    end: str  # "duration", "interrupted", "robot_lost: ...", "exception: ..."
    clock_start: float  # the monotonic clock's reading at the loop's time 0


OPERATOR_COLUMNS = ("d_true", "nearest_true", "d_measured", "nearest_measured", "S")


def trace_header(operators: list[tuple[str, list[str]]]) -> list[str]:
    """The trace's columns (see the module docstring) of ``operators``: (name, its
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

    def fill(self, row: np.ndarray, loop: SafetyLoop, k: float, rate: float) -> float:
        """Writes the operators' columns of ``row`` at a tick that commanded k under the
        rate bound ``rate``; returns the segment nearest in the monitor's measure over
        every operator (an index of ``SEGMENT_NAMES``, NaN with none measured)."""
        d = loop.out[0].reshape(self.K, -1)
        none = np.isnan(d).all(axis=1)
        finite = np.where(np.isnan(d), np.inf, d)
        j = finite.argmin(axis=1)
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
        if none.all():
            return math.nan
        o = int(finite[self.rows, j].argmin())
        return float(self.which[o, j[o]])


def log_columns(loop: SafetyLoop, names: list[str], joints: int) -> tuple[list, list]:
    """(the trace's columns, a /tick row's columns: ``run_log_format.tick_columns``)."""
    trace = _OperatorColumns(loop, names).header
    return trace, tick_columns(trace, joints)


def run_live(loop: SafetyLoop, bodies: BodyMap, names: list[str], mocap: NatNetSource,
             robot, *, latency: float, period: float, options: LiveOptions,
             log: RunLogPipe, now=time.monotonic) -> LiveResult:
    """Runs the control loop until ``options.duration`` has passed, an interrupt or an
    error (see the module docstring), feeding ``log`` (its tally holds the summary's
    figures). ``names``: the tracked bodies' (``operator/body``), in slot order."""
    columns = _OperatorColumns(loop, names)
    header = columns.header
    width = len(header) - len(EXTRA)
    row = np.full(log.width, math.nan)  # one row, refilled every tick
    at_log, at_q = len(header), len(header) + 2
    tally = log.tally
    clock = FrameClock(latency)
    sockets = mocap.sockets()
    state = dict(bad=False, overrun_until=-math.inf, lost="", frames=0, good_frame=math.nan,
                 stop_asked=None, rate=math.nan)

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

    def take_frames() -> tuple[list, bool]:
        """The frames waiting, into the tracker: ([(arrival, frame, capture time)],
        whether k must be decided anew: a frame came, or a packet was bad)."""
        before = mocap.bad_packets
        frames = mocap.poll()
        if mocap.bad_packets > before:
            state["bad"] = True
        taken = []
        for arrival, frame in frames:
            t_capture = clock.capture_time(frame.suffix.timestamp, arrival)
            z, valid, ids = bodies.entries(frame.rigid_bodies)
            loop.frame(t_capture, z, valid, ids)
            taken.append((arrival, frame, t_capture))
            state["frames"] += 1
        if frames and mocap.bad_packets == before:
            state["bad"] = False
        if frames or state["bad"]:
            state["good_frame"] = loop.t_good[0]
        return taken, bool(frames) or state["bad"]

    def after_k(taken: list) -> None:
        """Once k was commanded for ``taken``: the time it took, and the frames logged."""
        if taken:
            done = now()
            tally.frame_to_k(done - taken[-1][0])
            for arrival, frame, t_capture in taken:
                _log_frame(log, frame, arrival - t_start, t_capture - t_start, done - arrival)
        tally.set(FRAMES, state["frames"])
        tally.set(BAD_PACKETS, mocap.bad_packets)

    mocap.poll()  # frames queued while connecting are old: the loop starts afresh
    mocap.frames.clear()
    t_start = now()
    log.begin({"clock_start": t_start, "unix_start_ns": time.time_ns()})
    end_at = math.inf if options.duration is None else t_start + options.duration
    next_tick, end = t_start, "duration"
    k, reason = 0.0, stops.STOP_STALE_FRAME
    work, deferred, taken = FRAME_WORK, False, []
    robot.command(0.0)
    try:
        while True:
            t = now()
            if t >= end_at:
                break
            wait = min(next_tick, end_at) - t
            if wait > 0.0:
                if deferred:  # a frame waits for the tick: sleep to it
                    select.select([], [], [], wait)
                elif select.select(sockets, [], [], wait)[0]:
                    if next_tick - now() > work:  # a new k at once, not at the next tick
                        began = now()
                        now_taken, new = take_frames()
                        if new:
                            command(now())
                        after_k(now_taken)
                        work = min(max(now() - began, work * WORK_DECAY),
                                   WORK_MOST * period)
                    else:  # the tick is due sooner than the frame's work ends: it takes it
                        deferred = True
                continue
            if deferred:
                taken, _ = take_frames()
                deferred = False
            late = t - next_tick
            if late > options.max_overrun:
                state["overrun_until"] = t + options.overrun_hold
            robot.advance_to(next_tick - t_start)  # a model robot's time: the tick's
            try:
                q, t_q = robot.read()
                loop.robot(q, t_q)
            except RobotLost as e:
                if not state["lost"]:
                    state["lost"] = str(e)
                q, t_q = math.nan, math.nan
            k, s_max, reason = command(t)
            row[:10] = (t - t_start, k, getattr(robot, "rate", math.nan),
                        float(np.nanmax(np.linalg.norm(loop.end_velocities, axis=-1),
                                        initial=0.0)),
                        reason, s_max, *loop.rejected)
            nearest = columns.fill(row, loop, k, state["rate"])
            row[width:at_log] = (state["good_frame"] - t_start, state["frames"],
                                 mocap.bad_packets, late)
            row[at_log], row[at_log + 1], row[at_q:] = log.dropped, t_q, q
            log.tick(row)
            tally.tick(t - t_start, reason, late, loop.rejected, _hidden(loop.status),
                       nearest)
            if taken:
                after_k(taken)
                taken = []
            next_tick += period
            if next_tick < t - period:  # fell more than a period behind: skip, and say so
                next_tick += period * math.floor((t - next_tick) / period + 1.0)
    except KeyboardInterrupt:
        end = "interrupted"
    except Exception as e:  # noqa: BLE001 - any error ends the run at k = 0
        end = f"exception: {type(e).__name__}: {e}"
        reason = stops.STOP_EXCEPTION
    finally:
        with held_interrupts() as came:
            robot.command(0.0)  # never left where it was
            robot.protective_stop(reason >= stops.STOP_STALE_FRAME)
            robot.close()
            mocap.close()
    if came and end == "duration":
        end = "interrupted"
    if state["lost"] and end == "duration":
        end = f"robot_lost: {state['lost']}"
    if end.startswith("exception"):  # the last row says why the robot was stopped
        row[:] = math.nan
        row[:5] = (now() - t_start, 0.0, math.nan, math.nan, stops.STOP_EXCEPTION)
        row[at_log] = log.dropped
        log.tick(row)
        tally.tick(row[0], stops.STOP_EXCEPTION, math.nan, row[6:10], np.zeros(loop.n, bool))
    log.publish(row)
    return LiveResult(header, end, t_start)


@contextlib.contextmanager
def held_interrupts():
    """Ctrl-C held off while the body runs (the robot's last command, the log's end);
    yields a list that holds True if one came (only the main thread can hold it)."""
    came: list = []
    if threading.current_thread() is not threading.main_thread():
        yield came
        return
    previous = signal.signal(signal.SIGINT, lambda *_: came.append(True))
    try:
        yield came
    finally:
        signal.signal(signal.SIGINT, previous)


def _log_frame(log: RunLogPipe, frame, arrival: float, capture: float, to_k: float) -> None:
    """A frame as received (its rigid bodies in the capture frame) into the log."""
    received = frame.rigid_bodies
    logged = received[:MAX_FRAME_BODIES]
    log.frame((arrival, capture, frame.suffix.timestamp, frame.prefix.frame_number, to_k,
               len(received)),
              [b.id_num for b in logged], [b.pos for b in logged], [b.rot for b in logged],
              [b.tracking_valid is not False for b in logged])


def _hidden(status: np.ndarray) -> np.ndarray:
    """Whether each status is hidden or lost."""
    return (status == TRACK_HIDDEN) | (status == TRACK_LOST)
