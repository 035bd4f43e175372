"""verify's and tune's phases, each named with its count, and the time left, on stderr.

A long command says what it is doing: before each phase a line such as
``verify: phase 2 of 4: searching, a budget of 200 simulation-equivalents (about 12 s
left in all)``; a progress bar then counts the phase's steps. The estimates assume the
per-tick maths compiled (a first run says it is compiling, and for how long). They come
from measured costs: one closed-loop simulation of the batched evaluator takes
``SIMULATION_SECONDS`` of CPU and one Drake run ``verification.search.counts.COST``'s
price of it (``benchmarks/bench_verify.py --parts costs``); the Drake diagram runs a
scenario at about ``DRAKE_REAL_TIME`` times real time (``benchmarks/bench_simulate.py``);
once a phase has run, what it took replaces them.
"""

import math
import sys

from verification.search.counts import COST

SIMULATION_SECONDS = 0.0023  # CPU s of one simulation (counts.py: 2.2-2.3 ms measured)
DRAKE_SECONDS = COST["drake"] * SIMULATION_SECONDS  # a 10 s scenario in the Drake diagram
DRAKE_REAL_TIME = 13.0  # the diagram's speed over real time (bench_simulate: 13.7x)


def duration_words(seconds: float) -> str:
    """"about 12 s", "about 3 min", "about 2.5 h"."""
    if not math.isfinite(seconds):
        return "not known"
    if seconds < 90.0:
        return f"about {max(1, round(seconds))} s"
    if seconds < 5400.0:
        return f"about {round(seconds / 60.0)} min"
    return f"about {seconds / 3600.0:.1f} h"


def verify_seconds(budget: int, replays: int, workers: int, drake_search: bool) -> float:
    """What a verification is expected to take once compiled: its search (``budget``
    simulation-equivalents on ``workers`` cores; each a Drake run where the space's
    scenarios run in the diagram, ``drake_search``) and its Drake replays, one after
    another."""
    each = DRAKE_SECONDS if drake_search else SIMULATION_SECONDS
    return budget * each / max(1, workers) + replays * DRAKE_SECONDS


class Phases:
    """Prints ``COMMAND: phase i of n: WHAT (about T left in all)`` on stderr (above any
    progress bar), or nothing when off."""

    def __init__(self, command: str, count: int, on: bool = True, write=None):
        self.command, self.count, self.on, self.index = command, count, on, 0
        self.write = write or _stderr

    def start(self, what: str, left: float | tuple[float, float] | None = None) -> None:
        """The next phase: ``what`` it does, and ``left``, the time the command may
        still take (seconds, or the least and the most)."""
        self.index += 1
        if not self.on:
            return
        line = f"{self.command}: phase {self.index} of {self.count}: {what}"
        if isinstance(left, tuple) and duration_words(left[0]) != duration_words(left[1]):
            low, high = (duration_words(x) for x in left)
            line += f" ({low} to {high.removeprefix('about ')} left in all)"
        elif left is not None:
            line += f" ({duration_words(left[0] if isinstance(left, tuple) else left)} " \
                    "left in all)"
        self.write(line)


def _stderr(line: str) -> None:
    from tqdm import tqdm

    tqdm.write(line, file=sys.stderr)
    sys.stderr.flush()
