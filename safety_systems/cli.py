"""The ``safety-systems`` command line: thin subcommands that parse, call and report.

Every subcommand reads and checks all its inputs first (``safety_systems.files.documents``),
then creates (or refuses) its output folder, and only then does its work; every
result file is written atomically (``safety_systems.files.output_files``) and carries its
provenance (``safety_systems.outputs.provenance``).

Exit codes: 0 done, 1 (``plan``: the IAPF did not reach the goal; ``tune``: no
candidate met its constraint; ``check``, ``run``: parameters not certified), 2 bad input
(one line on stderr naming the file, the field, the value and what is allowed), 3
(``verify``: inconclusive; ``run``: a fault ended it), 4 (``verify``, ``check``: a verdict
weaker than ``--require``), 130 interrupted; ``verify``'s table:
``verification.verdicts``.
"""

import argparse
import contextlib
import dataclasses
import os
import sys
import warnings

from safety_systems.files.documents import forget_inputs
from safety_systems.files.input_error import InputError
from safety_systems.files.ranges import SEED_MAX

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130
MAX_BUDGET = 10_000_000  # simulations of one verify run
MAX_WORKERS = 1024
MAX_CANDIDATES = 10_000  # configurations one tune run simulates
MAX_SCREEN = 1_000  # screened points per simulated candidate


def _warn(message: str) -> None:
    print(f"safety-systems: warning: {message}", file=sys.stderr)


class Refused(Exception):
    """A command refuses its input: exit ``code`` with one ``line`` on stderr."""

    def __init__(self, code: int, line: str):
        super().__init__(line)
        self.code, self.line = code, line


def _configuration(path: str, unverified: bool):
    """(controller configuration, (certified robot, params.yaml's folder) or None) of a
    configuration file or a params.yaml; a params.yaml must pass its certificate check,
    unless ``unverified`` (then a warning says it is unverified)."""
    from pathlib import Path

    from safety_systems.config.params_file import looks_like_params
    from safety_systems.config.scenario import load_controller_config

    if not looks_like_params(path):
        return load_controller_config(path), None
    from verification.deploy.certificate import EXIT_UNREADABLE, check

    result = check(path)
    if result.params is None:  # params.yaml itself cannot be read
        raise Refused(EXIT_UNREADABLE, result.line)
    if not result.certified:
        if not unverified:
            raise Refused(result.code, result.line + " (--unverified runs it anyway)")
        _warn(f"UNVERIFIED parameters (--unverified): {result.line}")
    elif result.verdict == "passed":
        _warn(result.line)
    return result.params.controller, (result.params.robot, Path(path).parent)


def _origin(argv: list[str], seeds: dict[str, int]) -> dict:
    from safety_systems.outputs.provenance import provenance

    return provenance(seeds, ["safety-systems", *argv])


def _whole(name: str, value: int | None, low: int, high: int) -> None:
    if value is not None and not low <= value <= high:
        raise InputError(name, value, f"an integer, {low} <= {name.lstrip('-')} <= {high:,}")


def _ur5e_only(robot, command: str, file: str) -> None:
    """Refuses, in one line, a robot other than the UR5e for ``command`` (the verifier,
    the tuner and the comparison of seed 001/004's measures model the UR5e only)."""
    from safety_systems.cell.robot_model import is_ur5e
    from safety_systems.config.scenario import robot_model_of

    try:
        model = robot_model_of(robot)
    except InputError as e:
        raise e.in_file(file) from None
    if not is_ur5e(model):
        raise InputError("robot.model", model.name, f"ur5e for {command} (another robot: "
                         "simulate only, for now)", file=file)


def _same_robot(robot, reference, file: str, reference_file: str) -> None:
    """Refuses, in one line, a task scenario whose robot is not the space's (tune times
    the tasks of the robot it verifies)."""
    from safety_systems.config.scenario import robot_model_of

    mine, theirs = robot_model_of(robot), robot_model_of(reference)
    if (mine.name, mine.sha256) != (theirs.name, theirs.sha256):
        raise InputError("robot", mine.name, f"the space's robot, {theirs.name} "
                         f"({reference_file}): --tasks on the robot that is verified",
                         file=file)


