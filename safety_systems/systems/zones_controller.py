"""ZonesController: green/yellow/red speed zones with performance recovery (seed 001)."""

import numpy as np
from pydrake.systems.framework import Context, DiscreteValues, LeafSystem

from safety_systems.cell.joint_path import joint_path_state
from safety_systems.sensing.stops import STOP_NONE
from safety_systems.sensing.tracks import tracker_stop, usable_bodies
from safety_systems.cell.ur5e import tool0_position
from safety_systems.planning.zones import (
    RED,
    STOP,
    closest_distance,
    recovery_step,
    zone_of,
    zone_speed,
)

# Discrete state: commanded speed k, its rate, zone, closest distance.
_K, _RATE, _ZONE, _D = range(4)


class ZonesController(LeafSystem):
    """Commands the zone's speed (Eq. 6c) from the closest tracked body (Eq. 6b), with
    bounded-jerk recovery, in the same interface as the other controllers.

    A ``stop`` gesture holds the robot (speed 0) until ``start`` or ``resume``. Fail
    safe: a sensor fault or a lost track counts as the red zone with speed 0.

    .. pydrake_system::

        name: ZonesController
        input_ports:
        - positions_estimated
        - track_status
        - fault
        - path_state
        - gesture
        output_ports:
        - path_speed_commanded
        - zone
        - closest_distance

    Args:
        path: the robot's path (the tool position comes from its path parameter).
        config: ``ZonesConfig``.
        num_bodies: body slots N.
    """

    def __init__(self, *, path, config, num_bodies: int) -> None:
        super().__init__()
        self._path, self._cfg, self._n = path, config, num_bodies
        self._dt = 1.0 / config.rate_hz
        self._speeds = (config.green_speed, config.yellow_speed, config.red_speed)
        self._state = self.DeclareDiscreteState(np.array([0.0, 0.0, float(RED), np.inf]))
        self._p = self.DeclareVectorInputPort("positions_estimated", 3 * num_bodies)
        self._status = self.DeclareVectorInputPort("track_status", num_bodies)
        self._fault = self.DeclareVectorInputPort("fault", 1)
        self._path_state = self.DeclareVectorInputPort("path_state", 3)
        self._gesture = self.DeclareVectorInputPort("gesture", 1)
        self.DeclarePeriodicDiscreteUpdateEvent(period_sec=self._dt, offset_sec=0.0,
                                                update=self._update)
        for name, index in (("path_speed_commanded", _K), ("zone", _ZONE),
                            ("closest_distance", _D)):
            self.DeclareVectorOutputPort(
                name, 1, lambda c, o, i=index: o.SetAtIndex(
                    0, c.get_discrete_state(self._state).get_value()[i]),
                prerequisites_of_calc={self.xd_ticket()})

    def _update(self, context: Context, discrete_state: DiscreteValues) -> None:
        k, rate, _, _ = context.get_discrete_state(self._state).get_value()
        status = self._status.Eval(context)
        p = np.asarray(self._p.Eval(context)).reshape(self._n, 3)
        usable = usable_bodies(status, p)
        tool = tool0_position(joint_path_state(self._path, self._path_state.Eval(context)[0])[0])
        d = closest_distance(tool, p, usable)
        cfg = self._cfg
        zone = int(zone_of(d, green_distance=cfg.green_distance,
                           yellow_distance=cfg.yellow_distance))
        target = float(zone_speed(zone, self._speeds))
        fault = tracker_stop(status, self._fault.Eval(context)[0]) != STOP_NONE
        if fault:
            zone = RED
        if fault or self._gesture.Eval(context)[0] == STOP:
            target = 0.0
        k, rate = recovery_step(k, rate, target, self._dt, max_acceleration=cfg.max_acceleration,
                                max_jerk=cfg.max_jerk)
        discrete_state.set_value(self._state, [k, rate, float(zone), d])
