"""Proofs that the robot is at rest whenever any segment of an operator's body is within the
contact distance of it, and that it never moves with a segment inside the protective
distance of the true speeds.

Theorem 1 (what ``prove`` checks). Take the kinematic workcell (``robot.mode: kinematic``,
a checked premise: the theorem covers no other mode, ``Proof.robot_mode`` says which)
with the SSM speed override, a configuration whose human-speed term is a constant floor
v (``iso`` or ``estimated_with_floor``), whose monitor measures capsules containing the
property's (``ResolvedCell.capsules`` against ``contact_capsules``), whose
tracker keeps hidden bodies as balls growing at ``occlusion_speed`` >= v_max until they
are seen leaving (``hidden_bodies: hazard``, ``safety_systems.sensing.tracks``), whose
monitor measures every segment of every operator by its envelope
(``safety_systems.cell.human_body``: capsules certain to hold the segment while the
operator's body is within the configuration's body model and every tracked point within
the tracking allowance sigma of its estimate, or, hidden, within sigma + occlusion_speed
times the time unseen), and a space whose scenarios satisfy the premises ``prove`` lists
(each marked *checked*, against this model, or *trusted*, taken from the files). Let

    M = v (T_s + T_r) + r_low T_r + B + C + Z_d + Z_r        (the configured S, lower bound)
        - v_max (tau + T_stop + h)                           (human travel)
        - V_R h - D                                          (robot travel)
        - c                                                  (contact distance)

where T_s, T_r, B, C, Z_d, Z_r are the configuration's, tau its frame timeout, h the
control period, V_R the largest speed of any point of the monitor's capsule axes on
the path, r_low the least the monitor's robot speed term can be (-V_R for Eq. 7's
directed speed, 0 for ``robot_speed: fastest_point``), T_stop the longest stop from full
speed under the real brakes and D the longest travel of any capsule axis point in it
(plus one tick); v_max bounds the speed of every point of every operator's body. A
premise (checked) takes the place of the tracker's error: sigma >= E, with E a bound on
the distance between a tracked point and its estimate at the estimate's capture time.
If M >= 0 over the whole box, no scenario in it has any segment of an operator within c
of any capsule of the moving robot, whatever the occlusions (of any length, of any
bodies), dropped frames, and outlier or corrupted frames.

Proof sketch. Suppose the robot moves at tick t_c with segment i within c of capsule j.
The path rate only rises after a command k > 0, so there is a last tick t' <= t_c with
k(t') > 0; after it every command is 0, so the robot rests within T_stop of t' + h and
t_c - t' <= T_stop + h. At t' there was no fault: the newest good frame was captured at
t_f >= t' - tau, and it was clean (a rejected entry: a bad time, an unknown id, a
non-finite position or one outside the gate, stops the robot until a clean frame). Every
body of segment i's operator had a usable track: it was seen before its onset and a
track ends only where a body leaves the cell, which the space's bodies never do (an
operator seen in part stops the robot). So d_i(t') >= S_max >= S_ij(t'), with d_i the
clearance from segment i's envelope to the monitor's capsule j. Each tracked point's
true position at t_f lies within E + v_max (t_f - t_seen) of its estimate x: E bounds
the error at the last accepted measurement (the filter restarts after every gap, so E
is the error of a track seen in consecutive frames since its start, by the gain
recursion, with every accepted frame within the noise bound: frames inside the gate
are trusted to be, and the space's outliers are checked to fall outside it), and the
hidden region covers the rest; so, with sigma >= E, every tracked point's region holds
it, and the envelope holds the true segment at t_f (the body within the model: trusted
of real people, checked of the space's postures). Its points move at most v_max. Then
    clearance_ij(t_c) >= d_i(t') - v_max (t_c - t_f) - (V_R h + D),
the real capsules being inside the monitor's (a larger radius, a longer axis) and the
robot's axis points moving at most V_R h in the tick after t' and D while braking, and
S_ij >= v (T_s + T_r) + r_low T_r + B + C + Z_d + Z_r (Eq. 5's speed of any axis point
towards the body is at least -V_R). Together clearance_ij(t_c) >= M + c >= c.

Theorem 2 (what ``prove_separation`` checks): the separation invariant
(``verification.properties``): at every tick t where the override's k > 0, every
segment i of every operator and every capsule j of the real robot have clearance_ij(t) >=
S_true_ij(t), seed Eqs.
9-11 on the true directed speeds with T_r and C, and the simulated robot's stopping
time T* and distance B* (``safety_systems.cell.stopping``), without Z_d and Z_r. Under the
premises of Theorem 1 but the ordering of braking speeds (S_true uses the full-speed
stop), let

    M_S = v_lo (T_s + T_r) - v_hi (T_stop + T_r)     (the human terms)
          + g T_r                                   (the robot speed terms)
          + B - D + Z_d + Z_r                       (stopping distance, allowances)
          - v_max tau                               (what the monitor does not see)

with v_lo the monitor's least human speed (the 1.6 m/s rule's lower speed, or the
floor), v_hi the most S_true can use (the larger iso speed, or max(v_max, floor)), and
g = -2 V_R for the directed robot speed (the monitor's capsule point may move away from
the envelope at V_R while the true segment's moves towards it at V_R) or -a h for
``fastest_point`` (the monitor's speed is the capsule's fastest end by Eq. 5, its ends
differenced over the last tick, at most a h short of the instant's speed of any of its
axis points, a: ``robot_acceleration_bound``). If M_S >= 0 over the box, the invariant
holds in every scenario of it. C cancels (it is in both S), so only Z_d + Z_r can buy
the margin; ``Proof.needed_allowance`` says how much is missing.

Proof sketch. At a tick t with k(t) > 0 there is no fault, the newest good frame is
at most tau old, every body's track is usable, and the closest d_i exceeds S_max. The
monitor's robot is the true robot at t (the same joint state). As in Theorem 1 the true
segment lies in its envelope at t_f and moves at most v_max (t - t_f) since, so
clearance_ij(t) >= d_i(t) - v_max tau > S_max - v_max tau. S_max is at least
v_lo (T_s + T_r) + r T_r + B + C + Z_d + Z_r with r the monitor's robot speed term, and
S_true_ij at most v_hi (T* + T_r) + r* T_r + B* + C with T* <= T_stop, B* <= D and r*
the true directed speed: r* - r <= -g. So clearance_ij(t) - S_true_ij(t) > M_S >= 0.

Speed levels (``safety.stopping: by_speed``, ISO/TS 15066's S_s from the robot's
current speed). The override commands one of the levels sigma_g = g / G (G =
``ssm.SPEED_LEVELS``) by ``ssm.by_speed_command``; the monitor computes each body's S at
every level with T_s(sigma_g) and B(sigma_g) (``ResolvedCell.level_stops``), and
S_true takes T* and B* from the simulated robot's stop from its true rate at the tick
(``cell.stopping.stops_by_rate``: the grid rate at or above it). Both theorems then
hold with one margin per level g = 1..G, each checked over the box (one z3 query, the
levels' conditions in a disjunction); the proof reports the least, and at which level
(``Proof.terms``: ``speed_level``, ``level_margins``). Let rho_g (:func:`level_rate`)
bound every rate the override counts as level g or below and the grid rate S_true
takes for such a rate (g / G but for the rules' rounding), and rho'_g = min(1, rho_g +
a_b h) every rate over the tick before (a_b: the table's fastest deceleration at the
space's shortest braking time scale; the rate falls at most a_b h in a tick). Then

    M_g = v (T_s(sigma_g) + T_r) + r_g T_r + B(sigma_g) + C + Z_d + Z_r
          - v_max (tau + T_stop(rho_g) + h) - V_R rho_g h - D(rho_g) - c

    M_S,g = v_lo (T_s(sigma_g) + T_r) - v_hi (T_stop(rho_g) + T_r) + g_g T_r
            + B(sigma_g) - D(rho_g) + Z_d + Z_r - v_max tau

with T_stop(rho) and D(rho) the stop commanded at path rate rho (D over a path
window of that stop plus one tick at rho), r_g = -V_R rho'_g (directed) or 0
(fastest_point), and g_g = -V_R (rho_g + rho'_g) (directed) or -a(rho'_g) h
(fastest_point, a(rho) = |d2p/ds2| rho^2 + V_R |d sigma/dt|). At g = G every term is
the full-speed one (rho = rho' = 1, T_s(1) = T_s, B(1) = B): M_G = M and M_S,G = M_S.
Z_d + Z_r adds to every level's margin alike, so ``needed_allowance`` is the least
level's shortfall.

Proof sketch (what changes). Whenever k(t) > 0 the override found d(t) >= S_max(g_now)
(g_now the level at or above the rate now) and d(t) >= dS S_max(g_k) with k = g_k / G,
g_k >= 1 (the level 0 never permits motion, though g_now may be 0). So d(t) >=
S_max(g') with g' = max(g_now, g_k) in 1..G (for dS > 1 this needs S_max(g_k) >= 0: a
checked premise, the monitor's least S at any level is not negative). The rate now is
at most rho_{g'}, and so is k; one tick moves the rate from the rate now towards k
without passing it (``braking.rate_step_one``), so sigma(t + h) <= rho_{g'}.
Theorem 1: at the last tick t' with k > 0 before t_c the rate left is at most
rho_{g'}; every later command is 0, and a stop from a lower rate takes no longer and
travels no farther (a braking step preserves the order of rates: checked), so t_c - t'
<= T_stop(rho_{g'}) + h and the capsule axes travel at most V_R rho_{g'} h +
D(rho_{g'}) after t'. The monitor's capsule velocities at t' are differenced over the
tick before, at rates up to rho'_{g'}, so its directed robot term is at least -V_R
rho'_{g'}. The rest is as above, with the level's terms: clearance_ij(t_c) >= M_{g'} +
c. Theorem 2: at a tick t with k(t) > 0, S_true takes the stop from the grid rate at
or above sigma(t), at most rho_{g'}: T* <= T_stop(rho_{g'}) and B* <= D(rho_{g'})
(stops grow with the rate, checked there too); S_true's robot term is at most V_R
sigma(t) <= V_R rho_{g'}, the monitor's at least -V_R rho'_{g'} (directed), or within
a(rho'_{g'}) h of the instant's speed of any axis point (fastest_point). The rest is as
above: clearance_ij(t) - S_true_ij(t) > M_S,{g'}. As g' is one of 1..G, every level's
margin >= 0 proves the theorem.

The bounds V_R, D, T_stop and E are computed soundly (``robot_bounds``,
``tracking_error``): V_R and D by a Lipschitz covering of the path (grid values of every
capsule end's speed, whose maximum bounds every axis point's, plus the largest change
between grid points, from a bound on a rigid point's acceleration); T_stop by running
the braking model from full speed; E by running the filter's deterministic gain
recursion from a new track until it converges and propagating worst-case error and
velocity bounds (linear in noise and v_max), at the box's largest noise (its bound in
sigmas) and speed, for the allowance premise. M is then checked over the box's
continuous range of v_max by z3 (unsatisfiability of M < 0, and of M_S < 0), with the
robot bounds taken at the largest braking time scale (stopping time and distance grow
with it). Interpretation: the three-ball model subtracted E from the margin; the
envelopes take it in their allowance instead (an ellipsoid's width is not Lipschitz in
its foci, so only an allowance on the foci, not a margin on the distance, makes an
envelope of the estimates hold the true segment), so M no longer depends on the noise.

Theorem 3 (what ``prove_permitted_contact`` checks, ``safety.mode: ssm_pfl``): every
contact while the robot moves is with a segment that permits transient contact, not
clampable against a declared fixed surface, at a relative speed (the robot's speed towards
it) at or below its permissible speed v_i (``verification.properties``). The override's k
is the least over the usable segments of max(k_i, c_i) (k_i Eq. 12's, or the segment's
level under by_speed; c_i its cap in force: ``pfl.speed_caps``). Under Theorem 1's
premises, if M >= 0 over the box, and

- c_i V_R <= v_i for every segment (the caps are min(v_pfl, v_i) / V_R with V_R the
  same Lipschitz cover; the head, face and neck have c_i = 0),
- a command below the rate brings the rate down by the stop's own steps and never
  below the command, and one at or above it never takes the rate past it
  (``braking.rate_step_one``, checked on a grid of rates and commands),
- clamp_margin >= v_max (tau + T_stop + h) + V_R h + D (the robot's mounting surface
  and the declared fixed surfaces, and the robot's own links, which move too),
- for every segment with a cap c_i > 0: x_det,i + c_i V_R (t_det + T_stop + 2 h) <=
  x_qs,i (``pfl.contact_limits``: the robot's contact detection indentation, its
  detection time t_det; x_qs,i <= x_tr,i),

the property holds in every scenario of the box. Proof sketch. Take a contact with
segment i at tick t_c while the robot moves. If k(t) <= c_i(t) at every tick up to t_c,
the rate never exceeded max c_i (it rises only towards a command), so every axis point
moved at most c_i V_R <= v_i (for c_i = 0 the robot would rest: no contact while
moving). Else let t' be the last tick before t_c with k(t') > c_i(t'): then k_i(t') >=
k(t') > 0, which is Theorem 1's premise for segment i (d_i >= S_max, or S_max(g') by
speed), and after t' every command is at most the cap in force. If t_c - t' <= T_stop + h
Theorem 1's argument gives the pair's clearance >= M + c > c at t_c: no contact.
Otherwise the commands after t' bring the rate down by the stop's steps (braking
preserves the order of rates) to at most the cap within T_stop of t': at t_c the rate is
at most c_i, and the contact's relative speed at most c_i V_R <= v_i. For a clampable
segment (its true capsule within ``CLAMP_GAP`` of a surface, or of two links' capsules, at
t_c): its envelope at every frame of the last tau + T_stop + h held the true segment
then, which moved at most v_max (tau + T_stop + h) since, and the links' capsules at any
tick of the last T_stop + h are within V_R h + D of where they are at t_c (the tick
after the last command above 0, then the stop), so with that clamp_margin its cap in
force was 0 at every tick of the last T_stop + h; the argument above with c_i = 0 over
that window leaves the robot at rest at t_c or the clearance above c. A contact that
lasts (the indentation x of ``pfl.contact_limits``): at every tick of it while the robot
moves the rate is at most c_i (above), so x grows at most c_i V_R per second; while x <
x_det,i the indentation is below x_qs,i; once x >= x_det,i the robot's contact
detection (trusted) has stopped it within t_det (plus the tick it acts on and the tick
counted early), and it then brakes from a rate at most c_i, travelling at most c_i V_R
T_stop; it stays stopped while the contact lasts. So x <= x_det,i + c_i V_R (t_det +
T_stop + 2 h) <= x_qs,i <= x_tr,i at every tick: within the transient compression in the
window and the quasi-static one after. Interpretation (ours): the relative speed is the
robot's, Eq. 7's v_R^d at the pair's nearest points (``pfl.speed_caps``).

Under ``ssm_pfl`` Theorem 2 is claimed for speed and separation monitoring's part only:
at the ticks where k exceeds a segment's cap in force, for that segment's pairs. There
k_i >= k > 0, so the segment's d_i >= S_max (S_max(g') by speed), which is all the proof
of Theorem 2 takes of the override: its margin M_S is unchanged.

A space built around a recording (``verification.spaces.recorded``) is declined: the
margins are checked over scripted approaches' parameters only (:func:`_declined` lists
what a proof over recorded motion would need, measured from the recording).
"""

