"""IAPF with Eq. 5's optimisation beside RRT* (seed 001) on the four-obstacle scene.

    python benchmarks/bench_plan.py [--repeats 5] [--rrt-time 1.0] [--scene FILE]

Goals: IAPF + optimisation plans in under 1 s; its path is no longer than 1.05 times
RRT*'s best within its time budget, and bends less (Eq. 5b). Figures from one run,
the IAPF's planning time the median of ``--repeats`` runs.

SLSQP calls BLAS on tiny matrices; on a machine whose cores are busy, OpenBLAS's
worker threads wait for each other and the optimisation runs several times slower.
Run with ``OPENBLAS_NUM_THREADS=1`` there (the header line shows the setting).
"""

import argparse
import dataclasses
import os
from pathlib import Path

import numpy as np

from safety_systems.planning.path_metrics import bending_energy, path_length, resample
from safety_systems.planning.path_optimisation import plan_optimised
from safety_systems.planning.planners import plan_iapf
from safety_systems.planning.rrt_star import plan_rrt_star
from safety_systems.planning.task_space import load_scene

PAPER = Path(__file__).parents[1] / "models" / "scenes" / "paper.yaml"
GOAL_SECONDS = 1.0
GOAL_LENGTH_RATIO = 1.05


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--rrt-time", type=float, default=None,
                        help="RRT* budget, s (default: the scene's planner.rrt_time)")
    parser.add_argument("--scene", default=str(PAPER))
    args = parser.parse_args()
    scene = load_scene(args.scene)
    if args.rrt_time is not None:
        scene = dataclasses.replace(scene, planner=dataclasses.replace(
            scene.planner, rrt_time=args.rrt_time))
    spacing = scene.planner.metric_spacing
    runs = []
    for _ in range(args.repeats):
        iapf = plan_iapf(scene)
        runs.append((plan_optimised(scene, iapf), iapf))
    seconds = [opt.planning_time for opt, _ in runs]
    opt, iapf = runs[int(np.argsort(seconds)[len(seconds) // 2])]
    rrt = plan_rrt_star(scene)
    if not (opt.reached_goal and rrt.reached_goal):
        raise SystemExit(f"goal not reached: IAPF+opt {opt.note!r}, RRT* {rrt.note!r}")
    t_opt, t_iapf = float(np.median(seconds)), iapf.planning_time
    length = {n: path_length(p.points) for n, p in (("opt", opt), ("rrt", rrt))}
    bend = {n: bending_energy(resample(p.points, spacing)) for n, p in (("opt", opt),
                                                                        ("rrt", rrt))}

    def line(measure: str, figure: str, goal: str = "", met: bool | None = None) -> None:
        mark = "" if met is None else ("yes" if met else "NO")
        print(f"{measure:46s} {figure:>12s} {goal:>10s} {mark:>5s}")

    print(f"scene {scene.name}: {len(runs)} IAPF runs, RRT* budget {scene.planner.rrt_time} s "
          f"({rrt.iterations} iterations), load average {os.getloadavg()[0]:.1f} on "
          f"{os.cpu_count()} cores, OPENBLAS_NUM_THREADS="
          f"{os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}")
    print(f"{'measure':46s} {'figure':>12s} {'goal':>10s} {'met':>5s}")
    line("IAPF planning time (median)", f"{t_iapf:.3f} s")
    line("IAPF + optimisation planning time (median)", f"{t_opt:.3f} s", f"< {GOAL_SECONDS} s",
         t_opt < GOAL_SECONDS)
    line("RRT* planning time (its budget)", f"{rrt.planning_time:.3f} s")
    line("planning time IAPF+opt / RRT*", f"{t_opt / rrt.planning_time:.3f}")
    line("length IAPF+opt", f"{length['opt']:.4f} m")
    line("length RRT* (best found)", f"{length['rrt']:.4f} m")
    ratio = length["opt"] / length["rrt"]
    line("length IAPF+opt / RRT*", f"{ratio:.3f}", f"<= {GOAL_LENGTH_RATIO}",
         ratio <= GOAL_LENGTH_RATIO)
    line("bending energy IAPF+opt", f"{bend['opt']:.2f} 1/m")
    line("bending energy RRT*", f"{bend['rrt']:.2f} 1/m")
    line("bending energy IAPF+opt / RRT*", f"{bend['opt'] / bend['rrt']:.4f}", "< 1",
         bend["opt"] < bend["rrt"])


if __name__ == "__main__":
    main()
