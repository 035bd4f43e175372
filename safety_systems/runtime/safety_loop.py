"""The safety controller on live data: the simulator's own compiled functions, called in
the order the Drake diagram calls them (no copy of any rule lives here).

- a frame: ``tracks.frame_step`` (the KalmanTracker's rules: ids, finite positions, the
  gate, Eqs. 2-4, hidden bodies, exits), ``tracks.estimate_rows`` and
  ``human_body.envelope_rows`` (OperatorEnvelopes: every operator's twelve segments
  bounded from its tracked bodies' estimates, a hidden body's region grown at
  ``safety.occlusion_speed``; a function of the tracker's outputs, which change only
  with a frame);
- the robot: ``robot_geometry.model_capsule_ends_at`` (RobotCapsules' forward
  kinematics, any robot's model) and Eq. 5, (ends - previous ends) / dt over the robot's
  own sample times;
- a decision at time t: ``tracks.tracker_fault`` (the frame's fault, else stale after
  the frame timeout), ``separation.separation_rows`` over the segments
  (SeparationMonitor, Eqs. 6-11) and ``ssm.override_decision`` over the segments'
  statuses (SpeedOverride, Eq. 12 and its fail-safe stops: a lost or partly seen
  operator's segments are lost, a NaN stops); under ``safety.stopping: by_speed`` also
  ``separation.level_rows`` (S at every speed level) and
  ``ssm.by_speed_override_command``, given a bound on the robot's path rate now (the
  robot link's ``rate_bound``). Under ``safety.mode: ssm_pfl`` (the resolved cell's
  ``pfl``) the same with each segment's cap in force
  (``pfl.speed_caps.clamp_caps`` of the envelopes against the fixed surfaces and the
  robot's links) by ``ssm.capped_override_command`` or ``ssm.capped_by_speed_command``.
  The contact detection that ends a lasting contact (``pfl.contact_limits``; the
  simulation's ContactStop) is the real robot's own: a premise the certificate names,
  not a rule of this loop.

Times are the runtime's monotonic clock (capture times from ``mocap.FrameClock``).
"""

import math

import numpy as np

from safety_systems.cell.human_body import envelope_rows
from safety_systems.cell.model_points import model_arrays, model_work
from safety_systems.cell.robot_geometry import model_capsule_ends_at
from safety_systems.config.resolved_cell import ResolvedCell
from safety_systems.sensing.tracks import TRACK_SLOT, estimate_rows, frame_step, tracker_fault
from safety_systems.pfl.speed_caps import clamp_caps
from safety_systems.ssm.formulas import override_decision
from safety_systems.ssm.separation import level_rows, separation_rows


