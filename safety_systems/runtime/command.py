"""``safety-systems run``: check everything, connect, run the loop, write the log.

Exit codes: 0 the run ended (its duration, or the replay's end), 1 parameters not
certified, 2 bad input, 3 the run was ended by a fault it cannot ride out (an error in
the runtime, a lost robot, no NatNet server), 130 interrupted.
"""

import argparse
import json
import math
import select
import subprocess
import sys
import time

from safety_systems.files.input_error import InputError
from safety_systems.runtime.child_process import start_without_ctrl_c
from safety_systems.runtime.startup import Phases

EXIT_FAULT = 3
EXIT_INTERRUPTED = 130
REPLAY_TAIL = 0.5  # s the runtime runs on after a replay's last frame
PORT_WAIT = 30.0  # s to wait for the replay server to listen
SEGMENT = 600.0  # s of the run in each of the log's files (default)
MIN_SEGMENT, MAX_SEGMENT = 1.0, 86400.0


def replay_argv(file: str, options: dict, rate: float, mapping=None,
                untracked: dict | None = None) -> list[str]:
    """``replay_server``'s command line: with a ``mapping`` it streams the mapping's
    bodies, read as the mapping reads them, and ``untracked`` (recorded name -> sample
    runs, ``replay_server.sample_runs``) as untracked: the samples the mapping's
    ``implausible: untracked`` reads so."""
    argv = [sys.executable, "-m", "safety_systems.runtime.replay_server", file,
            "--rate", repr(rate), "--parent-death"]
    if mapping is not None:
        bodies = {b.recorded: b.streaming_id for o in mapping.operators for b in o.bodies}
        argv += ["--bodies", json.dumps(bodies), "--units", mapping.units,
                 "--truncated", mapping.truncated]
    if untracked:
        argv += ["--untracked", json.dumps(untracked)]
    for key, value in options.items():
        argv += [f"--{key}", *value.split(":")]
    return argv


def replay_untracked(recording, mapping) -> dict[str, list[list[int]]]:
    """Reads every operator of ``mapping`` from ``recording`` under simulate's rules
    (raises InputError as simulate does); recorded name -> the sample runs the mapping's
    ``implausible: untracked`` reads as untracked, for :func:`replay_argv`."""
    from safety_systems.runtime.replay_server import sample_runs
    from safety_systems.sensing.recording_mapping import find_operator, recorded_bodies

    untracked = {}
    for o in mapping.operators:
        read = recorded_bodies(recording, mapping, find_operator(mapping, o.name, "name"))
        for b, held in zip(o.bodies, read.held.T):
            if held.any():
                untracked[b.recorded] = sample_runs(held)
    return untracked


def start_replay(file: str, options: dict, rate: float, mapping=None,
                 untracked: dict | None = None) -> tuple[subprocess.Popen, int]:
    """Starts ``replay_server`` on 127.0.0.1 in its own process (:func:`replay_argv`);
    (process, its port)."""
    argv = replay_argv(file, options, rate, mapping, untracked)
    process = start_without_ctrl_c(argv, stdout=subprocess.PIPE, text=True)
    try:
        ready, _, _ = select.select([process.stdout], [], [], PORT_WAIT)
        line = process.stdout.readline() if ready else ""
    except BaseException:  # Ctrl-C while it starts (Ctrl-C does not reach it): end it
        process.kill()
        process.wait()
        raise
    if not line.startswith("port "):
        process.kill()
        raise ConnectionError(f"the replay server did not start ({line.strip() or 'silent'})")
    return process, int(line.split()[1])


def run(args: argparse.Namespace, origin) -> int:
    """``safety-systems run``; ``origin()`` gives the provenance (called once every input
    was read: params, certificate, mapping, recording). Ctrl-C at any moment commands
    k = 0 to whatever robot is connected, writes what the run has and exits 130."""
    phases = Phases(args.quiet)
    try:
        return _run(args, origin, phases)
    except KeyboardInterrupt:  # (before the log folder was made: nothing connected yet)
        print(f"safety-systems: interrupted while {phases.now}: nothing was connected, "
              "nothing written", file=sys.stderr)
        return EXIT_INTERRUPTED


