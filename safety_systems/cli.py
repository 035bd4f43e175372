"""The ``safety-systems`` command line: thin subcommands that parse, call and report.

Exit codes: 0 done, 2 bad input (one line on stderr naming the field, the value and
what is allowed).
"""

import argparse
import dataclasses
import sys
from pathlib import Path

from safety_systems.scenario import ScenarioError, load_scenario

EXIT_BAD_INPUT = 2


def _simulate(args: argparse.Namespace) -> int:
    scenario = load_scenario(args.scenario)
    if args.mode is not None:
        scenario = dataclasses.replace(
            scenario, robot=dataclasses.replace(scenario.robot, mode=args.mode))
    if args.duration is not None:
        if not args.duration > 0.0:
            raise ScenarioError("--duration", args.duration, "a number of seconds > 0")
        scenario = dataclasses.replace(scenario, duration=args.duration)
    from safety_systems.outputs import write_outputs
    from safety_systems.simulation import simulate

    run = simulate(scenario, progress=not args.quiet)
    summary = write_outputs(run, Path(args.out), html=args.html)
    if not args.quiet:
        task = summary["task_time"]
        sep = summary["min_separation_while_moving"]
        print(f"{scenario.name}: task_time={'unfinished' if task is None else f'{task:.2f} s'}"
              f", min_separation_while_moving={'n/a' if sep is None else f'{sep:.3f} m'}"
              f", contact_while_moving={summary['contact_while_moving']}"
              f", stopped_time={summary['stopped_time']:.2f} s -> {args.out}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="safety-systems",
        description="Simulate, verify and tune ISO/TS 15066 speed and separation monitoring "
                    "of a collaborative UR5e cell.")
    commands = parser.add_subparsers(dest="command", required=True)
    sim = commands.add_parser("simulate", help="run one scenario and write its outputs")
    sim.add_argument("scenario", help="scenario YAML file")
    sim.add_argument("--out", required=True, help="output directory")
    sim.add_argument("--html", action="store_true", help="also write replay.html (Meshcat)")
    sim.add_argument("--mode", choices=("kinematic", "dynamic"),
                     help="override the scenario's robot.mode")
    sim.add_argument("--duration", type=float, help="override the scenario's duration, s")
    sim.add_argument("--quiet", action="store_true", help="no progress bar or summary line")
    sim.set_defaults(run=_simulate)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.run(args)
    except ScenarioError as e:
        print(f"safety-systems: {e}", file=sys.stderr)
        return EXIT_BAD_INPUT


if __name__ == "__main__":
    sys.exit(main())