def _simulate(args: argparse.Namespace) -> int:
    from safety_systems.files.output_files import prepare_out
    from safety_systems.outputs.provenance import scenario_seeds
    from safety_systems.config.resolved_cell import resolve_scenario
    from safety_systems.config.scenario import (
        MAX_DURATION,
        load_scenario,
        validate_robot,
        validate_robot_controller,
    )

    scenario = load_scenario(args.scenario)
    if args.config is not None:
        from safety_systems.config.configuration import with_controller
        from safety_systems.config.params_file import robot_config

        config, robot = _configuration(args.config, args.unverified)
        scenario = with_controller(scenario, config)
        if robot is not None:
            scenario = dataclasses.replace(scenario, robot=robot_config(
                robot[0], scenario.robot, robot[1]))
        try:  # the configuration (and the robot settings it certifies) on the robot
            validate_robot(scenario.robot)
            validate_robot_controller(scenario.robot, scenario.controller, "config")
        except InputError as e:
            raise e.in_file(args.config) from None
    if args.mode is not None:
        scenario = dataclasses.replace(
            scenario, robot=dataclasses.replace(scenario.robot, mode=args.mode))
    if args.duration is not None:
        if not 0.0 < args.duration <= MAX_DURATION:
            raise InputError("--duration", args.duration,
                             f"0 < duration <= {MAX_DURATION:g} s")
        scenario = dataclasses.replace(scenario, duration=args.duration)
    try:  # what the configuration means on this robot in this cell, once
        cell = resolve_scenario(scenario)
    except InputError as e:
        raise e.in_file(args.scenario if args.config is None else args.config) from None
    out = prepare_out(args.out)
    if cell.braking_source == "placeholder":
        _warn(cell.braking_warning)
    from safety_systems.outputs.run_files import write_outputs
    from safety_systems.diagrams.simulation import simulate

    run = simulate(scenario, progress=not args.quiet, cell=cell)
    summary = write_outputs(run, out, html=args.html,
                            origin=_origin(args.argv, scenario_seeds(scenario)))
    for line in summary.get("unknown_pivots", []):
        _warn(line)
    if not args.quiet:
        print(f"{scenario.name}: {simulate_line(summary)} -> {args.out}")
    return 0


def simulate_line(summary: dict) -> str:
    """``simulate``'s console line: a run's figures from its summary.json."""
    task = summary["task_time"]
    sep = summary["min_separation_while_moving"]
    margin = summary["min_separation_margin"]
    return (f"task_time={'unfinished' if task is None else f'{task:.2f} s'}"
            f", min_separation_while_moving={'n/a' if sep is None else f'{sep:.3f} m'}"
            f", contact_while_moving={summary['contact_while_moving']}"
            f", min_separation_margin="
            + ("n/a" if margin is None else f"{margin:+.3f} m at "
               f"{summary['min_separation_margin_time']:.2f} s"
               + (" (the separation invariant broken: d_true < S_true while the robot "
                  "was let move)" if margin < 0.0 else ""))
            + f", stopped_time={summary['stopped_time']:.2f} s"
            + (f"; {words}" if (words := _held_words(summary)) else ""))


def _held_words(summary: dict) -> str:
    from safety_systems.outputs.held_terms import held_words

    return held_words(summary["held"]) if "held" in summary else ""


def _verify(args: argparse.Namespace) -> int:
    from safety_systems.files.documents import read_text
    from safety_systems.files.output_files import prepare_out
    from verification.report import (
        counts_in_words,
        disagreement_lines,
        first_words,
        metres,
        placeholder_words,
        vacuous_warnings,
        write_report,
    )
    from verification.search.runner import check_scheduler
    from verification.spaces.space import load_space
    from verification.phases import Phases
    from verification.verdicts import EXIT_REQUIREMENT, exit_code
    from verification.verify import PHASES, verify

    config, robot = _configuration(args.config, args.unverified)
    space = load_space(args.space)
    if robot is not None:
        from safety_systems.config.params_file import robot_config

        space = dataclasses.replace(space, robot=robot_config(robot[0], space.robot,
                                                              robot[1]))
    _whole("--budget", args.budget, 1, MAX_BUDGET)
    _whole("--workers", args.workers, 1, MAX_WORKERS)
    _whole("--seed", args.seed, 0, SEED_MAX)
    if args.scheduler is not None:
        check_scheduler(args.scheduler)
    out = prepare_out(args.out)
    if space.recording is not None:
        from safety_systems.sensing.recording_mapping import pivot_warnings

        for line in pivot_warnings(space.recording.mapping):
            _warn(line)  # (the report's assumptions name them too)
    phases = Phases("verify", PHASES, on=not args.quiet)
    outcome = verify(config, space, out, budget=args.budget, method=args.method,
                     workers=args.workers, scheduler=args.scheduler, seed=args.seed,
                     progress=not args.quiet, config_text=read_text(args.config),
                     properties=args.property, stop_at_first=args.stop_at_first,
                     phases=phases)
    phases.start("writing the report, its figure and the worst counterexample's replay")
    report = write_report(outcome, out, config_path=args.config, space_path=args.space,
                          origin=_origin(args.argv, {"search": args.seed}))
    if report["braking_data"] == "placeholder":
        _warn(placeholder_words(report))
    for line in vacuous_warnings(report):
        _warn(line)
    for line in disagreement_lines(report):
        print(f"safety-systems: {line}", file=sys.stderr)
    code = exit_code(outcome.verdict, args.require)
    if not args.quiet:
        for name, p in report["properties"].items():
            first = p["simulations_to_first_counterexample"]
            vacuous = p["vacuous"]["evaluated"]["share"]
            figure = metres(p["min_robustness"])
            if name == "permitted_contact" and figure.endswith(" m"):
                figure = figure[:-2] + " (m/s at a contact; without one, m of clearance)"
            print(f"{name}: {p['verdict']}: the search's min robustness {figure}"
                  + (f", {first_words(first)}" if first else "")
                  + (f", {100.0 * vacuous:.0f}% vacuous" if vacuous is not None else "")
                  + (f"; needs {p['proof']['needed_allowance']:.3f} m more Z_d + Z_r"
                     if p["proof"].get("needed_allowance") else ""))
        e = report["evaluations"]
        print(f"{report['verdict']} over {report['simulations']} simulations "
              f"({e['total']} model evaluations: {counts_in_words(e)} of "
              f"{report['budget']}; {report['cpu_seconds']:.1f} s CPU) -> {out}")
    if code == EXIT_REQUIREMENT:
        print(f"safety-systems: --require {args.require}: the verdict is {outcome.verdict}",
              file=sys.stderr)
    return code