def _run(args: argparse.Namespace, origin, phases) -> int:
    with phases.step("loading_modules", "loading"):
        from safety_systems.files.output_files import prepare_out, write_json
        from safety_systems.runtime.live_run import (
            LiveOptions,
            held_interrupts,
            log_columns,
            run_live,
        )
        from safety_systems.runtime.mocap import BodyMap, MocapAddress, NatNetSource, parse_mocap
        from safety_systems.runtime.params import (
            NotCertified,
            load_certified_params,
            warn_unverified,
        )
        from safety_systems.runtime.realtime import (
            MAX_PRIORITY,
            lock_for_run,
            real_time,
            unlock_memory,
        )
        from safety_systems.runtime.robot_link import connect_robot, parse_robot
        from safety_systems.runtime.run_log_pipe import RunLogPipe
        from safety_systems.runtime.run_log_writer import FLUSH_PERIOD, SYNC_PERIOD
        from safety_systems.runtime.run_tally import run_summary
        from safety_systems.runtime.safety_loop import SafetyLoop
        from safety_systems.sensing.recording_files import read_recording
        from safety_systems.sensing.recording_mapping import (
            load_mapping,
            mapped_names,
            mapped_point,
            unknown_pivots,
        )
        from safety_systems.sensing.run_log_format import FORMAT_VERSION, SEGMENT_PATTERN

    try:
        with phases.step("parameters", "reading the parameters, checking their certificate"):
            params = load_certified_params(args.params, unverified=args.unverified)
    except NotCertified as e:
        print(f"safety-systems: {e.line}", file=sys.stderr)
        return e.code
    warn_unverified(params)
    mapping = load_mapping(args.mapping)
    for field, bound in unknown_pivots(mapping):  # where its proof's allowance ends
        if bound > params.pivot_offset + 1e-12:
            error = InputError(
                f"{field}.pivot", [], "[x, y, z] (m, the body point from its reported "
                "position in the body's own frame) or at_point: true: unmoved, a rigid "
                f"body's pivot (its markers' centroid) may be {bound:g} m from the point, "
                f"beyond the {params.pivot_offset:g} m the certificate's proof covers",
                file=args.mapping)
            if params.certified:
                raise error
            print(f"safety-systems: warning: {error}", file=sys.stderr)
    mocap_address, robot_address = parse_mocap(args.mocap), parse_robot(args.robot)
    try:
        bodies = BodyMap(mapping)
    except InputError as e:
        raise e.in_file(args.mapping) from None
    if params.controller.type != "ssm_override":
        raise InputError("controller.type", params.controller.type,
                         "ssm_override (the runtime runs the SSM speed override)",
                         file=args.params)
    names = [f"{o.name}/{b.name}" for o in mapping.operators for b in o.bodies]
    points = [[mapped_point(b) for b in o.bodies] for o in mapping.operators]
    rate = params.controller.sensor.rate_hz
    duration = args.duration
    if duration is not None and not 0.0 < duration <= 1e7:
        raise InputError("--duration", duration, "0 < duration <= 1e7 s")
    if not 0.0 < args.max_overrun <= 1.0:
        raise InputError("--max-overrun", args.max_overrun, "0 < max-overrun <= 1 s")
    if not 0 <= args.priority <= MAX_PRIORITY:
        raise InputError("--priority", args.priority,
                         f"0 (normal scheduling) or a real-time priority 1-{MAX_PRIORITY}")
    if not MIN_SEGMENT <= args.log_segment <= MAX_SEGMENT:
        raise InputError("--log-segment", args.log_segment,
                         f"{MIN_SEGMENT:g} <= seconds <= {MAX_SEGMENT:g}")
    if mocap_address.kind == "replay":
        try:
            recording = read_recording(mocap_address.file, mapped_names(mapping),
                                       truncated=mapping.truncated, units=mapping.units)
            untracked = replay_untracked(recording, mapping)
        except InputError as e:
            raise e.in_file(args.mapping) from None
        options = dict(mocap_address.options)
        rate = float(options.pop("rate", rate))
        if not 1.0 <= rate <= 1000.0:
            raise InputError("--mocap rate", rate, "1 <= rate <= 1000 Hz")
        if duration is None:
            start = float(options.get("start", 0.0))
            length = float(options.get("duration", recording.times[-1] - start))
            duration = max(length, 0.0) + REPLAY_TAIL + 0.1
    from safety_systems.cell.robot_model import KIND_UR
    from safety_systems.config.resolved_cell import resolve

    try:  # what the parameters mean on their robot for these operators, once
        cell = resolve(params.controller, params.robot, points=points,
                       names=[o.name for o in mapping.operators])
    except InputError as e:
        raise e.in_file(args.params) from None
    model = cell.model
    if robot_address.kind != "none" and model.kind != KIND_UR:
        raise InputError("--robot", args.robot, f"none for the {model.name} (RTDE drives "
                         "UR arms only; another arm: --robot none, the monitor alone)")
    out = prepare_out(args.log, "--log")
    earlier = sorted(out.glob(SEGMENT_PATTERN))
    if earlier:
        raise InputError("--log", args.log, f"a folder without an earlier run's log "
                         f"({earlier[0].name} is there; a log is never overwritten: give "
                         "another folder)")
    fields = dict(params=str(args.params), certified=params.certified,
                  certificate_check=params.line, mocap=args.mocap, robot=args.robot,
                  mapping=str(args.mapping))
    fixed = dict(fields=fields, names=names, period=1.0 / params.robot.control_rate_hz,
                 log=dict(folder=str(out), format=f"MCAP, safety-systems run log "
                          f"{FORMAT_VERSION}", segment_length=args.log_segment,
                          flush_period=FLUSH_PERIOD, sync_period=SYNC_PERIOD),
                 startup=phases.took, tracked=points)
    server = robot = mocap = log = None
    end, locked = None, {}
    try:
        with phases.step("safety_loop", "loading the compiled safety loop (its first run "
                                        "on a machine compiles it: minutes)"):
            loop = SafetyLoop(cell, points, [o.name for o in mapping.operators])
            fixed["lowest_speed"] = _lowest_speed(cell)  # (summary's held)
            trace, columns = log_columns(loop, names, model.n)
            log = RunLogPipe(out, width=len(columns), bodies=len(names))
        if args.priority:  # before connecting: once frames flow, the loop starts at once
            with phases.step("locking", "locking the memory (real-time)"):
                locked = lock_for_run(args.priority)
        with phases.step("connecting", "connecting"):
            if mocap_address.kind == "replay":
                server, port = start_replay(mocap_address.file, options, rate, mapping,
                                            untracked)
                mocap_address = MocapAddress("natnet", "127.0.0.1", port, "127.0.0.1")
            mocap = NatNetSource(mocap_address, time.monotonic)
            robot = connect_robot(robot_address, cell)
            mocap.connect()  # last: frames flow from here on, and the loop starts at once
    except ConnectionError as e:
        end = f"fault while {phases.now}: {e}"
    except KeyboardInterrupt:
        end = f"interrupted while {phases.now}"
    if end is not None:  # it never ran: k = 0 to what was connected, and what it has
        with held_interrupts():
            _stop(robot, mocap, server)
            if locked.get("memory_locked"):
                unlock_memory()
            fields["robot"] = getattr(robot, "name", args.robot)
            summary = _close(log, run_summary, fixed, end, origin)
            write_json(out / "summary.json", summary)
        print(f"safety-systems: {end}", file=sys.stderr)
        return EXIT_INTERRUPTED if end.startswith("interrupted") else EXIT_FAULT
    fields["robot"] = robot.name
    result = None
    try:
        with real_time(args.priority) as scheduling:
            if "refused" in scheduling:
                print(f"safety-systems: warning: no real-time priority ({scheduling['refused']}"
                      "): the loop runs at normal priority, its late ticks stopped by the "
                      "overrun watchdog", file=sys.stderr)
            fields["scheduling"] = {**scheduling, **locked}
            fixed["provenance"] = origin()
            log.start(dict(fixed=fixed, trace_columns=trace, columns=columns,
                           status=not args.quiet, segment_length=args.log_segment,
                           metadata=_metadata(args, trace, columns, names, mapping, params,
                                              model.n)))
            phases.say(f"ready after {sum(phases.took.values()):.1f} s ("
                       + ", ".join(f"{k.replace('_', ' ')} {v:.1f} s"
                                   for k, v in phases.took.items())
                       + f"); log: {out / 'log-0000.mcap'}, ...; waiting for the first frame")
            result = run_live(loop, bodies, names, mocap, robot,
                              latency=params.controller.sensor.latency,
                              period=fixed["period"], log=log,
                              options=LiveOptions(duration=duration,
                                                  max_overrun=args.max_overrun))
        end = result.end
    except KeyboardInterrupt:  # (before the loop: run_live ends the loop's own)
        end = "interrupted while starting the loop"
    except Exception as e:  # noqa: BLE001 - an error before the loop: k = 0 all the same
        end = f"exception: {type(e).__name__}: {e}"
    finally:
        with held_interrupts():
            if result is None:
                _stop(robot, mocap, None)
            else:
                fixed["clock_start"] = result.clock_start
            if server is not None:
                server.terminate()
                server.wait(timeout=10.0)
            if locked.get("memory_locked"):
                unlock_memory()
            summary = _close(log, run_summary, fixed, end or "exception", origin)
            write_json(out / "summary.json", summary)
    if not args.quiet:
        timing, written = summary["timing"], summary["log"]
        p99 = timing["frame_to_k_p99"]
        print(f"run: {end_words(summary['end'])}: {summary['duration']:.1f} s, "
              f"{summary['ticks']} ticks, {summary['frames']} frames, "
              f"tick late p99 {1e3 * (timing['tick_late_p99'] or math.nan):.3f} ms, "
              f"frame to k p99 {1e3 * (p99 if p99 is not None else math.nan):.3f} ms; log: "
              f"{written['segments']} segment(s), {written['bytes'] / 1e6:.1f} MB, "
              f"{written['dropped_ticks'] + written['dropped_frames']} records dropped "
              f"-> {args.log}")
        from safety_systems.outputs.held_terms import held_words

        if words := held_words(summary.get("held", {})):
            print(f"run: {words}")
    if end.startswith("interrupted"):
        return EXIT_INTERRUPTED
    return 0 if end == "duration" else EXIT_FAULT


