"""Breadth: step many scenarios at once, through the same maths as the diagram.

:func:`evaluate_batch` reproduces the Drake workcell (kinematic mode) tick by tick for a
batch of scenarios that share the robot, the controller configuration and the shape of
their operators (number of operators, bodies and waypoints), as the scenarios of one
space do. It runs the compiled functions the LeafSystems wrap, in compiled loops: at
each tracker update, in one call (:func:`_update`), the frame each sensor delivers, the
MocapSensor's capture (:func:`_capture`; the unit noise of each capture index drawn once
by the sensor's rule, ``delivery.unit_noise``, and kept for a sweep's next batches)
and the KalmanTracker's rows (``kalman_tracker._track_rows``, Eqs. 2-4), and
between two updates every control tick of every scenario in :func:`_advance`: the
joint path (``joint_path.path_state_one``), the robot (``model_points``), Eq. 5,
the monitor and the override (``ssm``: Eqs. 6-12), the properties on the operators'
truth (``operator_paths.path_point_one``) and the follower's braked step
(``braking.path_follower_step``). Event order follows the diagram: a tracker update at time
u is seen by the first control tick after u; outputs at a tick are computed from the
state before that tick's updates, as Drake's loggers record them.
``tests/verification`` checks the two agree. It refuses dynamic-mode scenarios (the
plant and its inverse-dynamics controller, whose tracking error it does not model);
:func:`evaluate_many` runs those in the diagram instead, and so it does scenarios whose
operators are played from recordings (their truth is the recording's samples, which
these compiled loops do not carry; ``RecordedMotion``).
"""

import dataclasses
import math
import threading

import numba
import numpy as np

from safety_systems.sensing import stops
from safety_systems.cell.braking import path_follower_step
from safety_systems.cell.human_body import KIND_DIRECT, NUM_POINTS, envelope_batch
from safety_systems.config.configuration import (
    contact_capsules,
    operator_postures,
    truth_recipe,
)
from safety_systems.config.configuration import sensor_faults as scenario_faults
from safety_systems.cell.joint_path import path_arrays, path_state_one
from safety_systems.outputs.metrics import robot_stopping, robot_stops_by_rate
from safety_systems.cell.operator_paths import (
    check_bodies,
    path_point_one,
    stack_operator_paths,
)
from safety_systems.cell.model_points import (
    model_arrays,
    model_points_one,
    model_tool0_one,
    model_work,
)
from safety_systems.cell.robot_geometry import (
    capsule_ends_one,
    segments_pair,
)
from safety_systems.config.scenario import (
    Scenario,
    actual_sensor,
    operator_points,
)
from safety_systems.sensing.sensor_faults import FAULT_COLUMNS, apply_faults
from safety_systems.ssm.separation import (
    capsule_axis,
    pair_separation,
    segment_levels,
    segment_of,
    segment_separation,
)
from safety_systems.ssm.formulas import (
    ISO_REDUCED_SPEED_THRESHOLD,
    by_speed_command,
    by_speed_command_caps,
    level_at_or_above,
    override_command,
    override_command_caps,
    speed_scale_eq12,
)
from safety_systems.ssm.true_measures import is_moving, is_permitted, true_margin
from safety_systems.pfl.contact_limits import (
    E_LATCHED,
    E_OVER,
    E_START,
    EPISODE_COLUMNS,
    contact_step,
)
from safety_systems.pfl.speed_caps import (
    CLAMP_GAP,
    between_links,
    capsule_links,
    clamp_caps,
    clampable,
    contact_robustness,
)
from safety_systems.sensing.delivery import TIME_TOL, delivered_frame, unit_noise
from safety_systems.sensing.tracks import (
    TRACK_SLOT,
    estimate_rows,
    frame_step,
    tracker_fault,
    tracker_stop,
    usable,
)
from safety_systems.config.configuration import is_recorded, joint_path
from safety_systems.config.resolved_cell import ResolvedCell, resolve_scenario, scenario_cell

_EVENT_TOL = 1e-9  # s: events this close to a tick count as simultaneous with it


@dataclasses.dataclass(frozen=True)
class BatchResult:
    """Per-scenario figures, each of shape (B,) (see ``verification.properties``)."""

    robustness: np.ndarray  # stopped before contact, m (>= 0 safe)
    min_separation_while_moving: np.ndarray
    separation: np.ndarray  # the separation invariant, m (>= 0 safe)
    separation_violation_time: np.ndarray  # s permitted with some pair inside S_true
    permitted_contact: np.ndarray  # permitted contact (m/s at a contact, else m; >= 0 safe)


def _common(scenarios: list[Scenario], get, what: str):
    first = get(scenarios[0])
    for s in scenarios[1:]:
        if get(s) != first:
            raise ValueError(f"evaluate_batch: scenarios differ in {what}; batch them apart")
    return first


