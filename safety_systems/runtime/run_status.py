"""The live run's status line, printed by the log writer process (``run_log_writer``)
from the numbers the loop publishes (``run_tally``): the loop itself prints nothing while
it runs, so a console that stalls (a paused terminal, a full pipe) cannot stall it."""

import math
import sys
import threading

from safety_systems.cell.human_body import SEGMENT_NAMES
from safety_systems.runtime.run_tally import (
    FIRST_FRAME_WAIT,
    FRAMES,
    HOLDING,
    LOG_DROPPED_FRAMES,
    LOG_DROPPED_TICKS,
    TICKS,
    WRITER_ERRORS,
    RunTally,
)
from safety_systems.sensing.stops import STOP_REASONS

STATUS_PERIOD = 0.25  # s between status lines


def status_line(tally: RunTally, columns: list[str]) -> str:
    """The console's status line from the tally's last published row."""
    row = tally.row
    at = {c: j for j, c in enumerate(columns)}
    near, best = "", math.inf
    for c, j in at.items():
        if c.endswith(":d_measured") and row[j] < best:
            op = c[:-len(":d_measured")]
            segment = row[at[f"{op}:nearest_measured"]]
            name = SEGMENT_NAMES[int(segment)] if segment == segment else "?"
            best = row[j]
            near = f"  closest {op}/{name} {row[j]:.2f} m (S {row[at[op + ':S']]:.2f} m)"
    reason = row[at["stop_reason"]]
    stop = STOP_REASONS[int(reason)] if reason == reason else "-"
    dropped = int(tally.count[LOG_DROPPED_TICKS] + tally.count[LOG_DROPPED_FRAMES])
    lost = int(tally.count[WRITER_ERRORS])
    log = "" if not dropped + lost else f"  LOG: {dropped + lost} records lost"
    return (f"\r{row[at['time']]:8.1f} s  k={row[at['k']]:4.2f}{near}  stop: {stop:<11}"
            f" frames {int(tally.count[FRAMES])}{log}   ")


def show_status(tally: RunTally, columns: list[str], done: threading.Event) -> None:
    """Prints the status line every STATUS_PERIOD until ``done`` (then ends its line);
    says when the first frame came."""
    first = False
    while not done.wait(STATUS_PERIOD):
        if not first and tally.count[TICKS] > 0 and tally.count[HOLDING] == 0:
            first = True  # (the wait the summary reports: to the first tick it ended)
            print(f"\rrun: first frame after {tally.time[FIRST_FRAME_WAIT]:.2f} s; running "
                  "(Ctrl-C stops the robot and ends the run)", file=sys.stderr, flush=True)
        print(status_line(tally, columns), end="", file=sys.stderr, flush=True)
    print(file=sys.stderr, flush=True)  # the runtime's last line begins a line of its own
