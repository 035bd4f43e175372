"""GestureSource: timed gesture commands (seed 001, Section 2.1) from a scenario."""

import numpy as np
from pydrake.systems.framework import BasicVector, Context, LeafSystem

from safety_systems.planning.zones import GESTURE_CODES, NO_GESTURE


class GestureSource(LeafSystem):
    """The code of the latest gesture at the current time (0 none, 1 start, 2 stop,
    3 resume), as a recognised-gesture stream would deliver it.

    .. pydrake_system::

        name: GestureSource
        output_ports:
        - gesture

    Args:
        events: (time in seconds, command name) pairs, times increasing.
    """

    def __init__(self, *, events) -> None:
        super().__init__()
        events = list(events)
        for t, command in events:
            if command not in GESTURE_CODES:
                raise ValueError(f"command: got {command!r}; allowed: {sorted(GESTURE_CODES)}")
        self._times = np.array([t for t, _ in events], dtype=float)
        if np.any(np.diff(self._times) <= 0.0):
            raise ValueError(f"events: times {self._times.tolist()} must increase")
        self._codes = np.array([GESTURE_CODES[c] for _, c in events], dtype=float)
        self.DeclareVectorOutputPort("gesture", 1, self._calc,
                                     prerequisites_of_calc={self.time_ticket()})

    def _calc(self, context: Context, output: BasicVector) -> None:
        i = np.searchsorted(self._times, context.get_time(), side="right") - 1
        output.SetAtIndex(0, float(self._codes[i]) if i >= 0 else float(NO_GESTURE))