def _tune(args: argparse.Namespace) -> int:
    """Search the tunable parameters for the shortest task time under the verdict
    constraint; exit 1 when no candidate meets it."""
    from safety_systems.files.output_files import prepare_out
    from safety_systems.config.scenario import load_scenario
    from verification.search.runner import check_scheduler
    from verification.spaces.space import load_space
    from verification.tune.tuner import TASKS, Tuner
    from verification.tune.report import write_tune
    from verification.tune.tunable import check_block, load_levers, load_tunable
    from safety_systems.config.configuration import is_recorded

    config, block = load_tunable(args.config, args.tune)
    levers = load_levers(args.tune)
    space = load_space(args.space)
    if space.recording is not None and args.allow == "proved":
        raise InputError("--allow", args.allow, "passed with a space built around a "
                         "recording (the proofs decline recorded motion: its verdicts are "
                         "passed or falsified, never proved)")
    tasks = [load_scenario(path) for path in (args.tasks or TASKS)]
    for path, task in zip(args.tasks or TASKS, tasks):
        _same_robot(task.robot, space.robot, path, args.space)
        if levers and is_recorded(task):
            raise InputError("levers", f"{len(levers)} levers", "a tune file without levers "
                             f"for a recorded task ({path}: its operators wear what the "
                             "recording tracked, so no sensor set can be priced on it)"
                             ).in_file(args.tune)
    try:
        check_block(block, config, control_period=1.0 / space.robot.control_rate_hz)
    except InputError as e:
        raise e.in_file(args.tune or args.config) from None
    _whole("--budget", args.budget, 1, MAX_BUDGET)
    _whole("--candidates", args.candidates, 1, MAX_CANDIDATES)
    _whole("--screen", args.screen, 1, MAX_SCREEN)
    _whole("--workers", args.workers, 1, MAX_WORKERS)
    _whole("--seed", args.seed, 0, SEED_MAX)
    if args.scheduler is not None:
        check_scheduler(args.scheduler)
    out = prepare_out(args.out)
    say = (lambda line: None) if args.quiet else (lambda line: print(line, flush=True))
    result = Tuner(config, block, space, tasks, out, space_path=args.space, allow=args.allow,
                   budget=args.budget, candidates=args.candidates, screen=args.screen,
                   workers=args.workers, scheduler=args.scheduler, seed=args.seed,
                   origin=_origin(args.argv, {"search": args.seed}), say=say,
                   progress=not args.quiet, levers=levers).run()
    write_tune(result, out)
    if not args.quiet:
        def seconds(x):
            return "unfinished" if x is None else f"{x:.2f} s"

        for row in result["table"]:
            print(f"{row['configuration']}: {row['verdict']}, total task time "
                  f"{seconds(row['total_task_time'])}, lost {seconds(row['total_lost_time'])}")
        reduction = result["lost_time_reduction_vs_iso"]
        if reduction is not None:
            iso = next(r for r in result["table"] if r["configuration"] == "iso.yaml")
            print(f"time lost: {100.0 * reduction:.1f}% less than iso.yaml"
                  + ("" if iso["verdict"] == "proved" else
                     f" (which is {iso['verdict']}, not proved, over this space)"))
        for row in result["levers"]:
            print(f"lever {row['label']}: {'proved' if row['proved'] else 'not proved'}, "
                  f"lost {seconds(row['total_lost'])}"
                  + ("" if row["reduction"] is None else
                     f", {100.0 * row['reduction']:.1f}% less than iso.yaml"))
        print(f"-> {out / 'tune.md'}")
    if result["chosen"] is None:
        print(f"safety-systems: tune: no candidate was {args.allow}", file=sys.stderr)
        return 1
    return 0


