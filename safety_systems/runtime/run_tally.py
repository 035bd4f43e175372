"""The live run's summary, kept as the run goes: counts, stops by cause and timing
percentiles in a fixed block of numbers that does not grow with the run.

:class:`RunTally` is updated by the control loop at every tick and frame (a few
arithmetic steps on preallocated numbers; nothing is appended), and can live in memory
shared with the log writer process (``run_log_writer``), which rewrites summary.json
from it every second while the run goes on (a reading taken between two of the loop's
updates can be one tick behind in some figures; the summary written at the end is the
loop's own). Its :meth:`~RunTally.summary` has the fields summary.json had when the
runtime held its whole log in memory (``outputs.metrics.stops_by_cause`` and
``first_frame_wait`` of the ticks' stop reasons, the same numbers, now counted as the
ticks come), and its timing percentiles come from histograms:

**Percentiles** (tick lateness, frame to k): each value is counted in one of
:data:`BINS` bins whose edges grow by :data:`BIN_RATIO` (1%) from :data:`BIN_LOW`
(0.1 us; below it, a bin of its own read as 0) to 100 s; a percentile is the geometric
middle of the bin that holds the value of its rank (numpy's ``inverted_cdf``), so it
is within 0.5% of that value. The largest value is kept exactly.
"""

import math

import numpy as np

from safety_systems.cell.human_body import SEGMENT_NAMES
from safety_systems.outputs.held_terms import lowest_speed_of, untracked_points
from safety_systems.sensing.stops import STOP_REASONS, STOP_SEPARATION, STOP_STALE_FRAME
from safety_systems.sensing.stops import REJECT_CAUSES

BIN_LOW = 1e-7  # s: the lower edge of the first bin (below it: bin 0, read as 0)
BIN_RATIO = 1.01
BINS = 2 + int(math.ceil(math.log(100.0 / BIN_LOW) / math.log(BIN_RATIO)))
_LOG_RATIO = math.log(BIN_RATIO)
CAUSES = len(STOP_REASONS)
# the counters, by index into the tally's ``count`` field
(TICKS, FRAMES, BAD_PACKETS, HOLDING, LAST_CODE, LOG_SENT, LOG_DROPPED_TICKS,
 LOG_DROPPED_FRAMES, LATE_N, LATENCY_N, WRITER_ROWS, WRITER_FRAMES, WRITER_BYTES,
 WRITER_SEGMENTS, WRITER_ERRORS, WRITER_STATE) = range(16)
COUNTS = 16
# the times (s), by index into the ``time`` field
T_FIRST, T_LAST, FIRST_FRAME_WAIT, HOLD_TIME, LATE_MAX, LATENCY_MAX, WRITER_LAG_MAX = \
    range(7)
TIMES = 7
WRITER_RUNNING, WRITER_DONE, WRITER_FAILED = 0, 1, 2
NO_SEGMENT = len(SEGMENT_NAMES)  # the ``held`` slot of a separation stop with no segment


def bin_of(x: float) -> int:
    """The histogram bin of a value in seconds (see the module docstring)."""
    if not x >= BIN_LOW:  # (NaN too)
        return 0
    return min(1 + int(math.log(x / BIN_LOW) / _LOG_RATIO), BINS - 1)


def bin_value(b: int) -> float:
    """The value a bin stands for: its geometric middle (bin 0: 0)."""
    return 0.0 if b == 0 else BIN_LOW * BIN_RATIO ** (b - 0.5)


def percentile(hist: np.ndarray, q: float) -> float | None:
    """The ``q``-th percentile (0-100) of the values counted in ``hist``: the value of
    the bin holding the value of rank ceil(q / 100 n) (numpy's ``inverted_cdf``); None
    when nothing was counted."""
    n = int(hist.sum())
    if n == 0:
        return None
    rank = max(1, math.ceil(q / 100.0 * n))
    return bin_value(int(np.searchsorted(np.cumsum(hist), rank)))


def tally_dtype(bodies: int, width: int) -> np.dtype:
    """The tally's numbers for ``bodies`` tracked bodies and log rows of ``width``."""
    return np.dtype([("count", "<i8", (COUNTS,)), ("time", "<f8", (TIMES,)),
                     ("stop_count", "<i8", (CAUSES,)), ("stop_time", "<f8", (CAUSES,)),
                     ("rejected", "<f8", (len(REJECT_CAUSES),)),
                     ("hidden_ticks", "<i8", (max(bodies, 1),)),
                     ("late", "<i8", (BINS,)), ("latency", "<i8", (BINS,)),
                     ("held", "<f8", (NO_SEGMENT + 1,)),
                     ("row", "<f8", (max(width, 1),))])


