"""SpeedOverride: the robot's speed scale k (seed Eq. 12), with a fail-safe stop."""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem, ValueProducer

from safety_systems.ssm.formulas import by_speed_override_command, speed_override_command


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
        - path_speed_commanded
        - max_protective_distance
        - stop_reason

    k is the smallest Eq. 12 value over the bodies with a usable track (tracking or
    hidden), and fail safe (:func:`safety_systems.ssm.formulas.override_command`): a tracker
    fault (a stale or bad frame, with its cause), a lost track or a non-finite d_i or
    S_i of a usable body gives k = 0, a protective stop, and ``stop_reason`` says why
    (``safety_systems.sensing.stops``).

    With ``levels`` (``safety.stopping: by_speed``) k is instead one of the speed levels
    g / levels by :func:`safety_systems.ssm.formulas.by_speed_command`, from the input
    ``level_protective_distances`` (the SeparationMonitor's S at every level, in place
    of ``protective_distances``) and the path rate now (``path_state``, the
    PathFollower's [s, sigma, finished]); the same fail-safe stops.

    Args:
        num_bodies: registered body slots N.
        delta_s: dS of Eq. 12, dimensionless, >= 1 (seed: 2).
        d_min: minimum distance in metres below which the robot stops (seed: 0.30).
        levels: None (Eq. 12), or the number of speed levels G (by_speed).
    """

    def __init__(self, *, num_bodies: int, delta_s: float = 2.0, d_min: float = 0.30,
                 levels: int | None = None):
        super().__init__()
        if not (np.isfinite(delta_s) and delta_s >= 1.0):
            raise ValueError(f"delta_s: got {delta_s}; allowed: a finite number >= 1")
        if not (np.isfinite(d_min) and d_min >= 0.0):
            raise ValueError(f"d_min: got {d_min}; allowed: a finite number >= 0")
        self._delta_s, self._d_min = delta_s, d_min
        self._d = self.DeclareVectorInputPort("distances", num_bodies)
        self._levels = levels
        if levels is None:
            self._s = self.DeclareVectorInputPort("protective_distances", num_bodies)
        else:
            if not (isinstance(levels, int) and levels >= 1):
                raise ValueError(f"levels: got {levels}; allowed: an integer >= 1")
            self._s = self.DeclareVectorInputPort("level_protective_distances",
                                                  (levels + 1) * num_bodies)
            self._path_state = self.DeclareVectorInputPort("path_state", 3)
        self._status = self.DeclareVectorInputPort("track_status", num_bodies)
        self._fault = self.DeclareVectorInputPort("fault", 1)
        self._cache = self.DeclareCacheEntry(
            description="override",
            value_producer=ValueProducer(
                allocate=AbstractValue.Make(np.zeros(3)).Clone, calc=self._calc_all
            ),
            prerequisites_of_calc={self.all_input_ports_ticket()},
        )
        for i, name in enumerate(("path_speed_commanded", "max_protective_distance",
                                  "stop_reason")):
            self.DeclareVectorOutputPort(
                name, 1, lambda c, o, i=i: o.SetAtIndex(0, self._cache.Eval(c)[i]),
                prerequisites_of_calc={self._cache.ticket()},
            )

    def _calc_all(self, context, value):
        out = value.get_mutable_value()
        if self._levels is not None:
            d = self._d.Eval(context)
            out[0], out[1], out[2] = by_speed_override_command(
                d, np.asarray(self._s.Eval(context)).reshape(self._levels + 1, d.size),
                self._status.Eval(context), self._fault.Eval(context)[0],
                self._path_state.Eval(context)[1], delta_s=self._delta_s, d_min=self._d_min)
            return
        out[0], out[1], out[2] = speed_override_command(
            self._d.Eval(context), self._s.Eval(context), self._status.Eval(context),
            self._fault.Eval(context)[0], delta_s=self._delta_s, d_min=self._d_min)
