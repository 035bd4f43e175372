"""What ``safety-systems simulate`` writes: trace.csv, summary.json and plot.png."""

import csv
import math
import textwrap
from pathlib import Path

import numpy as np

from safety_systems.cell.human_body import SEGMENT_NAMES
from safety_systems.outputs.metrics import (
    first_frame_ticks,
    hidden,
    robot_contact_state,
    robot_speed,
    stop_reasons,
    summarize,
    tool_state,
)
from safety_systems.files.output_files import atomic_path, save_figure, write_json
from safety_systems.outputs.provenance import provenance, scenario_seeds
from safety_systems.diagrams.simulation import Run
from safety_systems.sensing.stops import REJECT_CAUSES, STOP_REASONS, STOP_SEPARATION
from safety_systems.planning.zones import ZONE_NAMES
from safety_systems.outputs.operator_figures import (
    commanded_speed,
    operator_figures,
)

# trace.csv columns written as words, by the column's name after its last ":"
WORDS = {"stop_reason": STOP_REASONS, "zone": ZONE_NAMES, "nearest_true": SEGMENT_NAMES,
         "nearest_measured": SEGMENT_NAMES}


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
    measurements the tracker has rejected so far, by cause.

    Then for each operator (``safety_systems.cell.human_body``: twelve segments each):
    ``<op>:d_true``, the least true clearance to the robot over its segments (as the
    scenario's ``contact_geometry`` measures it; empty while it is absent), and
    ``<op>:nearest_true``, the segment that has it (written as its name,
    ``human_body.SEGMENT_NAMES``); for the SSM override ``<op>:d_measured``, the least
    of the monitor's d over its segments (empty while none is monitored),
    ``<op>:nearest_measured``, that segment, and ``<op>:S``, the monitor's S of that
    segment (under ``safety.stopping: by_speed`` at the speed level the override held
    it to, :func:`override_levels`); and for each of its body slots (tracked bodies)
    ``<op>/<body>:d_measured`` (seed-004 controllers and zones only: the distance they
    saw, the tool's to the body's estimate, empty without a track) and
    ``<op>/<body>:hidden`` (1 while its track is a hidden ball, or lost).
    """
    speed = robot_speed(robot_contact_state(run)[1])
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
    is_hidden = hidden(run)
    for op in operator_figures(run):
        name = op["name"]
        header += [f"{name}:d_true", f"{name}:nearest_true"]
        columns += [op["d_true"], op["nearest_true"]]
        if "d_measured" in op:
            header += [f"{name}:d_measured", f"{name}:nearest_measured", f"{name}:S"]
            columns += [op["d_measured"], op["nearest_measured"], op["S"]]
        for j, i in enumerate(op["bodies"]):
            body = run.body_names[i]
            if "d_measured_bodies" in op:
                header.append(f"{body}:d_measured")
                columns.append(op["d_measured_bodies"][:, j])
            header.append(f"{body}:hidden")
            columns.append(is_hidden[:, i].astype(float))
    return header, np.column_stack(columns)


def write_trace(run: Run, path: Path) -> None:
    """trace.csv: :func:`trace_table`, numbers to 6 significant digits (empty where not
    finite), stop reasons, zones and segments by name (``WORDS``)."""
    write_table(*trace_table(run), path)


def write_table(header: list[str], rows: np.ndarray, path: Path, *,
                digits: dict[str, int] | None = None) -> None:
    """A trace table as CSV (atomically): numbers to 6 significant digits (the columns
    of ``digits`` to as many as it says; empty where not finite), the columns named in
    ``WORDS`` (by their name after its last ":") by name. Shared by ``simulate`` and
    ``run``."""
    words = {j: WORDS[name.rsplit(":", 1)[-1]] for j, name in enumerate(header)
             if name.rsplit(":", 1)[-1] in WORDS}
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
    """``summarize(run)``, what held the robot (``held``: ``outputs.held.held_by``),
    whether the stopping data is the built-in placeholder
    (``braking_data``: ``placeholder`` with the warning, or ``configured``), a recorded
    body whose mapping leaves its pivot unknown (``unknown_pivots``: one line each,
    ``recording_mapping.pivot_warnings``), and where
    the run came from (``provenance``: ``origin``, by default this process's)."""
    from safety_systems.outputs.held import held_by
    from safety_systems.sensing.recording_mapping import pivot_warnings

    summary = summarize(run)
    summary["held"] = held_by(run)
    if run.cell.braking_source == "placeholder":
        summary["braking_data"] = "placeholder"
        summary["braking_data_warning"] = run.cell.braking_warning
    else:
        summary["braking_data"] = "configured"
    pivots = [line for o in run.scenario.operators if o.recording
              for line in pivot_warnings(o.mapping, o.name)]
    if pivots:  # recorded bodies taken for their points, which they may be off
        summary["unknown_pivots"] = pivots
    summary["provenance"] = origin or provenance(scenario_seeds(run.scenario))
    write_json(path, summary)
    return summary


S_NOTE = ("S < 0 where a segment moves away from the robot: the estimated directed speeds "
          "(seed Eqs. 10-11) are then negative; drawn as computed, not clipped.")
NOTE_WIDTH = 160  # characters per line of a note under the figure
D_NOTE = ("d (monitored) < 0 where the envelope the monitor keeps around what the sensor "
          "does not see of an operator (an arm or the trunk, bounded from the tracked points) "
          "overlaps a robot capsule: it knows the body is somewhere inside, not where; the "
          "true distance is the wide pale line.")
# Hatches that tell an operator's body slots apart where their hidden intervals are shaded
HATCHES = ("//", "\\\\", "..", "xx", "++", "--", "||", "oo")
# Line styles of an operator's body slots (speeds; tool-to-estimate distances)
BODY_STYLES = ("-", "-.", (0, (5, 1)), (0, (1, 1)), (0, (3, 1, 1, 1, 1, 1)))


def plot_run(run: Run, path: Path, summary: dict | None = None) -> None:
    """Writes :func:`run_figure` to ``path`` (PNG)."""
    fig = run_figure(run, summary)
    import matplotlib.pyplot as plt

    save_figure(fig, path, dpi=110)
    plt.close(fig)


def run_figure(run: Run, summary: dict | None = None):
    """Three panels in the manner of the seed's Figs. 7 and 9, one colour per operator:
    the bodies' estimated speeds and the tool's (top); per operator its true clearance
    d_true (a wide pale line) and, with the SSM monitor, the monitor's d of its nearest segment and that
    segment's S (``operator_figures``), else the tool's distance to each of its bodies'
    estimates, and d_min (middle); k (and the danger index or the zone) on its own axis
    (bottom). Shaded: the intervals a body slot was hidden (middle, in its operator's
    colour, hatched by slot) and the protective stops for a fault of the sensing chain
    (grey, every panel). Marked (with ``summary``): the tick of the smallest separation
    margin d_true - S_true while the robot was let move (red where it is below 0: the
    separation invariant broken). Legends stand beside the panels, off the data; notes
    under the figure explain a monitored d < 0 and S < 0 when they occur."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = run.time
    _, speed = tool_state(run)
    v_est = np.linalg.norm(run.bodies("tracker.velocities_estimated"), axis=-1)
    operators = operator_figures(run)
    ssm = "monitor.distances" in run.signals
    fig, (top, middle, bottom) = plt.subplots(
        3, 1, sharex=True, figsize=(13, 9.5), layout="constrained",
        gridspec_kw={"height_ratios": (1.0, 1.6, 0.8)})
    colors = [f"C{k % 10}" for k in range(len(operators))]
    for op, color in zip(operators, colors):
        for j, i in enumerate(op["bodies"]):
            twin = _same_trace(v_est, op["bodies"][:j], i)
            if twin is None:
                top.plot(t, v_est[:, i], color=color, ls=BODY_STYLES[j % len(BODY_STYLES)],
                         lw=1.0, label=f"v {run.body_names[i]} (the tracker's estimate)")
            else:  # a body moving with another (an operator's gloves) would hide under it
                top.plot(t, v_est[:, i], color=color, lw=4.0, alpha=0.3, zorder=1.5,
                         label=f"v {run.body_names[i]} (estimate; as "
                               f"{run.body_names[twin].split('/')[-1]}'s, "
                               f"within {SAME_SPEED:g} m/s)")
    top.plot(t, speed, color="goldenrod", label="v_R (tool)")
    top.set_ylabel("speed [m/s]")
    top.grid(alpha=0.3)
    s_low, d_low, low = 0.0, 0.0, 0.0
    for op, color in zip(operators, colors):
        name = op["name"]
        middle.plot(t, op["d_true"], color=color, lw=4.0, alpha=0.3, solid_capstyle="butt",
                    label=f"d_true {name} (nearest segment)")
        low = min(low, float(np.nanmin(op["d_true"], initial=0.0)))
        if ssm:
            middle.plot(t, op["d_measured"], color=color, lw=1.1,
                        label=f"d {name} (monitored, nearest segment)")
            middle.plot(t, op["S"], color=color, ls="--", lw=1.1,
                        label=f"S {name} (of that segment)")
            s_low = min(s_low, float(np.nanmin(op["S"], initial=0.0)))
            d_low = min(d_low, float(np.nanmin(op["d_measured"], initial=0.0)))
            low = min(low, s_low, d_low)
        else:
            for j, i in enumerate(op["bodies"]):
                middle.plot(t, op["d_measured_bodies"][:, j], color=color, lw=1.0,
                            ls=BODY_STYLES[j % len(BODY_STYLES)],
                            label=f"d {run.body_names[i]} (tool to estimate)")
    for op, color in zip(operators, colors):  # where a trace ends before the run does
        seen = np.flatnonzero(np.isfinite(op["d_true"]))
        if seen.size and seen[-1] < t.size - 1:
            middle.axvline(t[seen[-1]], color=color, lw=0.8, ls="-.",
                           label=f"{op['name']} gone (left the cell) at {t[seen[-1]]:.1f} s")
    if ssm:
        middle.axhline(run.scenario.controller.safety.d_min, color="red", lw=1.0,
                       label="d_min")
    _shade((top, middle, bottom), middle, run, operators, colors)
    margin = None if summary is None else summary.get("min_separation_margin")
    if margin is not None:
        when = summary["min_separation_margin_time"]
        middle.axvline(when, color="red" if margin < 0.0 else "green", lw=1.2, ls=":",
                       label=f"smallest d_true - S_true while let move: {margin:+.3f} m "
                             f"at {when:.2f} s")
    middle.set_ylabel("distance [m]")
    middle.set_ylim(bottom=low - 0.05 if low < 0.0 else 0.0)
    middle.grid(alpha=0.3)
    k = commanded_speed(run)
    bottom.plot(t, k, color="black", label="k (commanded speed / nominal)")
    if "speed.danger_index" in run.signals:
        bottom.plot(t, run["speed.danger_index"][:, 0], color="purple", label="danger index")
    if "zones.zone" in run.signals:
        bottom.plot(t, run["zones.zone"][:, 0] / 2.0, color="tab:red", lw=0.8,
                    label="zone (0 green, 0.5 yellow, 1 red)")
    bottom.set_ylim(min(-0.05, float(k.min()) - 0.05), max(1.05, float(k.max()) + 0.05))
    bottom.set_ylabel("k" + ("" if ssm else ", DI / zone"))
    bottom.set_xlabel("time [s]")
    bottom.grid(alpha=0.3)
    for axis in (top, middle, bottom):
        axis.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small")
    notes = [note for note, low_ in ((D_NOTE, d_low), (S_NOTE, s_low)) if low_ < 0.0]
    if notes:
        fig.supxlabel("\n".join(textwrap.fill(n, NOTE_WIDTH) for n in notes),
                      fontsize="small")
    c = run.scenario.controller
    fig.suptitle(f"{run.scenario.name}: SSM speed override (the human speed in S: "
                 f"{_human_speed_words(c.safety)})"
                 if c.type == "ssm_override" else f"{run.scenario.name}: controller {c.type}")
    return fig


SAME_SPEED = 0.01  # m/s: two bodies' speed traces this close throughout draw as one line


def _same_trace(v: np.ndarray, earlier, i: int) -> int | None:
    """The first of the ``earlier`` columns of ``v`` whose trace stays within
    ``SAME_SPEED`` of column ``i`` wherever both are known (and that are known at the
    same ticks), or None."""
    known = np.isfinite(v[:, i])
    for e in earlier:
        if (np.array_equal(known, np.isfinite(v[:, e])) and known.any()
                and float(np.max(np.abs(v[known, i] - v[known, e]))) <= SAME_SPEED):
            return int(e)
    return None


def _intervals(t: np.ndarray, on: np.ndarray) -> list[tuple[float, float]]:
    """[start, end) of the runs of True in ``on`` over the times ``t``."""
    edges = np.diff(np.r_[0, on.astype(int), 0])
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    dt = t[1] - t[0] if t.size > 1 else 0.0
    return [(t[a], t[b - 1] + dt) for a, b in zip(starts, ends)]


def _human_speed_words(safety) -> str:
    """How the human speed enters S, in words for a title."""
    mode = safety.human_speed
    if mode == "iso":
        return f"constant, {safety.iso_human_speed:g} m/s (iso)"
    if mode == "estimated":
        return "the tracker's estimate (estimated)"
    return (f"the estimate, at least {safety.iso_human_speed:g} m/s "
            f"({mode})")


def _shade(axes, distance_axis, run: Run, operators: list[dict], colors: list) -> None:
    """Fault stops (grey, on every one of ``axes``) and the hidden intervals of each body
    slot (on ``distance_axis``, in its operator's colour, hatched by slot)."""
    reasons = stop_reasons(run)
    faults = reasons > STOP_SEPARATION
    faults[:first_frame_ticks(reasons)] = False  # (the wait for the first frame: no fault)
    # a stop of a tick or two would be thinner than a pixel: drawn at least 0.4% of the axis
    least = 0.004 * float(run.time[-1] - run.time[0]) if run.time.size else 0.0
    for k, (a, b) in enumerate(_intervals(run.time, faults)):
        if b - a < least:
            a, b = (a + b - least) / 2.0, (a + b + least) / 2.0
        for axis in axes:
            axis.axvspan(a, b, color="0.5", alpha=0.35, lw=0,
                         label="fault stop (short ones widened to be seen)" if k == 0
                         else None)
    is_hidden = hidden(run)
    for op, color in zip(operators, colors):
        for j, i in enumerate(op["bodies"]):
            for k, (a, b) in enumerate(_intervals(run.time, is_hidden[:, i])):
                distance_axis.axvspan(a, b, facecolor=matplotlib_rgba(color, 0.10),
                                      edgecolor=matplotlib_rgba(color, 0.45), lw=0,
                                      hatch=HATCHES[j % len(HATCHES)],
                                      label=f"{run.body_names[i]} hidden" if k == 0 else None)


def matplotlib_rgba(color: str, alpha: float) -> tuple:
    """``color`` with ``alpha`` as an RGBA tuple (a face and an edge of different
    opacity in one patch)."""
    from matplotlib.colors import to_rgba

    return to_rgba(color, alpha)


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