class RunTally:
    """See the module docstring. ``buffer``: memory to keep the numbers in (shared with
    another process), or None (a block of its own); ``fresh``: start the count there
    (False: read the numbers another process keeps in ``buffer``)."""

    def __init__(self, bodies: int, width: int, buffer=None, *, fresh: bool = True):
        self.dtype = tally_dtype(bodies, width)
        self.bodies, self.width = bodies, width
        if buffer is None:
            self.block = np.zeros(1, dtype=self.dtype)
        else:
            self.block = np.frombuffer(buffer, dtype=self.dtype, count=1)
        if fresh:
            self.reset()
        field = {name: self.block[name][0] for name in self.dtype.names}  # views
        self.count, self.time = field["count"], field["time"]
        self.stop_count, self.stop_time = field["stop_count"], field["stop_time"]
        self.rejected, self.hidden_ticks = field["rejected"], field["hidden_ticks"]
        self.late, self.latency, self.row = field["late"], field["latency"], field["row"]
        self.held = field["held"]
        self._segment = NO_SEGMENT
        self._scalars = [int(x) for x in self.count]  # the loop's counters as it goes
        self._times = [float(x) for x in self.time]
        self._rejected = None

    @staticmethod
    def nbytes(bodies: int, width: int) -> int:
        return tally_dtype(bodies, width).itemsize

    def reset(self) -> None:
        """Every number to its start (nothing counted)."""
        self.block[...] = np.zeros(1, dtype=self.dtype)
        count, time = self.block["count"][0], self.block["time"][0]
        count[HOLDING], count[LAST_CODE] = 1, -1
        time[LATE_MAX] = time[LATENCY_MAX] = time[WRITER_LAG_MAX] = -math.inf
        self.block["rejected"][0] = math.nan
        self.block["row"][0] = math.nan

    def tick(self, t: float, reason: int, late: float, rejected, hidden,
             segment: float = math.nan) -> None:
        """A tick at ``t`` (s since the loop started) that stopped for ``reason`` (a
        ``stops`` code), started ``late`` s after its due time, with the tracker's
        rejected counts so far ((4,), NaN: none known), whether each body was hidden
        (bool (N,)) and the segment nearest in the monitor's measure (an index of
        ``SEGMENT_NAMES``, NaN: none): a separation stop's seconds are counted to it. The
        counters reach the block at :meth:`publish`."""
        s = self._scalars
        if s[TICKS] == 0:
            self._times[T_FIRST] = t
        else:
            dt = t - self._times[T_LAST]
            if s[LAST_CODE] > 0:
                self.stop_time[s[LAST_CODE]] += dt
                if s[LAST_CODE] == STOP_SEPARATION:
                    self.held[self._segment] += dt
            if s[HOLDING]:
                self._times[HOLD_TIME] += dt
        code = int(reason)
        if s[HOLDING] and code != STOP_STALE_FRAME:  # the first frame came: the wait ends
            s[HOLDING] = 0
            self._times[FIRST_FRAME_WAIT] = t - self._times[T_FIRST]
        if s[HOLDING]:
            code = -1  # waiting for the first frame is not a stop (``first_frame_wait``)
        if code > 0 and code != s[LAST_CODE]:
            self.stop_count[code] += 1
        s[LAST_CODE] = code
        self._segment = int(segment) if 0 <= segment < NO_SEGMENT else NO_SEGMENT
        s[TICKS] += 1
        self._times[T_LAST] = t
        if rejected[0] == rejected[0]:
            self._rejected = rejected
        self.hidden_ticks += hidden
        if late == late:  # (the row after an exception has none)
            self.late[bin_of(late)] += 1
            s[LATE_N] += 1
            if late > self._times[LATE_MAX]:
                self._times[LATE_MAX] = late

    def frame_to_k(self, seconds: float) -> None:
        """A frame's time from its arrival to the k commanded for it."""
        self.latency[bin_of(seconds)] += 1
        self._scalars[LATENCY_N] += 1
        if seconds > self._times[LATENCY_MAX]:
            self._times[LATENCY_MAX] = seconds

    def set(self, index: int, value: int) -> None:
        """Sets a counter (frames, bad packets, the log's) to ``value``."""
        self._scalars[index] = value

    def publish(self) -> None:
        """Writes the loop's counters into the block (where another process reads them)."""
        s = self._scalars
        self.count[:WRITER_ROWS] = s[:WRITER_ROWS]
        self.time[:WRITER_LAG_MAX] = self._times[:WRITER_LAG_MAX]
        if self._rejected is not None:
            self.rejected[:] = self._rejected

    def summary(self, names: list[str], period: float, end: str) -> dict:
        """summary.json's run figures (see the module docstring): ``names`` the tracked
        bodies', ``period`` the control period (s), ``end`` how the run ended."""
        c, tm = self.count.copy(), self.time.copy()
        stop_count, stop_time = self.stop_count.copy(), self.stop_time.copy()
        ticks = int(c[TICKS])
        if c[HOLDING] and ticks:  # no frame ever came: that wait was a stop (a fault)
            stop_count[STOP_STALE_FRAME] += 1
            stop_time[STOP_STALE_FRAME] += tm[HOLD_TIME]
        rejected = np.nan_to_num(self.rejected, nan=0.0)
        stops = {name: {"count": int(stop_count[code]), "time": float(stop_time[code])}
                 for code, name in enumerate(STOP_REASONS) if code}
        held = self.held.copy()
        by_segment = {name: float(x) for name, x in zip(SEGMENT_NAMES + ("none",), held)
                      if x > 0.0}
        return {
            "end": end,
            "duration": float(tm[T_LAST]) if ticks else 0.0,
            "ticks": ticks,
            "frames": int(c[FRAMES]),
            "bad_packets": int(c[BAD_PACKETS]),
            "first_frame_wait": 0.0 if c[HOLDING] else float(tm[FIRST_FRAME_WAIT]),
            "protective_stops": stops,
            "rejected_frames": {name: int(x) for name, x in zip(REJECT_CAUSES, rejected)},
            # what held the robot (``outputs.held.held_by``'s fields; a live run has no
            # true clearance)
            "held": {"causes": {name: stop["time"] for name, stop in stops.items()
                                if stop["time"] > 0.0},
                     "separation": {"time": float(held.sum()),
                                    "by_segment": dict(sorted(by_segment.items(),
                                                              key=lambda x: -x[1])),
                                    "true_clearance_median": None}},
            "hidden_time": {name: float(self.hidden_ticks[i] * period)
                            for i, name in enumerate(names)},
            "timing": {
                "control_period": period,
                "tick_late_p50": percentile(self.late, 50),
                "tick_late_p99": percentile(self.late, 99),
                "tick_late_max": float(tm[LATE_MAX]) if c[LATE_N] else None,
                "frame_to_k_p50": percentile(self.latency, 50),
                "frame_to_k_p99": percentile(self.latency, 99),
                "frame_to_k_max": float(tm[LATENCY_MAX]) if c[LATENCY_N] else None,
                "percentiles": f"from histograms of bins {100 * (BIN_RATIO - 1):g}% wide: "
                               f"within {50 * (BIN_RATIO - 1):g}% of the value of their rank",
            },
        }

    def log_figures(self) -> dict:
        """What the log writer did (its counters in the block) and what the loop could
        not hand it."""
        c, tm = self.count, self.time
        state = ("writing", "closed", "failed")[int(c[WRITER_STATE])]
        return {
            "writer": state,
            "segments": int(c[WRITER_SEGMENTS]),
            "ticks_written": int(c[WRITER_ROWS]),
            "frames_written": int(c[WRITER_FRAMES]),
            "bytes": int(c[WRITER_BYTES]),
            "dropped_ticks": int(c[LOG_DROPPED_TICKS]),
            "dropped_frames": int(c[LOG_DROPPED_FRAMES]),
            "lost_to_errors": int(c[WRITER_ERRORS]),
            "flush_age_max": float(tm[WRITER_LAG_MAX]) if tm[WRITER_LAG_MAX] > -math.inf
            else None,
        }


def run_summary(fixed: dict, tally: RunTally, end: str) -> dict:
    """summary.json of a run: ``fixed``'s fields (``fields``: what was run, with what,
    how scheduled; ``names``, ``period``; ``log``: the log's settings; ``clock_start``,
    ``startup``, ``provenance``), the tally's figures and the log's."""
    out = dict(fixed["fields"])
    out.update(tally.summary(fixed["names"], fixed["period"], end))
    separation = out["held"]["separation"]
    first = next(iter(separation["by_segment"]), "none")
    if "tracked" in fixed:  # the segment's untracked points and what its stop asked
        separation["untracked_points"] = untracked_points(first, fixed["tracked"])
    if "lowest_speed" in fixed:
        separation["lowest_speed"] = lowest_speed_of(fixed["lowest_speed"], first,
                                                     separation)
    out["log"] = {**fixed["log"], **tally.log_figures()}
    for key in ("clock_start", "startup", "provenance"):
        if key in fixed:
            out[key] = fixed[key]
    return out