def _stop(robot, mocap, server) -> None:
    """k = 0 and a protective stop to a robot connected before the loop ran, and the
    connections closed."""
    if robot is not None:
        robot.command(0.0)
        robot.protective_stop(True)
        robot.close()
    if mocap is not None:
        mocap.close()
    if server is not None:
        server.kill()
        server.wait(timeout=10.0)


def _close(log, run_summary, fixed: dict, end: str, origin) -> dict:
    """Ends the log (its writer finishes the segment) and gives summary.json."""
    fixed.setdefault("provenance", origin())
    if log is None:
        from safety_systems.runtime.run_tally import RunTally

        return run_summary(fixed, RunTally(len(fixed["names"]), 1), end)
    log.close({"end": end})
    summary = run_summary(fixed, log.tally, end)
    log.release()
    return summary


def _metadata(args, trace, columns, names, mapping, params, joints) -> dict:
    """The log's Metadata record (``sensing.run_log_format``): what a reader needs."""
    from pathlib import Path

    from safety_systems.sensing.run_log_format import FORMAT_VERSION, field_names

    recorded = {b.streaming_id: b.recorded for o in mapping.operators for b in o.bodies}
    return {
        "format": FORMAT_VERSION, "columns": columns, "fields": field_names(columns),
        "trace_columns": trace, "joints": joints, "tracked_bodies": names,
        "bodies": {str(i): n for i, n in recorded.items()},
        "ignore_ids": list(mapping.ignore_ids),
        "mapping": str(args.mapping), "mapping_text": Path(args.mapping).read_text(),
        "params": str(args.params), "certified": params.certified,
        "control_period": 1.0 / params.robot.control_rate_hz,
        "sensor_latency": params.controller.sensor.latency,
        "segment_length": args.log_segment, "mocap": args.mocap, "robot": args.robot,
    }


