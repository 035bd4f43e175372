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

from safety_systems.cell.human_body import SEGMENT_NAMES
from safety_systems.config.configuration import tracked_points
from safety_systems.config.resolved_cell import resolve_scenario
from safety_systems.diagrams.simulation import Run
from safety_systems.outputs.metrics import protective_stops, stop_reasons
from safety_systems.outputs.held_terms import (
    lowest_speed_of,
    lowest_speed_table,
    untracked_points,
)
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
    if run.scenario.controller.type == "ssm_override":
        table = lowest_speed_table(resolve_scenario(run.scenario))
        out["separation"]["lowest_speed"] = lowest_speed_of(
            table, next(iter(ordered), "none"), out["separation"])
    return out

