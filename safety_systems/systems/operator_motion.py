"""OperatorMotion: true positions and velocities of scripted operators' tracked bodies and
of every point of their bodies."""

from collections.abc import Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, LeafSystem, ValueProducer

from safety_systems.cell.operator_paths import ScriptedOperator, body_layout, operators_bodies_state
from safety_systems.cell.operators import MAX_OPERATORS



class OperatorMotion(LeafSystem):
    """Ground-truth motion of up to five scripted operators (a function of time only).

    Body slots are numbered operator by operator (N = total number of bodies); body i's
    xyz is at [3i:3i+3]. Absent bodies keep following their script (so a body re-enters
    where its script puts it) but are flagged 0.0 in ``present``. ``points_true`` and
    ``point_velocities_true`` give every body point of every operator (10 per operator,
    ``human_body.POINTS``; operator k's point p at [3 (10 k + p):...]), which the
    properties measure; ``operators_present`` flags each operator.

    .. pydrake_system::

        name: OperatorMotion
        output_ports:
        - positions_true
        - velocities_true
        - present
        - points_true
        - point_velocities_true
        - operators_present

    Args:
        operators: the scripted operators (1 to 5), each with 1 to 3 bodies; positions in
            metres, velocities in metres per second, world frame.
    """

    def __init__(self, *, operators: Sequence[ScriptedOperator]) -> None:
        super().__init__()
        operators = tuple(operators)
        if not 1 <= len(operators) <= MAX_OPERATORS:
            raise ValueError(
                f"operators has {len(operators)} entries: allowed 1 to {MAX_OPERATORS}"
            )
        for k, op in enumerate(operators):
            if not isinstance(op, ScriptedOperator):
                raise ValueError(f"operators[{k}]={op!r}: must be a ScriptedOperator")
        self._operators = operators
        self._layout = body_layout(operators)
        self._points = body_layout(operators, points=True)
        n = self._layout.operator_index.size
        self._num_bodies = n
        m, k = self._points.operator_index.size, len(operators)

        # One time-dependent evaluation feeds all three outputs.
        self._state_cache = self.DeclareCacheEntry(
            description="bodies_state",
            value_producer=ValueProducer(
                allocate=AbstractValue.Make(
                    (np.zeros(3 * n), np.zeros(3 * n), np.zeros(n))
                ).Clone,
                calc=self._calc_state,
            ),
            prerequisites_of_calc={self.time_ticket()},
        )
        ticket = {self._state_cache.ticket()}
        self.DeclareVectorOutputPort(
            "positions_true", BasicVector(3 * n), self._make_output(0), ticket
        )
        self.DeclareVectorOutputPort(
            "velocities_true", BasicVector(3 * n), self._make_output(1), ticket
        )
        self.DeclareVectorOutputPort("present", BasicVector(n), self._make_output(2), ticket)
        self._points_cache = self.DeclareCacheEntry(
            description="points_state",
            value_producer=ValueProducer(
                allocate=AbstractValue.Make(
                    (np.zeros(3 * m), np.zeros(3 * m), np.zeros(m))).Clone,
                calc=self._calc_points),
            prerequisites_of_calc={self.time_ticket()},
        )
        ticket = {self._points_cache.ticket()}
        self.DeclareVectorOutputPort(
            "points_true", BasicVector(3 * m),
            lambda c, o: o.SetFromVector(self._points_cache.Eval(c)[0]), ticket)
        self.DeclareVectorOutputPort(
            "point_velocities_true", BasicVector(3 * m),
            lambda c, o: o.SetFromVector(self._points_cache.Eval(c)[1]), ticket)
        self.DeclareVectorOutputPort(
            "operators_present", BasicVector(k),
            lambda c, o: o.SetFromVector(self._points_cache.Eval(c)[2][::10]), ticket)

    @property
    def num_bodies(self) -> int:
        """Number of body slots N."""
        return self._num_bodies

    def _calc_state(self, context: Context, value: AbstractValue) -> None:
        value.set_value(
            operators_bodies_state(self._operators, context.get_time(), self._layout)
        )

    def _calc_points(self, context: Context, value: AbstractValue) -> None:
        value.set_value(
            operators_bodies_state(self._operators, context.get_time(), self._points))

    def _make_output(self, which: int):
        def calc(context: Context, output: BasicVector) -> None:
            output.SetFromVector(self._state_cache.Eval(context)[which])

        return calc