class SafetyLoop:
    """Tracker, operator envelopes, robot capsules, monitor and override state of one
    live cell whose configuration (``type: ssm_override``) on its robot is the resolved
    ``cell`` (every term the loop takes is the cell's): operators whose tracked bodies
    mark the body points ``points`` (per operator, the point of each body in slot order,
    ``recording_mapping.mapped_point``), N body slots in all (ids 1..N, the operators'
    bodies in order), M = 12 segments per operator (``segment_names``:
    ``operator/segment``, by ``names``, the operators' names; None: their indices).

    State after a frame: the tracker's estimates per body (``p``, ``v``, ``status``,
    ``std``, ``unseen``, N) and the envelopes per segment (``segment_ends``,
    ``segment_velocities`` (M, 2, 3), ``segment_radius``, ``segment_status``,
    ``segment_std`` (M,)); after a decision, ``out`` (4, M: d, S, v_human, v_robot) and
    ``nearest`` (M,)."""

    def __init__(self, cell: ResolvedCell, points: list[list[str]],
                 names: list[str] | None = None):
        config = cell.config
        if config.type != "ssm_override":
            raise ValueError(f"controller.type: got {config.type!r}; the runtime runs "
                             "ssm_override only")
        f = config.safety
        n = self.n = sum(len(o) for o in points)
        self.rules, self.regions = cell.tracker_rules, cell.tracker_regions
        self.timeout = cell.frame_timeout
        self.model = cell.model
        self.capsules = cell.capsules
        self._arrays = model_arrays(self.model)
        self._work = model_work(self.model)
        self._points = np.empty((2, self.model.num_points, 3))
        self.recipe = cell.recipe_for(points, names)
        self.operator_names = [str(x) for x in (names or range(len(points)))]
        self.segment_names = list(self.recipe.names)
        self.envelope_terms = (float(config.body.tracking_allowance),
                               float(f.occlusion_speed))
        self.monitor = cell.monitor_terms
        self.z_d_terms = cell.z_d_terms
        self.delta_s, self.d_min = f.delta_s, f.d_min
        self.tracks = np.zeros((n, TRACK_SLOT))
        self.t_good = np.array([-np.inf])
        self.rejected = np.zeros(4)
        self.frame_fault = 0.0
        self.p, self.v = np.full((n, 3), np.nan), np.full((n, 3), np.nan)
        self.status, self.std, self.unseen = np.zeros(n), np.zeros(n), np.zeros(n)
        m = self.m = self.recipe.radius.size
        self.segment_ends = np.full((m, 2, 3), np.nan)
        self.segment_velocities = np.full((m, 2, 3), np.nan)
        self.segment_radius = np.full(m, np.nan)
        self.segment_status = np.zeros(m)
        self.segment_std = np.full(m, np.nan)
        K = self.capsules.radius.size
        self.ends = np.full((K, 2, 3), np.nan)
        self.end_velocities = np.full((K, 2, 3), np.nan)  # NaN until two samples: stop
        self._robot_time = math.nan
        self.out = np.full((4, m), np.nan)  # d, S, v_human, v_robot per segment
        self.nearest = np.full(m, -1, dtype=np.int64)
        self.levels = cell.level_terms if f.stopping == "by_speed" else None
        if self.levels is not None:  # S at each level, (G + 1, M)
            self.level_out = np.full((self.levels[0].size, m), np.nan)
        self.pfl = cell.pfl if f.mode == "ssm_pfl" else None
        self.caps = np.zeros(m)  # each segment's cap in force (0 under ssm)
        if self.pfl is not None:
            self._segment_caps = np.tile(self.pfl.caps, m // self.pfl.caps.size)
        self._warm_up()

    def _warm_up(self) -> None:
        """Calls every compiled function once on scratch copies (loading them from the
        cache takes long enough to make the first tick late), leaving the state as new."""
        saved = (self.tracks.copy(), self.t_good.copy(), self.rejected.copy(),
                 self.frame_fault, self.ends.copy(), self.end_velocities.copy(),
                 self._robot_time)
        self.frame(0.0, np.zeros((0, 3)), np.zeros(0), np.zeros(0))
        self.robot(np.zeros(self.model.n), 0.0)
        self.decide(0.0)
        (self.tracks, self.t_good, self.rejected, self.frame_fault, self.ends,
         self.end_velocities, self._robot_time) = saved
        self.out[:] = np.nan
        self.nearest[:] = -1
        self._estimates()

    def _estimates(self) -> None:
        """The tracker's estimates (``tracks.estimate_rows``) and the segments'
        envelopes from them (``human_body.envelope_rows``)."""
        estimate_rows(self.tracks, 0, self.n, self.t_good[0], self.p, self.v, self.status,
                      self.std, self.unseen)
        r = self.recipe
        envelope_rows(r.regions, r.candidates, r.radius, r.operator, r.slots, self.p, self.v,
                      self.status, self.std, self.unseen, *self.envelope_terms,
                      self.segment_ends, self.segment_velocities, self.segment_radius,
                      self.segment_status, self.segment_std)

    def frame(self, t_capture: float, z: np.ndarray, valid: np.ndarray,
              ids: np.ndarray) -> float:
        """A new frame captured at ``t_capture`` with entries z (E, 3), valid (E,), ids
        (E,); returns its fault (``stops`` code, 0 clean)."""
        self.frame_fault = float(frame_step(
            self.tracks, 0, self.n, float(t_capture), np.ascontiguousarray(z, dtype=float),
            np.ascontiguousarray(valid, dtype=float), np.ascontiguousarray(ids, dtype=float),
            self.t_good, self.rejected, self.rules, self.regions))
        self._estimates()
        return self.frame_fault

    def robot(self, q: np.ndarray, t: float) -> None:
        """The robot's joint positions q (n,) at its time t (a repeated t changes
        nothing)."""
        if t == self._robot_time:
            return
        c = self.capsules
        ends = np.empty_like(self.ends)
        model_capsule_ends_at(self._arrays, np.asarray(q, dtype=float), c.tool_length, c.a,
                              c.b, c.t0, c.t1, *self._work, self._points[0], self._points[1],
                              ends, np.empty_like(ends))
        self.end_velocities = (ends - self.ends) / (t - self._robot_time)
        self.ends, self._robot_time = ends, t

    def fault(self, now: float) -> float:
        """The tracker's fault at ``now`` (``tracks.tracker_fault``)."""
        return float(tracker_fault(self.frame_fault, now, self.t_good[0], self.timeout))

    def decide(self, now: float, rate: float = 1.0) -> tuple[float, float, int]:
        """(k, S_max, stop reason) at ``now``: the monitor over every segment and the
        override over the segments' statuses. ``rate``: a bound on the robot's path rate
        now (used under ``by_speed`` only; a NaN or a missing bound counts as full
        speed)."""
        if self.m:
            separation_rows(self.ends, self.end_velocities, self.capsules.radius,
                            self.segment_ends, self.segment_velocities, self.segment_radius,
                            self.segment_status, self.segment_std, self.z_d_terms,
                            self.monitor, self.out, self.nearest)
        if self.pfl is not None:
            clamp_caps(self.segment_ends, self.segment_radius, self._segment_caps,
                       self.pfl.boxes, self.pfl.reach, self.ends, self.end_velocities,
                       self.capsules.radius, self.pfl.monitor_links, self.caps)
        protective = self.out[1]
        if self.levels is not None:
            if self.m:
                level_rows(self.ends, self.end_velocities, self.capsules.radius,
                           self.segment_ends, self.segment_velocities, self.segment_radius,
                           self.segment_status, self.segment_std, self.z_d_terms,
                           self.monitor, self.levels[0], self.levels[1], self.level_out)
            protective = self.level_out
        return override_decision(self.out[0], protective, self.segment_status, self.fault(now),
                                 rate=rate if math.isfinite(rate) else 1.0,
                                 caps=None if self.pfl is None else self.caps,
                                 delta_s=self.delta_s, d_min=self.d_min)
