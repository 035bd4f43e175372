"""What ``safety-systems simulate`` writes: trace.csv, summary.json and plot.png."""

import csv
import math
from pathlib import Path

import numpy as np

from safety_systems.cell.braking import PLACEHOLDER_WARNING
from safety_systems.outputs.metrics import (
    hidden,
    robot_contact_state,
    robot_speed,
    stop_reasons,
    summarize,
    tool_state,
    true_separations,
)
from safety_systems.files.output_files import atomic_path, save_figure, write_json
from safety_systems.outputs.provenance import provenance, scenario_seeds
from safety_systems.diagrams.simulation import Run
from safety_systems.ssm.formulas import separation_distances
from safety_systems.sensing.stops import REJECT_CAUSES, STOP_REASONS, STOP_SEPARATION
from safety_systems.config.configuration import placeholder_braking
from safety_systems.planning.zones import ZONE_NAMES

WORDS = {"stop_reason": STOP_REASONS, "zone": ZONE_NAMES}  # trace.csv columns written as words


def commanded_speed(run: Run) -> np.ndarray:
    """(T,) the controller's commanded path speed (k for the SSM override)."""
    key = next(k for k in ("override", "speed", "zones")
               if f"{k}.path_speed_commanded" in run.signals)
    return run[f"{key}.path_speed_commanded"][:, 0]


def measured_distances(run: Run) -> np.ndarray:
    """(T, N) distances the controller saw: the monitor's d_i, or, for the seed-004
    controllers, the tool's distance to each tracked estimate."""
    if "monitor.distances" in run.signals:
        return run["monitor.distances"]
    return separation_distances(tool_state(run)[0], run.bodies("tracker.positions_estimated"))


def trace_table(run: Run) -> tuple[list[str], np.ndarray]:
    """Header and rows of the trace: one row per control tick.

    Columns: time (s), k (commanded speed scale), path_rate (sigma), robot_speed (the
    real robot's speed, m/s: its fastest capsule axis end, the tool flange on the tool
    point; see ``safety_systems.outputs.metrics``); for the SSM override stop_reason
    (``safety_systems.sensing.stops``: 0 none, 1 separation, 2 stale frame, 3 lost track, 4 bad
    frame time, 5 non-finite position, 6 unknown body id, 7 gate; trace.csv writes
    their names, ``STOP_REASONS``) and S_max (m), for the seed-004 controllers
    danger_index (the controller's predicted DI), for the zones zone (0 green, 1 yellow,
    2 red; written as names) and closest_distance (m, Eq. 6b); ``rejected_<cause>``:
    measurements the tracker has rejected so far, by cause; then for each body
    ``<body>:d_true`` (true clearance to the robot as the scenario's
    ``contact_geometry`` measures it, empty when absent), ``<body>:d_measured`` (the
    distance the controller saw, empty without a track), ``<body>:hidden`` (1 while its
    track is a hidden ball, or lost) and, for the SSM override, ``<body>:S`` (the
    monitor's S_i).
    """
    speed = robot_speed(robot_contact_state(run)[1])
    d_true = true_separations(run)
    ssm = "override.stop_reason" in run.signals
    header = ["time", "k", "path_rate", "robot_speed"]
    columns = [run.time, commanded_speed(run), run["follower.path_state"][:, 1], speed]
    if ssm:
        header += ["stop_reason", "S_max"]
        columns += [run["override.stop_reason"][:, 0],
                    run["override.max_protective_distance"][:, 0]]
    elif "zones.zone" in run.signals:
        header += ["zone", "closest_distance"]
        columns += [run["zones.zone"][:, 0], run["zones.closest_distance"][:, 0]]
    else:
        header.append("danger_index")
        columns.append(run["speed.danger_index"][:, 0])
    header += [f"rejected_{cause}" for cause in REJECT_CAUSES]
    columns += list(run["tracker.rejected_frames"].T)
    measured = measured_distances(run)
    is_hidden = hidden(run)
    for i, name in enumerate(run.body_names):
        header += [f"{name}:d_true", f"{name}:d_measured", f"{name}:hidden"]
        columns += [d_true[:, i], measured[:, i], is_hidden[:, i].astype(float)]
        if ssm:
            header.append(f"{name}:S")
            columns.append(run["monitor.protective_distances"][:, i])
    return header, np.column_stack(columns)