def _compare(args: argparse.Namespace) -> int:
    from safety_systems.files.output_files import prepare_out
    from safety_systems.outputs.provenance import scenario_seeds
    from safety_systems.config.scenario import CONTROLLER_TYPES, load_scenario

    controllers = [c.strip() for c in args.controllers.split(",") if c.strip()]
    allowed = "a comma-separated list of " + " | ".join(CONTROLLER_TYPES)
    if not controllers:
        raise InputError("--controllers", args.controllers, allowed + " (one or more)")
    for c in controllers:
        if c not in CONTROLLER_TYPES:
            raise InputError("--controllers", c, allowed)
    scenarios = [load_scenario(path) for path in args.scenarios]
    for path, s in zip(args.scenarios, scenarios):
        _ur5e_only(s.robot, "compare", path)
    out = prepare_out(args.out)
    from safety_systems.outputs.compare import compare, markdown_table, write_comparison

    rows = compare(scenarios, controllers)
    seeds = {}
    for i, s in enumerate(scenarios):
        seeds.update(scenario_seeds(s, prefix=f"{s.name or i}."))
    write_comparison(rows, out, origin=_origin(args.argv, seeds))
    if not args.quiet:
        print(markdown_table(rows), end="")
    return 0


def _plan(args: argparse.Namespace) -> int:
    """Plan with IAPF (+ Eq. 5 optimisation), GDA and RRT*; exit 1 when the IAPF does
    not reach the goal (no ``task_path.yaml`` is written then)."""
    from safety_systems.files.output_files import prepare_out
    from safety_systems.planning.plan_sweeps import SWEEPS, sweep_scenes
    from safety_systems.planning.task_space import load_scene

    if args.sweep is not None and args.sweep not in SWEEPS:
        raise InputError("--sweep", args.sweep, " | ".join(SWEEPS))
    scene = load_scene(args.scene)
    if args.sweep is not None:
        sweep_scenes(scene, args.sweep)  # raises InputError before any work
    out = prepare_out(args.out)
    from safety_systems.outputs.plan_report import write_plan

    report = write_plan(scene, out, sweep=args.sweep,
                        origin=_origin(args.argv, {"planner": scene.planner.seed}))
    rows = {r["planner"]: r for r in report["rows"]}
    if not args.quiet:
        from safety_systems.outputs.plan_report import markdown_table

        print(markdown_table(report["rows"]), end="")
        print(f"-> {args.out}")
    return 0 if rows["IAPF"]["reached_goal"] else 1


def _run(args: argparse.Namespace) -> int:
    from safety_systems.runtime.command import run

    # (the provenance is taken when the summary is written: by then every input was read)
    return run(args, lambda: _origin(args.argv, {}))


def _export(args: argparse.Namespace) -> int:
    """params.yaml, certificate.json and report.html of a verified configuration."""
    from pathlib import Path

    from safety_systems.files.output_files import prepare_out
    from safety_systems.config.scenario import load_controller_config
    from verification.deploy.export import build, read_report, read_tune, write_export

    config = load_controller_config(args.config)
    report = read_report(args.report)
    tune = read_tune(args.tune) if args.tune is not None else None
    params, certificate, space = build(config, args.config, report, Path(args.report), tune,
                                       args.tune, Path(args.out))
    out = prepare_out(args.out)
    written = write_export(params, certificate, space, report, Path(args.report).parent,
                           args.config, out)
    if written["braking_data"]["origin"] == "placeholder":
        from verification.deploy.certificate import params_cell

        _warn(params_cell(params, Path(args.out)).braking_warning)
    if written["verdict"] not in ("proved", "passed"):
        _warn(f"the verdict is {written['verdict']}: check refuses these parameters")
    if not args.quiet:
        print(f"{written['verdict']}, safety checksum {written['checksum_short']} -> "
              f"{out / 'params.yaml'}, {out / 'certificate.json'}, {out / 'report.html'}")
    return 0


def _explained(path: str):
    """(controller configuration, (certified robot, params.yaml's folder) or None) of a
    configuration file or a params.yaml, for ``explain``: a params.yaml is checked against
    its certificate, and explained with a warning when it fails the check (what a file
    means does not need it certified); an unreadable one is refused."""
    from pathlib import Path

    from safety_systems.config.params_file import looks_like_params
    from safety_systems.config.scenario import load_controller_config

    if not looks_like_params(path):
        return load_controller_config(path), None
    from verification.deploy.certificate import EXIT_UNREADABLE, check

    result = check(path)
    if result.params is None:
        raise Refused(EXIT_UNREADABLE, result.line)
    if not result.certified:
        _warn(f"NOT CERTIFIED (explained all the same): {result.line}")
    return result.params.controller, (result.params.robot, Path(path).parent)


