"""SpeedOverride: the robot's speed scale k (seed Eq. 12), with a fail-safe stop."""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem, ValueProducer

from safety_systems.ssm import overall_speed_override
from safety_systems.systems.separation_monitor import (
    TRACK_COASTING,
    TRACK_LOST,
    TRACK_TRACKING,
)

# stop_reason values.
STOP_NONE, STOP_SEPARATION, STOP_SENSOR_FAULT, STOP_LOST_TRACK = 0, 1, 2, 3


class SpeedOverride(LeafSystem):
    """Commanded path speed k in [0, 1] from separations, seed Eq. 12.

    .. pydrake_system::

        name: SpeedOverride
        input_ports:
        - distances
        - protective_distances
        - track_status
        - fault
        output_ports:
        - speed_scale_commanded
        - max_protective_distance
        - stop_reason

    k is the smallest Eq. 12 value over the tracked bodies (see
    :func:`safety_systems.ssm.overall_speed_override`). Fail safe: a sensor fault
    (``fault`` > 0: no fresh frame, or a non-finite measurement), a lost track (a body
    that vanished near the robot) or a non-finite d_i or S_i of a tracked body gives
    k = 0, a protective stop, and ``stop_reason`` says which (0 none, 1 separation,
    2 sensor fault, 3 lost track).

    Args:
        num_bodies: registered body slots N.
        delta_s: dS of Eq. 12, dimensionless, >= 1 (seed: 2).
        d_min: minimum distance in metres below which the robot stops (seed: 0.30).
    """

    def __init__(self, *, num_bodies: int, delta_s: float = 2.0, d_min: float = 0.30):
        super().__init__()
        if not (np.isfinite(delta_s) and delta_s >= 1.0):
            raise ValueError(f"delta_s: got {delta_s}; allowed: a finite number >= 1")
        if not (np.isfinite(d_min) and d_min >= 0.0):
            raise ValueError(f"d_min: got {d_min}; allowed: a finite number >= 0")
        self._delta_s, self._d_min = delta_s, d_min
        self._d = self.DeclareVectorInputPort("distances", num_bodies)
        self._s = self.DeclareVectorInputPort("protective_distances", num_bodies)
        self._status = self.DeclareVectorInputPort("track_status", num_bodies)
        self._fault = self.DeclareVectorInputPort("fault", 1)
        self._cache = self.DeclareCacheEntry(
            description="override",
            value_producer=ValueProducer(
                allocate=AbstractValue.Make(np.zeros(3)).Clone, calc=self._calc_all
            ),
            prerequisites_of_calc={self.all_input_ports_ticket()},
        )
        for i, name in enumerate(("speed_scale_commanded", "max_protective_distance",
                                  "stop_reason")):
            self.DeclareVectorOutputPort(
                name, 1, lambda c, o, i=i: o.SetAtIndex(0, self._cache.Eval(c)[i]),
                prerequisites_of_calc={self._cache.ticket()},
            )

    def _calc_all(self, context, value):
        out = value.get_mutable_value()
        status = self._status.Eval(context)
        included = (status == TRACK_TRACKING) | (status == TRACK_COASTING)
        k, s_max = overall_speed_override(
            self._d.Eval(context), self._s.Eval(context), included,
            delta_s=self._delta_s, d_min=self._d_min,
        )
        reason = STOP_SEPARATION if k <= 0.0 else STOP_NONE
        if np.any(status == TRACK_LOST):
            k, reason = 0.0, STOP_LOST_TRACK
        fault = self._fault.Eval(context)[0]
        if not (fault == 0.0):  # NaN counts as a fault
            k, reason = 0.0, STOP_SENSOR_FAULT
        out[0], out[1], out[2] = float(k), float(s_max), float(reason)
