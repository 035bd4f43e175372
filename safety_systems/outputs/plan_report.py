"""``safety-systems plan``: the planners on a scene, their metrics as the seed's Tables
I-VII (markdown and JSON), a 3-D plot of the paths, and the optimised IAPF path for
the robot.

Metrics of every path, after resampling at ``planner.metric_spacing``
(``safety_systems.planning.path_metrics``): length (m), bending energy (1/m, Eq. 5b), minimum
clearance (m, checked every 0.5 mm along each segment), time to goal (s, rest to rest
at ``max_tool_speed`` and ``max_tool_acceleration``), planning time (s).
The seed times its planners' paths in Gazebo; its Table V (K_att x time ~ 0.14 s for
every row) suggests a tool speed proportional to the attraction, which we do not
model: every path here is timed at the same tool limits, so the time to goal reflects
its length and curvature only.
"""

import json
from pathlib import Path

import numpy as np
from pydrake.common.yaml import yaml_dump_typed

from safety_systems.files.output_files import save_figure, write_json, write_text
from safety_systems.planning.path_metrics import (
    bending_energy,
    min_clearance,
    path_length,
    resample,
    time_to_goal,
)
from safety_systems.planning.path_optimisation import plan_optimised
from safety_systems.planning.plan_sweeps import sweep_scenes
from safety_systems.planning.planners import PlannedPath, plan_gda, plan_iapf
from safety_systems.planning.rrt_star import plan_rrt_star
from safety_systems.config.scenario import TaskPoints
from safety_systems.planning.task_space import TaskScene, obstacle_set

PLANNERS = ("IAPF", "IAPF+opt", "GDA", "RRT*")


def run_planners(scene: TaskScene) -> dict[str, PlannedPath]:
    """Every planner on ``scene``, by name (``PLANNERS``)."""
    iapf = plan_iapf(scene)
    return {"IAPF": iapf, "IAPF+opt": plan_optimised(scene, iapf), "GDA": plan_gda(scene),
            "RRT*": plan_rrt_star(scene)}


def path_row(path: PlannedPath, scene: TaskScene) -> dict:
    """The metrics of one path (module docstring)."""
    p = scene.planner
    sampled = resample(path.points, p.metric_spacing)
    return {"planner": path.planner, "reached_goal": path.reached_goal,
            "time_to_goal": time_to_goal(sampled, p.max_tool_speed, p.max_tool_acceleration)
            if path.reached_goal else None,
            "length": path_length(path.points), "bending_energy": bending_energy(sampled),
            "min_clearance": min_clearance(path.points, obstacle_set(scene.obstacles)),
            "planning_time": path.planning_time, "points": len(path.points),
            "escapes": path.escapes, "note": path.note}


def _f(value, digits: int) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def markdown_table(rows: list[dict]) -> str:
    """One line per planner (Tables I-IV give the time to goal; Table VIII length and
    bending energy)."""
    lines = [("| planner | reached goal | time to goal (s) | length (m) | bending energy (1/m) "
              "| min clearance (m) | planning time (s) | note |"),
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['planner']} | {'yes' if r['reached_goal'] else 'no'} | "
                     f"{_f(r['time_to_goal'], 2)} | {r['length']:.4f} | "
                     f"{r['bending_energy']:.2f} | {r['min_clearance']:.4f} | "
                     f"{r['planning_time']:.3f} | {r['note']} |")
    return "\n".join(lines) + "\n"


def sweep_table(settings: list[dict]) -> str:
    """One line per setting: the time to goal of each planner, then length and bending
    energy of the optimised IAPF path and of RRT*'s."""
    head = " | ".join(f"time to goal {name} (s)" for name in PLANNERS)
    lines = [(f"| setting | {head} | length IAPF+opt / RRT* (m) | bending IAPF+opt / RRT* "
              "(1/m) |"), "|---" * (3 + len(PLANNERS)) + "|"]
    for s in settings:
        by = {r["planner"]: r for r in s["rows"]}
        times = " | ".join(_f(by[name]["time_to_goal"], 2) for name in PLANNERS)
        o, r = by["IAPF+opt"], by["RRT*"]
        lines.append(f"| {s['setting']} | {times} | {o['length']:.4f} / {r['length']:.4f} | "
                     f"{o['bending_energy']:.2f} / {r['bending_energy']:.2f} |")
    return "\n".join(lines) + "\n"


def _cylinder(ax, c, colour) -> None:
    angle, z = np.meshgrid(np.linspace(0.0, 2.0 * np.pi, 30), [0.0, c.height])
    ax.plot_surface(c.x + c.radius * np.cos(angle), c.y + c.radius * np.sin(angle), z,
                    color=colour, alpha=0.35, linewidth=0)


def _sphere(ax, s, colour) -> None:
    u, v = np.meshgrid(np.linspace(0.0, 2.0 * np.pi, 24), np.linspace(0.0, np.pi, 12))
    c, r = s.centre, s.radius
    ax.plot_surface(c[0] + r * np.cos(u) * np.sin(v), c[1] + r * np.sin(u) * np.sin(v),
                    c[2] + r * np.cos(v), color=colour, alpha=0.35, linewidth=0)


