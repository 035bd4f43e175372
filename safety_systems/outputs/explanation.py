"""What ``safety-systems explain`` shows of a resolved cell (``config.resolved_cell``): each
segment's protective separation distance S at a few speed levels, which term of it
dominates, what the override commands at a few distances, and the premises each figure
rests on.

S is computed by the monitor's own compiled function (``formulas.body_protective_distance``,
which ``separation.segment_levels`` and ``separation.pair_separation`` call, here through
``formulas.monitor_protective_distances``) with the resolved terms: T_s + T_r and B + C + Z_r of each speed level (``safety.stopping:
by_speed``) or of full speed, and the command by the override's
(``formulas.override_decision``). The speeds are the worst the premises allow: the human
speed bound (ISO 13855's 2.0 m/s hand speed, or a space's peak speed) and the robot's
speed towards the body at path rate k, at most k V_R (V_R: the monitor's capsules'
fastest axis point on the robot's path at rate 1, ``path_speed.path_speed_bound``).
"""

import dataclasses
import math

import numpy as np

from safety_systems.cell import human_body
from safety_systems.config.resolved_cell import ResolvedCell
from safety_systems.sensing.tracks import TRACK_TRACKING
from safety_systems.ssm.formulas import (
    HUMAN_SPEED_MODES,
    SPEED_LEVELS,
    human_speed,
    level_at_or_above,
    monitor_protective_distances,
    override_decision,
)

RATES = (1.0, 0.6, 0.4, 0.2)  # the path rates k the table shows by default
DISTANCES = (0.5, 1.0, 1.5, 2.0, 3.0)  # m: the clearances the command table shows
TERMS = ("human speed x time", "robot speed x T_r", "stopping distance",
         "C + envelope", "Z_d + Z_r")
SHORT = dict(zip(TERMS, ("human", "robot", "stop", "C+env", "Z")))  # the table's words
ISO_HAND_SPEED = 2.0  # m/s, ISO 13855's hand and arm speed


def level_distances(cell: ResolvedCell, v_human, v_robot, std=0.0) -> np.ndarray:
    """S (m) at every speed level g = 0..SPEED_LEVELS, shape (G + 1,) + the speeds'
    shape, of a segment whose pair with a robot capsule has the directed human speed
    ``v_human`` and robot speed ``v_robot`` (m/s) and whose tracks' position std is
    ``std`` (m; Z_d = base + sigmas std), by the monitor's compiled
    ``formulas.body_protective_distance`` (through ``monitor_protective_distances``) with
    the cell's stops: each level's T_s and B under ``by_speed``, else the full-speed ones
    at every level (what the SeparationMonitor's ``level_protective_distances`` and
    ``protective_distances`` hold; T_s + T_r and B + C + Z_r summed in the order
    ``configuration.level_terms`` and ``monitor_terms`` sum them)."""
    f = cell.config.safety
    v_h, v_r, std = np.broadcast_arrays(*(np.asarray(x, dtype=float)
                                          for x in (v_human, v_robot, std)))
    base, sigmas = cell.z_d_terms

    def at(t_s: float, b: float) -> np.ndarray:
        return monitor_protective_distances(
            v_h, v_r, mode=f.human_speed, reaction_time=f.reaction_time, stopping_time=t_s,
            stopping_distance=b, intrusion_distance=f.intrusion_distance,
            human_uncertainty=base + sigmas * std, robot_uncertainty=f.robot_uncertainty,
            iso_speed=f.iso_human_speed, iso_reduced_speed=f.iso_reduced_human_speed)

    if f.stopping != "by_speed":
        return np.broadcast_to(at(*cell.stopping), (SPEED_LEVELS + 1,) + v_h.shape).copy()
    return np.stack([at(t_s, b) for t_s, b in zip(*cell.level_stops)])


def human_speed_bound(peak_speed: float | None = None) -> float:
    """The directed human speed the table takes (m/s): the space's peak speed, else ISO
    13855's hand speed; ``iso`` mode replaces it by its constant in S (``human_speed``)."""
    return ISO_HAND_SPEED if peak_speed is None else float(peak_speed)


