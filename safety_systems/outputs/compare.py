"""``safety-systems compare``: several controllers on the same scenarios (seed 004, Table 1).

For every scenario and controller: the largest danger index between the robot's and the
operators' ellipsoids over the run (true positions, every control tick), whether and
when the tool reached the end of its path, and the mean and standard deviation of the
jerk of the tool's speed along the path, sampled at the controller's period, over the
scenario's ``jerk_window`` (the seed's Fig. 9(d) and 11(f) windows). The seed takes
jerk from the selected velocity; we take it from the speed the robot actually ran,
which the PathFollower makes follow the selection (and which every controller, the SSM
override included, has).

The measures live beside this module: seed 004's danger index and jerk in
``danger_and_jerk``, seed 001's metric in ``evaluation_of_run``, the robot's inverse
dynamics in ``cell.robot_plant``. Each run is scored with seed 001's metric, whose
contact gate counts as contact a danger index of 1 or more (seed 004's Eqs. 6-7, the
scenario's ellipsoids) or a true separation below the scenario's contact distance while
the robot moves (``metrics.contact_while_moving``). For seed 004's two simulations
``comparison.md`` puts Table 1's jerk figures beside ours, with the ratios, and says why
where they differ by more than 2x.
"""

import dataclasses
from pathlib import Path

import numpy as np

from safety_systems.config.configuration import joint_path
from safety_systems.config.scenario import Scenario
from safety_systems.diagrams.simulation import Run, simulate
from safety_systems.files.output_files import save_figure, write_json, write_text
from safety_systems.outputs.danger_and_jerk import danger_over_run, jerk, sampled_speed
from safety_systems.outputs.evaluation_of_run import evaluation_of_run
from safety_systems.outputs.metrics import contact_while_moving, separation_while_moving, task_time
from safety_systems.outputs.table_1 import table_1
from safety_systems.speed_alteration.methods import preprogrammed_speed


def controller_metrics(run: Run) -> dict:
    danger = danger_over_run(run)
    _, min_sep = separation_while_moving(run)
    contact = bool(danger.max() >= 1.0) or contact_while_moving(min_sep,
                                                                run.scenario.contact_distance)
    speed, period = sampled_speed(run)
    j = jerk(speed, period)
    window = run.scenario.jerk_window
    # Jerk k uses samples k-2..k: the window's jerks use samples first - 2 .. last.
    used = [max(window[0] - 2, 0), window[1]] if window else [0, len(speed) - 1]
    j = j[used[0]:max(used[1] - 1, 0)]
    finished = task_time(run)
    return {"max_danger_index": float(danger.max()),
            "min_separation_while_moving": float(min_sep) if np.isfinite(min_sep) else None,
            "contact": contact, "goal_reached": finished is not None,
            "evaluation": evaluation_of_run(run, contact=contact),
            "goal_time": finished, "jerk_mean": float(j.mean()) if j.size else None,
            "jerk_sd": float(j.std()) if j.size else None, "jerk_samples": used,
            "v_pre": preprogrammed_speed(joint_path(run.scenario.robot)),
            "samples": speed.tolist(), "sample_period": period, "danger_at_samples":
                danger[::max(1, int(round(period * run.scenario.robot.control_rate_hz)))
                       ].tolist()}


def compare(scenarios: list[Scenario], controllers: list[str]) -> list[dict]:
    """One row per (scenario, controller)."""
    rows = []
    for scenario in scenarios:
        for kind in controllers:
            run = simulate(dataclasses.replace(
                scenario, controller=dataclasses.replace(scenario.controller, type=kind)))
            rows.append({"scenario": scenario.name, "controller": kind,
                         **controller_metrics(run)})
    reference = {r["scenario"]: r["jerk_sd"] for r in rows if r["controller"] == controllers[0]}
    for r in rows:
        ref = reference.get(r["scenario"])
        r["jerk_sd_percent"] = (100.0 * r["jerk_sd"] / ref) if ref and r["jerk_sd"] else None
    return rows