def _explain(args: argparse.Namespace) -> int:
    """The resolved terms of a configuration or params.yaml on its robot: S of every
    segment at a few path rates, the dominating term, the override's command at a few
    clearances, and the premises (``safety_systems.outputs.explanation``)."""
    from safety_systems.config.params_file import robot_config
    from safety_systems.config.resolved_cell import DEFAULT_POINTS, resolve
    from safety_systems.config.scenario import (
        RobotConfig,
        robot_model_of,
        validate_robot,
        validate_robot_controller,
    )
    from safety_systems.files.output_files import write_json
    from safety_systems.outputs.explanation import explanation, explanation_text

    for name, values, low, high in (("--rates", args.rates, 0.0, 1.0),
                                    ("--distances", args.distances, 0.0, 100.0)):
        for x in values:
            if not (low < x <= high):
                raise InputError(name, x, f"numbers {low:g} < x <= {high:g}")
    if args.robot is not None and args.space is not None:
        raise InputError("--robot", args.robot, "omitted with --space (the space brings its "
                         "robot)")
    config, certified = _explained(args.config)
    points, names, peak, noise = [list(DEFAULT_POINTS)], ["operator"], None, None
    robot = RobotConfig()
    if args.space is not None:
        from verification.spaces.space import explained_operators, load_space

        space = load_space(args.space)
        robot = space.robot
        points, names, peak, noise = explained_operators(space)
    elif args.robot is not None:
        is_urdf = args.robot.lower().endswith(".urdf")
        robot = RobotConfig(model="" if is_urdf else args.robot,
                            urdf=args.robot if is_urdf else "")
    if certified is not None:
        if args.robot is not None:
            raise InputError("--robot", args.robot, "omitted with a params.yaml (it brings "
                             "its robot)")
        robot = robot_config(certified[0], robot, certified[1])
    if args.robot is not None:
        try:
            robot_model_of(robot)
        except InputError as e:
            raise InputError("--robot", args.robot, e.allowed) from None
    try:
        validate_robot(robot)
        validate_robot_controller(robot, config, "config")
        cell = resolve(config, robot, points=points, names=names)
    except InputError as e:
        raise e.in_file(args.config) if e.field.startswith("config") else e from None
    data = explanation(cell, tuple(args.rates), tuple(args.distances), peak, noise)
    if args.json is not None:
        write_json(args.json, data)
    print(explanation_text(data), end="")
    return 0


def _loaders() -> dict:
    from safety_systems.config.scenario import (
        TaskPoints,
        load_controller_config,
        load_scenario,
        load_typed,
    )
    from safety_systems.sensing.recording_mapping import check_mapping, check_recording_file
    from safety_systems.planning.task_space import load_scene
    from verification.spaces.space import load_space

    return {"scenario": load_scenario, "config": load_controller_config, "space": load_space,
            "scene": load_scene, "task-path": lambda path: load_typed(TaskPoints, path),
            "mapping": check_mapping, "robot-log": _check_robot_log,
            "recording": check_recording_file}


def _check_robot_log(path: str) -> None:
    """A robot log (an RTDE CSV, or a bag's only JointState topic) under the rules of
    ``cell.robot_log`` against the UR5e's joints (a scenario checks its own robot's)."""
    from safety_systems.cell.robot_log import (
        check_joint_log,
        check_path_speeds,
        make_log_path,
        read_joint_log,
    )
    from safety_systems.cell.robot_model import default_model
    from safety_systems.config.scenario import RobotLogConfig

    model = default_model()
    log = read_joint_log(path, tuple(model.joint_names))
    check_joint_log(log, lower=model.position_lower, upper=model.position_upper,
                    speed_limit=model.velocity_limit, robot=model.name,
                    max_gap=RobotLogConfig().max_gap)
    path = make_log_path(log.times - log.times[0], log.q)
    check_path_speeds(log, path, speed_limit=model.velocity_limit, robot=model.name)


KINDS = ("scenario", "config", "space", "scene", "task-path", "mapping", "robot-log",
         "recording")


def _check(args: argparse.Namespace) -> int:
    """``check KIND FILE...`` reads files under the reading rules; ``check PARAMS...``
    (or ``check params PARAMS...``) checks params files against their certificates."""
    kind, files = None, list(args.files)
    if files[0] in KINDS + ("params",):
        kind, files = files[0], files[1:]
        if not files:
            raise InputError("check", kind, f"{kind} followed by one or more files")
    if kind not in (None, "params"):
        load = _loaders()[kind]
        for path in files:
            read = load(path)
            if not args.quiet:
                print(f"{path}: ok" + (_recorded_line(read) if kind == "mapping" else
                                       _recording_line(read) if kind == "recording" else ""))
        return 0
    from safety_systems.config.params_file import looks_like_params
    from verification.deploy.certificate import check

    if args.certificate is not None and len(files) != 1:
        raise InputError("--certificate", args.certificate, "one params file to check with it")
    for path in files:
        if kind is None and not looks_like_params(path):
            raise InputError("check", path, "a params.yaml of safety-systems export (to read "
                             "another file, name its kind first: check "
                             f"{'|'.join(KINDS)} FILE...)")
    code = 0
    for path in files:
        result = check(path, args.certificate, require=args.require)
        if result.code == 0:
            if not args.quiet:
                print(result.line)
        else:
            print(f"safety-systems: {result.line}", file=sys.stderr)
            code = code or result.code
    return code


def _recorded_line(operators: list) -> str:
    """What ``check mapping`` read of the recording a mapping names (simulate's rules)."""
    if not operators:
        return " (it names no recording: its own fields only)"
    frames = operators[0].times.size
    bodies = sum(len(o.names) for o in operators)
    return (f" (its recording read as simulate reads it: {len(operators)} operator(s), "
            f"{bodies} bodies, {frames:,} frames, every body within the plausibility bounds)")