def add_parser(commands) -> None:
    """The ``run`` subcommand's arguments."""
    p = commands.add_parser(
        "run", help="run the certified controller live: NatNet frames in (natnet://HOST or "
                    "replay://RECORDING), the UR's speed slider out over RTDE (ur-rtde://HOST) "
                    "or none (exit 0 ended, 1 not certified, 2 bad input, 3 a fault ended it)")
    p.add_argument("params", help="the parameters to run: an exported params.yaml with its "
                                  "certificate.json beside it")
    p.add_argument("--mocap", required=True,
                   help="natnet://HOST[:PORT][?local=IP] (unicast), or replay://FILE[?start=S"
                        "&rate=HZ&duration=S&stop=T&garbage=T&late=T:D] to stream a recording "
                        "as NatNet packets over loopback (required; no default)")
    p.add_argument("--robot", required=True,
                   help="ur-rtde://HOST[?timeout=S&stop_register=N], or none: a model "
                        "following the verified path, logging what would be commanded "
                        "(required; no default)")
    p.add_argument("--mapping", required=True,
                   help="mapping YAML: which streamed rigid body (streaming_id) is which "
                        "operator's body point (a glove, the head, an elbow...), and the "
                        "capture-to-cell transform (required; no default)")
    p.add_argument("--log", required=True,
                   help="output folder for the run's log (log-0000.mcap, ... as the run "
                        "goes) and summary.json, created if missing; a folder that holds "
                        "an earlier run's log is refused (required; no default)")
    p.add_argument("--log-segment", type=float, default=SEGMENT,
                   help="seconds of the run in each of the log's files: a new one is "
                        "begun every so often, so a shift's log can be copied and removed "
                        "while the run goes on (default: %(default)s)")
    p.add_argument("--duration", type=float,
                   help="seconds to run (default: until interrupted; a replay: its length)")
    p.add_argument("--max-overrun", type=float, default=0.005,
                   help="seconds a control tick may start late before the watchdog holds "
                        "k at 0 for 0.2 s (default: %(default)s)")
    p.add_argument("--priority", type=int, default=50,
                   help="real-time scheduling priority of the loop (Linux SCHED_FIFO, "
                        "1-99; 0: normal scheduling). Without the privilege for it the "
                        "loop runs at normal priority and says so (default: %(default)s)")
    p.add_argument("--unverified", action="store_true",
                   help="run parameters that fail their certificate check, saying so "
                        "(default: off, refuse them)")
    p.add_argument("--quiet", action="store_true", help="no status line (default: off)")


def end_words(end: str) -> str:
    """How a run ended (summary.json's ``end``), in words for its last line."""
    if end == "duration":
        return "ended when its duration was up"
    if end == "interrupted":
        return "interrupted (Ctrl-C)"
    if end.startswith("interrupted "):
        return f"interrupted (Ctrl-C) {end[12:]}"
    if end.startswith("robot_lost: "):
        return f"ended by a fault: the robot's connection was lost ({end[12:]})"
    if end.startswith("exception: "):
        return f"ended by a fault: {end[11:]}"
    return end


def _lowest_speed(cell) -> dict:
    """What the monitor asks of each segment before the robot may move at all
    (``outputs.held_terms.lowest_speed_table`` of the run's resolved ``cell``), for the
    summary's ``held``."""
    from safety_systems.outputs.held_terms import lowest_speed_table

    return lowest_speed_table(cell)