def _box(ax, b, colour) -> None:
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    c, h = np.asarray(b.centre), np.asarray(b.half_sizes)
    corners = c + h * np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    faces = [[0, 1, 3, 2], [4, 5, 7, 6], [0, 1, 5, 4], [2, 3, 7, 6], [0, 2, 6, 4],
             [1, 3, 7, 5]]
    ax.add_collection3d(Poly3DCollection([corners[f] for f in faces], color=colour,
                                         alpha=0.35))


def plot(scene: TaskScene, paths: dict[str, PlannedPath], path: Path) -> None:
    """The obstacles and every planner's path in 3-D (as the seed's Figs. 6-8) and seen
    from above, as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle, Rectangle

    fig = plt.figure(figsize=(14, 6.5))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    top_view = fig.add_subplot(1, 2, 2)
    o = scene.obstacles
    for c in o.cylinders:
        _cylinder(ax, c, "grey")
        top_view.add_patch(Circle((c.x, c.y), c.radius, color="grey", alpha=0.5))
    for s in o.spheres:
        _sphere(ax, s, "grey")
        top_view.add_patch(Circle(s.centre[:2], s.radius, color="grey", alpha=0.5))
    for b in o.boxes:
        _box(ax, b, "grey")
        top_view.add_patch(Rectangle((b.centre[0] - b.half_sizes[0], b.centre[1] -
                                      b.half_sizes[1]), 2 * b.half_sizes[0],
                                     2 * b.half_sizes[1], color="grey", alpha=0.5))
    names = obstacle_set(o).names
    centres = ([s.centre[:2] for s in o.spheres] + [b.centre[:2] for b in o.boxes]
               + [[c.x, c.y] for c in o.cylinders])
    for name, (x, y) in zip(names, centres):
        top_view.annotate(name, (x, y), ha="center", va="center", fontsize="small")
    styles = {"IAPF": ("tab:blue", ":"), "IAPF+opt": ("tab:blue", "-"),
              "GDA": ("tab:orange", "-"), "RRT*": ("tab:green", "-")}
    for name, planned in paths.items():
        colour, style = styles.get(name, ("black", "-"))
        x, y, z = np.asarray(planned.points).T
        label = name + ("" if planned.reached_goal else " (goal not reached)")
        ax.plot(x, y, z, style, color=colour, lw=1.5, label=label)
        top_view.plot(x, y, style, color=colour, lw=1.5, label=label)
    for point, marker, label in ((scene.start, "o", "start"), (scene.goal, "*", "goal")):
        ax.scatter(*point, marker=marker, s=80, color="black")
        ax.text(*point, f" {label}")
        top_view.plot(*point[:2], marker, ms=9, color="black")
        top_view.annotate(f" {label}", point[:2])
    everything = np.vstack([np.asarray(p.points) for p in paths.values()]
                           + [np.array([scene.start, scene.goal])])
    top = max([c.height for c in o.cylinders] + [float(everything[:, 2].max())])
    ax.set_box_aspect((np.ptp(everything[:, 0]) + 0.1, np.ptp(everything[:, 1]) + 0.1,
                       top + 0.05))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_title(f"{scene.name or 'scene'}: planned tool paths")
    ax.legend(loc="upper left", fontsize="small")
    top_view.set_aspect("equal")
    top_view.set_xlabel("x [m]")
    top_view.set_ylabel("y [m]")
    top_view.set_title("seen from above (UR5e base frame)")
    top_view.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


def write_plan(scene: TaskScene, out: Path, sweep: str | None = None, *,
               origin: dict | None = None) -> dict:
    """Plans ``scene`` (and every setting of ``sweep``) and writes ``paths.json``,
    ``plan.md``, ``plan.json`` (with ``origin`` as its provenance), ``plan.png`` and,
    when the IAPF reached the goal, ``task_path.yaml`` (the optimised IAPF path, a
    ``TaskPoints`` mapping, m), each atomically. Returns the contents of ``plan.json``."""
    variants = sweep_scenes(scene, sweep) if sweep is not None else []
    out.mkdir(parents=True, exist_ok=True)
    paths = run_planners(scene)
    rows = [path_row(p, scene) for p in paths.values()]
    report = {"scene": scene.name, "rows": rows, "provenance": origin}
    text = f"# Planned paths: {scene.name or 'scene'}\n\n" + markdown_table(rows)
    if sweep is not None:
        settings = [{"setting": label, "rows": [path_row(p, v) for p in run_planners(v).values()]}
                    for label, v in variants]
        report["sweep"] = {"name": sweep, "settings": settings}
        text += f"\n## Sweep: {sweep}\n\n" + sweep_table(settings)
    write_text(out / "plan.md", text)
    write_json(out / "plan.json", report)
    write_text(out / "paths.json", json.dumps(
        {name: {"reached_goal": p.reached_goal, "planning_time": p.planning_time,
                "points": np.asarray(p.points).tolist()} for name, p in paths.items()},
        indent=1) + "\n")
    plot(scene, paths, out / "plan.png")
    optimised = paths["IAPF+opt"]
    task = out / "task_path.yaml"
    if optimised.reached_goal:
        write_text(task, yaml_dump_typed(TaskPoints(points=np.asarray(optimised.points).tolist())))
    elif task.exists():
        task.unlink()
    return report