def _recording_line(rec) -> str:
    """What ``check recording`` read and checked (every body, at the default bounds)."""
    from safety_systems.sensing.plausibility import MAX_ACCELERATION, MAX_SPEED

    return (f" ({len(rec.names)} bodies, {rec.times.size:,} frames, every body within the "
            f"default plausibility bounds, {MAX_SPEED:g} m/s and {MAX_ACCELERATION:g} m/s^2: "
            "check mapping applies a mapping's own to its bodies)")


def build_parser() -> argparse.ArgumentParser:
    from safety_systems.outputs.provenance import version_line

    parser = argparse.ArgumentParser(
        prog="safety-systems",
        description="Simulate, verify and tune ISO/TS 15066 speed and separation monitoring "
                    "of a collaborative UR5e cell, and export verified parameters. Exit "
                    "codes: 0 done, 1 verify falsified, plan short of its goal, tune without "
                    "a configuration meeting its constraint, check or run of parameters not "
                    "certified, 2 bad input (one line naming the file, the field, the value "
                    "and what is allowed), 3 verify inconclusive or run ended by a fault, 4 "
                    "verify or check weaker than --require, 130 interrupted.")
    parser.add_argument("--version", action="version", version=version_line(),
                        help="print the versions of safety-systems and Drake and exit")
    commands = parser.add_subparsers(dest="command", required=True)
    quiet = "no progress bar or summary on stdout (default: off)"
    unverified = ("run a params.yaml that fails its certificate check, saying that it is "
                  "unverified (default: off, refuse it)")
    sim = commands.add_parser("simulate", help="run one scenario and write its outputs")
    sim.add_argument("scenario", help="scenario YAML file")
    sim.add_argument("--out", required=True,
                     help="output folder, created if missing (required; no default)")
    sim.add_argument("--html", action="store_true",
                     help="also write replay.html, a Meshcat recording (default: off)")
    sim.add_argument("--mode", choices=("kinematic", "dynamic"),
                     help="override the scenario's robot.mode (default: the scenario's)")
    sim.add_argument("--duration", type=float,
                     help="override the scenario's duration, s (default: the scenario's)")
    sim.add_argument("--config",
                     help="a controller configuration or params.yaml run instead of the "
                          "scenario's (the scenario's cell stays: its real sensor, exits and "
                          "walls; a params.yaml brings its robot's path, rate and tool) "
                          "(default: the scenario's)")
    sim.add_argument("--unverified", action="store_true", help=unverified)
    sim.add_argument("--quiet", action="store_true", help=quiet)
    sim.set_defaults(run=_simulate)
    from verification.verdicts import EXIT_TABLE, REQUIREMENTS  # (light: no Drake)

    ver = commands.add_parser(
        "verify", help="prove or falsify 'stopped before contact' and the separation "
                       "invariant (distance never below S while the robot may move) over a "
                       "scenario space (exit 0 proved/passed, 1 falsified, 2 bad input, "
                       "3 inconclusive, 4 weaker than --require)",
        formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EXIT_TABLE)
    ver.add_argument("config", help="controller configuration YAML file, or a params.yaml "
                                    "(checked against its certificate; it brings its "
                                    "robot's path, rate and tool into the space)")
    ver.add_argument("--space", required=True,
                     help="scenario space YAML file (required; no default)")
    ver.add_argument("--out", required=True,
                     help="output folder, created if missing; run again with the same "
                          "folder to resume (required; no default)")
    ver.add_argument("--budget", type=int, default=200,
                     help="the search's work in simulation-equivalents: simulations, "
                          "and the candidates its rankings score, priced (default: "
                          "%(default)s)")
    ver.add_argument("--method", default="falsify",
                     choices=("falsify", "sobol", "halton", "grid", "uniform", "corners"),
                     help="how the space is searched (default: %(default)s)")
    where = ver.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int,
                       help="local processes (default: all cores)")
    where.add_argument("--scheduler",
                       help="Dask scheduler address, e.g. tcp://10.0.0.5:8786 (default: "
                            "none, run on local processes)")
    ver.add_argument("--property", default="both",
                     choices=("contact", "separation", "permitted_contact", "both"),
                     help="which property to verify: contact (stopped before contact), "
                          "separation (distance never below S while motion is permitted), "
                          "permitted_contact (every contact while the robot moves within "
                          "ISO/TS 15066's power and force limits) or both (the two of the "
                          "configuration's safety.mode: contact and separation under ssm, "
                          "permitted_contact and separation under ssm_pfl; default: "
                          "%(default)s; the verdict is the weaker)")
    ver.add_argument("--seed", type=int, default=0,
                     help="seed of the search (default: %(default)s)")
    ver.add_argument("--require", default="none", choices=REQUIREMENTS,
                     help="exit 4 when the verdict is weaker than this (passed under "
                          "'proved'); falsified (1) and inconclusive (3) fail under any "
                          "(default: %(default)s)")
    ver.add_argument("--unverified", action="store_true", help=unverified)
    ver.add_argument("--stop-at-first", action="store_true",
                     help="return as soon as one counterexample is confirmed in the Drake "
                          "diagram (exit 1; other properties are left unchecked; default: "
                          "off, every property searched with the whole budget)")
    ver.add_argument("--quiet", action="store_true", help=quiet)
    ver.set_defaults(run=_verify)
    tune = commands.add_parser(
        "tune", help="search the tunable parameters for the shortest task time whose "
                     "verdict is proved (or passed with --allow passed); exit 1 when none is")
    tune.add_argument("config", help="controller configuration YAML file; its tune: block "
                                     "lists the tunable parameters unless --tune is given")
    tune.add_argument("--space", required=True,
                      help="scenario space YAML file (required; no default)")
    tune.add_argument("--tasks", nargs="+",
                      help="task scenario YAML files (default: models/scenarios/"
                           "inspection_seed.yaml and co_kitting.yaml)")
    tune.add_argument("--out", required=True,
                      help="output folder, created if missing (required; no default)")
    tune.add_argument("--tune", help="YAML file with a tune: block (default: the "
                                     "configuration's own)")
    tune.add_argument("--allow", default="proved", choices=("proved", "passed"),
                      help="weakest verdict accepted (default: %(default)s)")
    tune.add_argument("--budget", type=int, default=200,
                      help="each verification's search, in simulation-equivalents "
                           "(default: %(default)s)")
    tune.add_argument("--candidates", type=int, default=24,
                      help="candidates simulated besides the base configuration "
                           "(default: %(default)s)")
    tune.add_argument("--screen", type=int, default=16,
                      help="configurations screened by the proofs per candidate simulated "
                           "(default: %(default)s)")
    tune_where = tune.add_mutually_exclusive_group()
    tune_where.add_argument("--workers", type=int, help="local processes (default: all cores)")
    tune_where.add_argument("--scheduler", help="Dask scheduler address (default: none, run "
                                                "on local processes)")
    tune.add_argument("--seed", type=int, default=0,
                      help="seed of the search and of the verifications (default: "
                           "%(default)s)")
    tune.add_argument("--quiet", action="store_true", help=quiet)
    tune.set_defaults(run=_tune)
    cmp_ = commands.add_parser("compare", help="run several controllers on the same scenarios "
                                                "and tabulate danger index, goal and jerk")
    cmp_.add_argument("scenarios", nargs="+", help="scenario YAML files")
    cmp_.add_argument("--controllers", default="erga,hwang,bimodal,none",
                      help="comma-separated controller types; the first is the reference "
                           "(default: %(default)s)")
    cmp_.add_argument("--out", required=True,
                      help="output folder, created if missing (required; no default)")
    cmp_.add_argument("--quiet", action="store_true", help=quiet)
    cmp_.set_defaults(run=_compare)
    plan = commands.add_parser(
        "plan", help="plan a tool path around static obstacles with IAPF, GDA and RRT* "
                     "(seed 001) and write paths, tables, a plot and task_path.yaml "
                     "(exit 1 if the IAPF does not reach the goal)")
    plan.add_argument("scene", help="task-space scene YAML file (models/scenes/)")
    plan.add_argument("--out", required=True,
                      help="output folder, created if missing (required; no default)")
    plan.add_argument("--sweep", help="also run one of the seed's sweeps: obstacles, "
                                      "radius, radii, height, k_att, k_rep, zeta "
                                      "(default: none)")
    plan.add_argument("--quiet", action="store_true", help=quiet)
    plan.set_defaults(run=_plan)
    exp = commands.add_parser(
        "export", help="write a verified configuration as params.yaml (a ROS 2 parameter "
                       "file), certificate.json and report.html for the safety assessor")
    exp.add_argument("config", help="controller configuration YAML file")
    exp.add_argument("--report", required=True,
                     help="report.json of its verification by verify or tune (required; "
                          "no default)")
    exp.add_argument("--tune", help="tune.json of the tune run that chose it: its "
                                    "counterexamples go into the certificate (default: none)")
    exp.add_argument("--out", required=True,
                     help="output folder, created if missing (required; no default)")
    exp.add_argument("--quiet", action="store_true", help=quiet)
    exp.set_defaults(run=_export)
    check = commands.add_parser(
        "check", help="check params.yaml against its certificate (check PARAMS...: exit 0 "
                      "certified proved or passed, 1 not certified, 2 unreadable, 4 weaker "
                      "than --require), or read input files of a kind without running "
                      "anything (check KIND FILE...: exit 0 all good, 2 at the first bad "
                      "one; a mapping that names its recording has it read under every rule "
                      "simulate applies, with simulate's line)")
    check.add_argument("files", nargs="+", metavar="[KIND] FILE",
                       help=f"params files; or a kind ({', '.join(KINDS)}) and files of it "
                            "(robot-log: an RTDE CSV or a ROS bag's only JointState topic, "
                            "against the UR5e's joints; recording: a Motive CSV, C3D, BVH "
                            "or a ROS bag's PoseStamped topics, every body under a mapping's "
                            "glitch and plausibility rules at their defaults)")
    check.add_argument("--certificate",
                       help="the certificate of one params file (default: certificate.json "
                            "beside it)")
    check.add_argument("--require", default="passed", choices=("proved", "passed"),
                       help="weakest certified verdict accepted; passed under proved exits 4 "
                            "(default: %(default)s)")
    check.add_argument("--quiet", action="store_true",
                       help="print nothing for good files (default: off)")
    check.set_defaults(run=_check)
    expl = commands.add_parser(
        "explain", help="what a configuration or params.yaml makes the robot do: S of every "
                        "body segment at a few path rates, the term that dominates it, the "
                        "override's command at a few distances and the premises each figure "
                        "rests on (exit 0, 2 bad input)")
    expl.add_argument("config", help="controller configuration YAML file, or a params.yaml "
                                     "(it brings its robot; explained with a warning when "
                                     "its certificate check fails)")
    expl.add_argument("--robot",
                      help="a shipped robot model (e.g. ur10e) or a URDF file, on its "
                           "default path (default: the UR5e, or a params.yaml's robot)")
    expl.add_argument("--space",
                      help="scenario space YAML file: its robot, its tracked points, its "
                           "peak speed and noise bound (default: none: two gloves, ISO "
                           "13855's 2.0 m/s)")
    expl.add_argument("--rates", type=float, nargs="+", default=[1.0, 0.6, 0.4, 0.2],
                      help="path rates k shown, 0 < k <= 1 (default: %(default)s)")
    expl.add_argument("--distances", type=float, nargs="+", default=[0.5, 1.0, 1.5, 2.0, 3.0],
                      help="segment clearances d in m at which the override's command is "
                           "shown (default: %(default)s)")
    expl.add_argument("--json", help="also write the figures to this JSON file (default: "
                                     "none)")
    expl.set_defaults(run=_explain)
    from safety_systems.runtime.command import add_parser

    add_parser(commands)
    commands.choices["run"].set_defaults(run=_run)
    return parser


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A library's warning (a truncated export used, capture glitches) as one line."""
    _warn(" ".join(str(message).split()))


