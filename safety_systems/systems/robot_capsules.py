"""RobotCapsules: where the robot's capsules are and how fast they move (seed Eq. 5)."""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (
    BasicVector,
    Context,
    DiscreteValues,
    LeafSystem,
    ValueProducer,
)

from safety_systems.cell.model_points import model_arrays, model_work
from safety_systems.cell.robot_geometry import Capsules, model_capsule_ends_at


class RobotCapsules(LeafSystem):
    """The ends of the robot's capsules by forward kinematics, and their velocities by
    seed Eq. 5.

    ``capsule_ends`` holds, capsule by capsule, the two ends of its axis
    (``safety_systems.cell.robot_geometry``; the seed's tool point is one capsule whose ends
    are both tool0). ``capsule_velocities`` is the change of each end since the previous
    control tick divided by the period (Eq. 5: the seed differences successive
    end-effector transforms). Before the first tick the velocities are NaN, which the
    safety controller treats as a fault (it stops).

    .. pydrake_system::

        name: RobotCapsules
        input_ports:
        - joint_positions
        output_ports:
        - capsule_ends
        - capsule_velocities

    ``joint_positions`` has one entry per joint of the capsules' robot
    (``capsules.model``).

    Args:
        capsules: the robot's capsules (K of them; outputs of size 6 K).
        period_sec: control period in seconds.
    """

    def __init__(self, *, capsules: Capsules, period_sec: float) -> None:
        super().__init__()
        if not (np.isfinite(period_sec) and period_sec > 0.0):
            raise ValueError(f"period_sec: got {period_sec}; allowed: a finite number > 0")
        self._dt = float(period_sec)
        c = self._capsules = capsules
        size = 6 * c.radius.size
        model = c.model
        self._arrays, self._work = model_arrays(model), model_work(model)
        self._points = (np.empty((model.num_points, 3)), np.empty((model.num_points, 3)))
        self._unused = np.empty((c.radius.size, 2, 3))
        self._q = self.DeclareVectorInputPort("joint_positions", model.n)
        self._previous = self.DeclareDiscreteState(np.full(size, np.nan))
        self.DeclarePeriodicDiscreteUpdateEvent(period_sec=period_sec, offset_sec=0.0,
                                                update=self._store)
        self._ends = self.DeclareCacheEntry(
            description="capsule_ends",
            value_producer=ValueProducer(allocate=AbstractValue.Make(np.zeros(size)).Clone,
                                         calc=self._calc_ends),
            prerequisites_of_calc={self._q.ticket()},
        )
        self.DeclareVectorOutputPort(
            "capsule_ends", size, lambda ctx, o: o.SetFromVector(self._ends.Eval(ctx)),
            prerequisites_of_calc={self._ends.ticket()})
        self.DeclareVectorOutputPort(
            "capsule_velocities", size, self._calc_velocities,
            prerequisites_of_calc={self._ends.ticket(), self.xd_ticket()})

    def _calc_ends(self, context: Context, value: AbstractValue) -> None:
        c = self._capsules
        out = value.get_mutable_value().reshape(-1, 2, 3)
        model_capsule_ends_at(self._arrays, np.asarray(self._q.Eval(context), dtype=float),
                              c.tool_length, c.a, c.b, c.t0, c.t1, *self._work, *self._points,
                              out, self._unused)

    def _store(self, context: Context, discrete_state: DiscreteValues) -> None:
        discrete_state.set_value(self._previous, self._ends.Eval(context))

    def _calc_velocities(self, context: Context, output: BasicVector) -> None:
        previous = context.get_discrete_state(self._previous).get_value()
        output.SetFromVector((self._ends.Eval(context) - previous) / self._dt)
