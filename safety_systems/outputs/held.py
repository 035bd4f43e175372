"""What held the robot in a run, in the terms an integrator can act on (issue 47: every
stop explained): the seconds of each protective stop's cause, and for the separation
stops the segment that held it (the nearest in the monitor's measure: where that
segment's points are untracked, an envelope bounded from the tracked ones) with the true
clearance of the real body at those ticks. A large gap between the two says the envelope,
not the person, held the robot: tracking that segment's points is what would release it.

Shared by ``simulate``'s summary.json and console line and by ``tune`` (the chosen
configuration's tasks, in tune.json and tune.md); the live run counts the same fields as
its ticks come (``runtime.run_tally``).
"""

import numpy as np

from safety_systems.cell.human_body import SEGMENT_NAMES, SEGMENTS
from safety_systems.config.configuration import tracked_points
from safety_systems.diagrams.simulation import Run
from safety_systems.outputs.metrics import protective_stops, stop_reasons
from safety_systems.outputs.operator_figures import operator_figures
from safety_systems.sensing.stops import STOP_SEPARATION


def held_by(run: Run) -> dict:
    """``causes``: seconds held per protective stop cause (those that held it at all);
    ``separation``: the separation stops' seconds (``time``), those seconds by the
    segment that held the robot (``by_segment``, the most first; under ``safety.mode:
    ssm_pfl`` the nearest segment without a cap in force, since a capped one cannot stop
    the robot), and the median true clearance of the nearest real segment at those ticks
    (``true_clearance_median``, m; None without a body present). Runs without the SSM
    monitor (the seed-004 controllers, the zones) give the causes only."""
    causes = {name: stop["time"] for name, stop in protective_stops(run).items()
              if stop["time"] > 0.0}
    out: dict = {"causes": causes}
    if "monitor.distances" not in run.signals or not run.time.size:
        return out
    dt = np.diff(run.time, append=run.time[-1])
    held = stop_reasons(run) == STOP_SEPARATION
    nearest_d = np.full(run.time.size, np.inf)
    nearest = np.full(run.time.size, np.nan)
    true_least = np.full(run.time.size, np.inf)
    for op in operator_figures(run):
        d = np.where(np.isnan(op["d_measured"]), np.inf, op["d_measured"])
        closer = d < nearest_d
        nearest_d = np.where(closer, d, nearest_d)
        nearest = np.where(closer, op["nearest_measured"], nearest)
        true_least = np.fmin(true_least, op["d_true"])
    if "override.segment_caps" in run.signals and \
            run.scenario.controller.safety.mode == "ssm_pfl":
        d = np.where(run["override.segment_caps"] > 0.0, np.inf, run["monitor.distances"])
        d = np.where(np.isnan(d), np.inf, d)
        nearest = np.where(np.isfinite(d.min(axis=1)),
                           np.argmin(d, axis=1) % len(SEGMENT_NAMES), np.nan)
    by_segment: dict[str, float] = {}
    for k in np.flatnonzero(held):
        name = SEGMENT_NAMES[int(nearest[k])] if np.isfinite(nearest[k]) else "none"
        by_segment[name] = by_segment.get(name, 0.0) + float(dt[k])
    true_held = true_least[held & np.isfinite(true_least)]
    measured_held = nearest_d[held & np.isfinite(nearest_d)]
    ordered = dict(sorted(by_segment.items(), key=lambda x: -x[1]))
    out["separation"] = {
        "time": float(np.sum(dt[held])),
        "by_segment": ordered,
        "true_clearance_median": float(np.median(true_held)) if true_held.size else None,
        "measured_clearance_median": float(np.median(measured_held))
        if measured_held.size else None,
        "untracked_points": untracked_points(next(iter(ordered), "none"),
                                             tracked_points(run.scenario))}
    out["separation"]["lowest_speed"] = lowest_speed_terms(
        run.scenario, next(iter(ordered), "none"), out["separation"])
    return out


def lowest_speed_terms(scenario, segment: str, separation: dict) -> dict | None:
    """What the monitor asked of ``segment`` before the robot could move at all: S at the
    lowest speed level (the human's speed bound, ``explanation.segment_figures``) with its
    terms, d_min, which of the two binds, the largest term of S, and how far the segment's
    envelope reached beyond the real body (the true minus the measured clearance, medians:
    what tracking its points would give back). None for no segment, another controller,
    or a human speed in S that is not a constant floor (``estimated``: S then follows the
    tracker's speeds, not a bound the monitor keeps)."""
    from safety_systems.config.resolved_cell import resolve_scenario
    from safety_systems.outputs.explanation import TERMS, segment_figures
    from safety_systems.ssm.formulas import SPEED_LEVELS

    if segment == "none" or scenario.controller.type != "ssm_override" or \
            scenario.controller.safety.human_speed == "estimated":
        return None
    figures = [f for f in segment_figures(resolve_scenario(scenario),
                                          rates=(1.0 / SPEED_LEVELS,))
               if f.segment.rsplit("/", 1)[-1] == segment]
    if not figures:
        return None
    f = max(figures, key=lambda x: x.s)
    terms = {t: float(f.terms[t]) for t in TERMS if t != "C + envelope"}
    d_min = float(scenario.controller.safety.d_min)
    true, measured = separation["true_clearance_median"], separation["measured_clearance_median"]
    return {"S": float(f.s), "terms": terms, "dominant": max(terms, key=terms.get),
            "d_min": d_min, "binding": "d_min" if d_min >= f.s else "S",
            "envelope_beyond_body": None if true is None or measured is None
            else max(0.0, float(true) - float(measured))}


def untracked_points(segment: str, tracked: list[list[str]]) -> list[str]:
    """The body points of ``segment`` (its two ends, ``human_body.SEGMENTS``) that no
    operator's bodies mark: tracking them is what would bound it by its own points
    instead of an envelope of the others (empty: its points are tracked, or no segment)."""
    ends = next((s[1:3] for s in SEGMENTS if s[0] == segment), ())
    marked = {q for points in tracked for q in points}
    return [q for q in dict.fromkeys(ends) if q not in marked]


def held_words(held: dict) -> str:
    """The console's words for :func:`held_by`: the separation stops' segments, most
    first, with the real body's median clearance; empty when nothing held the robot."""
    separation = held.get("separation") or {}
    if not separation.get("time"):
        return ""
    parts = ", ".join(f"{name} {t:.1f} s" for name, t in separation["by_segment"].items())
    clearance = separation["true_clearance_median"]
    measured = separation.get("measured_clearance_median")
    then = []
    if clearance is not None:
        then.append(f"the real body then {clearance:.2f} m away, median")
    if measured is not None:
        then.append(f"the monitor's measure {measured:.2f} m")
    low = separation.get("lowest_speed")
    if low:
        binding = (f"d_min {low['d_min']:.3f} m binds" if low["binding"] == "d_min"
                   else f"S binds, {low['dominant']} {low['terms'][low['dominant']]:.3f} m "
                        "its largest term")
        then.append(f"at the lowest speed S {low['S']:.3f} m and {binding}")
        if low["envelope_beyond_body"]:
            then.append(f"the envelope {low['envelope_beyond_body']:.2f} m beyond the body")
    points = separation.get("untracked_points")
    first = next(iter(separation["by_segment"]), None)
    if points:
        then.append(f"tracking {' and '.join(points)} would bound {first} by its own points")
    return (f"held on separation stops {separation['time']:.1f} s by {parts}"
            + (f" ({'; '.join(then)})" if then else ""))
