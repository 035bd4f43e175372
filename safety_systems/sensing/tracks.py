"""The tracker's rules, written once: which measurements a frame may give, the Kalman step
(seed 000, Section 5.1, Eqs. 2-4), hidden bodies, exits and rejected frames.

Compiled (numba) and shared by the KalmanTracker system and the batched verifier.

**Frames.** A frame has a capture time and one entry per registered body: a position, a
seen flag and the body id the entry carries (ids 1..N name the N body slots, as a
motion-capture system names its rigid bodies). A new frame whose capture time is not
later than the newest good frame's is rejected whole (``bad_time``). An entry is
rejected when its id is not registered or two entries claim one body (``unknown_id``),
when it is flagged seen without a finite position (``non_finite``), or when it lies
farther from its track than a body can have moved (``gate``, below). A rejected entry
counts as an occlusion of its body, and the frame's fault stops the robot until a clean
frame comes (``safety_systems.sensing.stops``): the seed trusts every frame; a marker swap, a
reflection or a corrupted frame must not be taken as truth.

**Gate.** Around the track's last accepted estimate c (the ball's centre, below), an
entry z is accepted while |z - c| <= v_g (t - t_seen) + w + Z_d: the largest human speed
v_g (``gate_speed``) times the time since the body was last accepted, plus the gate
width w (``gate_width``, for sensor noise and the estimate's own error) and the
configured Z_d. A body cannot be farther than that from where it was; a frame that puts
it there is wrong.

**Hidden bodies** (``hidden_bodies: hazard``). A body that is not seen (occluded,
rejected) keeps its track as a ball: its centre is the last accepted estimate (the
state is frozen there) and the SeparationMonitor grows its radius at ``occlusion_speed``
over the time since it was last seen (``unseen_time``). The track never ends because
time passed or because of its distance from the robot: it ends only when the body was
last seen inside an exit region (it left through an exit) or outside the cell's walls
(the ``cell`` box; from there it can come back only through an exit, where it is seen
again). When the body is seen again after any gap, its filter restarts at the new
measurement (velocity unknown): the estimate never rests on a prediction across a gap,
which is what lets the proof bound the tracker's error for gaps of any length.

**The previous rule** (``hidden_bodies: expire``, kept to show why it was replaced): the
filter coasts through gaps, a track unseen for longer than ``max_coast_time`` ends when
its coasted estimate lies farther than ``exit_radius`` from the robot base horizontally,
and is otherwise *lost* (the robot stops until it is seen again).

Track slot (``TRACK_SLOT`` floats per body): x = [p, v] (6) at the last accepted
measurement, the covariance (p, c, w) of one axis (the filter is isotropic, see
``safety_systems.sensing.kalman``), status, and t_seen, the capture time of the last accepted
measurement.
"""

import math

import numba
import numpy as np

from safety_systems.sensing import stops
from safety_systems.sensing.kalman import axis_predict, axis_update

TRACK_NONE, TRACK_TRACKING, TRACK_HIDDEN, TRACK_LOST = 0, 1, 2, 3
TRACK_SLOT = 11
# Offsets in a track slot: the axis covariance [[p, c], [c, w]] of (position, velocity),
# then the status and the capture time of the last accepted measurement.
_POS_VAR, _COVAR, _VEL_VAR, _STATUS, _T_SEEN = 6, 7, 8, 9, 10
HIDDEN_BODY_RULES = ("hazard", "expire")
MIN_MEASUREMENT_STD = 1e-6  # m; keeps R positive definite for a noise-free sensor
GAP_PERIODS = 1.5  # a measurement more than this many periods after the last one ends a gap

# rules: the parameters of frame_step, one float array (see make_rules).
(R_VAR, R_Q2, R_V0_VAR, R_PERIOD, R_MODE, R_COAST, R_EXIT_RADIUS, R_GATE, R_GATE_SPEED,
 R_GATE_WIDTH, R_Z_D) = range(11)
NUM_RULES = 11