@dataclasses.dataclass(frozen=True)
class SegmentFigure:
    """One segment at one path rate: S and its terms, m."""

    segment: str
    rate: float  # k
    level: int  # g: the level at or above k whose S the robot keeps
    v_human: float  # m/s, as S takes it (by the human-speed mode)
    v_robot: float  # m/s, k V_R
    terms: dict  # TERMS -> m
    s: float  # S, m (the monitor's)
    dominant: str  # the largest of TERMS


def envelope_widths(cell: ResolvedCell) -> tuple[np.ndarray, list[str]]:
    """Each segment's envelope beyond its axis while seen (m): its radius plus the
    tracking allowance, and how it is bounded: ``tracked`` (its points are tracked: the
    capsule between their estimates) or ``from A, B`` (an envelope of the tracked points,
    wider still as the posture allows)."""
    recipe, allowance = cell.recipe, cell.config.body.tracking_allowance
    direct = {int(row[0]) for row in recipe.candidates
              if int(row[4]) == human_body.KIND_DIRECT}
    how = []
    for m, name in enumerate(recipe.names):
        if m in direct:
            how.append("tracked")
        else:
            k = int(recipe.operator[m])
            how.append("from " + ", ".join(cell.points[k]))
    return recipe.radius + allowance, how


def segment_figures(cell: ResolvedCell, rates=RATES, peak_speed: float | None = None
                    ) -> list[SegmentFigure]:
    """Every segment's :class:`SegmentFigure` at each path rate of ``rates``."""
    f = cell.config.safety
    widths, _ = envelope_widths(cell)
    mode = cell.monitor_terms[0]
    bound = human_speed_bound(peak_speed)
    out = []
    for m, name in enumerate(cell.segment_names):
        for k in rates:
            g = int(level_at_or_above(k, SPEED_LEVELS))
            v_r = k * cell.speed_bound
            s = float(level_distances(cell, bound, v_r)[g])
            by_speed = f.stopping == "by_speed"
            t_s = cell.level_stops[0][g] if by_speed else cell.stopping[0]
            b = cell.level_stops[1][g] if by_speed else cell.stopping[1]
            robot = v_r * f.reaction_time
            z = f.human_uncertainty + f.robot_uncertainty
            human = s - robot - b - f.intrusion_distance - z  # the 1.6 m/s rule included
            terms = {TERMS[0]: human, TERMS[1]: robot, TERMS[2]: float(b),
                     TERMS[3]: f.intrusion_distance + float(widths[m]), TERMS[4]: z,
                     "C": f.intrusion_distance}
            dominant = max(TERMS, key=lambda t: terms[t])
            t_sr = t_s + f.reaction_time  # v_H as S took it (iso: 1.6 m/s where S > 0.5 m)
            v_h = human / t_sr if t_sr > 0.0 else human_speed(bound, mode, f.iso_human_speed)
            out.append(SegmentFigure(name, float(k), g, float(v_h), float(v_r), terms, s,
                                     dominant))
    return out


def commands(cell: ResolvedCell, rates=RATES, distances=DISTANCES,
             peak_speed: float | None = None) -> np.ndarray:
    """(rates, distances) the path rate the override commands (``override_decision``)
    with the robot at rate k and one segment, tracked, at that clearance, its S at the
    speed bounds (the same for every segment: its power and force limiting cap, under
    ssm_pfl, is the least of the segments')."""
    f = cell.config.safety
    bound = human_speed_bound(peak_speed)
    caps = cell.pfl.caps if f.mode == "ssm_pfl" else None
    out = np.empty((len(rates), len(distances)))
    for a, k in enumerate(rates):
        s = level_distances(cell, bound, k * cell.speed_bound)
        protective = s[:, None] if f.stopping == "by_speed" else s[-1:]
        for b, d in enumerate(distances):
            out[a, b] = override_decision(
                np.array([d]), protective, np.array([float(TRACK_TRACKING)]), 0.0, rate=k,
                caps=None if caps is None else np.array([float(caps.min())]),
                delta_s=f.delta_s, d_min=f.d_min)[0]
    return out


