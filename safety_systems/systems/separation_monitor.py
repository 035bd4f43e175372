"""SeparationMonitor: d_i, directed speeds and S_i for every operator segment."""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem, ValueProducer

from safety_systems.ssm import separation
from safety_systems.ssm.formulas import (
    HUMAN_SPEED_MODES,
    ISO_HUMAN_SPEED,
    ISO_REDUCED_HUMAN_SPEED,
    ROBOT_SPEED_TERMS,
)


class SeparationMonitor(LeafSystem):
    """Separation distances and protective separation distances, seed Eqs. 6-11, between
    every operator segment (a capsule: ``OperatorEnvelopes``) and the robot's capsules.

    .. pydrake_system::

        name: SeparationMonitor
        input_ports:
        - capsule_ends
        - capsule_velocities
        - segment_ends
        - segment_velocities
        - segment_radii
        - segment_status
        - segment_std
        output_ports:
        - distances
        - protective_distances
        - human_directed_speeds
        - robot_directed_speeds
        - nearest_capsule

    ``safety_systems.ssm.separation`` holds the maths: d_i is a segment's smallest
    clearance to the capsules, S_i its largest S over them (Eqs. 9-11 from each pair's
    directed speeds), the directed speeds and ``nearest_capsule`` (an index into the
    capsules) the nearest pair's. Segments without a usable status (none or lost) have
    NaN on every output and index -1; the SpeedOverride decides what a lost track means.
    A hidden body's growing ball is inside its segments' envelopes. Outputs are computed
    on demand from the inputs (one shared cache entry), so they follow the robot at its
    control rate.

    Args:
        num_segments: the operators' segments M (12 per operator).
        capsule_radii: the radius of each of the robot's K capsules, metres (the seed's
            tool point: one capsule of radius 0).
        human_speed: ``estimated`` | ``iso`` | ``estimated_with_floor`` (see
            :func:`safety_systems.ssm.formulas.human_speed_term`).
        reaction_time: T_r in seconds.
        stopping_time: T_s in seconds.
        stopping_distance: B (S_S) in metres.
        intrusion_distance: C in metres.
        human_uncertainty: Z_d in metres.
        robot_uncertainty: Z_r in metres.
        human_uncertainty_sigmas: adds this many position standard deviations of each
            segment's bodies to Z_d (0: the seed's constant Z_d).
        iso_speed, iso_reduced_speed: ISO/TS 15066 human speeds in metres per second.
        robot_speed: the robot's speed in S: ``directed`` (Eq. 7) or ``fastest_point``
            (``separation.pair_separation``).
        level_terms: None, or (T_s + T_r, B + C + Z_r) at each speed level
            (``configuration.level_terms``, ``safety.stopping: by_speed``): then the
            output ``level_protective_distances`` holds every segment's S at each level
            ((G + 1) x M, level-major; ``separation.level_rows``).
    """

    def __init__(
        self,
        *,
        num_segments: int,
        capsule_radii=(0.0,),
        human_speed: str = "estimated",
        reaction_time: float,
        stopping_time: float,
        stopping_distance: float,
        intrusion_distance: float = 0.0,
        human_uncertainty: float = 0.0,
        robot_uncertainty: float = 0.0,
        human_uncertainty_sigmas: float = 0.0,
        iso_speed: float = ISO_HUMAN_SPEED,
        iso_reduced_speed: float = ISO_REDUCED_HUMAN_SPEED,
        robot_speed: str = "directed",
        level_terms=None,
    ):
        super().__init__()
        if num_segments < 0:
            raise ValueError(f"num_segments: got {num_segments}; allowed: an integer >= 0")
        if human_speed not in HUMAN_SPEED_MODES:
            raise ValueError(f"human_speed: got {human_speed!r}; allowed: {HUMAN_SPEED_MODES}")
        if robot_speed not in ROBOT_SPEED_TERMS:
            raise ValueError(f"robot_speed: got {robot_speed!r}; allowed: {ROBOT_SPEED_TERMS}")
        for name, value in dict(
            reaction_time=reaction_time, stopping_time=stopping_time,
            stopping_distance=stopping_distance, human_uncertainty_sigmas=human_uncertainty_sigmas,
        ).items():
            if not np.isfinite(value) or value < 0:
                raise ValueError(f"{name}: got {value}; allowed: a finite number >= 0")
        self._radius = np.array(capsule_radii, dtype=float).reshape(-1)
        if self._radius.size == 0 or not np.all(np.isfinite(self._radius)
                                                & (self._radius >= 0.0)):
            raise ValueError(f"capsule_radii: got {self._radius.tolist()}; allowed: one or "
                             "more finite radii >= 0 (m)")
        self._n, k = num_segments, self._radius.size
        self._z_d_terms = (float(human_uncertainty), float(human_uncertainty_sigmas))
        self._monitor = (HUMAN_SPEED_MODES.index(human_speed),
                         float(stopping_time + reaction_time), float(reaction_time),
                         float(stopping_distance + intrusion_distance + robot_uncertainty),
                         float(iso_speed), float(iso_reduced_speed),
                         ROBOT_SPEED_TERMS.index(robot_speed))
        m = num_segments
        self._ends = self.DeclareVectorInputPort("capsule_ends", 6 * k)
        self._end_v = self.DeclareVectorInputPort("capsule_velocities", 6 * k)
        self._h_ends = self.DeclareVectorInputPort("segment_ends", 6 * m)
        self._h_v = self.DeclareVectorInputPort("segment_velocities", 6 * m)
        self._h_radius = self.DeclareVectorInputPort("segment_radii", m)
        self._status = self.DeclareVectorInputPort("segment_status", m)
        self._std = self.DeclareVectorInputPort("segment_std", m)
        self._cache = self.DeclareCacheEntry(
            description="separation",
            value_producer=ValueProducer(
                allocate=AbstractValue.Make(np.zeros((5, m))).Clone,
                calc=self._calc_all,
            ),
            prerequisites_of_calc={self.all_input_ports_ticket()},
        )
        for row, name in enumerate(
            ("distances", "protective_distances", "human_directed_speeds",
             "robot_directed_speeds", "nearest_capsule")
        ):
            self.DeclareVectorOutputPort(
                name, m, lambda c, o, r=row: o.SetFromVector(self._cache.Eval(c)[r]),
                prerequisites_of_calc={self._cache.ticket()},
            )

        self._levels = None
        if level_terms is not None:
            self._levels = tuple(np.ascontiguousarray(x, dtype=float) for x in level_terms)
            g = self._levels[0].size
            if g < 2 or self._levels[1].size != g or not all(
                    np.all(np.isfinite(x)) for x in self._levels):
                raise ValueError(f"level_terms: got {[x.tolist() for x in self._levels]}; "
                                 "allowed: two equal lists of 2 or more finite numbers")
            self._level_cache = self.DeclareCacheEntry(
                description="levels",
                value_producer=ValueProducer(
                    allocate=AbstractValue.Make(np.zeros((g, m))).Clone,
                    calc=self._calc_levels),
                prerequisites_of_calc={self.all_input_ports_ticket()})
            self.DeclareVectorOutputPort(
                "level_protective_distances", g * m,
                lambda c, o: o.SetFromVector(self._level_cache.Eval(c).reshape(-1)),
                prerequisites_of_calc={self._level_cache.ticket()})

    def _segments(self, context):
        """The segments' inputs as ``separation.separation_rows`` takes them."""
        m = self._n
        return (np.asarray(self._h_ends.Eval(context)).reshape(m, 2, 3),
                np.asarray(self._h_v.Eval(context)).reshape(m, 2, 3),
                np.asarray(self._h_radius.Eval(context)), np.asarray(self._status.Eval(context)),
                np.asarray(self._std.Eval(context)))

    def _robot(self, context):
        return (np.asarray(self._ends.Eval(context)).reshape(-1, 2, 3),
                np.asarray(self._end_v.Eval(context)).reshape(-1, 2, 3), self._radius)

    def _calc_levels(self, context, value):
        if self._n == 0:
            return
        separation.level_rows(*self._robot(context), *self._segments(context), self._z_d_terms,
                              self._monitor, self._levels[0], self._levels[1],
                              value.get_mutable_value())

    def _calc_all(self, context, value):
        n = self._n
        out = value.get_mutable_value()
        if n == 0:
            return
        nearest = np.empty(n, dtype=np.int64)
        separation.separation_rows(*self._robot(context), *self._segments(context),
                                   self._z_d_terms, self._monitor, out[:4], nearest)
        out[4] = nearest
