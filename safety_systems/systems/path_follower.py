"""PathFollower: runs the cyclic joint path at the commanded speed, within the brakes."""

import numpy as np
from pydrake.systems.framework import Context, DiscreteValues, LeafSystem

from safety_systems.cell.braking import BrakingTable, path_follower_step
from safety_systems.cell.joint_path import JointPath, joint_path_state


class PathFollower(LeafSystem):
    """Advances the path parameter s at rate sigma towards the commanded speed scale.

    Every control period the rate sigma moves towards the commanded value as the
    braking model allows (:func:`safety_systems.cell.braking.path_rate_step`), and
    s advances by the mean of the old and new rates times the period. At the end of the
    task (s = ``path.end``) the robot rests; s never goes below 0. The outputs are the
    braked joint reference: q(s), v = q'(s) sigma and a = q''(s) sigma^2 + q'(s) dsigma/dt,
    with dsigma/dt the change of sigma over the last tick. Each tick computes them with
    the new (s, sigma) and keeps them in the discrete state, one group per output port,
    so the ports are the state itself (no Python call when they are read).

    .. pydrake_system::

        name: PathFollower
        input_ports:
        - path_speed_commanded
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
        self._path = path
        self._accel, self._dt = float(acceleration_limit), float(period_sec)
        self._brake_scale = float(braking_time_scale)
        self._max_rate = float(max_rate)
        self._fractions, self._deceleration = braking.speed_fraction, braking.deceleration
        # State: path_state [s, sigma, finished] and the reference q, v, a at it.
        self._path_state = self.DeclareDiscreteState(np.array([0.0, 0.0, 0.0]))
        self._reference = [self.DeclareDiscreteState(row)
                           for row in self._reference_at(0.0, 0.0, 0.0)]
        self._cmd = self.DeclareVectorInputPort("path_speed_commanded", 1)
        self.DeclarePeriodicDiscreteUpdateEvent(period_sec=period_sec, offset_sec=0.0,
                                                update=self._step)
        for group, name in zip(self._reference, ("joint_positions_desired",
                                                 "joint_velocities_desired",
                                                 "joint_accelerations_desired")):
            self.DeclareStateOutputPort(name, group)
        self.DeclareStateOutputPort("path_state", self._path_state)

    @property
    def path(self) -> JointPath:
        return self._path

    def _step(self, context: Context, discrete_state: DiscreteValues) -> None:
        s, rate, _ = context.get_discrete_state(self._path_state).value()
        end = self._path.end
        # path_follower_step holds s and sigma at the end (sigma is 0 from the tick that got there).
        s_new, new = path_follower_step(s, rate, float(self._cmd.Eval(context)[0]), end,
                                   self._brake_scale, self._dt, self._fractions,
                                   self._deceleration, self._accel, self._max_rate)
        discrete_state.set_value(self._path_state, [s_new, new, float(s_new >= end)])
        for group, row in zip(self._reference,
                              self._reference_at(s_new, new, (new - rate) / self._dt)):
            discrete_state.set_value(group, row)

    def _reference_at(self, s: float, rate: float, rate_dot: float) -> tuple:
        """(q, v, a) of the braked reference at path parameter s and rate sigma."""
        q, dq, ddq = joint_path_state(self._path, s)
        return q, dq * rate, ddq * rate * rate + dq * rate_dot