def make_rules(*, measurement_std: float, velocity_process_noise: float,
               initial_velocity_std: float, period: float, hidden_bodies: str = "hazard",
               max_coast_time: float = 0.5, exit_radius: float = 2.5, gate: bool = True,
               gate_speed: float = 2.0, gate_width: float = 0.05,
               human_uncertainty: float = 0.0) -> np.ndarray:
    """The rules array of :func:`frame_step` (see the module docstring for each rule).

    ``measurement_std``: m per axis (R = std^2 I3, at least ``MIN_MEASUREMENT_STD``);
    ``velocity_process_noise``: q2 of Eq. 4, m^2/s^2; ``initial_velocity_std``: m/s of a
    new track; ``period``: the sensor's capture period, s; ``gate_speed`` m/s,
    ``gate_width`` and ``human_uncertainty`` (Z_d) m.
    """
    if hidden_bodies not in HIDDEN_BODY_RULES:
        raise ValueError(f"hidden_bodies: got {hidden_bodies!r}; allowed: "
                         f"{' | '.join(HIDDEN_BODY_RULES)}")
    for name, value in dict(velocity_process_noise=velocity_process_noise,
                            initial_velocity_std=initial_velocity_std, period=period,
                            max_coast_time=max_coast_time, exit_radius=exit_radius).items():
        if not (math.isfinite(value) and value > 0.0):
            raise ValueError(f"{name}: got {value}; allowed: a finite number > 0")
    for name, value in dict(measurement_std=measurement_std, gate_speed=gate_speed,
                            gate_width=gate_width,
                            human_uncertainty=human_uncertainty).items():
        if not (math.isfinite(value) and value >= 0.0):
            raise ValueError(f"{name}: got {value}; allowed: a finite number >= 0")
    rules = np.empty(NUM_RULES)
    rules[R_VAR] = max(float(measurement_std), MIN_MEASUREMENT_STD) ** 2
    rules[R_Q2] = velocity_process_noise
    rules[R_V0_VAR] = initial_velocity_std**2
    rules[R_PERIOD] = period
    rules[R_MODE] = HIDDEN_BODY_RULES.index(hidden_bodies)
    rules[R_COAST] = max_coast_time
    rules[R_EXIT_RADIUS] = exit_radius
    rules[R_GATE] = 1.0 if gate else 0.0
    rules[R_GATE_SPEED] = gate_speed
    rules[R_GATE_WIDTH] = gate_width
    rules[R_Z_D] = human_uncertainty
    return rules


def make_regions(cell=None, exits=()) -> np.ndarray:
    """(1 + E, 2, 3) boxes [min, max] (m, base frame): the cell's walls first (all of
    space when ``cell`` is None), then the exit regions."""
    regions = np.empty((1 + len(exits), 2, 3))
    regions[0, 0], regions[0, 1] = -np.inf, np.inf
    if cell is not None:
        regions[0] = np.asarray(cell, dtype=float).reshape(2, 3)
    for j, box in enumerate(exits):
        regions[1 + j] = np.asarray(box, dtype=float).reshape(2, 3)
    return regions


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def _inside(regions, j, x0, x1, x2):
    low, high = regions[j, 0], regions[j, 1]
    return (low[0] <= x0 <= high[0] and low[1] <= x1 <= high[1]
            and low[2] <= x2 <= high[2])


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def has_left(regions, x0, x1, x2):
    """Whether a body last seen at (x0, x1, x2) has left the cell: inside an exit region
    or outside the cell's walls (``regions`` from :func:`make_regions`)."""
    left = not _inside(regions, 0, x0, x1, x2)
    for j in range(1, regions.shape[0]):
        left = left or _inside(regions, j, x0, x1, x2)
    return left


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def gate_radius(rules, elapsed):
    """How far (m) from its last accepted estimate a body can be ``elapsed`` seconds later
    (see the module docstring); +inf without the gate."""
    radius = np.inf
    if rules[R_GATE] != 0.0:
        radius = rules[R_GATE_SPEED] * elapsed + rules[R_GATE_WIDTH] + rules[R_Z_D]
    return radius


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def _slot_of(body_id, n):
    """The slot of a body id (ids 1..n), or -1 when it is not registered."""
    slot = -1
    if body_id >= 1.0 and body_id <= n and body_id == math.floor(body_id):
        slot = int(body_id) - 1
    return slot


