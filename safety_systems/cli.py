"""The ``safety-systems`` command line: thin subcommands that parse, call and report.

Exit codes: 0 done, 2 bad input (one line on stderr naming the field, the value and
what is allowed); ``verify`` has its own table (``verification.verdicts``).
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


def _verify(args: argparse.Namespace) -> int:
    from safety_systems.scenario import load_controller_config
    from verification.report import disagreement_lines, vacuous_warnings, write_report
    from verification.space import load_space
    from verification.verdicts import EXIT_REQUIREMENT, exit_code
    from verification.verify import verify

    config = load_controller_config(args.config)
    space = load_space(args.space)
    for name in ("budget", "workers"):
        value = getattr(args, name)
        if value is not None and value < 1:
            raise ScenarioError(f"--{name}", value, "an integer >= 1")
    if args.seed < 0:
        raise ScenarioError("--seed", args.seed, "an integer >= 0")
    out = Path(args.out)
    outcome = verify(config, space, out, budget=args.budget, method=args.method,
                     workers=args.workers, scheduler=args.scheduler, seed=args.seed,
                     progress=not args.quiet, config_text=Path(args.config).read_text(),
                     properties=args.property, stop_at_first=args.stop_at_first)
    report = write_report(outcome, out, config_path=args.config, space_path=args.space)
    if report["braking_data"] == "placeholder":
        from verification.report import PLACEHOLDER_WARNING

        print(f"safety-systems: warning: {PLACEHOLDER_WARNING}", file=sys.stderr)
    for line in vacuous_warnings(report):
        print(f"safety-systems: warning: {line}", file=sys.stderr)
    for line in disagreement_lines(report):
        print(f"safety-systems: {line}", file=sys.stderr)
    code = exit_code(outcome.verdict, args.require)
    if not args.quiet:
        for name, p in report["properties"].items():
            first = p["simulations_to_first_counterexample"]
            vacuous = p["vacuous"]["evaluated"]["share"]
            print(f"{name}: {p['verdict']}: min robustness {p['min_robustness']}"
                  + (f", first counterexample after {first} simulations" if first else "")
                  + (f", {100.0 * vacuous:.0f}% vacuous" if vacuous is not None else "")
                  + (f"; needs {p['proof']['needed_allowance']:.3f} m more Z_d + Z_r"
                     if p["proof"].get("needed_allowance") else ""))
        e = report["evaluations"]
        print(f"{report['verdict']} over {report['simulations']} simulations "
              f"({e['total']} model evaluations: {e['simulations']} simulations, "
              f"{e['rankings']} rankings, {e['drake']} Drake runs; "
              f"{report['cpu_seconds']:.1f} s CPU) -> {out}")
    if code == EXIT_REQUIREMENT:
        print(f"safety-systems: --require {args.require}: the verdict is {outcome.verdict}",
              file=sys.stderr)
    return code


def _compare(args: argparse.Namespace) -> int:
    from safety_systems.compare import compare, markdown_table, write_comparison
    from safety_systems.scenario import CONTROLLER_TYPES

    controllers = [c.strip() for c in args.controllers.split(",") if c.strip()]
    for c in controllers:
        if c not in CONTROLLER_TYPES:
            raise ScenarioError("--controllers", c, " | ".join(CONTROLLER_TYPES))
    scenarios = [load_scenario(path) for path in args.scenarios]
    rows = compare(scenarios, controllers)
    write_comparison(rows, Path(args.out))
    if not args.quiet:
        print(markdown_table(rows), end="")
    return 0


def _plan(args: argparse.Namespace) -> int:
    """Plan with IAPF (+ Eq. 5 optimisation), GDA and RRT*; exit 1 when the IAPF does
    not reach the goal (no ``task_path.yaml`` is written then)."""
    from safety_systems.plan_report import write_plan
    from safety_systems.plan_sweeps import SWEEPS
    from safety_systems.task_space import load_scene

    if args.sweep is not None and args.sweep not in SWEEPS:
        raise ScenarioError("--sweep", args.sweep, " | ".join(SWEEPS))
    scene = load_scene(args.scene)
    report = write_plan(scene, Path(args.out), sweep=args.sweep)
    rows = {r["planner"]: r for r in report["rows"]}
    if not args.quiet:
        from safety_systems.plan_report import markdown_table

        print(markdown_table(report["rows"]), end="")
        print(f"-> {args.out}")
    return 0 if rows["IAPF"]["reached_goal"] else 1


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
    from verification.verdicts import EXIT_TABLE, REQUIREMENTS  # (light: no Drake)

    ver = commands.add_parser(
        "verify", help="prove or falsify 'stopped before contact' and the separation "
                       "invariant (distance never below S while the robot may move) over a "
                       "scenario space (exit 0 proved/passed, 1 falsified, 2 bad input, "
                       "3 inconclusive, 4 weaker than --require)",
        formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EXIT_TABLE)
    ver.add_argument("config", help="controller configuration YAML file")
    ver.add_argument("--space", required=True, help="scenario space YAML file")
    ver.add_argument("--out", required=True, help="output directory (reused to resume)")
    ver.add_argument("--budget", type=int, default=200, help="closed-loop simulations")
    ver.add_argument("--method", default="falsify",
                     choices=("falsify", "sobol", "halton", "grid", "uniform", "corners"))
    where = ver.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, help="local processes (default: all cores)")
    where.add_argument("--scheduler", help="Dask scheduler address, e.g. tcp://10.0.0.5:8786")
    ver.add_argument("--property", default="both", choices=("contact", "separation", "both"),
                     help="which property to verify: contact (stopped before contact), "
                          "separation (distance never below S while motion is permitted) or "
                          "both (default: both; the verdict is the weaker)")
    ver.add_argument("--seed", type=int, default=0)
    ver.add_argument("--require", default="none", choices=REQUIREMENTS,
                     help="exit 4 when the verdict is weaker than this (passed under "
                          "'proved'); falsified (1) and inconclusive (3) fail under any")
    ver.add_argument("--stop-at-first", action="store_true",
                     help="return as soon as one counterexample is confirmed in the Drake "
                          "diagram (exit 1; other properties are left unchecked)")
    ver.add_argument("--quiet", action="store_true")
    ver.set_defaults(run=_verify)
    cmp_ = commands.add_parser("compare", help="run several controllers on the same scenarios "
                                                "and tabulate danger index, goal and jerk")
    cmp_.add_argument("scenarios", nargs="+", help="scenario YAML files")
    cmp_.add_argument("--controllers", default="erga,hwang,bimodal,none",
                      help="comma-separated controller types; the first is the reference")
    cmp_.add_argument("--out", required=True, help="output directory")
    cmp_.add_argument("--quiet", action="store_true")
    cmp_.set_defaults(run=_compare)
    plan = commands.add_parser(
        "plan", help="plan a tool path around static obstacles with IAPF, GDA and RRT* "
                     "(seed 001) and write paths, tables, a plot and task_path.yaml "
                     "(exit 1 if the IAPF does not reach the goal)")
    plan.add_argument("scene", help="task-space scene YAML file (models/scenes/)")
    plan.add_argument("--out", required=True, help="output directory")
    plan.add_argument("--sweep", help="also run one of the seed's sweeps: obstacles, "
                                      "radius, radii, height, k_att, k_rep, zeta")
    plan.add_argument("--quiet", action="store_true")
    plan.set_defaults(run=_plan)
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