def markdown_table(rows: list[dict]) -> str:
    lines = ["| scenario | controller | max DI | contact | goal reached | jerk mean (mm/s^3) | "
             "jerk SD (mm/s^3) | SD vs first |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        def mm(x):
            return "-" if x is None else f"{1000 * x:.1f}"
        goal = f"yes, {r['goal_time']:.2f} s" if r["goal_reached"] else "no"
        pct = "-" if r["jerk_sd_percent"] is None else f"{r['jerk_sd_percent']:.0f}%"
        lines.append(f"| {r['scenario']} | {r['controller']} | {r['max_danger_index']:.5f} | "
                     f"{'yes' if r['contact'] else 'no'} | {goal} | {mm(r['jerk_mean'])} | "
                     f"{mm(r['jerk_sd'])} | {pct} |")
    names = list(rows[0]["evaluation"]) if rows else []
    lines += ["", "Safety and efficiency evaluation (seed 001, Tables IX-X; scores 0-100):", "",
              "| scenario | controller | " + " | ".join(n.replace("_", " ") for n in names) + " |",
              "|---|---|" + "---|" * len(names)]
    for r in rows:
        lines.append(f"| {r['scenario']} | {r['controller']} | "
                     + " | ".join(f"{r['evaluation'][n]:.1f}" for n in names) + " |")
    table = table_1(rows)
    return "\n".join(lines + ([""] + table if table else [])) + "\n"


def plot(rows: list[dict], path: Path) -> None:
    """Writes :func:`comparison_figure` to ``path`` (PNG)."""
    fig = comparison_figure(rows)
    import matplotlib.pyplot as plt

    save_figure(fig, path, dpi=100)
    plt.close(fig)


def comparison_figure(rows: list[dict]):
    """Danger index and speed at each controller sample over time, one column per
    scenario (seed Figs. 8, 11); one legend beside the panels, off the data. Controllers
    often share stretches (the pre-programmed speed, the same DI before they act): each
    is drawn narrower than the one before it, so one lying on another still shows. The
    line at DI = 1 is the seed's collision threshold (Eq. 6), drawn apart from the
    controllers' colours and named."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(dict.fromkeys(r["scenario"] for r in rows))
    fig, axes = plt.subplots(2, len(names), figsize=(6 * len(names) + 1.5, 7),
                             squeeze=False, layout="constrained")
    controllers = list(dict.fromkeys(r["controller"] for r in rows))
    width = {name: 1.0 + 1.2 * (len(controllers) - 1 - k) for k, name in
             enumerate(controllers)}  # the first drawn widest, the last 1.0
    colour = {name: f"C{k % 10}" for k, name in enumerate(controllers)}
    for c, name in enumerate(names):
        period = None
        for r in (r for r in rows if r["scenario"] == name):
            period = r["sample_period"]
            t = period * np.arange(len(r["samples"]))
            style = dict(marker=".", ms=2.0 + width[r["controller"]], lw=width[r["controller"]],
                         color=colour[r["controller"]], label=r["controller"])
            axes[0, c].plot(t, r["danger_at_samples"][:len(t)], **style)
            axes[1, c].plot(t, 1000 * np.array(r["samples"]), **style)
        axes[0, c].axhline(1.0, color="black", ls="--", lw=0.8,
                           label="DI = 1: the ellipsoids touch (seed Eq. 6)")
        axes[0, c].set_title(f"{name}: danger index")
        axes[1, c].set_title(f"{name}: speed along the path [mm/s]")
        axes[1, c].set_xlabel(f"time [s] (a sample every {period:g} s)")
    fig.legend(*axes[0, 0].get_legend_handles_labels(), loc="outside right upper",
               fontsize="small")
    return fig


def write_comparison(rows: list[dict], out: Path, *, origin: dict | None = None) -> None:
    """comparison.json (``{"provenance": origin, "rows": rows}``), comparison.md and
    comparison.png, each written atomically."""
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "comparison.json", {"provenance": origin, "rows": rows})
    write_text(out / "comparison.md", markdown_table(rows))
    plot(rows, out / "comparison.png")