import dataclasses

import numpy as np

from safety_systems.cell.braking import path_rate_step
from safety_systems.cell.human_body import SEGMENT_NAMES
from safety_systems.config.resolved_cell import ResolvedCell
from safety_systems.pfl.segment_regions import SEGMENT_FORBIDDEN
from safety_systems.ssm.formulas import SPEED_LEVELS
from verification.proof.margins import (
    Levels,
    Margin,
    check_cell,
    margin_of_levels,
    robot_speed_gap,
    speed_levels,
    unsat_below_zero,
)
from verification.proof.premises import (  # noqa: I001
    COVERED_MODE,
    Premise,
    model_premises,
    operators_reach,
    setting,
    tracks_never_end,
)
from verification.spaces.box import ScenarioSpace, stop_times_words
from verification.spaces.recorded import recorded_speed, tracked_from_start
from verification.spaces.space import parameter_ranges


@dataclasses.dataclass(frozen=True)

class Proof:
    """The outcome of ``prove``: ``proved`` only if every premise holds and z3 showed
    M >= 0 over the box."""

    proved: bool
    method: str
    box: dict
    premises: list  # Premise records
    margin_at_worst_corner: float | None
    terms: dict
    placeholder_braking: bool = False  # the built-in stopping data, not measured data
    property: str = "contact"  # the theorem: "contact", "separation", "permitted_contact"
    # separation: how much larger Z_d + Z_r must be for M_S >= 0 over the box (0 when it
    # is; None when a premise fails)
    needed_allowance: float | None = None
    robot_mode: str = COVERED_MODE  # the robot mode the theorem covers


