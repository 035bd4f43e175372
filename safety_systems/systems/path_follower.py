"""PathFollower: runs the cyclic joint path at the commanded speed, within the brakes."""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, LeafSystem, ValueProducer

from safety_systems.braking import BrakingTable, path_step_one
from safety_systems.joint_path import JointPath, joint_path_state


class PathFollower(LeafSystem):
    """Advances the path parameter s at rate sigma towards the commanded speed scale.

    Every control period the rate sigma moves towards the commanded value as the
    braking model allows (:func:`safety_systems.braking.path_rate_step`), and
    s advances by the mean of the old and new rates times the period. At the end of the
    task (s = ``path.end``) the robot rests; s never goes below 0. The outputs are the
    braked joint reference: q(s), v = q'(s) sigma and a = q''(s) sigma^2 + q'(s) dsigma/dt.

    .. pydrake_system::

        name: PathFollower
        input_ports:
        - speed_scale_commanded
        output_ports:
        - joint_positions_desired
        - joint_velocities_desired
        - joint_accelerations_desired
        - path_state

    ``path_state`` is [s, sigma, finished (1.0 once s reached the end)].

    Args:
        path: the cyclic joint path.
        braking: stopping data bounding how fast sigma can fall.
        acceleration_limit: how fast sigma may rise, fraction of nominal speed per second.
        period_sec: control period in seconds (the robot's 500 Hz: 0.002).
        braking_time_scale: the real brakes' stopping times relative to ``braking``'s
            (1: as the stopping data says).
        max_rate: the largest |sigma| a command may ask for (1: nominal speed).
    """

    def __init__(self, *, path: JointPath, braking: BrakingTable, acceleration_limit: float,
                 period_sec: float, braking_time_scale: float = 1.0,
                 max_rate: float = 1.0) -> None:
        super().__init__()
        for name, value in (("acceleration_limit", acceleration_limit), ("period_sec", period_sec),
                            ("braking_time_scale", braking_time_scale), ("max_rate", max_rate)):
            if not (np.isfinite(value) and value > 0.0):
                raise ValueError(f"{name}: got {value}; allowed: a finite number > 0")
        self._path, self._table = path, braking
        self._accel, self._dt = float(acceleration_limit), float(period_sec)
        self._brake_scale = float(braking_time_scale)
        self._max_rate = float(max_rate)
        self._fractions, self._deceleration = braking.speed_fraction, braking.deceleration
        # State: s, sigma, dsigma/dt over the last tick.
        self._state = self.DeclareDiscreteState(np.array([0.0, 0.0, 0.0]))
        self._cmd = self.DeclareVectorInputPort("speed_scale_commanded", 1)
        self.DeclarePeriodicDiscreteUpdateEvent(period_sec=period_sec, offset_sec=0.0,
                                                update=self._step)
        self._ref = self.DeclareCacheEntry(
            description="reference",
            value_producer=ValueProducer(allocate=AbstractValue.Make(np.zeros((3, 6))).Clone,
                                         calc=self._calc_reference),
            prerequisites_of_calc={self.xd_ticket()},
        )
        for row, name in enumerate(("joint_positions_desired", "joint_velocities_desired",
                                    "joint_accelerations_desired")):
            self.DeclareVectorOutputPort(
                name, 6, lambda c, o, r=row: o.SetFromVector(self._ref.Eval(c)[r]),
                prerequisites_of_calc={self._ref.ticket()},
            )
        self.DeclareVectorOutputPort("path_state", 3, self._calc_path_state,
                                     prerequisites_of_calc={self.xd_ticket()})

    @property
    def path(self) -> JointPath:
        return self._path

    def _step(self, context: Context, discrete_state: DiscreteValues) -> None:
        s, rate, _ = context.get_discrete_state(self._state).get_value()
        end = self._path.end
        if s >= end:
            discrete_state.set_value(self._state, [end, 0.0, 0.0])
            return
        s_new, new = path_step_one(s, rate, float(self._cmd.Eval(context)[0]), end,
                                   self._brake_scale, self._dt, self._fractions,
                                   self._deceleration, self._accel, self._max_rate)
        discrete_state.set_value(self._state, [s_new, new, (new - rate) / self._dt])

    def _calc_reference(self, context: Context, value: AbstractValue) -> None:
        s, rate, rate_dot = context.get_discrete_state(self._state).get_value()
        q, dq, ddq = joint_path_state(self._path, s)
        out = value.get_mutable_value()
        out[0] = q
        out[1] = dq * rate
        out[2] = ddq * rate * rate + dq * rate_dot

    def _calc_path_state(self, context: Context, output: BasicVector) -> None:
        s, rate, _ = context.get_discrete_state(self._state).get_value()
        output.SetFromVector([s, rate, float(s >= self._path.end)])
