"""A contact that lasts: ISO/TS 15066's transient and quasi-static limits on how far the
robot presses into a body region, and the robot's own contact detection that ends it, as
plain functions the batched evaluator, the Drake systems and the properties share.

**Why.** Annex A's permissible speeds (``pfl.contact_speed``) are for the *impact* of a
transient contact: the body region is free to recoil, and the robot must come off it
within the transient phase. A robot that keeps moving into a hand after the impact is a
quasi-static contact: the force is then the region's spring constant times how far the
robot has pressed into it, F = k x (Annex A's model, Table A.3's k), and it must stay
within the quasi-static force of Table A.2 once the transient window is over (within
twice that, the transient force, before). A speed cap alone bounds none of this: a robot
at a hand's 1 m/s limit pushes 99 mm into it in 0.1 s.

**The indentation x.** How far the robot has pressed into a segment since the contact
began: at every tick of the contact x grows by the robot's speed towards the segment (Eq.
7's v_R^d at the pair's nearest points, the largest over the capsules in contact) times
the tick, and never falls below 0 (a robot moving away unloads it). The operator's own
motion is not counted: a person walking into a standing robot presses themselves, not
the robot them. Interpretation (ours): Annex A's k is the body's effective stiffness in
a quasi-static (clamping) contact; taking the scripted or recorded body as not yielding
beyond that spring counts every millimetre the robot travels into it, which over-states
the force of a free region (it would be pushed away), never under-states it. The tick's
motion is counted at the tick it starts (one tick early: the larger figure).

**The limits, per segment** (:func:`segment_contact_limits`, from the segment's Annex A
regions, ``pfl.segment_regions``): where on the segment a contact falls is not known, so
each figure is the strictest over its regions, compressions in metres:

- transient x_tr = min over regions of F_transient / k (Table A.2's transient force, twice
  the quasi-static; Table A.3's k): the most x while the window lasts;
- quasi-static x_qs = min over regions of F / k: the most x once it is over;
- detection x_det = F_det / min over regions of k: the least x at which the robot's force
  reaches ``contact_stop_force`` F_det whichever region it presses (the softest region
  needs the most x: the latest detection).

For a hand (hands/fingers 140 N, 75 N/mm; wrist 160 N, 40 N/mm): x_qs 1.87 mm, x_tr
3.73 mm; with F_det = 175 N, x_det 4.4 mm.

**The contact's course** (:func:`contact_step`, one segment, one tick). A contact episode
is the ticks a segment stays within the contact distance of the robot, from the first of
them at which the robot moves or moves towards it at all (t0; a contact the robot never
moved in is the operator's own; one it creeps into below ``true_measures.MOVING_SPEED``
is not: its indentation counts at every tick of the episode). At every tick of it:

- while the robot moves: the impact rule, limit - v_R^d (m/s, ``speed_caps.
  contact_robustness``; minus infinity for a forbidden or clampable segment);
- x_tr - x before t0 + ``transient_window``, x_qs - x from then on (m);

and the robot's contact detection: once x >= x_det has held for ``contact_detection_time``
the robot stops (a protective stop, ``sensing.stops.STOP_CONTACT``, latched until the
contact ends: the force is gone). The figure is the least of these (>= 0 safe; metres and
metres per second, as the permitted contact property's other figures).

**The robot's detection is a premise, trusted from the configuration**, as its stopping
data are: a PFL robot's force limit, its tolerance and its detection time are the
manufacturer's (Universal Robots' manuals: the force limit's tolerance is 25 N; the CB3
manual's worst-case detection time for the TCP force limit is 250 ms, the defaults here
of 150 N + 25 N and 0.25 s). The ``transient_window`` (0.5 s, ISO/TS 15066's transient
contact as the literature applies Annex A) is also the configuration's.

A proof that x stays within x_qs (``verification.proof.theorems``, Theorem 3): detection
starts at x_det and the robot travels at most c_i V_R (t_det + T_stop + h) after it, so
x <= x_det + c_i V_R (t_det + T_stop + h) <= x_qs is what the configuration must give
each segment with a cap c_i > 0.
"""

import math

import numba
import numpy as np

from safety_systems.cell.human_body import NUM_SEGMENTS
from safety_systems.pfl.segment_regions import SEGMENT_FORBIDDEN, segment_regions
from safety_systems.pfl.speed_caps import between_links, clampable, contact_robustness

# A contact episode's state, per segment: (t0 (NaN: no episode), indentation x (m), since
# when x >= x_det (NaN: not), latched (1: the robot's contact stop holds)).
EPISODE_COLUMNS = 4
E_START, E_DEPTH, E_OVER, E_LATCHED = 0, 1, 2, 3
_TIME_TOL = 1e-9  # s: ticks this close count as simultaneous


