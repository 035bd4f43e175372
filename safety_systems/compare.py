"""``safety-systems compare``: several controllers on the same scenarios (seed 004, Table 1).

For every scenario and controller: the largest danger index between the robot's and the
operators' ellipsoids over the run (true positions, every control tick), whether and
when the tool reached the end of its path, and the mean and standard deviation of the
jerk of the tool's speed along the path, sampled at the controller's period, over the
scenario's ``jerk_window`` (the seed's Fig. 9(d) and 11(f) windows). The seed takes
jerk from the selected velocity; we take it from the speed the robot actually ran,
which the PathFollower makes follow the selection (and which every controller, the SSM
override included, has).
"""

import dataclasses
import json
from pathlib import Path

import numpy as np

from safety_systems.ellipsoids import Ellipsoids, danger_index, robot_ellipsoids
from safety_systems.metrics import task_time
from safety_systems.scenario import Scenario
from safety_systems.simulation import Run, simulate
from safety_systems.speed_alteration import operator_ellipsoids, preprogrammed_speed
from safety_systems.workcell import body_roles, joint_path


def danger_over_run(run: Run) -> np.ndarray:
    """(T,) largest DI over every robot-operator ellipsoid pair at each tick."""
    sizes = run.scenario.controller.alteration.ellipsoids
    operator_of, is_hand = body_roles(run.scenario)
    robot = robot_ellipsoids(run["q"], sizes.link_radii, sizes.tool_radius, sizes.tool_offset)
    bodies = run.bodies("operators.positions_true")
    present = run["operators.present"] > 0.5
    out = np.zeros(len(run.time))
    for i in range(len(run.time)):
        humans = operator_ellipsoids(bodies[i], present[i], operator_of, is_hand, sizes)
        if humans.centres.shape[0]:
            r = Ellipsoids(robot.centres[i], robot.rotations[i], robot.semi_axes[i])
            out[i] = danger_index(r, humans).max()
    return out


def sampled_speed(run: Run) -> tuple[np.ndarray, float]:
    """The tool's signed speed along the path (path rate times Eq. 8's V_pre), m/s,
    sampled every controller period, and that period."""
    period = 1.0 / run.scenario.controller.alteration.rate_hz
    step = max(1, int(round(period * run.scenario.robot.control_rate_hz)))
    v_pre = preprogrammed_speed(joint_path(run.scenario.robot))
    return run["follower.path_state"][::step, 1] * v_pre, period


def jerk(speed: np.ndarray, period: float) -> np.ndarray:
    """Second difference of the speed over the period squared, m/s^3."""
    return np.diff(speed, 2) / period**2


def controller_metrics(run: Run) -> dict:
    danger = danger_over_run(run)
    speed, period = sampled_speed(run)
    j = jerk(speed, period)
    window = run.scenario.jerk_window
    if window:
        j = j[max(window[0] - 2, 0):max(window[1] - 1, 0)]  # jerk k uses samples k-2..k
    finished = task_time(run)
    return {"max_danger_index": float(danger.max()), "goal_reached": finished is not None,
            "goal_time": finished, "jerk_mean": float(j.mean()) if j.size else None,
            "jerk_sd": float(j.std()) if j.size else None,
            "samples": speed.tolist(), "danger_at_samples":
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
    lines = ["| scenario | controller | max DI | goal reached | jerk mean (mm/s^3) | "
             "jerk SD (mm/s^3) | SD vs first |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        def mm(x):
            return "-" if x is None else f"{1000 * x:.1f}"
        goal = f"yes, {r['goal_time']:.2f} s" if r["goal_reached"] else "no"
        pct = "-" if r["jerk_sd_percent"] is None else f"{r['jerk_sd_percent']:.0f}%"
        lines.append(f"| {r['scenario']} | {r['controller']} | {r['max_danger_index']:.4f} | "
                     f"{goal} | {mm(r['jerk_mean'])} | {mm(r['jerk_sd'])} | {pct} |")
    return "\n".join(lines) + "\n"


def plot(rows: list[dict], path: Path) -> None:
    """Danger index and speed per sample, one column per scenario (seed Figs. 8, 11)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(dict.fromkeys(r["scenario"] for r in rows))
    fig, axes = plt.subplots(2, len(names), figsize=(6 * len(names), 7), squeeze=False)
    for c, name in enumerate(names):
        for r in (r for r in rows if r["scenario"] == name):
            axes[0, c].plot(r["danger_at_samples"], ".-", label=r["controller"])
            axes[1, c].plot(1000 * np.array(r["samples"]), ".-", label=r["controller"])
        axes[0, c].axhline(1.0, color="red", lw=0.8)
        axes[0, c].set_title(f"{name}: danger index")
        axes[1, c].set_title(f"{name}: speed along the path [mm/s]")
        axes[1, c].set_xlabel("sample")
        axes[0, c].legend(fontsize="small")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def write_comparison(rows: list[dict], out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / "comparison.json").write_text(json.dumps(rows, indent=2) + "\n")
    (out / "comparison.md").write_text(markdown_table(rows))
    plot(rows, out / "comparison.png")