def _say_first_compile(command: str, stack: contextlib.ExitStack) -> None:
    """A run that compiles the per-tick maths says so (on stderr) when the compile starts,
    with the first run's time where the kept builds foretold it; a run refused on a bad
    file before anything compiles prints its one line alone."""
    from safety_systems.compile_notice import NEEDS, first_run_line, watch_compiles

    if command not in NEEDS:
        return
    listener = watch_compiles(first_run_line(command))
    stack.callback(_unregister, listener)


def _unregister(listener) -> None:
    from numba.core import event

    event.unregister("numba:compile", listener)


# The commands Ctrl-C ends within a second or two (safety_systems.interrupts); ``run``
# ends its live loop itself, commanding k = 0 last.
INTERRUPTIBLE = ("simulate", "verify", "tune", "compare", "plan")


def _interrupted(args: argparse.Namespace) -> int:
    """Says so and returns 130; after a real Ctrl-C, exits at once: the interpreter's
    own shutdown (Drake's, numba's) takes seconds more, and every result file is whole
    or absent already."""
    from safety_systems.interrupts import interrupted, stop_workers

    resume = (f" (the same command resumes it: the finished simulations are kept in "
              f"{args.out})" if args.command == "verify" else "")
    print(f"safety-systems: interrupted{resume}", file=sys.stderr, flush=True)
    if interrupted():
        stop_workers()
        sys.stdout.flush()
        os._exit(EXIT_INTERRUPTED)
    return EXIT_INTERRUPTED


