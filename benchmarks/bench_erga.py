"""Time of one ERGA decision (seed 004) beside the seed's 100 ms sampling period.

    python benchmarks/bench_erga.py [--repeats 50]

One decision as ErgaSpeedController makes it: two operators with the upper-body model
(8 ellipsoids each) against the UR5e's 7 ellipsoids (112 pairs), the danger index on
the grid of reachable path positions, then 50 individuals x 100 generations.
"""

import argparse
import time

import numpy as np

from safety_systems.speed_alteration.erga import ErgaParameters
from safety_systems.cell.joint_path import default_joint_path
from safety_systems.config.scenario import EllipsoidConfig
from safety_systems.speed_alteration.methods import (
    GRID,
    danger_grid,
    erga_speed,
    operator_ellipsoids,
    preprogrammed_speed,
)

PERIOD = 0.1  # s, the seed's sampling period
GOAL_MS = 5.0


def one_decision(path, v_pre, sizes, bodies, k):
    valid = np.ones(len(bodies), dtype=bool)
    humans = operator_ellipsoids(bodies, valid, np.array([0, 0, 1, 1]),
                                 np.ones(4, dtype=bool), sizes)
    speeds = np.linspace(-0.25, 0.25, GRID)
    danger = danger_grid(path, 2.3, speeds, PERIOD, v_pre, humans, sizes)
    v, _ = erga_speed(grid_speeds=speeds, danger=danger, v_pre=v_pre, v_prev=v_pre,
                      limit=0.25, rng=np.random.default_rng([0, k]), params=ErgaParameters(),
                      P=1.0, D=1.0, R=10.0)
    return v, danger.shape[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=50)
    args = parser.parse_args()
    path = default_joint_path()
    v_pre = preprogrammed_speed(path)
    sizes = EllipsoidConfig()
    bodies = np.array([[0.75, -0.1, 0.3], [0.75, 0.2, 0.3], [0.2, 0.7, 0.3], [-0.1, 0.7, 0.3]])
    _, pairs = one_decision(path, v_pre, sizes, bodies, 0)  # warm up
    times = []
    for k in range(args.repeats):
        start = time.perf_counter()
        one_decision(path, v_pre, sizes, bodies, k)
        times.append(time.perf_counter() - start)
    ms = 1000.0 * float(np.median(times))
    best = 1000.0 * float(np.min(times))
    print(f"{'measure':44s} {'figure':>10s} {'goal':>8s} {'met':>5s}")
    print(f"{f'one ERGA decision, {pairs} pairs (median)':44s} {ms:8.2f}ms {GOAL_MS:6.0f}ms "
          f"{'yes' if ms <= GOAL_MS else 'NO':>5s}")
    print(f"{f'one ERGA decision, {pairs} pairs (best)':44s} {best:8.2f}ms {GOAL_MS:6.0f}ms "
          f"{'yes' if best <= GOAL_MS else 'NO':>5s}")
    print(f"{'share of the 100 ms sampling period':44s} {ms / 1000 / PERIOD:9.1%}")


if __name__ == "__main__":
    main()