@numba.njit(cache=True)
def frame_step(tracks, base, n, t, z, valid, ids, t_good, counts, rules, regions):
    """Processes one new frame for the body slots ``base`` .. ``base + n - 1`` of
    ``tracks`` (in place); returns its fault (a ``stops`` code, 0 when clean).

    ``t``: the frame's capture time; ``z`` (E, 3), ``valid`` (E,) and ``ids`` (E,): its
    entries (E = n from the simulated sensor; a live stream's frame carries the bodies
    it sees, any number); ``t_good`` (1,): the newest good frame's capture time (updated);
    ``counts`` (4,): rejected measurements by ``stops.REJECT_CAUSES`` (added to);
    ``rules`` from :func:`make_rules`; ``regions`` from :func:`make_regions`. See the
    module docstring for the rules; Eqs. 2 and 4 (predict) and 3 (update) are
    ``kalman.axis_predict`` and ``axis_update`` on one axis' covariance.
    """
    fault = stops.STOP_NONE
    if not (math.isfinite(t) and t > t_good[0]):  # repeated, earlier or unknown time
        counts[stops.REJECT_TIME] += 1.0
        fault = stops.STOP_BAD_TIME
    else:
        t_good[0] = t
        entry = np.full(n, -1)  # the entry each slot takes, -1 none
        claims = np.zeros(n)
        bad_id, non_finite, gated = False, False, False
        for e in range(valid.shape[0]):  # the frame's entries (n in simulation)
            if valid[e] == 0.0:
                continue
            slot = _slot_of(ids[e], n)
            if slot < 0:
                counts[stops.REJECT_UNKNOWN_ID] += 1.0
                bad_id = True
                continue
            claims[slot] += 1.0
            entry[slot] = e
        period, r2, mode = rules[R_PERIOD], rules[R_VAR], rules[R_MODE]
        for i in range(n):
            track = tracks[base + i]
            status = track[_STATUS]
            e = entry[i]
            seen = e >= 0
            if seen and claims[i] > 1.0:  # two entries name one body: neither is used
                counts[stops.REJECT_UNKNOWN_ID] += claims[i]
                bad_id, seen = True, False
            if seen and not (math.isfinite(z[e, 0]) and math.isfinite(z[e, 1])
                             and math.isfinite(z[e, 2])):
                counts[stops.REJECT_NON_FINITE] += 1.0
                non_finite, seen = True, False
            elapsed = t - track[_T_SEEN]
            if seen and status != TRACK_NONE:
                d0, d1, d2 = z[e, 0] - track[0], z[e, 1] - track[1], z[e, 2] - track[2]
                if not math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) <= gate_radius(rules, elapsed):
                    counts[stops.REJECT_GATE] += 1.0
                    gated, seen = True, False
            if seen:
                restart = status == TRACK_NONE or status == TRACK_LOST
                if mode == 0.0:  # hazard: after any gap the filter starts afresh
                    restart = restart or status == TRACK_HIDDEN or elapsed > GAP_PERIODS * period
                if restart:  # a new track at the measurement, velocity unknown
                    p, c, w = r2, 0.0, rules[R_V0_VAR]
                    for k in range(3):
                        track[k], track[k + 3] = z[e, k], 0.0
                else:  # Eqs. 2 and 4, then Eq. 3
                    p, c, w = axis_predict(track[_POS_VAR], track[_COVAR], track[_VEL_VAR],
                                           elapsed, rules[R_Q2])
                    k_p, k_v, p, c, w = axis_update(p, c, w, r2)
                    for k in range(3):
                        prior = track[k] + elapsed * track[k + 3]
                        innovation = z[e, k] - prior
                        track[k] = prior + k_p * innovation
                        track[k + 3] += k_v * innovation
                track[_POS_VAR], track[_COVAR], track[_VEL_VAR] = p, c, w
                track[_STATUS], track[_T_SEEN] = TRACK_TRACKING, t
            elif status == TRACK_TRACKING or status == TRACK_HIDDEN:
                track[_STATUS] = TRACK_HIDDEN
                if mode == 0.0:  # hazard: ends only when seen leaving
                    if has_left(regions, track[0], track[1], track[2]):
                        track[_STATUS] = TRACK_NONE
                elif elapsed > rules[R_COAST]:  # expire, on the coasted estimate
                    x0, x1 = track[0] + elapsed * track[3], track[1] + elapsed * track[4]
                    outside = math.sqrt(x0 * x0 + x1 * x1) > rules[R_EXIT_RADIUS]
                    track[_STATUS] = TRACK_NONE if outside else TRACK_LOST
        if non_finite:
            fault = stops.STOP_NON_FINITE
        elif bad_id:
            fault = stops.STOP_UNKNOWN_ID
        elif gated:
            fault = stops.STOP_GATE
    return fault


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def tracker_fault(frame_fault, now, t_good, timeout):
    """The tracker's fault at time ``now``: the newest processed frame's own fault (a
    ``stops`` code), else ``stops.STOP_STALE_FRAME`` when the newest good frame (captured
    at ``t_good``) is older than ``timeout`` s or there is none (t_good -inf), else 0.
    The one rule of the KalmanTracker, the batched verifier and the live runtime."""
    fault = frame_fault
    if fault == 0.0 and not (now - t_good <= timeout):
        fault = float(stops.STOP_STALE_FRAME)
    return fault


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def usable(status):
    """Whether a track is monitored: tracking, or hidden (a ball). The one rule: the
    monitor, the override, every controller, the batched evaluator and the runtime ask
    this function."""
    return status == TRACK_TRACKING or status == TRACK_HIDDEN


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def tracker_stop(status, fault):
    """Why the tracker holds the robot (a ``stops`` code, ``STOP_NONE`` if it does not):
    its ``fault`` (NaN or an unknown code counts as a stale frame), else a lost track
    (the ``expire`` rule's body hidden near the robot). The one stop rule of every
    controller that reads the tracker, and of the batched evaluator."""
    reason = float(stops.STOP_NONE)
    if fault != 0.0:  # NaN too
        known = fault >= stops.STOP_STALE_FRAME and fault < len(stops.STOP_REASONS)
        reason = fault if known else float(stops.STOP_STALE_FRAME)
    else:
        for i in range(status.size):
            if status[i] == TRACK_LOST:
                reason = float(stops.STOP_LOST_TRACK)
    return reason


