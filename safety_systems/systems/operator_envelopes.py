"""OperatorEnvelopes: every segment of every operator as the monitor bounds it from the
tracked bodies."""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem, ValueProducer

from safety_systems.cell.human_body import Recipe, envelope_rows


class OperatorEnvelopes(LeafSystem):
    """The operators' segments (``safety_systems.cell.human_body``) from the tracker's
    estimates: each segment's envelope, a capsule certain to hold it while the operator's
    dimensions are the model's and every estimate is within the tracking allowance.

    .. pydrake_system::

        name: OperatorEnvelopes
        input_ports:
        - positions_estimated
        - velocities_estimated
        - track_status
        - position_std
        - unseen_time
        output_ports:
        - segment_ends
        - segment_velocities
        - segment_radii
        - segment_status
        - segment_std

    ``human_body.envelope_rows`` holds the rule: a hidden body's region grows at
    ``occlusion_speed`` from its last estimate; every segment of an operator takes the
    operator's status (tracking, hidden, none, or lost when a body is lost or some are
    seen and others not); an unusable operator's segments are NaN. Outputs: M = 12 per
    operator; ends and velocities 6 per segment (its axis' two ends, x y z each), the
    ends carrying the velocities of the bodies the envelope was taken from.

    Args:
        num_bodies: registered body slots N (the tracker's).
        recipe: how to bound each segment (``human_body.envelope_recipe``).
        tracking_allowance: m, a tracked point's estimate error the envelopes allow.
        occlusion_speed: m/s at which a hidden body's region grows.
    """

    def __init__(self, *, num_bodies: int, recipe: Recipe, tracking_allowance: float,
                 occlusion_speed: float):
        super().__init__()
        for name, value in dict(tracking_allowance=tracking_allowance,
                                occlusion_speed=occlusion_speed).items():
            if not (np.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name}: got {value}; allowed: a finite number >= 0 (m, m/s)")
        if recipe.slots.size and recipe.slots.max() >= num_bodies:
            raise ValueError(f"recipe: a body slot {int(recipe.slots.max())} beyond the "
                             f"{num_bodies} registered")
        self._recipe, self._n, m = recipe, num_bodies, recipe.radius.size
        self._terms = (float(tracking_allowance), float(occlusion_speed))
        self._ports = [self.DeclareVectorInputPort(name, size) for name, size in (
            ("positions_estimated", 3 * num_bodies), ("velocities_estimated", 3 * num_bodies),
            ("track_status", num_bodies), ("position_std", num_bodies),
            ("unseen_time", num_bodies))]
        self._cache = self.DeclareCacheEntry(
            description="envelopes",
            value_producer=ValueProducer(
                allocate=AbstractValue.Make((np.zeros((m, 2, 3)), np.zeros((m, 2, 3)),
                                             np.zeros(m), np.zeros(m), np.zeros(m))).Clone,
                calc=self._calc),
            prerequisites_of_calc={self.all_input_ports_ticket()})
        for which, (name, size) in enumerate((("segment_ends", 6 * m),
                                              ("segment_velocities", 6 * m),
                                              ("segment_radii", m), ("segment_status", m),
                                              ("segment_std", m))):
            self.DeclareVectorOutputPort(
                name, size,
                lambda c, o, w=which: o.SetFromVector(self._cache.Eval(c)[w].reshape(-1)),
                prerequisites_of_calc={self._cache.ticket()})

    @property
    def num_segments(self) -> int:
        return self._recipe.radius.size

    def _calc(self, context, value):
        r, n = self._recipe, self._n
        p, v, status, std, unseen = (np.asarray(port.Eval(context)) for port in self._ports)
        m = r.radius.size
        out = (np.empty((m, 2, 3)), np.empty((m, 2, 3)), np.empty(m), np.empty(m), np.empty(m))
        envelope_rows(r.regions, r.candidates, r.radius, r.operator, r.slots,
                      p.reshape(n, 3), v.reshape(n, 3), status, std, unseen, *self._terms,
                      *out)
        value.set_value(out)
