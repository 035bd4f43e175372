"""A robot with a number of joints not seen before: its first ``verify`` against its second,
in CPU time (issue 50: no compile per robot kind).

    python benchmarks/bench_new_robot.py [--budget 32] [--joints 5] [--json FILE]

The robot is the Franka Panda's description (``models/panda``) with some of its revolute
joints made fixed, so its chain has ``--joints`` joints (5 by default: joints 5 and 7
fixed; the shipped robots have 6 and 7). First the shipped Panda verifies once (the
compiled cache as after the shipped robots have run), then the new robot twice, each
``safety-systems verify`` a process of its own over the Panda's default space on the new
robot (its cycle: the Panda's waypoints without the fixed joints' columns), with
``--workers 1`` (its configuration iso_panda.yaml with the Panda's placeholder stopping rows
stated as its own: a robot from another URDF has none built in). Printed: each run's wall and CPU time (the process and every process it
waited for), and the ratio of the new robot's first run's CPU to its second's beside the
goal (at most 2).
"""

import argparse
import json
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).parents[1]
PANDA = ROOT / "models" / "panda"
SPACE = ROOT / "models" / "spaces" / "robots" / "default_panda.yaml"
CONFIG = ROOT / "models" / "configs" / "robots" / "iso_panda.yaml"
GOAL = 2.0
FIXED_ORDER = (5, 7, 3, 6, 2)  # the Panda's joints made fixed, in this order


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def new_robot(folder: Path, joints: int) -> Path:
    """A space file for the Panda with ``7 - joints`` joints fixed (its URDF beside it,
    the meshes linked)."""
    fixed = FIXED_ORDER[:7 - joints]
    text = (PANDA / "panda.urdf").read_text()
    for j in fixed:
        text, n = re.subn(rf'(<joint name="panda_joint{j}" type=)"revolute"', r'\1"fixed"',
                          text)
        assert n == 1, j
    (folder / "meshes").symlink_to(PANDA / "meshes")
    (folder / "robot.urdf").write_text(text)
    space = yaml.safe_load(SPACE.read_text())
    keep = [i for i in range(7) if i + 1 not in fixed]
    path = space["robot"]["path"]
    path["waypoints_deg"] = [[row[i] for i in keep] for row in path["waypoints_deg"]]
    space["robot"]["urdf"] = str(folder / "robot.urdf")
    space["name"] = f"default_panda_{joints}_joints"
    out = folder / "space.yaml"
    out.write_text(yaml.safe_dump(space, sort_keys=False))
    return out


def new_config(folder: Path) -> Path:
    """iso_panda.yaml with stopping data of its own: a robot from another URDF has no
    placeholder, so it states the Panda's placeholder rows as its own (a benchmark's
    stand-in for measured data)."""
    from safety_systems.cell.placeholder_stops import placeholder_braking_table

    table = placeholder_braking_table("panda")
    config = yaml.safe_load(CONFIG.read_text())
    config["braking"] = {name: [float(x) for x in getattr(table, name)]
                         for name in ("speed_fraction", "stopping_time", "stopping_distance")}
    out = folder / "config.yaml"
    out.write_text(yaml.safe_dump(config, sort_keys=False))
    return out


def verify(config: Path, space: Path, out: Path, budget: int) -> dict:
    """One verify process: its wall and CPU seconds and its verdict."""
    cpu, start = _cpu(), time.perf_counter()
    done = subprocess.run([str(Path(sys.executable).parent / "safety-systems"), "verify",
                           str(config), "--space", str(space), "--out", str(out),
                           "--budget", str(budget), "--workers", "1", "--quiet"],
                          capture_output=True, text=True)
    wall, used = time.perf_counter() - start, _cpu() - cpu
    if done.returncode not in (0, 1):
        raise SystemExit(f"verify failed ({done.returncode}): {done.stderr[-2000:]}")
    report = json.loads((out / "report.json").read_text())
    return {"wall": wall, "cpu": used, "verdict": report["verdict"]}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budget", type=int, default=32)
    parser.add_argument("--joints", type=int, default=5, choices=(2, 3, 4, 5))
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        runs = {"shipped Panda (7 joints)": verify(CONFIG, SPACE, folder / "panda",
                                                   args.budget)}
        space, config = new_robot(folder, args.joints), new_config(folder)
        for run in ("first", "second"):
            runs[f"new robot ({args.joints} joints), {run}"] = verify(
                config, space, folder / run, args.budget)
    for name, r in runs.items():
        print(f"{name}: {r['wall']:.1f} s wall, {r['cpu']:.1f} s CPU, {r['verdict']}")
    first, second = list(runs.values())[1:]
    ratio = first["cpu"] / second["cpu"]
    met = ratio <= GOAL
    print(f"new robot's first verify / its second, CPU: {ratio:.2f} (goal: <= {GOAL:g}) -> "
          f"{'MET' if met else 'NOT MET'}")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"budget": args.budget, "joints": args.joints,
                                         "runs": runs, "ratio": ratio, "goal": GOAL,
                                         "met": met}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
