"""SpeedOverride: the robot's speed scale k (seed Eq. 12), with a fail-safe stop."""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem, ValueProducer

from safety_systems.pfl.speed_caps import clamp_caps
from safety_systems.sensing.stops import STOP_CONTACT, STOP_NONE, STOP_SEPARATION
from safety_systems.ssm.formulas import override_decision


class SpeedOverride(LeafSystem):
    """Commanded path speed k in [0, 1] from separations, seed Eq. 12.

    .. pydrake_system::

        name: SpeedOverride
        input_ports:
        - distances
        - protective_distances
        - track_status
        - fault
        - segment_ends (with caps)
        - segment_radii (with caps)
        - capsule_ends (with caps)
        - contact_stop (with caps)
        output_ports:
        - path_speed_commanded
        - max_protective_distance
        - stop_reason
        - segment_caps

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

    With ``caps`` (``safety.mode: ssm_pfl``, ``safety_systems.pfl.speed_caps``) k is the
    least over the usable segments of max(Eq. 12, cap_i) by
    :func:`safety_systems.ssm.formulas.capped_override_command` (with ``levels``, of
    max(the segment's level, cap_i): ``capped_by_speed_command``), with the same
    fail-safe stops; a segment whose envelope (inputs ``segment_ends``, ``segment_radii``)
    may lie within ``clamp_reach`` of a fixed surface or of two of the robot's links
    (input ``capsule_ends``: the monitor's capsules, of radii ``capsule_radii`` and links
    ``capsule_links``) has cap 0 (``pfl.speed_caps.clamp_caps``); and the robot's own
    contact detection (input ``contact_stop``, from a ContactStop:
    ``safety_systems.pfl.contact_limits``) stops it (k = 0, reason ``contact``) while it
    holds. ``segment_caps`` outputs the caps in force (all 0 without ``caps``).

    Args:
        num_bodies: registered body slots N.
        delta_s: dS of Eq. 12, dimensionless, >= 1 (seed: 2).
        d_min: minimum distance in metres below which the robot stops (seed: 0.30).
        levels: None (Eq. 12), or the number of speed levels G (by_speed).
        caps: None (``ssm``), or each segment's cap, N path rates in [0, 1].
        surfaces: the fixed surfaces, (S, 2, 3) boxes (min and max corners).
        clamp_reach: metres, see above.
        capsule_radii: the monitor's capsules' radii (J,), metres (with ``caps``).
        capsule_links: each of those capsules' link (J,) (with ``caps``).
    """

    def __init__(self, *, num_bodies: int, delta_s: float = 2.0, d_min: float = 0.30,
                 levels: int | None = None, caps=None, surfaces=None,
                 clamp_reach: float = 0.0, capsule_radii=None, capsule_links=None):
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
        self._caps = None
        if caps is not None:
            self._caps = np.array(caps, dtype=float).reshape(-1)
            if self._caps.size != num_bodies or not np.all(
                    (self._caps >= 0.0) & (self._caps <= 1.0)):
                raise ValueError(f"caps: got {self._caps.tolist()}; allowed: {num_bodies} "
                                 "path rates in [0, 1]")
        self._boxes = np.zeros((0, 2, 3)) if surfaces is None else np.array(
            surfaces, dtype=float).reshape(-1, 2, 3)
        self._reach = float(clamp_reach)
        if self._caps is not None:
            self._ends = self.DeclareVectorInputPort("segment_ends", 6 * num_bodies)
            self._radii = self.DeclareVectorInputPort("segment_radii", num_bodies)
            self._robot_radii = np.array(capsule_radii, dtype=float).reshape(-1)
            self._robot_links = np.array(capsule_links, dtype=np.int64).reshape(-1)
            if self._robot_links.size != self._robot_radii.size:
                raise ValueError(f"capsule_links: got {self._robot_links.tolist()}; allowed: "
                                 f"one link per capsule ({self._robot_radii.size})")
            self._robot_ends = self.DeclareVectorInputPort("capsule_ends",
                                                           6 * self._robot_radii.size)
            self._contact = self.DeclareVectorInputPort("contact_stop", 1)
        self._cache = self.DeclareCacheEntry(
            description="override",
            value_producer=ValueProducer(
                allocate=AbstractValue.Make(np.zeros(3 + num_bodies)).Clone,
                calc=self._calc_all
            ),
            prerequisites_of_calc={self.all_input_ports_ticket()},
        )
        for i, name in enumerate(("path_speed_commanded", "max_protective_distance",
                                  "stop_reason")):
            self.DeclareVectorOutputPort(
                name, 1, lambda c, o, i=i: o.SetAtIndex(0, self._cache.Eval(c)[i]),
                prerequisites_of_calc={self._cache.ticket()},
            )
        self.DeclareVectorOutputPort(
            "segment_caps", num_bodies, lambda c, o: o.SetFromVector(self._cache.Eval(c)[3:]),
            prerequisites_of_calc={self._cache.ticket()})

    def _calc_all(self, context, value):
        out = value.get_mutable_value()
        caps = out[3:]
        if self._caps is not None:
            n, robot = self._caps.size, np.asarray(self._robot_ends.Eval(context)).reshape(
                -1, 2, 3)
            clamp_caps(np.asarray(self._ends.Eval(context)).reshape(n, 2, 3),
                       np.asarray(self._radii.Eval(context)), self._caps, self._boxes,
                       self._reach, robot, robot, self._robot_radii, self._robot_links, caps)
        d, s = self._d.Eval(context), np.asarray(self._s.Eval(context))
        rate = 1.0
        if self._levels is not None:  # S at every speed level, and the path rate now
            s, rate = s.reshape(self._levels + 1, d.size), self._path_state.Eval(context)[1]
        out[0], out[1], out[2] = override_decision(
            d, s, self._status.Eval(context), self._fault.Eval(context)[0], rate=rate,
            caps=None if self._caps is None else caps, delta_s=self._delta_s,
            d_min=self._d_min)
        if self._caps is not None and not self._contact.Eval(context)[0] == 0.0:
            out[0] = 0.0  # the robot's own contact stop (a NaN input stops it too)
            if out[2] in (STOP_NONE, STOP_SEPARATION):
                out[2] = STOP_CONTACT