def _truth_segments(scenarios: list[Scenario]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(first point, second point, radius) of each of an operator's 12 true segments, as
    ``configuration.truth_recipe`` takes them for scripted operators (every segment the
    capsule between two known points, the same for every operator and scenario)."""
    recipe = truth_recipe(scenarios[0])
    if not np.all(recipe.candidates[:, 4] == KIND_DIRECT) or \
            recipe.candidates.shape[0] != recipe.radius.size:
        raise ValueError("evaluate_batch: a true segment is not between two known points")
    per = recipe.radius.size // len(scenarios[0].operators)
    rows = recipe.candidates[:per]
    point = recipe.regions[:, 0].astype(np.int64) % NUM_POINTS
    return (point[rows[:, 1].astype(np.int64)], point[rows[:, 2].astype(np.int64)],
            np.ascontiguousarray(recipe.radius[:per]))


def dropout_table(sensors: list) -> np.ndarray:
    """(B, most dropouts, 2) start and end of each sensor's dropped intervals (inf pads)."""
    drops = np.full((len(sensors), max((len(s.dropouts) for s in sensors), default=0), 2),
                    np.inf)
    for b, s in enumerate(sensors):
        for j, iv in enumerate(s.dropouts):
            drops[b, j] = (iv.start, iv.end)
    return drops


@numba.njit(cache=True)
def _delivered_rows(u, latency, period, drops, out):
    """:func:`delivered_frames` of every row, compiled (``delivery.delivered_frame``)."""
    for b in range(latency.size):
        out[b] = delivered_frame(u[b], latency[b], period, drops[b])


def delivered_frames(u: float | np.ndarray, latency: np.ndarray, period: float,
                     drops: np.ndarray) -> np.ndarray:
    """Index of the frame each sensor (latency (B,), dropped intervals ``drops``, see
    :func:`dropout_table`) shows at time(s) u, as MocapSensor delivers them: the newest
    capture at least a latency old that was not dropped (-1: none yet); compiled."""
    latency = np.ascontiguousarray(latency, dtype=float)
    u = np.ascontiguousarray(np.broadcast_to(np.asarray(u, dtype=float), latency.shape))
    out = np.empty(latency.size, dtype=np.int64)
    _delivered_rows(u, latency, float(period), np.ascontiguousarray(drops, dtype=float), out)
    return out


class _Cells:
    """The fixed data of a batch: truth, sensor conditions, configuration (its resolved
    ``cell``, which stands for the batch: ``evaluate_batch`` checked it)."""

    def __init__(self, scenarios: list[Scenario], cell: ResolvedCell):
        self.B = len(scenarios)
        self.config = _common(scenarios, lambda s: s.controller, "controller configuration")
        robot = _common(scenarios, lambda s: dataclasses.replace(
            s.robot, cycles=1, braking_time_scale=1.0), "robot")
        self.dt = 1.0 / robot.control_rate_hz
        self.accel = robot.acceleration_limit
        cycles = max(s.robot.cycles for s in scenarios)
        self.path = joint_path(dataclasses.replace(robot, cycles=cycles))
        # Each scenario's task ends after its cycles, or after the path's own (a one-way
        # path, a line or a robot log run once, has one whatever robot.cycles says).
        self.end = np.array([self.path.cycle_time * min(s.robot.cycles, self.path.cycles)
                             for s in scenarios])
        self.brake_scale = np.array([s.robot.braking_time_scale for s in scenarios])
        self.model = cell.model
        self.table = cell.braking
        self.ticks = np.array([math.floor(s.duration / self.dt + 1e-9) for s in scenarios])
        sensors = [actual_sensor(s) for s in scenarios]
        self.period = _common(scenarios, lambda s: 1.0 / actual_sensor(s).rate_hz, "sensor rate")
        self.seed = _common(scenarios, lambda s: actual_sensor(s).seed, "sensor seed")
        self.latency = np.array([s.latency for s in sensors])
        self.noise = np.array([s.noise_std for s in sensors])
        self.drops = dropout_table(sensors)
        # Operators: same shape in every scenario.
        _common(scenarios, lambda s: [(len(o.bodies), len(o.waypoints)) for o in s.operators],
                "operator shape")
        # Every operator's path at once, equal to stack_paths of their scripted_operators.
        specs = [o for s in scenarios for o in s.operators]
        self.K = len(scenarios[0].operators)
        st = stack_operator_paths(
            [[w.time for w in o.waypoints] for o in specs],
            [[w.position for w in o.waypoints] for o in specs],
            [o.max_speed for o in specs], [o.max_acceleration for o in specs])
        self.stack_arrays = (st.departure_times, st.accel_durations, st.cruise_durations,
                             st.peak_speeds, st.lengths, st.max_acceleration, st.directions,
                             st.waypoint_positions)
        self.op_index = np.repeat(np.arange(self.K),
                                  [len(o.bodies) for o in scenarios[0].operators])
        self.op_first = np.searchsorted(self.op_index, np.arange(self.K + 1))  # bodies by operator
        self.N = self.op_index.size
        for o in specs:  # as ScriptedOperator checks them
            check_bodies(np.array([b.offset for b in o.bodies], dtype=float), o.enter_time,
                         o.leave_time)
        self.offsets = np.array([[b.offset for o in s.operators for b in o.bodies]
                                 for s in scenarios], dtype=float).reshape(self.B, self.N, 3)
        # where the sensor reports each body from its point (its pivot, sensing.pivots)
        self.pivots = np.array([[b.pivot for o in s.operators for b in o.bodies]
                                for s in scenarios], dtype=float).reshape(self.B, self.N, 3)
        self.enter = np.array([[o.enter_time for o in s.operators] for s in scenarios],
                              dtype=float).reshape(self.B, self.K)
        self.leave = np.array([[o.leave_time for o in s.operators] for s in scenarios],
                              dtype=float).reshape(self.B, self.K)
        names = [f"{o.name}/{b.name}" for o in scenarios[0].operators for b in o.bodies]
        # The unit noise of every capture up to the last tick (MocapSensor's rule).
        frames = math.floor((self.ticks.max() + 1) * self.dt / self.period) + 2
        self.units = unit_noise_table(self.seed, self.N, frames)
        o = max((len(s.occlusions) for s in sensors), default=0)
        self.occ = np.full((self.B, o, 3), np.inf)  # body index, start, end
        for b, s in enumerate(sensors):
            for j, oc in enumerate(s.occlusions):
                self.occ[b, j] = (names.index(oc.body), oc.start, oc.end)
        tables = [scenario_faults(s) for s in scenarios]
        self.faults = np.zeros((self.B, max((len(t) for t in tables), default=0),
                                FAULT_COLUMNS))
        self.faults[:, :, 3:5] = np.inf  # padding rows never act
        for b, table in enumerate(tables):
            self.faults[b, :len(table)] = table

    def update(self, u: float, frames, tracks, rules, regions, est_p, est_v, status, std,
               unseen):
        """The tracker update at time u of every scenario (see :func:`_update`)."""
        _update(u, self.latency, self.period, self.drops, frames, self.stack_arrays,
                self.op_index, self.offsets, self.pivots, self.enter, self.leave, self.occ,
                self.faults,
                self.noise, self.units, tracks, rules, regions, est_p, est_v, status, std,
                unseen)


_UNIT_NOISE: dict[tuple[int, int], np.ndarray] = {}  # a few sensors' tables, newest last
_UNIT_NOISE_LOCK = threading.Lock()  # (a Dask worker runs batches in threads)


def unit_noise_table(seed: int, n: int, frames: int) -> np.ndarray:
    """(frames, n, 3) unit noise of captures 0 .. frames - 1 of a sensor with ``seed``
    and n bodies (``delivery.unit_noise``); kept for the next batches of a sweep
    (never changed in place: a longer table is a new array)."""
    with _UNIT_NOISE_LOCK:
        table = _UNIT_NOISE.pop((seed, n), np.zeros((0, n, 3)))
        if table.shape[0] < frames:
            table = np.concatenate([table, [unit_noise(seed, k, n).reshape(n, 3)
                                            for k in range(table.shape[0], frames)]])
        _UNIT_NOISE[(seed, n)] = table
        while len(_UNIT_NOISE) > 16:
            _UNIT_NOISE.pop(next(iter(_UNIT_NOISE)))
    return table


# frames (B, 7): per scenario the tracker's frame state: the last frame number processed,
# the newest good capture time, that frame's fault, and the rejected measurements by cause.
_F_NUMBER, _F_GOOD, _F_FAULT, _F_COUNTS = 0, 1, 2, 3


@numba.njit(cache=True)
def _update(u, latency, period, drops, frames, stack, op_index, offsets, pivots, enter, leave,
            occ,
            faults, noise, units, tracks, rules, regions, est_p, est_v, status, std, unseen):
    """A tracker update at time u of every scenario, compiled: the frame each sensor
    delivers (:func:`_delivered_rows`); where its frame number is new, its capture
    (:func:`_capture`, with the sensor's faults), the KalmanTracker's step of its bodies'
    tracks (``tracks.frame_step``: the rules of ids, finite positions, the gate, Eqs.
    2-4, hidden bodies and exits, with ``rules`` and ``regions``) and their outputs
    est_p, est_v, status, std, unseen (``tracks.estimate_rows``)."""
    B, N = est_p.shape[0], est_p.shape[1]
    index = np.empty(B, dtype=np.int64)
    _delivered_rows(np.full(B, u), latency, period, drops, index)
    rows = np.flatnonzero((index >= 0) & (index != frames[:, _F_NUMBER]))
    R = rows.size
    if R > 0:
        frame = index[rows]
        if frame.max() >= units.shape[0]:
            raise ValueError("_update: a capture beyond the unit noise table")
        z, valid = np.empty((R, N, 3)), np.empty((R, N))
        ids, carried = np.empty((R, N)), np.empty(R)
        _capture(stack, op_index, offsets, pivots, enter, leave, occ, faults, noise, units, rows,
                 frame,
                 period, z, valid, ids, carried)
        for r in range(R):
            b = rows[r]
            frames[b, _F_NUMBER] = frame[r]
            frames[b, _F_FAULT] = frame_step(
                tracks, b * N, N, carried[r], z[r], valid[r], ids[r],
                frames[b, _F_GOOD:_F_GOOD + 1], frames[b, _F_COUNTS:], rules, regions)
            estimate_rows(tracks, b * N, N, frames[b, _F_GOOD], est_p[b], est_v[b], status[b],
                          std[b], unseen[b])


@numba.njit(cache=True)
def _capture(stack, op_index, offsets, pivots, enter, leave, occ, faults, noise, units, rows,
             index,
             period, p, valid, ids, carried):
    """The MocapSensor's frames ``index`` (R,) of the scenarios ``rows``: positions p
    (R, N, 3), whether it sees the bodies (``valid``: present and not in an occlusion
    interval of ``occ`` (B, ., 3): body, start, end), the ids the entries carry and the
    capture time each frame carries (``sensor_faults.apply_faults`` of ``faults``
    (B, ., 8)); compiled. The truth at the capture time by ``path_point_one`` of the
    operator's path plus the body's offset, plus its pivot (``pivots`` (B, N, 3): where
    the sensor reports it from its point), plus noise std ``noise[b]`` times the frame's
    unit noise ``units[index]``; NaN where not seen."""
    departures, ta, tc, vp, lengths, a_max, directions, waypoints = stack
    K = enter.shape[1]
    for r in range(rows.size):
        b, k = rows[r], index[r]
        t = k * period
        for i in range(op_index.size):
            o = op_index[i]
            x0, x1, x2, _, _, _ = path_point_one(departures, ta, tc, vp, lengths, a_max,
                                                 directions, waypoints, b * K + o, t)
            p[r, i, 0], p[r, i, 1], p[r, i, 2] = (x0 + offsets[b, i, 0], x1 + offsets[b, i, 1],
                                                  x2 + offsets[b, i, 2])
            for j in range(3):  # (exact where 0: MocapSensor adds the same after the point)
                p[r, i, j] = p[r, i, j] + pivots[b, i, j]
            seen = t >= enter[b, o] and t < leave[b, o]
            for j in range(occ.shape[1]):
                if occ[b, j, 1] <= t < occ[b, j, 2] and occ[b, j, 0] == i:
                    seen = False
            valid[r, i] = 1.0 if seen else 0.0
            ids[r, i] = i + 1.0
            for j in range(3):
                if noise[b] > 0.0:
                    p[r, i, j] = p[r, i, j] + noise[b] * units[k, i, j]
                if not seen:
                    p[r, i, j] = np.nan
        carried[r] = apply_faults(faults[b], k, period, TIME_TOL, p[r], valid[r], ids[r])




_MARGIN = 1e-9  # m: the bounds below skip work only when rounding could not matter


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def _bounding_sphere(ends, radius):
    """(centre x, y, z, radius) of a sphere containing every capsule: about the ends'
    mean, out to the farthest end (every axis point is nearer than the farthest end)
    plus the largest capsule radius."""
    c0, c1, c2, n = 0.0, 0.0, 0.0, 2.0 * radius.size
    for j in range(radius.size):
        for e in range(2):
            c0, c1, c2 = c0 + ends[j, e, 0], c1 + ends[j, e, 1], c2 + ends[j, e, 2]
    c0, c1, c2 = c0 / n, c1 / n, c2 / n
    far, thick = 0.0, 0.0
    for j in range(radius.size):
        thick = max(thick, radius[j])
        for e in range(2):
            x0, x1, x2 = ends[j, e, 0] - c0, ends[j, e, 1] - c1, ends[j, e, 2] - c2
            far = max(far, x0 * x0 + x1 * x1 + x2 * x2)
    return c0, c1, c2, np.sqrt(far) + thick  # (the root of the largest square)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def monitor_segment(segment, r_H, z_d, ends, end_velocities, radius, monitor):
    """The SeparationMonitor's d_i, S_i (and the nearest pair's speeds and index) of one
    segment: the product's ``separation.segment_separation`` (a seam for the
    broken-variant test, which rebuilds :func:`_advance` with a variant here)."""
    return segment_separation(segment, r_H, z_d, ends, end_velocities, radius, monitor)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def monitor_pair(segment, r_H, z_d, ends, end_velocities, radius, j, monitor):
    """The SeparationMonitor's clearance and S (and speeds) of one segment and capsule j:
    the product's ``separation.pair_separation``, which ``segment_separation`` runs over
    every capsule (a seam for the broken-variant test, as :func:`monitor_segment`)."""
    return pair_separation(segment, r_H, z_d, ends, end_velocities, radius, j, monitor)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def _s_bound(v_h, v_r, z_d, mode, t_sr, t_r, const, iso, iso_reduced):
    """An upper bound on ``formulas.body_protective_distance`` (m) for every human speed
    at most v_h and robot speed at most v_r (m/s), with ``_MARGIN`` for rounding: v_h by
    the mode (``estimated_with_floor``: at least ``iso``), and in ``iso`` mode the larger
    of the two ISO speeds with the reduced rule's threshold as a floor (that rule is not
    monotonic in the speeds, so the bound takes both of its branches)."""
    h = max(iso, iso_reduced) if mode == 1 else (max(v_h, iso) if mode == 2 else v_h)
    s = h * t_sr + v_r * t_r + const + z_d + _MARGIN
    if mode == 1:
        s = max(s, ISO_REDUCED_SPEED_THRESHOLD + _MARGIN)
    return s


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def _cone_speed(v, speed, u0, u1, u2, cos_a, sin_a):
    """An upper bound on v . n over the unit vectors n within the angle a (< 90 deg) of the
    unit vector u (m/s), ``speed`` = |v|: the smaller of |v| and (v . u) cos a + |v| sin a.
    With theta the angle from u to v: outside the cone the largest v . n is |v| cos(theta -
    a) = (v . u) cos a + |v x u| sin a, and |v x u| <= |v|; inside it, it is |v|, and then
    cos theta cos a + sin a >= cos^2 a + sin a >= 1."""
    along = v[0] * u0 + v[1] * u1 + v[2] * u2
    return min(speed, along * cos_a + speed * sin_a)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def _speed_bounds(g0, g1, g2, apart, halves, vP, sP, vQ, sQ, vA, sA, vB, sB, robot_speed):
    """Upper bounds on a segment-capsule pair's directed speeds (v_human_directed,
    v_robot_directed) as ``robot_geometry.segments_pair`` takes them (m/s), from the
    segment's axis midpoint to the capsule's, g = (g0, g1, g2) (|g| = ``apart``), the sum
    of the two axes' half-lengths ``halves``, the segment's end velocities vP, vQ and the
    capsule's vA, vB, with their magnitudes sP, sQ, sA, sB.

    The nearest points x_h, x_r lie within their half-lengths of the midpoints, so
    x_r - x_h lies within ``halves`` of g: where the axes' spheres are apart, its
    direction n lies in the cone about g / |g| of half-angle asin(halves / |g|). The
    human's directed speed is the larger of vP . n, vQ . n, and the robot's is
    w . (-n) with w between vA and vB (at most the larger of vA . (-n), vB . (-n)): each
    is at most :func:`_cone_speed`. Where the spheres meet (or come within a micrometre,
    where the two points could coincide and the speeds are taken whole), the faster
    ends' speeds. ``robot_speed`` 1 (``fastest_point``): the robot's is the faster end's.
    """
    if not apart - halves > 1e-6:
        return max(sP, sQ), max(sA, sB)
    u0, u1, u2 = g0 / apart, g1 / apart, g2 / apart
    sin_a = min((halves + 1e-9) / apart, 1.0)
    cos_a = np.sqrt(1.0 - sin_a * sin_a)
    h = max(_cone_speed(vP, sP, u0, u1, u2, cos_a, sin_a),
            _cone_speed(vQ, sQ, u0, u1, u2, cos_a, sin_a))
    if robot_speed == 1:
        return h, max(sA, sB)
    return h, max(_cone_speed(vA, sA, -u0, -u1, -u2, cos_a, sin_a),
                  _cone_speed(vB, sB, -u0, -u1, -u2, cos_a, sin_a))


@numba.njit(cache=True)
def _segment_axes(h_ends, h_velocities, axes):
    """Per scenario and segment, what the monitor's bounds read at every tick until the
    next tracker update, into ``axes`` (B, M, 6): its axis' midpoint, half length and
    its ends' speeds |vP|, |vQ|. NaN where the segment is."""
    for b in range(axes.shape[0]):
        for m in range(axes.shape[1]):
            y0 = 0.5 * (h_ends[b, m, 0, 0] + h_ends[b, m, 1, 0])
            y1 = 0.5 * (h_ends[b, m, 0, 1] + h_ends[b, m, 1, 1])
            y2 = 0.5 * (h_ends[b, m, 0, 2] + h_ends[b, m, 1, 2])
            g0, g1, g2 = (h_ends[b, m, 1, 0] - y0, h_ends[b, m, 1, 1] - y1,
                          h_ends[b, m, 1, 2] - y2)
            axes[b, m, 0], axes[b, m, 1], axes[b, m, 2] = y0, y1, y2
            axes[b, m, 3] = np.sqrt(g0 * g0 + g1 * g1 + g2 * g2)
            for e in range(2):
                w0, w1, w2 = (h_velocities[b, m, e, 0], h_velocities[b, m, e, 1],
                              h_velocities[b, m, e, 2])
                axes[b, m, 4 + e] = np.sqrt(w0 * w0 + w1 * w1 + w2 * w2)


@numba.njit(cache=True)
def _operator_spheres(h_ends, axes, h_radius, h_std, operator, spheres):
    """Per scenario and operator, a sphere holding every segment capsule of the operator
    (centre, radius), its segments' fastest end speed (from :func:`_segment_axes`) and
    their largest std, into spheres (B, K, 6): about the mean of the ends, out to the
    farthest end plus its capsule's radius (every axis point is nearer than the farther
    end). NaN where a segment is NaN (an unusable operator, or a NaN estimate)."""
    B, K = spheres.shape[0], spheres.shape[1]
    count = np.zeros(K)
    for b in range(B):
        for k in range(K):
            for x in range(6):
                spheres[b, k, x] = 0.0
            count[k] = 0.0
        for m in range(operator.size):
            k = operator[m]
            count[k] += 2.0
            for e in range(2):
                for x in range(3):
                    spheres[b, k, x] += h_ends[b, m, e, x]
        for k in range(K):
            for x in range(3):
                spheres[b, k, x] /= max(count[k], 1.0)
        for m in range(operator.size):
            k = operator[m]
            for e in range(2):
                x0 = h_ends[b, m, e, 0] - spheres[b, k, 0]
                x1 = h_ends[b, m, e, 1] - spheres[b, k, 1]
                x2 = h_ends[b, m, e, 2] - spheres[b, k, 2]
                far = np.sqrt(x0 * x0 + x1 * x1 + x2 * x2) + h_radius[b, m]
                fast = axes[b, m, 4 + e]
                # (a NaN anywhere makes the sphere NaN: max would drop it)
                spheres[b, k, 3] = far if not far <= spheres[b, k, 3] else spheres[b, k, 3]
                spheres[b, k, 4] = fast if not fast <= spheres[b, k, 4] else spheres[b, k, 4]
            std = h_std[b, m]
            spheres[b, k, 5] = std if not std <= spheres[b, k, 5] else spheres[b, k, 5]


@numba.njit(cache=True)
def _segment_travel(h_ends, h_radius, prev_ends, prev_radius, travel, kept, pair_kept):
    """At a tracker update, how far each scenario's segments (their envelopes, (B, M, 2,
    3) ends and (B, M) radii) have gone since the last (``prev_ends``, ``prev_radius``,
    then set to these) added to ``travel`` (B, M): its farther end's displacement (every
    axis point moves at most that far) plus its radius' growth, by which its clearance
    to any capsule can have fallen. Where a segment is NaN now or was, its ``kept``
    clearance bound goes (-inf), and its pairs' (``pair_kept`` (B, M, capsules))."""
    for b in range(h_ends.shape[0]):
        for m in range(h_ends.shape[1]):
            top_sq = 0.0
            for e in range(2):
                x0 = h_ends[b, m, e, 0] - prev_ends[b, m, e, 0]
                x1 = h_ends[b, m, e, 1] - prev_ends[b, m, e, 1]
                x2 = h_ends[b, m, e, 2] - prev_ends[b, m, e, 2]
                sq = x0 * x0 + x1 * x1 + x2 * x2
                top_sq = sq if not sq <= top_sq else top_sq  # (keeps a NaN)
                for x in range(3):
                    prev_ends[b, m, e, x] = h_ends[b, m, e, x]
            grow = h_radius[b, m] - prev_radius[b, m]
            prev_radius[b, m] = h_radius[b, m]
            if math.isnan(top_sq) or math.isnan(grow):
                kept[b, m] = -np.inf
                for j in range(pair_kept.shape[2]):
                    pair_kept[b, m, j] = -np.inf
            else:
                travel[b, m] += np.sqrt(top_sq) + max(grow, 0.0)


@numba.njit(cache=True, inline="always")
def _separation_floor(sep_min, margin):
    """Below this a true pair's margin could change a separation figure at this tick: the
    least margin so far (``sep_min``), and 0 while the tick's least margin found
    (``margin``) is not yet below 0 (the time inside S_true counts the ticks whose margin
    is); once it is, only a lower margin matters."""
    if margin < 0.0:
        return min(sep_min, margin)
    return max(min(sep_min, margin), 0.0)


@numba.njit(cache=True)
def _advance(k0, k1, dt, last, path, stack, postures, enter, leave, h_ends, h_velocities,
             h_radius, h_status, h_std, op_spheres, h_axes, frames, timeout, monitor, z_d_terms,
             delta_s, d_min, truth_t, truth_b, levels, truth_rates, monitor_caps, contact_caps,
             truth_segments, reach, truth_memo, monitor_memo, end, brake_scale, brakes, s, rate,
             ends_prev, s_last, memo, hint, trig, min_sep, sep_min, sep_time, robot, work,
             sizes, caps_now, pfl_truth, pc):
    """Control ticks k0 <= k < k1 of every scenario, as the diagram runs them between two
    tracker updates (the operators' segments as the monitor bounds them, ``h_ends``,
    ``h_velocities``, ``h_radius``, ``h_status``, ``h_std`` (``human_body.envelope_batch`` of the
    tracker's outputs), and the tracker's ``frames`` state are fixed meanwhile); compiled,
    from the product's compiled
    functions. At each tick:

    - the robot from the PathFollower's state (s, sigma): q and dq/ds by
      ``path_state_one`` (``path`` from ``joint_path.path_arrays``), the robot's points
      and their velocities J(q) dq/ds sigma by ``model_points.model_points_one`` of the
      robot's model (``robot``: ``model_points.model_arrays``, its work arrays ``work``
      and ``sizes`` = (joints, points, tool0's point); a UR's trigonometry kept per
      scenario in ``trig``, its points ``robot_geometry.robot_points_one_memo``'s, bit for
      bit) and the capsule ends by
      ``capsule_ends_one``: the monitor's capsules (``monitor_caps`` = (a, b, t0, t1,
      radius, tool length)) and the real robot's for the properties (``contact_caps``),
      once per distinct (s, sigma) at a tick (scenarios go in order of s; all start at
      rest at s = 0 and share these until their monitors differ); the RobotCapsules'
      Eq. 5 (ends - ends_prev) / dt;
    - SeparationMonitor and SpeedOverride on the segments: d_i and S_i of every usable
      segment (``separation.segment_separation`` via :func:`monitor_segment`: Eqs. 6-11
      over the capsules, ``monitor`` = ``workcell.monitor_terms`` (mode, T_s + T_r, T_r,
      B + C + Z_r, v_iso, v_iso_reduced, robot speed term), Z_d = ``z_d_terms`` (base,
      sigmas) base + sigmas std per segment), k, S_max and the stop reason by
      ``ssm.override_command`` (Eq. 12 over the usable segments, a lost track or an
      operator seen in part, the tracker's fault, or its newest good frame older than
      ``timeout``);
    - the properties on the truth (``verification.properties``; each operator's true
      segments (``configuration.truth_recipe``: a scripted operator's are the capsules
      between its true body points) from ``path_point_one`` of its path in ``stack`` plus
      its posture's offsets ``postures`` (B, K, 10, 3), ``truth_segments`` = (first
      point, second point, radius) of each of the 12 segments, present from ``enter`` to
      ``leave``), while a scenario's ticks last (k <= ``last``):
      the smallest clearance to the real robot's capsules while the robot moves (its
      fastest capsule end); while the override's k is not 0, the smallest clearance
      less S_true of any pair (``body_protective_distance`` with the monitor's mode and speeds,
      T_r, the pair's true directed speeds and, per scenario, ``truth_t`` = T_stop +
      T_r and ``truth_b`` = the robot's stopping distance + C: ``metrics.
      true_protective_args``) and the time some pair is inside S_true;
    - the PathFollower's update (``braking.path_follower_step``; ``brakes`` = speed
      fractions, decelerations, acceleration limit).

    Under ``safety.mode: ssm_pfl`` (``pfl_truth``'s last, ``capped``) the override is
    ``formulas.override_command_caps`` with each segment's cap in force ``caps_now``
    (B, M; ``pfl.speed_caps.clamp_caps`` of the envelopes at the last tracker update) on
    every usable segment's exact d and S (the sweeps' shortcuts take the closest d for
    every segment, which the caps cannot); the separation invariant counts a true
    segment's pairs only while the command exceeds its monitor segment's cap in force;
    and the permitted contact property (``pc`` (B,), under either mode) takes, at every
    pair within the contact distance (``pfl_truth``: limits (segments,), fixed surfaces
    (S, 2, 3), contact distance (B,), capped) while the robot moves,
    ``speed_caps.contact_robustness`` of its segment's limit and the pair's true
    directed robot speed (so such pairs are never skipped while the robot moves).

    Work that cannot change a figure is skipped, and each skip is exact (the tests hold
    the figures to the diagram's and to a batch of one): the monitor's k is reused while
    the robot rests and the tracker's outputs and fault are unchanged (its inputs are
    then the same; ``memo`` (B, 3): k, s and the fault it was computed for, ``s_last``
    the previous tick's s); it is 1 without the pairs when every segment's clearance,
    bounded below through a sphere around the capsules, lies beyond dS times an upper
    bound of every S (the fastest end for v_R, the segment's faster end or the ISO speed
    for v_H); else the pairs are evaluated nearest first (``hint`` (B, M + K): each
    segment's nearest capsule and each operator's nearest segment at their last
    evaluation) and only until k is certain (Eq. 12 is monotonic in d and S_max: a pair
    is skipped when its clearance, bounded below through spheres about the two axes, is
    above the closest found and its S, bounded above, cannot change k; see the comments
    there); a true operator's properties are skipped when a sphere about its reference
    point (out to its farthest body point) shows it can lower neither figure (nor come
    inside S_true), a segment's when a sphere about its axis' midpoint (out to its ends,
    plus its radius) shows the same against the sphere around the robot's capsules, and
    a pair's when it holds against a sphere around the capsule (its axis' midpoint out
    to its ends, plus its radius); S_true is bounded by the operator's speed in its mode
    and the capsule's fastest end, and for a pair that the sphere leaves by S_true alone,
    by the directed speeds' bounds in the cone between the axes (:func:`_speed_bounds`).
    Each true pair's, segment's and operator's clearance bound (exact where measured,
    through the spheres where skipped) is kept across ticks (``truth_memo`` = (pair
    bounds (B, K, segments, capsules), segment bounds (B, K, segments), operator bounds
    (B, K), each operator's point at its last look, that time and how far it has gone
    (B, K, 5), the robot's capsule ends at the last look (B, capsules, 2, 3) and how far
    they have gone (B,))): a clearance falls by at most how far its two sides moved, a
    rigid operator's points all move as its point does and a capsule axis' points at
    most as far as its farther end; so each side's travel is summed, step by step, from
    one look to the next (the operator's point's displacement; the farthest capsule
    end's), and a bound is kept plus both sums at its tick: less both sums now, it
    still bounds the clearance (by the triangle inequality a sum of steps is at least
    the displacement between any two of its ticks). An operator is first tried without
    its point: its path's peak speed (``reach``'s third, (B, K)) times the time since
    its last look bounds how far it went since. The monitor's relaxed sweep keeps each
    segment's least clearance bound to its capsules the same way (``monitor_memo`` =
    (bounds (B, M), how far each segment's envelope has gone, summed over the tracker
    updates by :func:`_segment_travel` (B, M), how far the monitor's capsule ends have
    gone, summed over the ticks (B,), and each pair's bound (B, M, capsules), exact where
    measured): where larger than the bounds through the spheres, a segment or a pair is
    skipped by it, and an operator's least segment bound is its clearance bound in the
    far test and the sweeps.
    """
    mode, t_sr, t_r, const, iso, iso_reduced, robot_speed = monitor
    # safety.stopping: by_speed: S at every speed level, and S_true's stop by the rate
    level_t_sr, level_const = levels
    by_speed = level_t_sr.size > 0
    truth_rt, truth_rb = truth_rates
    s_levels = np.empty((max(level_t_sr.size, 1), h_radius.shape[1]))
    z_d_base, z_d_sigmas = z_d_terms
    seg_a, seg_b, seg_r = truth_segments
    op_reach, seg_mid, op_speed = reach
    kept, seg_kept, op_kept, last_x, last_ends, travel = truth_memo
    m_seg_kept, seg_travel, m_travel, m_kept = monitor_memo
    fractions, deceleration, acceleration = brakes
    (pfl_limits, pfl_boxes, contact_dist, capped, compressions, detection_time, window,
     contact_links, monitor_links, base_caps, reach_caps, episodes, open_any,
     latched_any) = pfl_truth
    departures, ta, tc, vp, lengths, a_max, directions, waypoints = stack
    ma, mb, mt0, mt1, m_radius, m_tool = monitor_caps
    ca, cb, ct0, ct1, c_radius, c_tool = contact_caps
    N, K = h_radius.shape[1], enter.shape[1]
    per_operator = pfl_limits.size
    seg_in = np.zeros(N, dtype=np.bool_)  # this tick: each segment in contact,
    seg_v = np.empty(N)  # the robot's fastest speed towards it there,
    seg_clamp = np.zeros(N, dtype=np.bool_)  # and whether it is clampable
    op_first_segment = np.arange(K) * (N // K)  # each operator's first segment
    n_joints, n_points, tool0 = sizes
    poses, twists = work
    q, dq, ddq = np.empty(n_joints), np.empty(n_joints), np.empty(n_joints)
    v_joint = np.empty(n_joints)
    points, point_v = np.empty((n_points, 3)), np.empty((n_points, 3))
    m_ends, m_unused = np.empty((ma.size, 2, 3)), np.empty((ma.size, 2, 3))
    m_velocities = np.empty((ma.size, 2, 3))
    c_ends, c_velocities = np.empty((ca.size, 2, 3)), np.empty((ca.size, 2, 3))
    d, s_row, included = np.empty(N), np.empty(N), np.empty(N, dtype=np.bool_)
    c_fast, c_reach, c_mid = np.empty(ca.size), np.empty(ca.size), np.empty((ca.size, 3))
    c_half = np.empty(ca.size)
    pair_ub = np.empty(ca.size)
    m_fast, m_half, m_mid = np.empty(ma.size), np.empty(ma.size), np.empty((ma.size, 3))
    m_end_speed, c_end_speed = np.empty((ma.size, 2)), np.empty((ca.size, 2))
    op_lb, op_ub = np.empty(enter.shape[1]), np.empty(enter.shape[1])
    speed = 0.0
    m_sphere, c_sphere = (0.0, 0.0, 0.0, np.inf), (0.0, 0.0, 0.0, np.inf)
    memo[:, 1] = np.nan  # the tracker's outputs may have changed: no k to reuse
    # Both robots the tool point only: tool0 alone (bit for bit), not all the points.
    tool_only = True
    for j in range(ma.size):
        tool_only = tool_only and ma[j] == tool0 and mb[j] == tool0
    for j in range(ca.size):
        tool_only = tool_only and ca[j] == tool0 and cb[j] == tool0
    # The monitor's capsules on the real robot's axes (only the radii differ): their ends
    # are the same numbers, computed once.
    same_axes = ma.size == ca.size and m_tool == c_tool
    for j in range(ma.size if same_axes else 0):
        same_axes = same_axes and ma[j] == ca[j] and mb[j] == cb[j] and mt0[j] == ct0[j] \
            and mt1[j] == ct1[j]
    # A scenario frozen from a tick on: at rest, held at k = 0 by the same inputs and
    # fault to the interval's end: every later tick of the interval repeats it.
    frozen = np.zeros(s.size, dtype=np.bool_)
    t_end = (k1 - 1) * dt
    # The bounds cost about one pair each: worth it only against several capsules.
    bound_monitor, bound_contact = ma.size > 1, ca.size > 1
    # The same axes and the same largest radius: the same bounding sphere.
    same_sphere = same_axes and bound_contact and np.max(m_radius) == np.max(c_radius)
    # Scenarios whose robot has not been slowed yet share its state (s, sigma) bit for bit:
    # in order of s, each computes the robot only where it differs from the one before.
    order = np.argsort(s, kind="mergesort")
    for k in range(k0, k1):  # scenarios inside: independent work the CPU can overlap
        t = k * dt
        s_before, rate_before = np.nan, np.nan
        for b in order:
            if frozen[b]:
                continue
            if not (s[b] == s_before and rate[b] == rate_before):  # else the robot as before
                path_state_one(s[b], path, q, dq, ddq)
                for j in range(n_joints):
                    v_joint[j] = dq[j] * rate[b]
                if tool_only:
                    (points[tool0, 0], points[tool0, 1], points[tool0, 2], point_v[tool0, 0],
                     point_v[tool0, 1], point_v[tool0, 2]) = model_tool0_one(
                        robot, q, v_joint, trig[b], poses, twists)
                else:
                    model_points_one(robot, m_tool, q, v_joint, trig[b], poses, twists, points,
                                     point_v)
                if same_axes:
                    capsule_ends_one(points, point_v, ca, cb, ct0, ct1, c_ends, c_velocities)
                    for j in range(ma.size):
                        for e in range(2):
                            for i in range(3):
                                m_ends[j, e, i] = c_ends[j, e, i]
                else:
                    capsule_ends_one(points, point_v, ma, mb, mt0, mt1, m_ends, m_unused)
                    if c_tool != m_tool and not tool_only:
                        model_points_one(robot, c_tool, q, v_joint, trig[b], poses, twists,
                                         points, point_v)
                    capsule_ends_one(points, point_v, ca, cb, ct0, ct1, c_ends, c_velocities)
                speed = 0.0  # the robot's: its fastest capsule end
                for j in range(ca.size):
                    # capsule j's fastest end (every axis point is slower): the larger of
                    # the ends' speeds (the root is monotonic and correctly rounded: the
                    # same number as the root of the larger square)
                    for e in range(2):
                        w0, w1, w2 = c_velocities[j, e, 0], c_velocities[j, e, 1], \
                            c_velocities[j, e, 2]
                        c_end_speed[j, e] = np.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
                    c_fast[j] = max(c_end_speed[j, 0], c_end_speed[j, 1])
                    speed = max(speed, c_fast[j])
                    # A sphere around capsule j: its axis' midpoint, out to its ends.
                    for i in range(3):
                        c_mid[j, i] = 0.5 * (c_ends[j, 0, i] + c_ends[j, 1, i])
                    x0 = c_ends[j, 1, 0] - c_mid[j, 0]
                    x1 = c_ends[j, 1, 1] - c_mid[j, 1]
                    x2 = c_ends[j, 1, 2] - c_mid[j, 2]
                    c_half[j] = np.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
                    c_reach[j] = c_half[j] + c_radius[j]
                for j in range(ma.size):  # each monitor capsule's axis: midpoint, half
                    for i in range(3):
                        m_mid[j, i] = 0.5 * (m_ends[j, 0, i] + m_ends[j, 1, i])
                    x0 = m_ends[j, 1, 0] - m_mid[j, 0]
                    x1 = m_ends[j, 1, 1] - m_mid[j, 1]
                    x2 = m_ends[j, 1, 2] - m_mid[j, 2]
                    m_half[j] = np.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
                if bound_contact:
                    c_sphere = _bounding_sphere(c_ends, c_radius)
                if bound_monitor:
                    m_sphere = c_sphere if same_sphere else _bounding_sphere(m_ends, m_radius)
                s_before, rate_before = s[b], rate[b]
            # SeparationMonitor and SpeedOverride on the tracker's estimates.
            fault = tracker_fault(frames[b, _F_FAULT], t, frames[b, _F_GOOD], timeout)
            resting = s[b] == s_last[b]  # the ends as at the last tick: Eq. 5 gives 0
            if resting and memo[b, 1] == s[b] and memo[b, 2] == fault:
                k_override = memo[b, 0]  # the same inputs as when it was computed
                # Held at rest to the interval's end (the fault cannot change: stale for
                # good, or fresh to the end): later ticks repeat this one.
                frozen[b] = (k_override == 0.0 and rate[b] == 0.0 and speed == 0.0
                             and not (capped and open_any[b])
                             and (fault != 0.0 or t_end - frames[b, _F_GOOD] <= timeout))
            else:
                if capped:  # the caps in force: the envelopes against surfaces and links
                    clamp_caps(h_ends[b], h_radius[b], base_caps, pfl_boxes, reach_caps, m_ends,
                               m_ends, m_radius, monitor_links, caps_now[b])
                # RobotCapsules' Eq. 5: its fastest end first, through the ends' largest
                # displacement (the bounds below need no more; its rounding differs from
                # the ends' speeds' by ulps, far below the bounds' _MARGIN), each end's
                # velocity only where the pairs are needed (below). NaN where an end is.
                top_sq = 0.0
                for j in range(ma.size):
                    for e in range(2):
                        x0 = m_ends[j, e, 0] - ends_prev[b, j, e, 0]
                        x1 = m_ends[j, e, 1] - ends_prev[b, j, e, 1]
                        x2 = m_ends[j, e, 2] - ends_prev[b, j, e, 2]
                        sq = x0 * x0 + x1 * x1 + x2 * x2
                        top_sq = sq if not sq <= top_sq else top_sq  # (max would drop a NaN)
                step = np.sqrt(top_sq)
                v_end = step / dt
                if not math.isnan(ends_prev[b, 0, 0, 0]):  # (the first tick: none yet)
                    m_travel[b] += step  # how far the monitor's capsule ends have gone
                # Each operator through its sphere (its segments share its status): its
                # clearance bounded below, its S above (the fastest end for v_R).
                for o in range(K if not by_speed else 0):  # (by_speed: not read)
                    c0, c1, c2, c_r, fastest, top_std = op_spheres[b, o]
                    op_ub[o] = _s_bound(fastest, v_end, z_d_base + z_d_sigmas * top_std, mode,
                                        t_sr, t_r, const, iso, iso_reduced)
                    g0, g1, g2 = c0 - m_sphere[0], c1 - m_sphere[1], c2 - m_sphere[2]
                    op_lb[o] = np.sqrt(g0 * g0 + g1 * g1 + g2 * g2) - c_r - m_sphere[3] \
                        - _MARGIN
                    # or its segments' least kept bound, where larger (a NaN sphere: not)
                    least = np.inf
                    for i in range(o * (N // K), (o + 1) * (N // K)):
                        lb = m_seg_kept[b, i] - (seg_travel[b, i] + m_travel[b])
                        if least == least and not lb >= least:
                            least = lb  # (a NaN, once met, is kept)
                    if least > op_lb[o]:
                        op_lb[o] = least
                # k = 1? Only where the tracker does not hold the robot (tracks.tracker_stop)
                far = bound_monitor and not by_speed and not math.isnan(v_end) \
                    and tracker_stop(h_status[b], fault) == stops.STOP_NONE
                if far:
                    closest_lb, s_ub = np.inf, -np.inf
                    for o in range(K):
                        if usable(h_status[b, op_first_segment[o]]):
                            lb, ub = op_lb[o], op_ub[o]
                            closest_lb, s_ub = min(closest_lb, lb), max(s_ub, ub)
                            far = far and not (math.isnan(lb) or math.isnan(ub))
                    far = far and closest_lb >= d_min + _MARGIN and (
                        closest_lb - s_ub >= max((delta_s - 1.0) * s_ub, 1e-12) + _MARGIN)
                if far:
                    k_override = 1.0  # Eq. 12's ramp is above 1 for every pair
                else:
                    for j in range(ma.size):  # Eq. 5 per end, and each capsule's faster
                        for e in range(2):
                            for i in range(3):
                                m_velocities[j, e, i] = (m_ends[j, e, i]
                                                         - ends_prev[b, j, e, i]) / dt
                            w0, w1, w2 = m_velocities[j, e, 0], m_velocities[j, e, 1], \
                                m_velocities[j, e, 2]
                            m_end_speed[j, e] = np.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
                        m_fast[j] = max(m_end_speed[j, 0], m_end_speed[j, 1])
                        if math.isnan(m_end_speed[j, 0]) or math.isnan(m_end_speed[j, 1]):
                            m_fast[j] = np.nan  # (max would drop it; a NaN bound skips nothing)
                    near = False
                    if fault == 0.0 and not (by_speed or capped):
                        # Eq. 12 reads only the closest clearance and the largest S over
                        # the pairs, and is monotonic in both (``speed_scale_eq12``): once
                        # the pairs seen give k = 0, more can only keep it there. First each
                        # operator's nearest pair at its last evaluation (``hint``); then
                        # the rest in up to two sweeps. The first skips every operator,
                        # segment or pair whose clearance, bounded below through spheres
                        # about the axes, is above the closest found, where its S (bounded
                        # above by the faster ends' speeds, or the ISO speed, or else by
                        # :func:`_speed_bounds`) would not change k, and keeps the largest
                        # of those bounds, U. If Eq. 12 then gives the same k with S_max = U
                        # as with the S found, k is exact (the true S_max lies between);
                        # else a second sweep skips only what can lower neither figure.
                        # Segments never evaluated take the figures found (the minimum and
                        # maximum hold). A NaN bound skips nothing; a NaN figure stops.
                        closest, top, faulty, near, bound = np.inf, -np.inf, False, False, -np.inf
                        for i in range(N):
                            d[i], s_row[i] = np.inf, -np.inf
                        for o in range(K):
                            if faulty or not usable(h_status[b, op_first_segment[o]]):
                                continue
                            i = hint[b, N + o]
                            c_j, s_j, _, _ = monitor_pair(
                                segment_of(h_ends[b], h_velocities[b], i), h_radius[b, i],
                                z_d_base + z_d_sigmas * h_std[b, i], m_ends, m_velocities,
                                m_radius, hint[b, i], monitor)
                            faulty = math.isnan(c_j) or math.isnan(s_j)
                            d[i], s_row[i] = c_j, s_j
                            closest, top = min(closest, c_j), max(top, s_j)
                        near = not faulty and closest < np.inf and speed_scale_eq12(
                            closest, top, delta_s, d_min) == 0.0
                        for sweep in range(2):
                            relaxed = sweep == 0
                            k_top = speed_scale_eq12(closest, top, delta_s, d_min)
                            if near or faulty or not (relaxed or (bound > top and speed_scale_eq12(
                                    closest, bound, delta_s, d_min) != k_top)):
                                break  # k is exact
                            for o in range(K):
                                if near or faulty or not usable(h_status[b, op_first_segment[o]]):
                                    continue
                                lb, ub = op_lb[o], op_ub[o]
                                if lb > closest and (ub <= top or (relaxed and speed_scale_eq12(
                                        closest, ub, delta_s, d_min) == k_top)):
                                    bound = max(bound, ub)
                                    continue  # none of its pairs can lower d or change k
                                for i in range(o * (N // K), (o + 1) * (N // K)):
                                    if near or faulty or not usable(h_status[b, i]):
                                        continue
                                    r_H = h_radius[b, i]
                                    z = z_d_base + z_d_sigmas * h_std[b, i]
                                    y0, y1, y2, half, sP, sQ = (
                                        h_axes[b, i, 0], h_axes[b, i, 1], h_axes[b, i, 2],
                                        h_axes[b, i, 3], h_axes[b, i, 4], h_axes[b, i, 5])
                                    # how far the segment and the robot have gone: its
                                    # clearance bound kept less this bounds it now
                                    shift = seg_travel[b, i] + m_travel[b]
                                    if relaxed:  # the segment against the whole robot
                                        ub = _s_bound(max(sP, sQ), v_end, z, mode, t_sr, t_r,
                                                      const, iso, iso_reduced)
                                        g0, g1, g2 = (m_sphere[0] - y0, m_sphere[1] - y1,
                                                      m_sphere[2] - y2)
                                        fresh = (np.sqrt(g0 * g0 + g1 * g1 + g2 * g2) - half
                                                 - r_H - m_sphere[3] - _MARGIN)
                                        lb = fresh  # (or the kept bound, where larger)
                                        if m_seg_kept[b, i] - shift > fresh:  # (NaN: not)
                                            lb = m_seg_kept[b, i] - shift
                                        if lb > closest and (ub <= top or speed_scale_eq12(
                                                closest, ub, delta_s, d_min) == k_top):
                                            bound = max(bound, ub)
                                            if fresh + shift > m_seg_kept[b, i]:
                                                m_seg_kept[b, i] = fresh + shift
                                            continue
                                    # the least clearance bound over its capsules, kept
                                    # where every pair is seen (NaN: none kept)
                                    least = d[i] - _MARGIN
                                    segment = segment_of(h_ends[b], h_velocities[b], i)
                                    P, Q, vP, vQ = segment
                                    for j in range(ma.size):
                                        if relaxed and i == hint[b, N + o] and j == hint[b, i]:
                                            continue  # (seen first)
                                        g0 = m_mid[j, 0] - y0  # segment -> capsule
                                        g1 = m_mid[j, 1] - y1
                                        g2 = m_mid[j, 2] - y2
                                        apart = np.sqrt(g0 * g0 + g1 * g1 + g2 * g2)
                                        fresh = apart - half - r_H - m_half[j] - m_radius[j] \
                                            - _MARGIN
                                        lb = fresh  # (or the pair's kept bound, if larger)
                                        if m_kept[b, i, j] - shift > fresh:  # (NaN: not)
                                            lb = m_kept[b, i, j] - shift
                                        if lb > closest:
                                            ub = _s_bound(max(sP, sQ), m_fast[j], z, mode,
                                                          t_sr, t_r, const, iso, iso_reduced)
                                            if not (ub <= top or (relaxed and speed_scale_eq12(
                                                    closest, ub, delta_s, d_min) == k_top)) \
                                                    and (mode != 1 or robot_speed == 0):
                                                h_ub, r_ub = _speed_bounds(
                                                    g0, g1, g2, apart, half + m_half[j], vP,
                                                    sP, vQ, sQ, m_velocities[j, 0],
                                                    m_end_speed[j, 0], m_velocities[j, 1],
                                                    m_end_speed[j, 1], robot_speed)
                                                ub = min(ub, _s_bound(
                                                    h_ub, r_ub, z, mode, t_sr, t_r, const, iso,
                                                    iso_reduced))
                                            if ub <= top or (relaxed and speed_scale_eq12(
                                                    closest, ub, delta_s, d_min) == k_top):
                                                bound = max(bound, ub)
                                                if least == least and not lb >= least:
                                                    least = lb  # (a NaN, once met, is kept)
                                                if fresh + shift > m_kept[b, i, j]:
                                                    m_kept[b, i, j] = fresh + shift
                                                continue  # can lower neither figure
                                        c_j, s_j, _, _ = monitor_pair(
                                            segment, r_H, z, m_ends, m_velocities, m_radius, j,
                                            monitor)
                                        if math.isnan(c_j) or math.isnan(s_j):
                                            faulty = True  # (the override stops)
                                            d[i], s_row[i] = np.nan, np.nan
                                            break
                                        m_kept[b, i, j] = (c_j - _MARGIN) + shift
                                        if least == least and not c_j - _MARGIN >= least:
                                            least = c_j - _MARGIN
                                        if c_j < d[i]:
                                            d[i], hint[b, i] = c_j, j
                                        s_row[i] = max(s_row[i], s_j)
                                        closest, top = min(closest, c_j), max(top, s_j)
                                        k_top = speed_scale_eq12(closest, top, delta_s, d_min)
                                        near = k_top == 0.0
                                        if near:
                                            break  # k = 0 for good
                                    if relaxed and not (near or faulty) and least < np.inf \
                                            and least + shift > m_seg_kept[b, i]:
                                        m_seg_kept[b, i] = least + shift
                        for o in range(K):  # each operator's nearest segment, for next time
                            best = np.inf
                            for i in range(o * (N // K), (o + 1) * (N // K)):
                                if usable(h_status[b, i]) and d[i] < best:
                                    best, hint[b, N + o] = d[i], i
                        for i in range(N):  # never evaluated: the figures found
                            if d[i] == np.inf:
                                d[i], s_row[i] = closest, top
                    if near:
                        k_override = 0.0  # a clearance below d_min, or below S_max
                    else:
                        if fault == 0.0 and (by_speed or capped):  # else the robot stops
                            for i in range(N):
                                if usable(h_status[b, i]):  # (the override reads only these)
                                    segment = segment_of(h_ends[b], h_velocities[b], i)
                                    z = z_d_base + z_d_sigmas * h_std[b, i]
                                    d[i], s_row[i], _, _, nearest = monitor_segment(
                                        segment, h_radius[b, i], z, m_ends, m_velocities,
                                        m_radius, monitor)
                                    if nearest >= 0:
                                        hint[b, i] = nearest
                                    if by_speed:
                                        segment_levels(segment, h_radius[b, i], z, m_ends,
                                                       m_velocities, m_radius, monitor,
                                                       level_t_sr, level_const, s_levels, i)
                        if by_speed and capped:
                            k_override = by_speed_command_caps(
                                d, s_levels, h_status[b], fault, rate[b], delta_s, d_min,
                                caps_now[b], included)[0]
                        elif by_speed:
                            k_override = by_speed_command(d, s_levels, h_status[b], fault,
                                                          rate[b], delta_s, d_min, included)[0]
                        elif capped:
                            k_override = override_command_caps(d, s_row, h_status[b], fault,
                                                               delta_s, d_min, caps_now[b],
                                                               included)[0]
                        else:
                            k_override = override_command(d, s_row, h_status[b], fault,
                                                          delta_s, d_min, included)[0]
                memo[b, 0], memo[b, 1], memo[b, 2] = k_override, s[b] if resting else np.nan, fault
            # The properties, on the true state at this tick.
            # The robot's own contact stop (ssm_pfl: pfl.contact_limits), set by a tick
            # before this one
            k_cmd = 0.0 if capped and latched_any[b] else k_override
            moving = is_moving(speed) and k <= last[b]
            allowed = is_permitted(k_cmd) and k <= last[b]
            # a contact under way is followed at rest too, to see it end, and one the
            # robot creeps into below MOVING_SPEED is one (pfl.contact_limits)
            open_floor = contact_dist[b] if capped and (open_any[b] or speed > 0.0) \
                and k <= last[b] else -np.inf
            if moving or allowed or open_floor > -np.inf:  # (they count only then)
                if capped:
                    for m in range(N):
                        seg_in[m], seg_v[m], seg_clamp[m] = False, -np.inf, False
                closest, margin = np.inf, np.inf
                # How far the robot's capsule axes have gone: each look adds the
                # farthest capsule end's displacement since the last (it bounds every
                # axis point's). A NaN sum skips nothing from then on.
                top_sq = np.inf  # (the first look: the ends kept, nothing gone yet)
                if not math.isnan(last_ends[b, 0, 0, 0]):
                    top_sq = 0.0
                    for j in range(ca.size):
                        for e in range(2):
                            g0 = c_ends[j, e, 0] - last_ends[b, j, e, 0]
                            g1 = c_ends[j, e, 1] - last_ends[b, j, e, 1]
                            g2 = c_ends[j, e, 2] - last_ends[b, j, e, 2]
                            sq = g0 * g0 + g1 * g1 + g2 * g2
                            top_sq = sq if not sq <= top_sq else top_sq  # (keeps a NaN)
                    travel[b] += np.sqrt(top_sq)
                if top_sq != 0.0:  # (where they moved: a robot at rest keeps them)
                    for j in range(ca.size):
                        for e in range(2):
                            for i in range(3):
                                last_ends[b, j, e, i] = c_ends[j, e, i]
                robot_travel = travel[b]
                stop_t, stop_b = truth_t[b], truth_b[b]  # (full speed: the upper bounds')
                if by_speed:  # the stop from the rate now (metrics.true_protective_distances)
                    g = level_at_or_above(rate[b], truth_rt.shape[1] - 1)
                    stop_t, stop_b = truth_rt[b, g], truth_rb[b, g]
                for o in range(K):  # each operator's point once, then its segments
                    if not (t >= enter[b, o] and t < leave[b, o]):
                        continue
                    # Below these a pair could lower a figure (or come inside S_true).
                    contact_floor = max(min(min_sep[b], closest), contact_dist[b]) \
                        if moving else open_floor
                    separation_floor = _separation_floor(sep_min[b], margin) if allowed \
                        else -np.inf
                    # Before its point: the operator's least kept bound less how far it can
                    # have gone by now, at its fastest (``op_speed``: its path's peak speed)
                    # since its last look (NaN before the first: no skip)
                    lb = op_kept[b, o] - ((last_x[b, o, 4] + op_speed[b, o] * (
                        t - last_x[b, o, 3])) + robot_travel)
                    if lb > contact_floor and lb - _s_bound(
                            op_speed[b, o], speed, 0.0, mode, truth_t[b], t_r, truth_b[b], iso,
                            iso_reduced) > separation_floor:
                        continue  # no segment of it can lower either figure
                    x0, x1, x2, w0, w1, w2 = path_point_one(
                        departures, ta, tc, vp, lengths, a_max, directions, waypoints,
                        b * K + o, t)
                    v_H = (w0, w1, w2)
                    h = np.sqrt(w0 * w0 + w1 * w1 + w2 * w2)  # S_true's upper bounds
                    # how far it has gone: its point's displacement since its last look
                    # added (the body is rigid)
                    if not math.isnan(last_x[b, o, 3]):
                        g0, g1, g2 = x0 - last_x[b, o, 0], x1 - last_x[b, o, 1], \
                            x2 - last_x[b, o, 2]
                        last_x[b, o, 4] += np.sqrt(g0 * g0 + g1 * g1 + g2 * g2)
                    last_x[b, o, 0], last_x[b, o, 1], last_x[b, o, 2] = x0, x1, x2
                    last_x[b, o, 3] = t
                    # a bound kept less this (how far both sides have gone) bounds now
                    shift = last_x[b, o, 4] + robot_travel
                    s_true_ub = _s_bound(h, speed, 0.0, mode, truth_t[b], t_r, truth_b[b], iso,
                                         iso_reduced)
                    # the operator's least kept bound (its segments'), less how far both
                    # have moved
                    lb = op_kept[b, o] - shift
                    if lb > contact_floor and lb - s_true_ub > separation_floor:
                        continue  # no segment of it can lower either figure
                    if bound_contact:  # the whole operator, through its reach about x
                        g0, g1, g2 = x0 - c_sphere[0], x1 - c_sphere[1], x2 - c_sphere[2]
                        lb = (np.sqrt(g0 * g0 + g1 * g1 + g2 * g2) - op_reach[b, o]
                              - c_sphere[3] - _MARGIN)
                        if lb > contact_floor and lb - s_true_ub > separation_floor:
                            lb += shift  # (kept for later ticks)
                            if lb > op_kept[b, o]:
                                op_kept[b, o] = lb
                            continue  # no segment of it can lower either figure
                    op_least = np.inf  # (its segments' least kept bound, below)
                    for j in range(ca.size):  # S_true's upper bound, per capsule
                        pair_ub[j] = _s_bound(h, c_fast[j], 0.0, mode, truth_t[b], t_r,
                                              truth_b[b], iso, iso_reduced)
                    for i in range(seg_r.size):
                        r_H = seg_r[i]
                        # the separation invariant's part: SSM's (above the cap in force)
                        seg_allowed = allowed and not (
                            capped and not k_cmd > caps_now[b, op_first_segment[o] + i])
                        seg_floor = separation_floor if seg_allowed else -np.inf
                        # the segment's least kept bound, less how far both have moved
                        lb = seg_kept[b, o, i] - shift
                        if lb > contact_floor and lb - s_true_ub > seg_floor:
                            op_least = min(op_least, seg_kept[b, o, i])
                            continue  # can lower neither figure
                        # (the segment's midpoint and half length, for the spheres below)
                        y0, y1, y2 = (x0 + seg_mid[b, o, i, 0], x1 + seg_mid[b, o, i, 1],
                                      x2 + seg_mid[b, o, i, 2])
                        out = seg_mid[b, o, i, 3] + r_H + _MARGIN
                        if bound_contact:
                            g0, g1, g2 = c_sphere[0] - y0, c_sphere[1] - y1, c_sphere[2] - y2
                            lb = np.sqrt(g0 * g0 + g1 * g1 + g2 * g2) - c_sphere[3] - out
                            if lb > contact_floor and lb - s_true_ub > seg_floor:
                                lb += shift  # (kept for later ticks)
                                if lb > seg_kept[b, o, i]:
                                    seg_kept[b, o, i] = lb
                                op_least = min(op_least, seg_kept[b, o, i])
                                continue  # can lower neither figure
                        pa, pb = seg_a[i], seg_b[i]
                        P = (x0 + postures[b, o, pa, 0], x1 + postures[b, o, pa, 1],
                             x2 + postures[b, o, pa, 2])
                        Q = (x0 + postures[b, o, pb, 0], x1 + postures[b, o, pb, 1],
                             x2 + postures[b, o, pb, 2])
                        least = np.inf
                        for j in range(ca.size):
                            # the pair's clearance when last bounded, less how far both
                            # have moved since
                            lb = kept[b, o, i, j] - shift
                            if lb > contact_floor and lb - pair_ub[j] > seg_floor:
                                least = min(least, kept[b, o, i, j])
                                continue  # this pair can lower neither figure
                            if bound_contact:  # the pair, through spheres around both
                                g0, g1, g2 = c_mid[j, 0] - y0, c_mid[j, 1] - y1, c_mid[j, 2] - y2
                                apart = np.sqrt(g0 * g0 + g1 * g1 + g2 * g2)
                                lb = apart - c_reach[j] - out
                                skip = lb > contact_floor and lb - pair_ub[j] > seg_floor
                                if lb > contact_floor and not skip:
                                    # S_true by the directed speeds' bounds in the cone of
                                    # directions between the axes (:func:`_speed_bounds`;
                                    # the truth's robot speed is always the directed one)
                                    h_ub, r_ub = _speed_bounds(
                                        g0, g1, g2, apart, seg_mid[b, o, i, 3] + c_half[j], v_H,
                                        h, v_H, h, c_velocities[j, 0], c_end_speed[j, 0],
                                        c_velocities[j, 1], c_end_speed[j, 1], 0)
                                    skip = lb - _s_bound(h_ub, r_ub, 0.0, mode, truth_t[b], t_r,
                                                         truth_b[b], iso, iso_reduced) \
                                        > seg_floor
                                if skip:
                                    lb += shift  # (kept for later ticks)
                                    if lb > kept[b, o, i, j]:
                                        kept[b, o, i, j] = lb
                                    least = min(least, kept[b, o, i, j])
                                    continue  # this pair can lower neither figure
                            end_a, end_b, vel_a, vel_b = capsule_axis(c_ends, c_velocities, j)
                            axis, vh_true, vr_true = segments_pair(P, Q, v_H, v_H, end_a, end_b,
                                                                   vel_a, vel_b)
                            sep = axis - c_radius[j] - r_H
                            kept[b, o, i, j] = (sep - _MARGIN) + shift
                            least = min(least, kept[b, o, i, j])
                            closest = min(closest, sep)
                            contact_floor = max(min(contact_floor, closest),
                                                contact_dist[b]) if moving else open_floor
                            if capped and sep < contact_dist[b]:  # a contact (its course below)
                                m = op_first_segment[o] + i
                                if not seg_in[m]:
                                    seg_clamp[m] = (pfl_boxes.shape[0] > 0 and clampable(
                                        P, Q, r_H, pfl_boxes, CLAMP_GAP)) or between_links(
                                        P, Q, r_H, c_ends, c_velocities, c_radius,
                                        contact_links, CLAMP_GAP)
                                seg_in[m] = True
                                seg_v[m] = vr_true if not vr_true <= seg_v[m] else seg_v[m]
                            elif moving and sep < contact_dist[b]:  # permitted contact
                                pc[b] = min(pc[b], contact_robustness(
                                    pfl_limits[i], vr_true, pfl_boxes.shape[0] > 0 and clampable(
                                        P, Q, r_H, pfl_boxes, CLAMP_GAP)))
                            if seg_allowed:
                                margin = min(margin, true_margin(
                                    sep, vh_true, vr_true, mode, stop_t, t_r, stop_b, iso,
                                    iso_reduced))
                            # Below this a later pair could still lower a figure.
                            separation_floor = _separation_floor(sep_min[b], margin) \
                                if allowed else -np.inf
                            seg_floor = separation_floor if seg_allowed else -np.inf
                        seg_kept[b, o, i] = least if not math.isnan(least) else -np.inf
                        op_least = min(op_least, seg_kept[b, o, i])
                    op_kept[b, o] = op_least
                if capped:  # each segment's contact, its course (pfl.contact_limits)
                    opened, held = False, False
                    for m in range(N):
                        i = m % per_operator
                        pc[b] = min(pc[b], contact_step(
                            episodes[b, m], seg_in[m], moving, seg_v[m], seg_clamp[m], t, dt,
                            pfl_limits[i], compressions[i, 0], compressions[i, 1],
                            compressions[i, 2], detection_time, window))
                        opened = opened or not math.isnan(episodes[b, m, E_START])
                        held = held or episodes[b, m, E_LATCHED] > 0.5
                    open_any[b], latched_any[b] = opened, held
                if moving:
                    min_sep[b] = min(min_sep[b], closest)
                if allowed:
                    sep_min[b] = min(sep_min[b], margin)
                    if margin < 0.0:
                        sep_time[b] += dt
            # Updates at this tick: the follower (PathFollower._step), Eq. 5's memory.
            if not resting:  # (at rest the ends are the ones kept)
                for j in range(ma.size):
                    for e in range(2):
                        for i in range(3):
                            ends_prev[b, j, e, i] = m_ends[j, e, i]
            s_last[b] = s[b]
            s[b], rate[b] = path_follower_step(s[b], rate[b], k_cmd, end[b], brake_scale[b],
                                               dt, fractions, deceleration, acceleration, 1.0)


def evaluate_batch(scenarios: list[Scenario], cell: ResolvedCell | None = None
                   ) -> BatchResult:
    """Closed-loop figures of every scenario (kinematic robot only: the dynamic mode's
    plant and its tracking error are not modelled here), under their configuration's
    resolved ``cell`` (None: resolved here, ``resolved_cell.resolve_scenario`` of the
    first; given, it must be of their configuration and robot, ``ResolvedCell.check_scenario``)."""
    if any(s.controller.type != "ssm_override" for s in scenarios):
        raise ValueError("evaluate_batch models the ssm_override controller only; "
                         "use evaluate_many")
    if any(s.robot.mode != "kinematic" for s in scenarios):
        raise ValueError("evaluate_batch models the kinematic robot only; use evaluate_many "
                         "(it runs dynamic-mode scenarios in the Drake diagram)")
    if any(is_recorded(s) for s in scenarios):
        raise ValueError("evaluate_batch models scripted operators only; use evaluate_many "
                         "(it runs recorded operators in the Drake diagram)")
    cell = scenario_cell(scenarios[0], cell, "evaluate_batch")
    c = _Cells(scenarios, cell)
    B, N, dt = c.B, c.N, c.dt
    cfg = c.config
    f, tr = cfg.safety, cfg.tracker
    model = c.model
    monitor = cell.monitor_terms
    timeout = cell.frame_timeout
    update_period, update_offset = 1.0 / cfg.sensor.rate_hz, cfg.sensor.latency + tr.processing_time
    truth_t, truth_b = true_stopping_terms(scenarios, cell)
    by_speed = f.stopping == "by_speed"
    levels = cell.level_terms if by_speed else (np.empty(0), np.empty(0))
    truth_rates = true_stopping_by_rate(scenarios, cell) if by_speed else (np.empty((B, 1)),
                                                                          np.empty((B, 1)))
    brakes = (c.table.speed_fraction, c.table.deceleration, c.accel)
    path = path_arrays(c.path)
    z_d_terms = cell.z_d_terms
    rules, regions = cell.tracker_rules, cell.tracker_regions

    caps = cell.capsules
    contact = _common(scenarios, lambda s: (s.contact_geometry, s.robot.payload_radius,
                                            s.robot.tool_length), "contact geometry")
    truth_caps = contact_capsules(scenarios[0].robot, contact[0])
    monitor_caps = (caps.a, caps.b, caps.t0, caps.t1, caps.radius, caps.tool_length)
    contact_caps = (truth_caps.a, truth_caps.b, truth_caps.t0, truth_caps.t1, truth_caps.radius,
                    truth_caps.tool_length)
    # The monitor's envelopes (one recipe: the scenarios share their operators' tracked
    # points, batch_key) and the true segments (a scripted operator's: each the capsule
    # between two of its true points).
    _common(scenarios, lambda s: [operator_points(o) for o in s.operators], "tracked points")
    recipe = cell.scenario_recipe(scenarios[0])
    truth_segments = _truth_segments(scenarios)
    postures = np.array([operator_postures(sc) for sc in scenarios], dtype=float).reshape(
        B, c.K, NUM_POINTS, 3)
    M = recipe.radius.size
    s = np.zeros(B)
    rate = np.zeros(B)
    ends_prev = np.full((B, caps.radius.size, 2, 3), np.nan)
    s_last, memo = np.full(B, np.nan), np.full((B, 3), np.nan)
    # each segment's capsule nearest at its last look, then each operator's nearest segment
    hint = np.zeros((B, M + c.K), dtype=np.int64)
    hint[:, M:] = np.arange(c.K) * (M // c.K)
    trig = np.full((B, 15), np.nan)  # a UR's trigonometry, kept per scenario
    robot_arrays = model_arrays(model)
    work = model_work(model)[1:]  # (poses, twists): a chain's
    sizes = (model.n, model.num_points, model.tool0)
    tracks = np.zeros((B * N, TRACK_SLOT))
    frames = np.zeros((B, 7))  # _F_*: no frame yet, none good
    frames[:, _F_NUMBER], frames[:, _F_GOOD] = -1.0, -np.inf
    est_p = np.full((B, N, 3), np.nan)
    est_v = np.full((B, N, 3), np.nan)
    status = np.zeros((B, N))
    std = np.zeros((B, N))
    unseen = np.zeros((B, N))
    h_ends, h_velocities = np.full((B, M, 2, 3), np.nan), np.full((B, M, 2, 3), np.nan)
    h_radius, h_std = np.full((B, M), np.nan), np.full((B, M), np.nan)
    h_status = np.zeros((B, M))  # no track yet: every segment none, as the tracker's
    op_spheres = np.full((B, c.K, 6), np.nan)
    h_axes = np.full((B, M, 6), np.nan)
    # each operator's reach: its farthest true point from its reference, plus a radius
    op_reach = (np.linalg.norm(postures, axis=-1).max(axis=-1)
                + float(truth_segments[2].max(initial=0.0)))
    # each true segment's midpoint from its operator's reference, and its half length
    ends_a, ends_b = postures[:, :, truth_segments[0]], postures[:, :, truth_segments[1]]
    seg_mid = np.concatenate([0.5 * (ends_a + ends_b), 0.5 * np.linalg.norm(
        ends_b - ends_a, axis=-1)[..., None]], axis=-1)  # (B, K, segments, 4)
    # each operator's fastest: its path's peak speed (no point of a rigid operator is faster)
    op_speed = c.stack_arrays[3].max(axis=1, initial=0.0).reshape(B, c.K)
    reach = (op_reach, np.ascontiguousarray(seg_mid), op_speed)
    # each true pair's clearance bound when last measured, plus how far both sides had
    # gone by then (each operator's point, the robot's capsule ends: summed from look to
    # look, kept with their last positions): less how far they have gone now, a bound now
    last_x = np.full((B, c.K, 5), np.nan)  # the point at the last look, its time, gone
    last_x[:, :, 4] = 0.0
    truth_memo = (np.full((B, c.K, truth_segments[2].size, truth_caps.radius.size), -np.inf),
                  np.full((B, c.K, truth_segments[2].size), -np.inf),
                  np.full((B, c.K), -np.inf), last_x,
                  np.full((B, truth_caps.radius.size, 2, 3), np.nan), np.zeros(B))
    # each segment's least clearance bound to the monitor's capsules when last bounded,
    # plus how far the segment (its envelope, summed over the tracker updates) and the
    # capsule ends (over the ticks) had gone by then: less how far they have gone now,
    # a bound now (:func:`_segment_travel`)
    monitor_memo = (np.full((B, M), -np.inf), np.zeros((B, M)), np.zeros(B),
                    np.full((B, M, caps.radius.size), -np.inf))
    prev_ends, prev_radius = np.full((B, M, 2, 3), np.nan), np.full((B, M), np.nan)
    allowance, occlusion_speed = float(cfg.body.tracking_allowance), float(f.occlusion_speed)
    min_sep = np.full(B, np.inf)
    sep_min = np.full(B, np.inf)
    sep_time = np.zeros(B)
    # Power and force limiting (safety.mode: ssm_pfl): each monitor segment's cap, in
    # force by the envelopes at the last update (none yet: 0, as a NaN envelope gives);
    # the permitted contact property's terms (computed under either mode).
    pfl = cell.pfl
    segments_per_operator = truth_segments[2].size
    if M != c.K * segments_per_operator or pfl.limits.size != segments_per_operator:
        raise ValueError("evaluate_batch: the monitor's segments are not the true ones")
    capped = cfg.safety.mode == "ssm_pfl"
    segment_caps = np.tile(pfl.caps, c.K)
    caps_now = np.zeros((B, M))
    pfl_truth = (np.ascontiguousarray(pfl.limits), np.ascontiguousarray(pfl.boxes),
                 np.array([sc.contact_distance for sc in scenarios], dtype=float), capped,
                 np.ascontiguousarray(pfl.compressions), float(pfl.detection_time),
                 float(pfl.window), capsule_links(truth_caps), np.ascontiguousarray(
                     pfl.monitor_links), np.ascontiguousarray(segment_caps), float(pfl.reach),
                 _no_episodes(B, M), np.zeros(B, dtype=np.bool_), np.zeros(B, dtype=np.bool_))
    pc = np.full(B, np.inf)
    last = int(c.ticks.max())
    k, j = 0, 0
    while k <= last:
        # The ticks before tracker update j: those not later than it (within the tolerance).
        u = update_offset + j * update_period
        stop = k
        while stop <= last and not u < stop * dt - _EVENT_TOL:
            stop += 1
        _advance(k, stop, dt, c.ticks, path, c.stack_arrays, postures, c.enter, c.leave,
                 h_ends, h_velocities, h_radius, h_status, h_std, op_spheres, h_axes, frames,
                 timeout,
                 monitor, z_d_terms, f.delta_s, f.d_min, truth_t, truth_b, levels, truth_rates,
                 monitor_caps, contact_caps, truth_segments, reach, truth_memo, monitor_memo,
                 c.end,
                 c.brake_scale,
                 brakes, s, rate, ends_prev, s_last, memo, hint, trig, min_sep, sep_min,
                 sep_time, robot_arrays, work, sizes, caps_now, pfl_truth, pc)
        k = stop
        if k > last:
            break
        c.update(u, frames, tracks, rules, regions, est_p, est_v, status, std, unseen)
        envelope_batch(recipe.regions, recipe.candidates, recipe.radius, recipe.operator,
                        recipe.slots, est_p, est_v, status, std, unseen, allowance,
                        occlusion_speed, h_ends, h_velocities, h_radius, h_status, h_std)
        _segment_axes(h_ends, h_velocities, h_axes)
        _segment_travel(h_ends, h_radius, prev_ends, prev_radius, monitor_memo[1],
                        monitor_memo[0], monitor_memo[3])
        _operator_spheres(h_ends, h_axes, h_radius, h_std, recipe.operator, op_spheres)
        j += 1
    robustness = min_sep - pfl_truth[2]
    return BatchResult(robustness, min_sep, sep_min, sep_time,
                       np.where(pc < np.inf, pc, robustness))


def _no_episodes(B: int, M: int) -> np.ndarray:
    """(B, M, ``contact_limits.EPISODE_COLUMNS``): no contact under way anywhere."""
    out = np.zeros((B, M, EPISODE_COLUMNS))
    out[:, :, E_START] = np.nan
    out[:, :, E_OVER] = np.nan  # (not over the detection force)
    return out


def batch_key(s: Scenario, memo: dict | None = None) -> tuple:
    """Scenarios with equal keys can share one batch: the same controller configuration,
    robot (but its cycles and braking time scale), contact geometry, sensor rate and
    seed, and operator shapes (the body points their tracked bodies mark, in order, and
    the number of waypoints). ``memo`` keeps the configurations' texts by object across calls (the
    scenarios of one space share them; writing them out is most of the cost)."""
    memo = {} if memo is None else memo

    def text(obj) -> str:
        seen = memo.get(id(obj))
        if seen is None or seen[0] is not obj:
            seen = memo[id(obj)] = (obj, repr(obj))
        return seen[1]

    sensor = actual_sensor(s)
    robot = tuple(text(getattr(s.robot, f.name)) for f in dataclasses.fields(s.robot)
                  if f.name not in ("cycles", "braking_time_scale"))
    return (text(s.controller), robot, s.contact_geometry, sensor.rate_hz, sensor.seed,
            tuple((tuple(operator_points(o)), len(o.waypoints)) for o in s.operators))


def true_stopping_terms(scenarios: list[Scenario], cell: ResolvedCell
                        ) -> tuple[np.ndarray, np.ndarray]:
    """S_true's time and distance terms of each scenario (the separation invariant's):
    the simulated robot's own stop from full speed (``metrics.robot_stopping``, once per
    braking time scale: the scenarios of a batch differ in their brakes' scale only)
    plus T_r, and its distance plus C; ``cell``: the scenarios' configuration resolved."""
    return _true_terms(scenarios, cell, robot_stopping)


def true_stopping_by_rate(scenarios: list[Scenario], cell: ResolvedCell
                          ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`true_stopping_terms` from every grid rate j / TRUTH_RATES ((B, TRUTH_RATES +
    1) each; ``metrics.robot_stops_by_rate``), for S_true by speed."""
    return _true_terms(scenarios, cell, robot_stops_by_rate)


def _true_terms(scenarios: list[Scenario], cell: ResolvedCell, stops_of
                ) -> tuple[np.ndarray, np.ndarray]:
    """``stops_of(scenario, cell)``'s time plus T_r and distance plus C for each scenario,
    taken once per braking time scale."""
    safety = cell.config.safety
    by_scale: dict = {}
    for sc in scenarios:
        if sc.robot.braking_time_scale not in by_scale:
            by_scale[sc.robot.braking_time_scale] = stops_of(sc, cell)
    stops_true = [by_scale[sc.robot.braking_time_scale] for sc in scenarios]
    return (np.array([x.time for x in stops_true]) + safety.reaction_time,
            np.array([x.distance for x in stops_true]) + safety.intrusion_distance)


def evaluate_many(scenarios: list[Scenario], *, batch_size: int = 1024,
                  cell: ResolvedCell | None = None) -> BatchResult:
    """``evaluate_batch`` over scenarios of any shapes: grouped by ``batch_key`` and cut
    into batches of at most ``batch_size``; results in the input order. ``cell``: the
    scenarios' configuration resolved (``resolved_cell``), for every batch (a verification's
    scenarios share it); None: each group of scenarios resolves its own once. Scenarios the
    batched evaluator does not model (the seed-004 speed alteration controllers, and
    every scenario whose robot is in ``dynamic`` mode, and every scenario whose operators
    are played from recordings) run one by one in the Drake diagram, so each is
    evaluated in the robot mode it asks for and with the motion it gives."""
    from verification.search.evaluate_drake import evaluate_drake

    out = np.zeros((len(dataclasses.fields(BatchResult)), len(scenarios)))
    groups: dict[tuple, list[int]] = {}
    memo: dict = {}
    for i, s in enumerate(scenarios):
        if s.controller.type != "ssm_override" or s.robot.mode != "kinematic" \
                or is_recorded(s):
            r, _ = evaluate_drake(s, cell=cell)
            out[:, i] = dataclasses.astuple(r)
            continue
        groups.setdefault(batch_key(s, memo), []).append(i)
    for members in groups.values():
        group_cell = resolve_scenario(scenarios[members[0]]) if cell is None else cell
        for start in range(0, len(members), batch_size):
            rows = members[start:start + batch_size]
            r = evaluate_batch([scenarios[i] for i in rows], group_cell)
            out[:, rows] = np.stack(dataclasses.astuple(r))
    return BatchResult(*out)
