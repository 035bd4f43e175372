"""ContactStop: the power and force limiting robot's own contact detection."""

import numpy as np
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, LeafSystem

from safety_systems.cell.robot_geometry import Capsules, capsule_ends
from safety_systems.pfl.contact_limits import (
    E_LATCHED,
    EPISODE_COLUMNS,
    contact_step,
    episode_reset,
    segment_contact_row,
)
from safety_systems.ssm.separation import pair_figures
from safety_systems.ssm.true_measures import is_moving, true_segments


class ContactStop(LeafSystem):
    """The robot's own force limit under ``safety.mode: ssm_pfl``
    (``safety_systems.pfl.contact_limits``): at every control tick, each operator segment's
    contact with the real robot (its true segments against the robot's capsules, the
    properties' truth), how far the robot has pressed into it, and a stop once the force
    that indentation gives has reached the robot's ``contact_stop_force`` for
    ``contact_detection_time``; the stop holds until the contact ends.

    .. pydrake_system::

        name: ContactStop
        input_ports:
        - joint_positions
        - joint_velocities
        - points_true
        - point_velocities_true
        - operators_present
        output_ports:
        - contact_stop

    ``contact_stop`` is 1 while the stop holds (after the tick that set it, as a real
    robot's detection acts on the next control cycle), else 0. Its state is every
    segment's contact episode (``contact_limits.EPISODE_COLUMNS``).

    This is a model of the real robot, a premise trusted from the configuration (its
    force limit, tolerance and detection time): the live runtime has no such system,
    the robot stops itself.

    Args:
        capsules: the real robot's capsules (the properties' contact geometry).
        links: each capsule's link (``speed_caps.capsule_links``).
        recipe: the true segments' recipe (``configuration.truth_recipe``).
        limits: each segment's permissible speed (M,), m/s.
        compressions: each segment's transient, quasi-static and detection compressions
            (M, 3), metres.
        boxes: the fixed surfaces, (S, 2, 3) boxes (min and max corners).
        contact_distance: metres: a segment this close to the robot touches it.
        clamp_gap: metres: within this of a surface or two links, a segment is clampable.
        detection_time: seconds, window: seconds (the transient window).
        period_sec: the control period, seconds.
    """

    def __init__(self, *, capsules: Capsules, links, recipe, limits, compressions, boxes,
                 contact_distance: float, clamp_gap: float, detection_time: float,
                 window: float, period_sec: float) -> None:
        super().__init__()
        self._capsules, self._recipe = capsules, recipe
        self._links = np.ascontiguousarray(links, dtype=np.int64)
        m = recipe.radius.size
        self._limits = np.ascontiguousarray(limits, dtype=float).reshape(m)
        self._x = np.ascontiguousarray(compressions, dtype=float).reshape(m, 3)
        self._boxes = np.ascontiguousarray(boxes, dtype=float).reshape(-1, 2, 3)
        self._c, self._gap = float(contact_distance), float(clamp_gap)
        self._detection, self._window, self._dt = (float(detection_time), float(window),
                                                   float(period_sec))
        n, k = capsules.model.n, recipe.slots.shape[0]
        self._q = self.DeclareVectorInputPort("joint_positions", n)
        self._v = self.DeclareVectorInputPort("joint_velocities", n)
        self._points = self.DeclareVectorInputPort("points_true", recipe.regions.shape[0] * 3)
        self._velocities = self.DeclareVectorInputPort("point_velocities_true",
                                                       recipe.regions.shape[0] * 3)
        self._present = self.DeclareVectorInputPort("operators_present", k)
        initial = np.empty((m, EPISODE_COLUMNS))
        for row in initial:
            episode_reset(row)
        self._state = self.DeclareDiscreteState(initial.reshape(-1))
        self.DeclarePeriodicDiscreteUpdateEvent(period_sec=period_sec, offset_sec=0.0,
                                                update=self._step)
        self._work = (np.empty(m, dtype=np.bool_), np.empty(m), np.empty(m, dtype=np.bool_))
        self.DeclareVectorOutputPort("contact_stop", BasicVector(1), self._output,
                                     prerequisites_of_calc={self.xd_ticket()})

    def _output(self, context: Context, out: BasicVector) -> None:
        state = context.get_discrete_state_vector().value().reshape(-1, EPISODE_COLUMNS)
        out.SetAtIndex(0, 1.0 if np.any(state[:, E_LATCHED] > 0.5) else 0.0)

    def _step(self, context: Context, discrete_state: DiscreteValues) -> None:
        state = np.array(context.get_discrete_state_vector().value()).reshape(
            -1, EPISODE_COLUMNS)
        q = np.asarray(self._q.Eval(context), dtype=float)[None]
        v = np.asarray(self._v.Eval(context), dtype=float)[None]
        ends, end_velocities = capsule_ends(q, self._capsules, v)
        h_ends, h_velocities, h_radius, present = true_segments(
            self._recipe, np.asarray(self._points.Eval(context))[None],
            np.asarray(self._velocities.Eval(context))[None],
            np.asarray(self._present.Eval(context))[None])
        clearance, _, v_r = pair_figures(ends, end_velocities, self._capsules.radius, h_ends,
                                         h_velocities, h_radius)
        absent = ~present[:, :, None]
        clearance, v_r = np.where(absent, np.nan, clearance), np.where(absent, np.nan, v_r)
        in_contact, v_rel, clamped = self._work
        segment_contact_row(h_ends[0], h_radius[0], clearance[0], v_r[0], ends[0],
                            end_velocities[0], self._capsules.radius, self._links, self._boxes,
                            self._c, self._gap, in_contact, v_rel, clamped)
        moving = is_moving(float(np.linalg.norm(end_velocities[0], axis=-1).max(initial=0.0)))
        t = context.get_time()
        for m in range(state.shape[0]):
            contact_step(state[m], in_contact[m], moving, v_rel[m], clamped[m], t, self._dt,
                         self._limits[m], self._x[m, 0], self._x[m, 1], self._x[m, 2],
                         self._detection, self._window)
        discrete_state.get_mutable_vector().SetFromVector(state.reshape(-1))