def usable_bodies(status: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """(N,) bool: the bodies a controller may use, a usable track (:func:`usable`) with a
    finite position (N, 3)."""
    return np.array([usable(s) for s in status], dtype=bool) & np.all(
        np.isfinite(positions), axis=1)


@numba.njit(cache=True)
def estimate_rows(tracks, base, n, t_good, p, v, status, std, unseen):
    """The tracker's outputs for slots ``base`` .. ``base + n - 1`` into p, v (n, 3) and
    status, std, unseen (n,): the estimate (NaN without a track; while hidden, the last
    accepted one: the ball's centre), the position standard deviation (m, per axis) and
    the seconds from the last accepted measurement to the newest good frame
    ``t_good`` (0 while tracking or untracked)."""
    for i in range(n):
        track = tracks[base + i]
        s = track[_STATUS]
        none = s == TRACK_NONE
        status[i] = s
        for k in range(3):
            p[i, k] = np.nan if none else track[k]
            v[i, k] = np.nan if none else track[k + 3]
        std[i] = 0.0 if none else math.sqrt(max(track[_POS_VAR], 0.0))
        unseen[i] = t_good - track[_T_SEEN] if (s == TRACK_HIDDEN or s == TRACK_LOST) else 0.0


def frame_update(tracks: np.ndarray, t: float, z: np.ndarray, valid: np.ndarray,
                 ids: np.ndarray | None = None, *, rules: np.ndarray,
                 regions: np.ndarray | None = None, t_good: float = -np.inf
                 ) -> tuple[np.ndarray, int, np.ndarray, float]:
    """:func:`frame_step` on a copy of an (N, TRACK_SLOT) track array: returns the new
    tracks, the frame's fault, its rejected measurements by cause (4,) and the new
    ``t_good``. ``ids`` None: entry i carries id i + 1."""
    out = np.array(tracks, dtype=float, order="C")
    n = out.shape[0]
    ids = np.arange(1.0, n + 1.0) if ids is None else np.asarray(ids, dtype=float)
    good, counts = np.array([t_good], dtype=float), np.zeros(4)
    fault = frame_step(out, 0, n, float(t), np.ascontiguousarray(z, dtype=float).reshape(n, 3),
                       np.asarray(valid, dtype=float), np.ascontiguousarray(ids),
                       good, counts, rules, make_regions() if regions is None else regions)
    return out, int(fault), counts, float(good[0])


def estimates(tracks: np.ndarray, t_good: float
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`estimate_rows` of an (N, TRACK_SLOT) array: (p, v, status, std, unseen)."""
    n = tracks.shape[0]
    p, v = np.empty((n, 3)), np.empty((n, 3))
    status, std, unseen = np.empty(n), np.empty(n), np.empty(n)
    estimate_rows(np.ascontiguousarray(tracks, dtype=float), 0, n, float(t_good), p, v,
                  status, std, unseen)
    return p, v, status, std, unseen
