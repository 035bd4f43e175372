"""EndEffectorVelocity: the robot point p_R and its velocity v_R (seed Eq. 5)."""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, LeafSystem, ValueProducer

from safety_systems.ur5e import tool0_position


class EndEffectorVelocity(LeafSystem):
    """End-effector position by forward kinematics and velocity by seed Eq. 5.

    p_R is the tool flange (``tool0``) from the joint positions. v_R is the change of
    p_R since the previous control tick divided by the period (Eq. 5: the seed
    differences successive end-effector transforms). Before the first tick v_R is NaN,
    which the safety controller treats as a fault (it stops).

    .. pydrake_system::

        name: EndEffectorVelocity
        input_ports:
        - joint_positions
        output_ports:
        - ee_position
        - ee_velocity

    Args:
        period_sec: control period in seconds.
    """

    def __init__(self, *, period_sec: float) -> None:
        super().__init__()
        if not (np.isfinite(period_sec) and period_sec > 0.0):
            raise ValueError(f"period_sec: got {period_sec}; allowed: a finite number > 0")
        self._dt = float(period_sec)
        self._q = self.DeclareVectorInputPort("joint_positions", 6)
        self._previous = self.DeclareDiscreteState(np.full(3, np.nan))
        self.DeclarePeriodicDiscreteUpdateEvent(period_sec=period_sec, offset_sec=0.0,
                                                update=self._store)
        self._p = self.DeclareCacheEntry(
            description="ee_position",
            value_producer=ValueProducer(
                allocate=AbstractValue.Make(np.zeros(3)).Clone,
                calc=lambda c, v: v.set_value(tool0_position(self._q.Eval(c)))),
            prerequisites_of_calc={self._q.ticket()},
        )
        self.DeclareVectorOutputPort(
            "ee_position", 3, lambda c, o: o.SetFromVector(self._p.Eval(c)),
            prerequisites_of_calc={self._p.ticket()})
        self.DeclareVectorOutputPort(
            "ee_velocity", 3, self._calc_velocity,
            prerequisites_of_calc={self._p.ticket(), self.xd_ticket()})

    def _store(self, context: Context, discrete_state: DiscreteValues) -> None:
        discrete_state.set_value(self._previous, self._p.Eval(context))

    def _calc_velocity(self, context: Context, output: BasicVector) -> None:
        previous = context.get_discrete_state(self._previous).get_value()
        output.SetFromVector((self._p.Eval(context) - previous) / self._dt)