def _declined(cell: ResolvedCell, space: ScenarioSpace, prop: str, method: str
              ) -> Proof:
    """A recording space's proof, declined: the theorems' margins are checked over the
    box of a scripted space's parameters, where the peak speed bounds every body's
    speed and every body is seen standing still for the settle time before it moves.
    Recorded motion has neither parameter. The premises a proof over it would need (the
    speed bound, every body seen from the start, no exit reached) are measured from the
    recording and listed, but no margin is checked over it, so the verdict over a
    recording space is ``passed`` or ``falsified``, never ``proved``."""
    check_cell(cell, space)
    config = cell.config
    f, t = config.safety, config.tracker
    p = space.recording.parameters
    v_max = recorded_speed(space.recording) * p.time_scale.max
    checked = model_premises(cell, space) + [
        (f"hidden bodies stay hazards (hidden_bodies: {t.hidden_bodies}) and a hidden "
         f"body's ball grows at least as fast as the recorded bodies move (occlusion_speed "
         f"{f.occlusion_speed:g} >= {v_max:.3f} m/s: the fastest segment of the part of the "
         f"recording the space plays at the "
         f"largest time scale, {p.time_scale.max:g})",
         t.hidden_bodies == "hazard" and f.occlusion_speed >= v_max),
        (f"the gate admits the recorded bodies' speeds (gate_speed {t.gate_speed:g} >= "
         f"{v_max:.3f} m/s)", not t.gate or t.gate_speed >= v_max),
        ("every body is tracked from t = 0 at every point of the box (seen before the "
         "robot first moves)", tracked_from_start(space)),
        ("no body reaches an exit region or the cell's walls (where its track would end): "
         f"all within {operators_reach(space):.2f} m of the base",
         tracks_never_end(config, space)),
        ("the operators are the scripted approaches the theorem's margin is checked over "
         "(a speed bound from their peak speed, every body seen standing still before it "
         "moves): a recording space's operators move as recorded, and no margin is "
         "checked over recorded motion, so this space is searched, never proved", False),
    ]
    trusted = [
        "the recording is the operators' true motion, linear between its samples, and "
        "the mapping puts it in the cell frame",
        "the stopping data describes the real robot's stops, "
        + stop_times_words(p.braking_time_scale),
    ]
    premises = ([Premise(x, bool(ok), "checked") for x, ok in checked]
                + [Premise(x, True, "trusted") for x in trusted])
    box = {name: [r.min, r.max] for name, r in parameter_ranges(space).items()}
    return Proof(False, method, box, premises, None, {},
                 cell.braking_source == "placeholder", prop)


