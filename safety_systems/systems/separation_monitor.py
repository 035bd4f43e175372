"""SeparationMonitor: d_i, directed speeds and S_i for every tracked body."""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem, ValueProducer

from safety_systems.ssm import (
    HUMAN_SPEED_MODES,
    ISO_HUMAN_SPEED,
    ISO_REDUCED_HUMAN_SPEED,
    hidden_ball_radius,
    human_uncertainty,
    monitor_protective_distances,
    separation_and_directed_speeds,
)
from safety_systems.tracks import TRACK_HIDDEN, TRACK_TRACKING


class SeparationMonitor(LeafSystem):
    """Separation distances and protective separation distances, seed Eqs. 6-11.

    .. pydrake_system::

        name: SeparationMonitor
        input_ports:
        - ee_position
        - ee_velocity
        - positions_estimated
        - velocities_estimated
        - track_status
        - position_std
        - unseen_time
        output_ports:
        - distances
        - protective_distances
        - human_directed_speeds
        - robot_directed_speeds

    Bodies without a usable track (status none or lost) have NaN on every output; the
    SpeedOverride decides what a lost track means. A hidden body is a ball around its
    last accepted estimate whose radius grows at ``occlusion_speed``
    (:func:`safety_systems.ssm.hidden_ball_radius`): its d_i is the distance to that
    ball. Outputs are computed on demand from
    the inputs (one shared cache entry), so they follow the robot at its control rate.

    Args:
        num_bodies: registered body slots N.
        human_speed: ``estimated`` | ``iso`` | ``estimated_with_floor`` (see
            :func:`safety_systems.ssm.human_speed_term`).
        reaction_time: T_r in seconds.
        stopping_time: T_s in seconds.
        stopping_distance: B (S_S) in metres.
        intrusion_distance: C in metres.
        human_uncertainty: Z_d in metres.
        robot_uncertainty: Z_r in metres.
        human_uncertainty_sigmas: adds this many position standard deviations of each
            track to Z_d (0: the seed's constant Z_d).
        occlusion_speed: metres per second at which a hidden body's ball grows (0: a
            hidden body stays where it was last seen, as in the seed).
        iso_speed, iso_reduced_speed: ISO/TS 15066 human speeds in metres per second.
    """

    def __init__(
        self,
        *,
        num_bodies: int,
        human_speed: str = "estimated",
        reaction_time: float,
        stopping_time: float,
        stopping_distance: float,
        intrusion_distance: float = 0.0,
        human_uncertainty: float = 0.0,
        robot_uncertainty: float = 0.0,
        human_uncertainty_sigmas: float = 0.0,
        occlusion_speed: float = 0.0,
        iso_speed: float = ISO_HUMAN_SPEED,
        iso_reduced_speed: float = ISO_REDUCED_HUMAN_SPEED,
    ):
        super().__init__()
        if num_bodies < 0:
            raise ValueError(f"num_bodies: got {num_bodies}; allowed: an integer >= 0")
        if human_speed not in HUMAN_SPEED_MODES:
            raise ValueError(f"human_speed: got {human_speed!r}; allowed: {HUMAN_SPEED_MODES}")
        for name, value in dict(
            reaction_time=reaction_time, stopping_time=stopping_time,
            stopping_distance=stopping_distance, human_uncertainty_sigmas=human_uncertainty_sigmas,
            occlusion_speed=occlusion_speed,
        ).items():
            if not np.isfinite(value) or value < 0:
                raise ValueError(f"{name}: got {value}; allowed: a finite number >= 0")
        self._n = num_bodies
        self._mode = human_speed
        self._sigmas = human_uncertainty_sigmas
        self._occlusion_speed = occlusion_speed
        self._z_d = human_uncertainty
        self._s_args = dict(
            mode=human_speed, reaction_time=reaction_time, stopping_time=stopping_time,
            stopping_distance=stopping_distance, intrusion_distance=intrusion_distance,
            robot_uncertainty=robot_uncertainty, iso_speed=iso_speed,
            iso_reduced_speed=iso_reduced_speed,
        )
        self._p_R = self.DeclareVectorInputPort("ee_position", 3)
        self._v_R = self.DeclareVectorInputPort("ee_velocity", 3)
        self._p_B = self.DeclareVectorInputPort("positions_estimated", 3 * num_bodies)
        self._v_B = self.DeclareVectorInputPort("velocities_estimated", 3 * num_bodies)
        self._status = self.DeclareVectorInputPort("track_status", num_bodies)
        self._std = self.DeclareVectorInputPort("position_std", num_bodies)
        self._unseen = self.DeclareVectorInputPort("unseen_time", num_bodies)
        self._cache = self.DeclareCacheEntry(
            description="separation",
            value_producer=ValueProducer(
                allocate=AbstractValue.Make(np.zeros((4, num_bodies))).Clone,
                calc=self._calc_all,
            ),
            prerequisites_of_calc={self.all_input_ports_ticket()},
        )
        for row, name in enumerate(
            ("distances", "protective_distances", "human_directed_speeds",
             "robot_directed_speeds")
        ):
            self.DeclareVectorOutputPort(
                name, num_bodies, lambda c, o, r=row: o.SetFromVector(self._row(c, r)),
                prerequisites_of_calc={self._cache.ticket()},
            )

    def _row(self, context, row):
        return self._cache.Eval(context)[row]

    def _calc_all(self, context, value):
        n = self._n
        out = value.get_mutable_value()
        if n == 0:
            return
        p_R = self._p_R.Eval(context)
        v_R = self._v_R.Eval(context)
        p_B = self._p_B.Eval(context).reshape(n, 3)
        v_B = self._v_B.Eval(context).reshape(n, 3)
        status = self._status.Eval(context)
        usable = (status == TRACK_TRACKING) | (status == TRACK_HIDDEN)
        z_d = human_uncertainty(self._z_d, self._sigmas, self._std.Eval(context))
        d, v_h, v_r = separation_and_directed_speeds(p_R, v_R, p_B, v_B)
        s = monitor_protective_distances(v_h, v_r, human_uncertainty=z_d, **self._s_args)
        if self._occlusion_speed > 0.0:
            d = d - hidden_ball_radius(self._unseen.Eval(context), self._occlusion_speed)
        out[0] = d
        out[1] = s
        out[2] = v_h
        out[3] = v_r
        out[:, ~usable] = np.nan
