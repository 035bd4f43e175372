"""RecordedMotion: true positions and velocities of operators played from recordings."""

import math
from collections.abc import Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, LeafSystem, ValueProducer

from safety_systems.cell.human_body import NUM_POINTS, point_index
from safety_systems.cell.recorded_operator import RecordedOperator
from safety_systems.cell.operators import MAX_OPERATORS



class RecordedMotion(LeafSystem):
    """Ground-truth motion of up to five recorded operators (a function of time only),
    with the ports of ``OperatorMotion``.

    Body slots are numbered operator by operator; body i's xyz is at [3i:3i+3]. Each
    body follows ``safety_systems.sensing.recording.recorded_state_one`` (linear between the
    recording's samples, the segment's slope as velocity, scaled by the operator's
    time scale); a body is present while its recording tracks it (from its first to its
    last tracked sample) and the operator is in the cell. ``points_true`` and
    ``point_velocities_true`` (as ``OperatorMotion``'s: 10 points per operator) hold the
    body points the recorded bodies mark, NaN at the others (the properties bound those
    from the known ones); an operator is present (``operators_present``) while any of
    its bodies is.

    .. pydrake_system::

        name: RecordedMotion
        output_ports:
        - positions_true
        - velocities_true
        - present
        - points_true
        - point_velocities_true
        - operators_present

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
                allocate=AbstractValue.Make(
                    (np.zeros(3 * n), np.zeros(3 * n), np.zeros(n),
                     np.zeros(3 * NUM_POINTS * len(operators)),
                     np.zeros(3 * NUM_POINTS * len(operators)),
                     np.zeros(len(operators)))).Clone,
                calc=self._calc_state),
            prerequisites_of_calc={self.time_ticket()})
        ticket = {self._cache.ticket()}
        k = len(operators)
        # the point slot of each body: 10 k + the body point it marks
        self._point_slots = np.concatenate([
            [NUM_POINTS * j + point_index(p) for p in op.bodies.points_marked]
            for j, op in enumerate(operators)]).astype(np.int64)
        self._first = np.cumsum([0] + [op.num_bodies for op in operators])
        for which, (name, size) in enumerate((
                ("positions_true", 3 * n), ("velocities_true", 3 * n), ("present", n),
                ("points_true", 3 * NUM_POINTS * k),
                ("point_velocities_true", 3 * NUM_POINTS * k), ("operators_present", k))):
            self.DeclareVectorOutputPort(
                name, BasicVector(size),
                lambda c, o, w=which: o.SetFromVector(self._cache.Eval(c)[w]), ticket)

    @property
    def num_bodies(self) -> int:
        return self._n

    def _calc_state(self, context: Context, value: AbstractValue) -> None:
        states = [op.state(context.get_time()) for op in self._operators]
        p = np.concatenate([s[0] for s in states])
        v = np.concatenate([s[1] for s in states])
        present = np.concatenate([s[2] for s in states])
        k = len(self._operators)
        points, velocities = np.full((NUM_POINTS * k, 3), np.nan), np.full((NUM_POINTS * k, 3),
                                                                            np.nan)
        points[self._point_slots], velocities[self._point_slots] = p, v
        operators = np.array([float(present[a:b].max(initial=0.0))
                              for a, b in zip(self._first[:-1], self._first[1:])])
        value.set_value((p.ravel(), v.ravel(), present, points.ravel(), velocities.ravel(),
                         operators))