def _worst(m: Margin, space: ScenarioSpace) -> tuple[float, int]:
    """The margin at the box's worst corner (the largest v_max: every row falls with it)
    and the row it is least in."""
    p = space.parameters
    rows = m.rows_at(p.peak_speed.max)
    i = int(np.argmin(rows))
    return float(rows[i]), i


def _z3_premise(name: str, lv: Levels, holds: bool, worst: float, i: int
                ) -> Premise:
    if not lv.by_speed:
        return Premise(f"z3: {name} >= 0 for every v_max in the box", holds, "checked")
    return Premise(f"z3: {name}(g) >= 0 at every speed level g = 1..{SPEED_LEVELS} for every "
                   f"v_max in the box (least at level {int(lv.level[i])}, rate "
                   f"{lv.rate[i]:.4f}: {worst:.4f} m at the worst corner)", holds, "checked")


def _level_terms(lv: Levels, m: Margin, space: ScenarioSpace, i: int) -> dict:
    """The terms that say which speed level the margin is least at (by_speed)."""
    f = {"stopping": "by_speed" if lv.by_speed else "full_speed"}
    if lv.by_speed:
        p = space.parameters
        rows = m.rows_at(p.peak_speed.max)
        f |= {"speed_level": int(lv.level[i]), "level_rate": float(lv.rate[i]),
              "previous_rate": float(lv.previous_rate[i]),
              "level_margins": {str(int(g)): float(x) for g, x in zip(lv.level, rows)}}
    return f