def write_trace(run: Run, path: Path) -> None:
    """trace.csv: :func:`trace_table`, numbers to 6 significant digits (empty where not
    finite), stop reasons and zones by name (``WORDS``)."""
    write_table(*trace_table(run), path)


def write_table(header: list[str], rows: np.ndarray, path: Path, *,
                digits: dict[str, int] | None = None) -> None:
    """A trace table as CSV (atomically): numbers to 6 significant digits (the columns
    of ``digits`` to as many as it says; empty where not finite), the columns of
    ``WORDS`` by name. Shared by ``simulate`` and ``run``."""
    words = {header.index(name): names for name, names in WORDS.items() if name in header}
    formats = [f"{{:.{(digits or {}).get(name, 6)}g}}" for name in header]

    def cell(j: int, x: float) -> str:
        if not math.isfinite(x):
            return ""
        return words[j][int(x)] if j in words else formats[j].format(x)

    with atomic_path(path) as temporary, open(temporary, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(header)
        for row in rows:
            writer.writerow([cell(j, x) for j, x in enumerate(row)])


def write_summary(run: Run, path: Path, *, origin: dict | None = None) -> dict:
    """``summarize(run)``, whether the stopping data is the built-in placeholder
    (``braking_data``: ``placeholder`` with the warning, or ``configured``), and where
    the run came from (``provenance``: ``origin``, by default this process's)."""
    summary = summarize(run)
    if placeholder_braking(run.scenario.controller):
        summary["braking_data"] = "placeholder"
        summary["braking_data_warning"] = PLACEHOLDER_WARNING
    else:
        summary["braking_data"] = "configured"
    summary["provenance"] = origin or provenance(scenario_seeds(run.scenario))
    write_json(path, summary)
    return summary


S_NOTE = ("S < 0 where a body moves away from the robot: the estimated directed speeds "
          "(seed Eqs. 10-11) are then negative; drawn as computed, not clipped.")


def plot_run(run: Run, path: Path, summary: dict | None = None) -> None:
    """Writes :func:`run_figure` to ``path`` (PNG)."""
    fig = run_figure(run, summary)
    import matplotlib.pyplot as plt

    save_figure(fig, path, dpi=110)
    plt.close(fig)


def run_figure(run: Run, summary: dict | None = None):
    """Two panels in the manner of the seed's Figs. 7 and 9: speeds above; d_i, S_i,
    d_min and k below. Shaded: the intervals a body was hidden (in its colour, below) and
    the protective stops for a fault of the sensing chain (grey, both panels). Marked
    (with ``summary``): the tick of the smallest separation margin d_true - S_true while
    the robot was let move (red where it is below 0: the separation invariant broken).
    Legends stand beside the panels, off the data; a note under the figure explains S < 0
    when it occurs."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = run.time
    _, speed = tool_state(run)
    v_est = np.linalg.norm(run.bodies("tracker.velocities_estimated"), axis=-1)
    d = measured_distances(run)
    s = run.signals.get("monitor.protective_distances")
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(13, 7.5),
                                      layout="constrained")
    for i, name in enumerate(run.body_names):
        top.plot(t, v_est[:, i], label=f"v {name} (estimated)")
    top.plot(t, speed, color="goldenrod", label="v_R (tool)")
    top.set_ylabel("speed [m/s]")
    top.legend(loc="upper left", bbox_to_anchor=(1.07, 1.0), fontsize="small")
    top.grid(alpha=0.3)
    colors = []
    for i, name in enumerate(run.body_names):
        (line,) = bottom.plot(t, d[:, i], label=f"d {name}")
        colors.append(line.get_color())
        if s is not None:
            bottom.plot(t, s[:, i], linestyle="--", color=line.get_color(), label=f"S {name}")
    if s is not None:
        bottom.axhline(run.scenario.controller.safety.d_min, color="red", label="d_min")
    _shade(top, bottom, run, colors)
    margin = None if summary is None else summary.get("min_separation_margin")
    if margin is not None:
        when = summary["min_separation_margin_time"]
        bottom.axvline(when, color="red" if margin < 0.0 else "green", lw=1.2, ls=":",
                       label=f"smallest d_true - S_true while let move: {margin:+.3f} m "
                             f"at {when:.2f} s")
    bottom.set_ylabel("distance [m]")
    bottom.set_xlabel("time [s]")
    bottom.set_ylim(bottom=min(0.0, float(np.nanmin(s, initial=0.0))) if s is not None else 0.0)
    k_axis = bottom.twinx()
    k = commanded_speed(run)
    k_axis.plot(t, k, color="black", label="k (commanded speed / nominal)")
    if "speed.danger_index" in run.signals:
        k_axis.plot(t, run["speed.danger_index"][:, 0], color="purple", label="danger index")
    if "zones.zone" in run.signals:
        k_axis.plot(t, run["zones.zone"][:, 0] / 2.0, color="tab:red", lw=0.8,
                    label="zone (0 green, 0.5 yellow, 1 red)")
    k_axis.set_ylim(min(-0.05, float(k.min()) - 0.05), max(1.05, float(k.max()) + 0.05))
    k_axis.set_ylabel("commanded speed k" + ("" if s is not None else ", DI / zone"))
    lines = bottom.get_legend_handles_labels()
    k_lines = k_axis.get_legend_handles_labels()
    bottom.legend(lines[0] + k_lines[0], lines[1] + k_lines[1], loc="upper left",
                  bbox_to_anchor=(1.07, 1.0), fontsize="small")
    bottom.grid(alpha=0.3)
    if s is not None and np.nanmin(s, initial=0.0) < 0.0:
        fig.supxlabel(S_NOTE, fontsize="small")
    c = run.scenario.controller
    fig.suptitle(f"{run.scenario.name}: SSM speed override (human speed: {c.safety.human_speed})"
                 if c.type == "ssm_override" else f"{run.scenario.name}: controller {c.type}")
    return fig


def _intervals(t: np.ndarray, on: np.ndarray) -> list[tuple[float, float]]:
    """[start, end) of the runs of True in ``on`` over the times ``t``."""
    edges = np.diff(np.r_[0, on.astype(int), 0])
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    dt = t[1] - t[0] if t.size > 1 else 0.0
    return [(t[a], t[b - 1] + dt) for a, b in zip(starts, ends)]


def _shade(top, bottom, run: Run, colors: list) -> None:
    """Hidden intervals per body (in the body's line colour) and fault stops (grey)."""
    reasons = stop_reasons(run)
    faults = reasons > STOP_SEPARATION
    for k, (a, b) in enumerate(_intervals(run.time, faults)):
        for axis in (top, bottom):
            axis.axvspan(a, b, color="0.5", alpha=0.25, lw=0,
                         label="fault stop" if k == 0 and axis is bottom else None)
    for i, name in enumerate(run.body_names):
        for k, (a, b) in enumerate(_intervals(run.time, hidden(run)[:, i])):
            bottom.axvspan(a, b, color=colors[i], alpha=0.12, lw=0,
                           label=f"{name} hidden" if k == 0 else None)


def write_outputs(run: Run, out_dir: Path, *, html: bool = False,
                  origin: dict | None = None) -> dict:
    """Writes trace.csv, summary.json (with ``origin`` as its provenance), plot.png (and
    replay.html) into ``out_dir``, each atomically."""
    out_dir.mkdir(parents=True, exist_ok=True)
    write_trace(run, out_dir / "trace.csv")
    summary = write_summary(run, out_dir / "summary.json", origin=origin)
    plot_run(run, out_dir / "plot.png", summary)
    if html:
        from safety_systems.outputs.replay import write_replay

        write_replay(run, out_dir / "replay.html")
    return summary
