"""RecordedMotion: true positions and velocities of operators played from recordings."""

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, LeafSystem, ValueProducer

from safety_systems.recording import recorded_state_one
from safety_systems.recording_mapping import RecordedBodies

MAX_OPERATORS = 5


@dataclasses.dataclass(frozen=True, eq=False)
class RecordedOperator:
    """One operator played from a recording: its ``bodies`` (cell frame), played from
    recording time ``start`` at t = 0 at ``time_scale`` recording seconds per second,
    every body moved by ``shift`` (m), present for enter_time <= t < leave_time (and
    while each body's recording tracks it)."""

    bodies: RecordedBodies
    start: float = 0.0
    time_scale: float = 1.0
    shift: tuple = (0.0, 0.0, 0.0)
    enter_time: float = 0.0
    leave_time: float = math.inf

    @property
    def num_bodies(self) -> int:
        return len(self.bodies.names)

    def recording_time(self, t: float | np.ndarray) -> float | np.ndarray:
        """The recording time played at time t."""
        return self.start + self.time_scale * np.asarray(t, dtype=float)

    def state(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(positions (n, 3), velocities (n, 3), present (n,)) at time t (m, m/s)."""
        n = self.num_bodies
        p, v, present = np.empty((n, 3)), np.empty((n, 3)), np.empty(n)
        b = self.bodies
        recorded_state_one(b.times, b.points, b.tracked_times, float(self.recording_time(t)),
                           p, v, present)
        if not self.enter_time <= t < self.leave_time:
            present[:] = 0.0
        return p + np.asarray(self.shift), v * self.time_scale, present

    def hidden_intervals(self) -> list[tuple[int, float, float]]:
        """(body index, start, end) intervals of time over which the recording did not
        track a body between its first and last tracked samples (the sensor does not see
        it then): each gap's open interval in recording time, mapped to time."""
        out = []
        for i, body_gaps in enumerate(self.bodies.gaps):
            for a, b in body_gaps:
                t0, t1 = ((x - self.start) / self.time_scale for x in (a, b))
                out.append((i, t0 + 1e-9, t1))
        return out


class RecordedMotion(LeafSystem):
    """Ground-truth motion of up to five recorded operators (a function of time only),
    with the ports of ``OperatorMotion``.

    Body slots are numbered operator by operator; body i's xyz is at [3i:3i+3]. Each
    body follows ``safety_systems.recording.recorded_state_one`` (linear between the
    recording's samples, the segment's slope as velocity, scaled by the operator's
    time scale); a body is present while its recording tracks it (from its first to its
    last tracked sample) and the operator is in the cell.

    .. pydrake_system::

        name: RecordedMotion
        output_ports:
        - positions_true
        - velocities_true
        - present

    Args:
        operators: the recorded operators (1 to 5); positions in metres, velocities in
            metres per second, cell (robot base) frame.
    """

    def __init__(self, *, operators: Sequence[RecordedOperator]) -> None:
        super().__init__()
        operators = tuple(operators)
        if not 1 <= len(operators) <= MAX_OPERATORS:
            raise ValueError(f"operators has {len(operators)} entries: allowed 1 to "
                             f"{MAX_OPERATORS}")
        for k, op in enumerate(operators):
            if not isinstance(op, RecordedOperator):
                raise ValueError(f"operators[{k}]={op!r}: must be a RecordedOperator")
            if not (math.isfinite(op.time_scale) and op.time_scale > 0.0):
                raise ValueError(f"operators[{k}].time_scale={op.time_scale}: must be > 0")
        self._operators = operators
        n = self._n = sum(op.num_bodies for op in operators)
        self._cache = self.DeclareCacheEntry(
            description="bodies_state",
            value_producer=ValueProducer(
                allocate=AbstractValue.Make((np.zeros(3 * n), np.zeros(3 * n),
                                             np.zeros(n))).Clone,
                calc=self._calc_state),
            prerequisites_of_calc={self.time_ticket()})
        ticket = {self._cache.ticket()}
        for which, (name, size) in enumerate((("positions_true", 3 * n),
                                              ("velocities_true", 3 * n), ("present", n))):
            self.DeclareVectorOutputPort(
                name, BasicVector(size),
                lambda c, o, w=which: o.SetFromVector(self._cache.Eval(c)[w]), ticket)

    @property
    def num_bodies(self) -> int:
        return self._n

    def _calc_state(self, context: Context, value: AbstractValue) -> None:
        states = [op.state(context.get_time()) for op in self._operators]
        value.set_value((np.concatenate([s[0] for s in states]).ravel(),
                         np.concatenate([s[1] for s in states]).ravel(),
                         np.concatenate([s[2] for s in states])))