def segment_contact_limits(contact_stop_force: float) -> np.ndarray:
    """(12, 3) per segment (aligned with ``SEGMENT_NAMES``): the transient and
    quasi-static compressions x_tr, x_qs and the detection compression x_det (metres;
    module docstring) for the robot's contact stop force ``contact_stop_force`` (N).
    Zeros for a segment presenting a forbidden region (no contact is permitted there)."""
    if not (math.isfinite(contact_stop_force) and contact_stop_force > 0.0):
        raise ValueError(f"contact_stop_force: got {contact_stop_force!r}; allowed: a "
                         "finite force > 0 N")
    out = np.zeros((NUM_SEGMENTS, 3))
    for i in range(NUM_SEGMENTS):
        if SEGMENT_FORBIDDEN[i]:
            continue
        regions = segment_regions(i)
        out[i, 0] = min(r.transient_force / r.spring_constant for r in regions)
        out[i, 1] = min(r.force / r.spring_constant for r in regions)
        out[i, 2] = contact_stop_force / min(r.spring_constant for r in regions)
    out.setflags(write=False)
    return out


def pressing_speeds(compressions, detection_time: float, stop_time: float,
                    period: float) -> np.ndarray:
    """(M,) the fastest the robot may move towards each segment (m/s) so that a contact
    that lasts stays within its quasi-static compression: (x_qs - x_det) / (t_det + T_stop
    + 2 h), 0 where the robot's detection comes later than x_qs (``compressions`` (M, 3)
    of :func:`segment_contact_limits`; the detection time, the stop's time and the control
    period h in seconds). Pressing at v, the robot reaches x_det, goes on for the
    detection time (and the tick it acts on, and the tick counted early), then brakes for
    at most T_stop at a speed at most v: x <= x_det + v (t_det + T_stop + 2 h) <= x_qs
    (the proof's premise, ``verification.proof.theorems`` Theorem 3)."""
    x = np.asarray(compressions, dtype=float)
    room = np.maximum(x[:, 1] - x[:, 2], 0.0)
    return room / (detection_time + stop_time + 2.0 * period)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def episode_reset(state):
    """No contact: the episode (if any) is over and the contact stop released."""
    state[E_START], state[E_DEPTH], state[E_OVER], state[E_LATCHED] = np.nan, 0.0, np.nan, 0.0


@numba.njit(cache=True)
def contact_step(state, in_contact, moving, v_rel, clamped, t, dt, limit, x_tr, x_qs, x_det,
                 detection_time, window):
    """One tick of one segment's contact (module docstring): updates ``state``
    (:data:`EPISODE_COLUMNS`) in place and returns the tick's permitted contact figure
    (+inf outside an episode). ``in_contact``: the segment is within the contact
    distance; ``moving``: the robot moves; ``v_rel``: the robot's speed towards it (m/s,
    the largest over the capsules in contact; NaN counts as unknown: a violation);
    ``clamped``: it may be pressed against a surface or between two links; ``limit``:
    its permissible speed (0: forbidden); compressions in metres; times in seconds."""
    if not in_contact:
        episode_reset(state)
        return np.inf
    if math.isnan(state[E_START]):
        if not (moving or not v_rel <= 0.0):  # (a NaN counts as pressing)
            return np.inf  # the operator touched a standing robot: not the robot's doing
        state[E_START] = t
    figure = np.inf
    if moving:
        figure = contact_robustness(limit, v_rel, clamped)
    step = v_rel * dt  # (a robot at rest: 0; one creeping below MOVING_SPEED still counts)
    if not step == step:  # NaN: fail safe
        return -np.inf
    state[E_DEPTH] = max(state[E_DEPTH] + step, 0.0)
    allowed = x_tr if t - state[E_START] < window - _TIME_TOL else x_qs
    figure = min(figure, allowed - state[E_DEPTH])
    if state[E_DEPTH] >= x_det:
        if math.isnan(state[E_OVER]):
            state[E_OVER] = t
        if t - state[E_OVER] >= detection_time - _TIME_TOL:
            state[E_LATCHED] = 1.0
    else:
        state[E_OVER] = np.nan
    return figure


@numba.njit(cache=True)
def contact_rows(in_contact, moving, v_rel, clamped, limits, x_limits, detection_time, window,
                 dt, start_time, figures, latched):
    """:func:`contact_step` of every segment over T ticks (``in_contact``, ``v_rel``,
    ``clamped`` (T, M); ``moving`` (T,); ``limits`` (M,); ``x_limits`` (M, 3): x_tr,
    x_qs, x_det), from no contact, into ``figures`` (T, M) and whether the contact stop
    holds after each tick ``latched`` (T, M)."""
    T, M = in_contact.shape
    state = np.empty((M, EPISODE_COLUMNS))
    for m in range(M):
        episode_reset(state[m])
    for t in range(T):
        for m in range(M):
            figures[t, m] = contact_step(state[m], in_contact[t, m], moving[t], v_rel[t, m],
                                         clamped[t, m], start_time + t * dt, dt, limits[m],
                                         x_limits[m, 0], x_limits[m, 1], x_limits[m, 2],
                                         detection_time, window)
            latched[t, m] = state[m, E_LATCHED] > 0.5