def premises(cell: ResolvedCell, peak_speed: float | None = None,
             noise_bound: float | None = None) -> list[tuple[str, str]]:
    """(basis, statement) of what the figures rest on: ``trusted`` (taken from the files
    and the real cell) or ``computed`` (from the configuration and the robot's model)."""
    f, c = cell.config.safety, cell.config
    t_s, b = cell.stopping
    source = (cell.braking_warning.rstrip(".") if cell.braking_source == "placeholder"
              else "the configuration's braking table")
    rows = [("trusted", f"stopping data ({source}): T_s = {t_s:g} s and B = {b:g} m from full "
                        "speed" + (", and the table's rows below full speed for the levels"
                                   if f.stopping == "by_speed" else " at every speed"))]
    bound = human_speed_bound(peak_speed)
    where = ("the space's peak speed" if peak_speed is not None
             else "ISO 13855's hand and arm speed")
    mode = f.human_speed
    if mode == "iso":
        rows.append(("trusted", (f"hand speed: S takes v_H = {f.iso_human_speed:g} m/s "
                                f"(safety.iso_human_speed; {f.iso_reduced_human_speed:g} m/s "
                                "where S exceeds 0.5 m); no body point moves faster than "
                                f"{bound:.3g} m/s ({where})"
                                + (": FASTER THAN THE v_H S TAKES"
                                   if bound > f.iso_human_speed else ""))))
    else:
        rows.append(("trusted", f"hand speed: S takes the tracker's directed estimate "
                                f"({mode}); the table takes its bound {bound:.3g} m/s ({where})"
                                + (f", at least {f.iso_human_speed:g} m/s"
                                   if mode == HUMAN_SPEED_MODES[2] else "")))
    noise = c.sensor.noise_std if noise_bound is None else noise_bound
    rows.append(("trusted", f"sensor noise: {noise:g} m per axis "
                            + ("(the space's bound)" if noise_bound is not None
                               else "(sensor.noise_std)")
                            + f"; Z_d = {f.human_uncertainty:g} m"
                            + (f" + {f.human_uncertainty_sigmas:g} position std (the table "
                               "takes std 0: at run time S is larger by that)"
                               if f.human_uncertainty_sigmas else "")))
    rows.append(("trusted", ("the operator's body within the configuration's dimensions "
                            f"(tracking allowance {c.body.tracking_allowance:g} m, radii "
                            "cell/human_body.py or the configuration's body block)")))
    rows.append(("computed", (f"V_R = {cell.speed_bound:.3f} m/s: the monitor's capsules' "
                             f"fastest point on {cell.model.name}'s path at rate 1 "
                             f"(robot speed {f.robot_speed}: at rate k at most k V_R)")))
    rows.append(("computed", (f"frame timeout {cell.frame_timeout:.3f} s; T_r = "
                             f"{f.reaction_time:g} s, C = {f.intrusion_distance:g} m, Z_r = "
                             f"{f.robot_uncertainty:g} m, dS = {f.delta_s:g}, d_min = "
                             f"{f.d_min:g} m (the configuration)")))
    if f.mode == "ssm_pfl":
        rows.append(("trusted", "power and force limiting: the segments' caps "
                                + ", ".join(f"{x:.3f}" for x in cell.pfl.caps)
                                + f" (path rate), effective mass {cell.pfl.effective_mass:.2f}"
                                f" kg, {len(cell.pfl.boxes)} clamping surface(s)"))
    return rows