def _method(theorem: str, stopping: str) -> str:
    """The ``method`` a proof of ``theorem`` (``stopping`` or ``separation``) states."""
    return (f"SSM {theorem} theorem over the robot's capsules (verification.proof); "
            "margin checked over the box by z3"
            + (", at every speed level" if stopping == "by_speed" else "")
            + "; robot bounds by Lipschitz covering; tracker error by gain recursion")


def prove(cell: ResolvedCell, space: ScenarioSpace) -> Proof:
    """Tries to prove "stopped before contact" for the cell's configuration over ``space``
    (under ``safety.stopping: by_speed`` at every speed level); ``cell`` is resolved for
    the space's robot (``spaces.space.space_cell``)."""
    config = cell.config
    f = config.safety
    h = 1.0 / space.robot.control_rate_hz
    v = {"iso": min(f.iso_human_speed, f.iso_reduced_human_speed),
         "estimated_with_floor": f.iso_human_speed}.get(f.human_speed, 0.0)
    method = _method("stopping", f.stopping)
    if space.recording is not None:
        return _declined(cell, space, "contact", method)
    premises, box, placeholder, (alpha, beta), _ = setting(cell, space, "contact")
    if not all(x.holds for x in premises):
        return Proof(False, method, box, premises, None, {}, placeholder)
    lv = speed_levels(cell, space)
    tau = cell.frame_timeout
    m = margin_of_levels(cell, space, "contact", lv)
    holds = unsat_below_zero(m, space)
    worst, i = _worst(m, space)
    terms = {"v": v, "T_s": float(lv.t_s[i]), "T_r": f.reaction_time, "B": float(lv.b[i]),
             "tau": tau, "h": h, "V_R": lv.tool_speed, "robot_speed": f.robot_speed,
             "T_stop": float(lv.stop_time[i]), "D": float(lv.stop_travel[i]),
             "E_per_axis": {"alpha": alpha, "beta": beta},
             "tracking_allowance": config.body.tracking_allowance,
             "C+Z_d+Z_r": f.intrusion_distance + f.human_uncertainty + f.robot_uncertainty,
             "contact_distance": space.contact_distance} | _level_terms(lv, m, space, i)
    premises = premises + [_z3_premise("M", lv, holds, worst, i)]
    return Proof(holds, method, box, premises, worst, terms, placeholder)


