"""SpeedAlterationController: the sampled interface every seed-004 controller shares."""

import numpy as np
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, LeafSystem

from safety_systems.speed_alteration.ellipsoids import danger_index
from safety_systems.speed_alteration.methods import (
    GRID,
    clearance,
    danger_grid,
    operator_ellipsoids,
    preprogrammed_speed,
    robot_at,
)
from safety_systems.sensing.stops import STOP_NONE
from safety_systems.sensing.tracks import tracker_stop, usable_bodies

# Discrete state: [V_select, max DI at the chosen pose, decision count, positions (3N)].
_V, _DI, _K = 0, 1, 2
_PREVIOUS_POSITIONS = 3


class SpeedAlterationController(LeafSystem):
    """Chooses a signed end-effector speed along the path every sampling period.

    Subclasses implement :meth:`choose`. This class predicts the operators one step
    ahead (Eqs. 9-10: from the last two samples, or the tracker's velocity), builds
    their ellipsoids and the robot's at the candidate poses, and outputs the speed as a
    fraction of the pre-programmed speed (Eq. 8) for the PathFollower. With no operator
    tracked it keeps the pre-programmed speed. Fail safe (not in the seed): a sensor
    fault or a lost track selects speed 0, a protective stop.

    .. pydrake_system::

        name: SpeedAlterationController
        input_ports:
        - positions_estimated
        - velocities_estimated
        - track_status
        - fault
        - path_state
        output_ports:
        - path_speed_commanded
        - speed_selected
        - danger_index

    ``danger_index`` is the largest DI over all pairs at the pose the chosen speed leads
    to, as predicted (Eq. 7).

    Args:
        path: the robot's path (``joint_path_state`` accepts it).
        config: ``SpeedAlterationConfig``.
        operator_of: (N,) operator index of each body slot.
        is_hand: (N,) True for gloves, False for heads.
        offset_sec: time of the first decision, s (the workcell puts decisions just
            after the tracker has processed a frame captured on the decision grid).
    """

    def __init__(self, *, path, config, operator_of, is_hand, offset_sec: float = 0.0) -> None:
        super().__init__()
        n = len(operator_of)
        self._n, self._path, self._cfg = n, path, config
        self._operator_of = np.asarray(operator_of)
        self._is_hand = np.asarray(is_hand, dtype=bool)
        self._dt = 1.0 / config.rate_hz
        self._v_pre = preprogrammed_speed(path)
        self._speeds = self.candidate_speeds()
        self._state = self.DeclareDiscreteState(
            np.r_[self._v_pre, 0.0, 0.0, np.full(3 * n, np.nan)])
        self._p = self.DeclareVectorInputPort("positions_estimated", 3 * n)
        self._v = self.DeclareVectorInputPort("velocities_estimated", 3 * n)
        self._status = self.DeclareVectorInputPort("track_status", n)
        self._fault = self.DeclareVectorInputPort("fault", 1)
        self._path_state = self.DeclareVectorInputPort("path_state", 3)
        self.DeclarePeriodicDiscreteUpdateEvent(period_sec=self._dt, offset_sec=offset_sec,
                                                update=self._update)
        for name, calc in (("path_speed_commanded", self._calc_scale),
                           ("speed_selected", self._calc_speed),
                           ("danger_index", self._calc_danger)):
            self.DeclareVectorOutputPort(name, 1, calc, prerequisites_of_calc={self.xd_ticket()})

    @property
    def preprogrammed_speed(self) -> float:
        """V_pre (Eq. 8), m/s."""
        return self._v_pre

    grid_size = GRID  # candidate speeds on which the danger index is evaluated

    def candidate_speeds(self) -> np.ndarray:
        """The speeds (m/s, sorted) at which ``choose`` gets the danger index:
        ``grid_size`` evenly over [-speed_limit, speed_limit]."""
        limit = self._cfg.speed_limit
        return np.linspace(-limit, limit, self.grid_size)

    def choose(self, *, s: float, v_prev: float, danger: np.ndarray,
               danger_now: np.ndarray, gap: float, k: int) -> float:
        """The speed to select (m/s); ``danger`` (G, pairs) is the DI at the pose each of
        ``self._speeds`` leads to, ``danger_now`` (pairs,) at the current pose, ``gap``
        the clearance now, ``k`` the decision count."""
        raise NotImplementedError

    def _update(self, context: Context, discrete_state: DiscreteValues) -> None:
        state = context.get_discrete_state(self._state).get_value()
        p = np.asarray(self._p.Eval(context)).reshape(self._n, 3)
        status = self._status.Eval(context)
        valid = usable_bodies(status, p)
        if self._cfg.prediction == "kalman":
            v = np.asarray(self._v.Eval(context)).reshape(self._n, 3)
        else:  # Eq. 9 from the previous sample (at rest when there is none)
            v = (p - state[_PREVIOUS_POSITIONS:].reshape(self._n, 3)) / self._dt
        v = np.where(np.isfinite(v), v, 0.0)
        s = self._path_state.Eval(context)[0]
        k = int(state[_K])
        new = state.copy()
        new[_PREVIOUS_POSITIONS:] = p.ravel()
        new[_K] = k + 1
        humans = operator_ellipsoids(p + v * self._dt, valid, self._operator_of,
                                     self._is_hand, self._cfg.ellipsoids)  # Eq. 10
        if tracker_stop(status, self._fault.Eval(context)[0]) != STOP_NONE:
            new[_V], new[_DI] = 0.0, state[_DI]
        elif humans.centres.shape[0] == 0:
            new[_V], new[_DI] = self._v_pre, 0.0
        else:
            sizes = self._cfg.ellipsoids
            danger = danger_grid(self._path, s, self._speeds, self._dt, self._v_pre, humans,
                                 sizes)
            robot_now = robot_at(self._path, s, sizes)
            now = operator_ellipsoids(p, valid, self._operator_of, self._is_hand, sizes)
            danger_now = danger_index(robot_now, now).ravel()
            gap = clearance(robot_now, now)
            v_sel = self.choose(s=s, v_prev=state[_V], danger=danger, danger_now=danger_now,
                                gap=gap, k=k)
            reached = danger_grid(self._path, s, np.array([v_sel]), self._dt, self._v_pre,
                                  humans, sizes)
            new[_V], new[_DI] = v_sel, float(reached.max(initial=0.0))
        discrete_state.set_value(self._state, new)

    def _calc_scale(self, context: Context, output: BasicVector) -> None:
        output.SetAtIndex(0, context.get_discrete_state(self._state).get_value()[_V]
                          / self._v_pre)

    def _calc_speed(self, context: Context, output: BasicVector) -> None:
        output.SetAtIndex(0, context.get_discrete_state(self._state).get_value()[_V])

    def _calc_danger(self, context: Context, output: BasicVector) -> None:
        output.SetAtIndex(0, context.get_discrete_state(self._state).get_value()[_DI])