@numba.njit(cache=True)
def segment_contact_row(h_ends, h_radius, clearance, v_r, c_ends, c_velocities, c_radius,
                        links, boxes, contact_distance, gap, in_contact, v_rel, clamped):
    """At one tick, what :func:`contact_step` reads of every segment (M) from its pairs
    with the real robot's K capsules (``clearance``, ``v_r`` (M, K): the true clearance
    and the robot's directed speed towards it, NaN where the segment is absent): whether
    it is within ``contact_distance`` of the robot, the largest robot speed towards it
    over the capsules within it (NaN kept), and, where in contact, whether it is
    clampable: within ``gap`` of a fixed surface (``boxes``, ``speed_caps.clampable``) or
    of two links (``speed_caps.between_links`` of ``c_ends`` (K, 2, 3), their velocities,
    ``c_radius`` and ``links``), on the true segment (``h_ends`` (M, 2, 3),
    ``h_radius``)."""
    for m in range(h_radius.size):
        in_contact[m], v_rel[m], clamped[m] = False, -np.inf, False
        for j in range(c_radius.size):
            if clearance[m, j] < contact_distance:
                in_contact[m] = True
                v = v_r[m, j]
                v_rel[m] = v if not v <= v_rel[m] else v_rel[m]  # (keeps a NaN)
        if in_contact[m]:
            clamped[m] = (boxes.shape[0] > 0 and clampable(
                h_ends[m, 0], h_ends[m, 1], h_radius[m], boxes, gap)) or between_links(
                h_ends[m, 0], h_ends[m, 1], h_radius[m], c_ends, c_velocities, c_radius,
                links, gap)


@numba.njit(cache=True)
def _segment_contact_rows(h_ends, h_radius, clearance, v_r, c_ends, c_velocities, c_radius,
                          links, boxes, contact_distance, gap, in_contact, v_rel, clamped):
    for t in range(h_radius.shape[0]):
        segment_contact_row(h_ends[t], h_radius[t], clearance[t], v_r[t], c_ends[t],
                            c_velocities[t], c_radius, links, boxes, contact_distance, gap,
                            in_contact[t], v_rel[t], clamped[t])


def lasting_contact(h_ends, h_radius, clearance, v_r, c_ends, c_velocities, c_radius, links,
                    boxes, contact_distance: float, gap: float, moving, limits, compressions,
                    detection_time: float, window: float, dt: float
                    ) -> tuple[np.ndarray, np.ndarray]:
    """A run's contacts, tick by tick (T ticks of period ``dt`` from 0): the true segments
    (``h_ends`` (T, M, 2, 3), ``h_radius`` (T, M)), their pairs with the real robot's
    capsules (``clearance``, ``v_r`` (T, M, K)), the capsules (``c_ends``, ``c_velocities``
    (T, K, 2, 3), ``c_radius`` (K,), ``links`` (K,)), the fixed surfaces ``boxes``, whether
    the robot moves (T,), each segment's permissible speed (M,) and compressions (M, 3):
    (figures (T, M) of :func:`contact_step`, +inf outside a contact episode; whether the
    robot's contact stop holds after each tick (T, M))."""
    T, M = clearance.shape[:2]
    f = np.ascontiguousarray
    in_contact, v_rel = np.empty((T, M), dtype=np.bool_), np.empty((T, M))
    clamped = np.empty((T, M), dtype=np.bool_)
    _segment_contact_rows(f(h_ends, dtype=float), f(h_radius, dtype=float),
                          f(clearance, dtype=float), f(v_r, dtype=float), f(c_ends, dtype=float),
                          f(c_velocities, dtype=float), f(c_radius, dtype=float),
                          f(links, dtype=np.int64), f(boxes, dtype=float).reshape(-1, 2, 3),
                          float(contact_distance), float(gap), in_contact, v_rel, clamped)
    figures, latched = np.empty((T, M)), np.empty((T, M), dtype=np.bool_)
    contact_rows(in_contact, f(moving, dtype=np.bool_), v_rel, clamped, f(limits, dtype=float),
                 f(compressions, dtype=float), float(detection_time), float(window),
                 float(dt), 0.0, figures, latched)
    return figures, latched