def prove_separation(cell: ResolvedCell, space: ScenarioSpace) -> Proof:
    """Tries to prove the separation invariant for the cell's configuration over ``space``
    (the second theorem of the module docstring; under ``safety.stopping: by_speed`` at
    every speed level); when the margin falls short, says by how much Z_d + Z_r would have
    to grow (``Proof.needed_allowance``: every level's margin gains what Z_d + Z_r gains).
    ``cell`` is resolved for the space's robot (``spaces.space.space_cell``)."""
    config = cell.config
    f = config.safety
    p = space.parameters
    floor = f.human_speed == "estimated_with_floor"
    v_lo = f.iso_human_speed if floor else min(f.iso_human_speed, f.iso_reduced_human_speed)
    method = _method("separation", f.stopping)
    if space.recording is not None:
        return _declined(cell, space, "separation", method)
    premises, box, placeholder, (alpha, beta), _ = setting(cell, space, "separation")
    if not all(x.holds for x in premises):
        return Proof(False, method, box, premises, None, {}, placeholder, "separation")
    lv = speed_levels(cell, space)
    tau = cell.frame_timeout
    m = margin_of_levels(cell, space, "separation", lv)
    holds = unsat_below_zero(m, space)
    worst, i = _worst(m, space)
    v_hi = float(m.human_speed(p.peak_speed.max))  # S_true's human speed, at most
    t_s, t_true = float(lv.t_s[i]), float(m.t_true[i])  # T_stop + T_r of S_true
    terms = {"v_lo": v_lo, "v_hi": v_hi, "T_s": t_s,
             "T_r": f.reaction_time, "B": float(lv.b[i]), "tau": tau, "V_R": lv.tool_speed,
             "T_stop": float(lv.stop_time[i]), "D": float(lv.stop_travel[i]),
             "E_per_axis": {"alpha": alpha, "beta": beta},
             "Z_d+Z_r": f.human_uncertainty + f.robot_uncertainty,
             "human_speed_term": v_lo * (t_s + f.reaction_time) - v_hi * t_true,
             "robot_speed": f.robot_speed,
             "robot_speed_term": float(robot_speed_gap(cell, space, lv)[i])
             * f.reaction_time,
             "stopping_distance_term": float(lv.b[i] - lv.stop_travel[i]),
             "sensing_term": -float(m.k_speed[i] * p.peak_speed.max),
             "tracking_allowance": config.body.tracking_allowance} \
        | _level_terms(lv, m, space, i)
    premises = premises + [_z3_premise("M_S", lv, holds, worst, i)]
    return Proof(holds, method, box, premises, worst, terms, placeholder, "separation",
                 0.0 if holds else max(-worst, 0.0))