def main(argv: list[str] | None = None) -> int:
    from pathlib import Path

    from safety_systems.interrupts import Interruptible, interrupted
    from safety_systems.third_party_noise import LOG_NAME, kept_in

    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(argv)
    args.argv = argv
    forget_inputs()  # the inputs of this command alone go into its results
    folder = getattr(args, "out", None) or getattr(args, "log", None)
    with contextlib.ExitStack() as stack:
        stack.enter_context(warnings.catch_warnings())
        # numba's and pydrake's warnings go to DIR/third_party.log; the rest, one line each
        stack.enter_context(kept_in(None if folder is None else Path(folder) / LOG_NAME,
                                    _one_line_warning))
        if args.command in INTERRUPTIBLE:
            stack.enter_context(Interruptible())
        _say_first_compile(args.command, stack)
        try:
            return args.run(args)
        except InputError as e:
            print(f"safety-systems: {e}", file=sys.stderr)
            return EXIT_BAD_INPUT
        except Refused as e:
            print(f"safety-systems: {e.line}", file=sys.stderr)
            return e.code
        except KeyboardInterrupt:
            return _interrupted(args)
        except Exception:
            if interrupted():  # what a Ctrl-C became on its way out of pydrake, say
                return _interrupted(args)
            raise


if __name__ == "__main__":
    sys.exit(main())