def explanation(cell: ResolvedCell, rates=RATES, distances=DISTANCES,
                peak_speed: float | None = None, noise_bound: float | None = None) -> dict:
    """The explanation as data (what ``explain --json`` writes)."""
    widths, how = envelope_widths(cell)
    return {
        "robot": cell.model.name,
        "stopping": cell.config.safety.stopping,
        "braking_data": cell.braking_source,
        "speed_bound": cell.speed_bound,
        "rates": list(rates),
        "segments": [
            {"segment": fig.segment, "rate": fig.rate, "level": fig.level,
             "v_human": fig.v_human, "v_robot": fig.v_robot, "S": fig.s,
             "dominant": fig.dominant, "envelope": float(widths[m // len(rates)]),
             "envelope_from": how[m // len(rates)],
             "terms": dict(fig.terms)}
            for m, fig in enumerate(segment_figures(cell, rates, peak_speed))],
        "distances": list(distances),
        "commands": commands(cell, rates, distances, peak_speed).tolist(),
        "premises": [{"basis": b, "statement": s}
                     for b, s in premises(cell, peak_speed, noise_bound)],
    }


def _m(x: float) -> str:
    return f"{x:.3f}" if math.isfinite(x) else "-"


def explanation_heading(data: dict) -> str:
    """One line: the robot, how S follows the speed, the stopping data's source, V_R."""
    return (f"robot {data['robot']}; S {data['stopping'].replace('_', ' ')}; stopping data: "
            f"{data['braking_data']}; V_R {data['speed_bound']:.3f} m/s")


def explanation_tables(data: dict) -> list[tuple[str, list[str], list[list[str]]]]:
    """The explanation (:func:`explanation`) as (caption, head, rows) of text: each
    segment's S and dominating term at each rate, S's terms at each rate, the override's
    command at each rate and clearance, and the premises. ``explain`` prints them and
    the assessor's report.html shows them."""
    rates, rows = data["rates"], data["segments"]
    by_segment = [rows[i:i + len(rates)] for i in range(0, len(rows), len(rates))]
    in_s = TERMS[:3] + ("C",) + TERMS[4:]
    return [
        ("S (m) of each segment at path rate k and the term that dominates it ("
         + ", ".join(f"{w}: {t}" for t, w in SHORT.items()) + "); envelope (m): how far "
         "beyond its axis the monitor takes the segment while seen, the least where it "
         "is bounded from other points (the posture widens it)",
         ["segment", "envelope", "bounded"] + [f"k = {k:g}" for k in rates],
         [[g[0]["segment"], _m(g[0]["envelope"]), g[0]["envelope_from"]]
          + [f"{_m(r['S'])} {SHORT[r['dominant']]}" for r in g] for g in by_segment]),
        (("terms of S (m) at each k (the same for every segment; the envelope is taken off "
         "the clearance d, not added to S)"),
         ["k", "level", "v_H", "v_R", *in_s, "S"],
         [[f"{r['rate']:g}", str(r["level"]), f"{r['v_human']:.2f}", f"{r['v_robot']:.3f}"]
          + [_m(r["terms"][t]) for t in in_s] + [_m(r["S"])] for r in by_segment[0]]),
        (("path rate the override commands with a segment at clearance d (m), the robot at "
         "rate k"),
         ["k"] + [f"d = {d:g}" for d in data["distances"]],
         [[f"{k:g}"] + [f"{x:.3f}" for x in row] for k, row in zip(rates, data["commands"])]),
        ("premises", ["basis", "statement"],
         [[p["basis"], p["statement"]] for p in data["premises"]]),
    ]


def explanation_text(data: dict) -> str:
    """The explanation (:func:`explanation`) as tables a person reads: the first column
    left-aligned, the others right-aligned (the premises left-aligned, one per line)."""
    lines = [explanation_heading(data)]
    for caption, head, rows in explanation_tables(data):
        lines += ["", caption]
        if caption == "premises":
            lines += [f"  {basis}: {statement}" for basis, statement in rows]
            continue
        widths = [max(len(str(x)) for x in column) for column in zip(head, *rows)]
        for row in [head, *rows]:
            lines.append("  ".join(x.ljust(w) if j == 0 or (j == 2 and head[2] == "bounded")
                                   else x.rjust(w) for j, (x, w) in enumerate(zip(row, widths)))
                         .rstrip())
    return "\n".join(lines) + "\n"