def prove_permitted_contact(cell: ResolvedCell, space: ScenarioSpace) -> Proof:
    """Tries to prove "permitted contact" for the cell's configuration over ``space``
    (resolved for the space's robot: ``spaces.space.space_cell``; Theorem 3 of the
    module docstring). Under ``safety.mode: ssm`` stopped before contact implies it, and
    its proof is Theorem 1's; under ``ssm_pfl`` Theorem 1's margin with the power and
    force limiting premises (caps within the limits, the rate following commands by the
    stop's steps, the clamping margin) checked, and Annex A's limits, the payload, the
    fixed surfaces and the meaning of relative speed trusted."""
    base = prove(cell, space)
    f = cell.config.safety
    if f.mode != "ssm_pfl":
        return dataclasses.replace(base, property="permitted_contact", premises=base.premises + [
            Premise("safety.mode is ssm: stopped before contact (proved here) leaves no "
                    "contact while the robot moves, so every such contact is permitted",
                    True, "checked")])
    method = ("SSM/PFL permitted-contact theorem (verification.proof, Theorem 3): "
              + base.method)
    if space.recording is not None:
        return dataclasses.replace(base, property="permitted_contact", method=method)
    pfl = cell.pfl
    h = 1.0 / space.robot.control_rate_hz
    v_max = space.parameters.peak_speed.max
    lv = speed_levels(cell, space)
    t_stop = float(np.max(lv.stop_time))
    window = cell.frame_timeout + t_stop + h
    surface_needed = v_max * window
    # between two links the robot's capsules move too: at most V_R h + D after the last
    # tick the cap was checked (the braking's own travel)
    reach_needed = surface_needed + lv.tool_speed * h + float(np.max(lv.stop_travel))
    limits = ", ".join(f"{name} {v:.3f}" for name, v in zip(SEGMENT_NAMES, pfl.limits))
    # a contact that lasts: the most the robot can press into segment i, from its contact
    # detection's indentation, at its cap's speed until the stop holds and while it brakes
    x_tr, x_qs, x_det = pfl.compressions.T
    pressed = x_det + pfl.caps * pfl.speed_bound * (f.contact_detection_time + t_stop + 2 * h)
    lasting = pfl.caps > 0.0
    worst = ", ".join(f"{name} {1e3 * a:.2f} mm of {1e3 * b:.2f}" for name, a, b, on in zip(
        SEGMENT_NAMES, pressed, x_qs, lasting) if on) or "none: every cap is 0"
    checked = [
        (f"each segment's cap keeps the robot at or below its permissible speed: c_i V_R <= "
         f"v_i (V_R {pfl.speed_bound:.4f} m/s by the Lipschitz cover of the monitor's "
         f"capsule axes, at least the proof's {lv.tool_speed:.4f}; v_i in m/s: {limits}; "
         "head and neck 0)",
         bool(np.all(pfl.caps * pfl.speed_bound <= pfl.limits * (1.0 + 1e-12)))
         and pfl.speed_bound >= lv.tool_speed * (1.0 - 1e-12)
         and not np.any(pfl.caps[SEGMENT_FORBIDDEN] > 0.0)),
        ("a command below the path rate brings the rate down by the stop's own steps and "
         "never below the command, and one at or above it never takes the rate past it "
         "(braking.rate_step_one on a grid of rates and commands)",
         follows_commands(cell, h, space.parameters.braking_time_scale.max,
                          space.robot.acceleration_limit)),
    ]
    checked.append((f"clamping: a segment's envelope loses its cap within clamp_margin "
                    f"{f.clamp_margin:g} m + CLAMP_GAP of the robot's mounting surface, a "
                    "declared fixed surface or two of the robot's links, at least how far a "
                    f"body moves in tau + T_stop + h (v_max {v_max:g} m/s x {window:.3f} s = "
                    f"{surface_needed:.3f} m) and the links in the tick and the stop (V_R h "
                    f"+ D): {reach_needed:.3f} m (or no segment has a cap: pure SSM)",
                    f.clamp_margin >= reach_needed or not bool(np.any(lasting))))
    checked.append((
        "a contact that lasts stays within the quasi-static compression (pfl.contact_limits: "
        "F / k of Table A.2 and A.3, the strictest region of each segment): the robot's "
        "contact detection indentation x_det (contact_stop_force "
        f"{f.contact_stop_force:g} N over the softest region's k) plus its cap's speed c_i "
        f"V_R for the detection time {f.contact_detection_time:g} s, T_stop and two ticks "
        f"is at most x_qs for every segment with a cap ({worst}); the transient "
        "compression x_tr is larger", bool(np.all(pressed[lasting] <= x_qs[lasting]))
        and bool(np.all(x_qs <= x_tr))))
    trusted = [
        "ISO/TS 15066:2016 Annex A's transient contact limits (Table A.2) and its body "
        "models' effective masses and spring constants (Table A.3) for every region a "
        "segment may present (pfl.segment_regions), and its energy model (Eqs. A.3, A.4)",
        f"the robot's effective mass {pfl.effective_mass:.2f} kg: half its moving mass (its "
        f"URDF's inertials) plus the configured payload {f.payload_mass:g} kg, the real "
        "tool and workpiece",
        "the relative speed of a contact is the robot's speed towards the body at the "
        "contact (Eq. 7's v_R^d; the operator's own speed is not counted: our reading of "
        "Annex A)",
        ("the robot's mounting surface (robot.mounting_size, else a square over its reach) "
         "and the declared fixed surfaces are every object in the cell a body region could "
         f"be pressed against ({len(pfl.boxes) - 1} declared)"),
        (f"the robot's own contact detection stops it (a protective stop, held while the "
         f"contact lasts) once its contact force has reached {f.contact_stop_force:g} N "
         f"(its force limit plus that limit's tolerance) for "
         f"{f.contact_detection_time:g} s, and it then stops by its stopping data; the "
         "proof takes this for a contact anywhere on the links and tool, while Universal "
         "Robots specify their force limit at the tool (the flange and the tool positions "
         "set) and the elbow only (e-Series Tool Force and Elbow Force): for a contact "
         "elsewhere on a link the integrator must show the robot detects it too"),
        (f"a transient contact's window is {f.transient_window:g} s from the impact; after it "
         "the quasi-static limits apply (ISO/TS 15066 5.5.5 and Annex A as applied)"),
    ]
    premises = (base.premises + [Premise(x, bool(ok), "checked") for x, ok in checked]
                + [Premise(x, True, "trusted") for x in trusted])
    proved = base.proved and all(x.holds for x in premises)
    terms = dict(base.terms) | {"caps": pfl.caps.tolist(), "limits": pfl.limits.tolist(),
                                "V_R_caps": pfl.speed_bound, "effective_mass": pfl.effective_mass,
                                "clamp_reach_needed": reach_needed,
                                "pressed_most": pressed.tolist(),
                                "quasi_static_compression": x_qs.tolist()}
    return dataclasses.replace(base, proved=proved, method=method, premises=premises,
                               terms=terms, property="permitted_contact")


def follows_commands(cell: ResolvedCell, period: float, scale: float,
                     acceleration_limit: float = 2.0) -> bool:
    """Whether one tick of the path rate (``braking.rate_step_one``, the cell's braking
    table at time scale ``scale``) towards a command c from a rate r is max(c, the stop's
    step from r) at most when c < r, and at most c when c >= r (to 1e-12: the step's
    rounding), on a grid of rates and commands in [0, 1]."""
    table = cell.braking
    rates = np.linspace(0.0, 1.0, 401)
    r, c = np.meshgrid(rates, rates, indexing="ij")
    step = path_rate_step(r.ravel(), c.ravel(), period, table=table,
                          acceleration_limit=acceleration_limit, time_scale=scale)
    stop = path_rate_step(r.ravel(), 0.0, period, table=table,
                          acceleration_limit=acceleration_limit, time_scale=scale)
    below = c.ravel() < r.ravel()
    return bool(np.all(step[below] <= np.maximum(c.ravel()[below], stop[below]) + 1e-12)
                and np.all(step[~below] <= c.ravel()[~below] + 1e-12))
