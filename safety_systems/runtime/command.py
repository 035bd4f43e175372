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

EXIT_FAULT = 3
EXIT_INTERRUPTED = 130
REPLAY_TAIL = 0.5  # s the runtime runs on after a replay's last frame
PORT_WAIT = 30.0  # s to wait for the replay server to listen


def start_replay(file: str, options: dict, rate: float, mapping=None
                 ) -> tuple[subprocess.Popen, int]:
    """Starts ``replay_server`` on 127.0.0.1 in its own process; (process, its port).
    With a ``mapping`` it streams the mapping's bodies, read as the mapping reads them."""
    argv = [sys.executable, "-m", "safety_systems.runtime.replay_server", file,
            "--rate", repr(rate)]
    if mapping is not None:
        bodies = {b.recorded: b.streaming_id for o in mapping.operators for b in o.bodies}
        argv += ["--bodies", json.dumps(bodies), "--units", mapping.units,
                 "--truncated", mapping.truncated]
    for key, value in options.items():
        argv += [f"--{key}", *value.split(":")]
    process = subprocess.Popen(argv, stdout=subprocess.PIPE, text=True)
    ready, _, _ = select.select([process.stdout], [], [], PORT_WAIT)
    line = process.stdout.readline() if ready else ""
    if not line.startswith("port "):
        process.kill()
        raise ConnectionError(f"the replay server did not start ({line.strip() or 'silent'})")
    return process, int(line.split()[1])


def run(args: argparse.Namespace, origin) -> int:
    """``safety-systems run``; ``origin()`` gives the provenance (called when the summary
    is written, so that it names every input read: params, certificate, mapping, recording)."""
    from safety_systems.files.output_files import prepare_out, write_json
    from safety_systems.outputs.run_files import write_table
    from safety_systems.sensing.recording_files import read_recording
    from safety_systems.sensing.recording_mapping import (
        find_operator,
        load_mapping,
        mapped_names,
        mapped_point,
        recorded_bodies,
        unknown_pivots,
    )
    from safety_systems.runtime.live_run import LiveOptions, run_live
    from safety_systems.runtime.mocap import BodyMap, MocapAddress, NatNetSource, parse_mocap
    from safety_systems.runtime.params import NotCertified, load_certified_params, \
        warn_unverified
    from safety_systems.runtime.realtime import MAX_PRIORITY, real_time
    from safety_systems.runtime.robot_link import connect_robot, parse_robot
    from safety_systems.runtime.safety_loop import SafetyLoop

    try:
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
    if mocap_address.kind == "replay":
        try:
            recording = read_recording(mocap_address.file, mapped_names(mapping),
                                       truncated=mapping.truncated, units=mapping.units)
            for o in mapping.operators:
                recorded_bodies(recording, mapping, find_operator(mapping, o.name, "name"))
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
    from safety_systems.config.scenario import robot_model_of

    model = robot_model_of(params.robot)
    if robot_address.kind != "none" and model.kind != KIND_UR:
        raise InputError("--robot", args.robot, f"none for the {model.name} (RTDE drives "
                         "UR arms only; another arm: --robot none, the monitor alone)")
    out = prepare_out(args.log)
    from safety_systems.config.configuration import pfl_terms

    pfl = (pfl_terms(params.robot, params.controller)
           if params.controller.safety.mode == "ssm_pfl" else None)
    loop = SafetyLoop(params.controller, points, [o.name for o in mapping.operators], model,
                      pfl)
    server = None
    robot = None
    try:
        if mocap_address.kind == "replay":
            server, port = start_replay(mocap_address.file, options, rate, mapping)
            mocap_address = MocapAddress("natnet", "127.0.0.1", port, "127.0.0.1")
        mocap = NatNetSource(mocap_address, time.monotonic)
        robot = connect_robot(robot_address, params.robot, params.controller)
        mocap.connect()  # last: frames flow from here on, and the loop starts at once
    except ConnectionError as e:
        print(f"safety-systems: {e}", file=sys.stderr)
        if server is not None:
            server.kill()
        return EXIT_FAULT
    try:
        with real_time(args.priority) as scheduling:
            if "refused" in scheduling:
                print(f"safety-systems: warning: no real-time priority ({scheduling['refused']}"
                      "): the loop runs at normal priority, its late ticks stopped by the "
                      "overrun watchdog", file=sys.stderr)
            result = run_live(loop, bodies, names, mocap, robot,
                              latency=params.controller.sensor.latency,
                              period=1.0 / params.robot.control_rate_hz,
                              options=LiveOptions(duration=duration,
                                                  max_overrun=args.max_overrun,
                                                  status=not args.quiet))
    finally:
        if server is not None:
            server.terminate()
            server.wait(timeout=10.0)
    write_table(result.header, result.rows, out / "trace.csv",
                digits={"time": 10, "frame_time": 10, "tick_late": 4})
    summary = dict(params=str(args.params), certified=params.certified,
                   certificate_check=params.line, mocap=args.mocap, robot=robot.name,
                   mapping=str(args.mapping), scheduling=scheduling, **result.summary,
                   provenance=origin())
    write_json(out / "summary.json", summary)
    if not args.quiet:
        timing = summary["timing"]
        p99 = timing["frame_to_k_p99"]
        print(f"run: {end_words(summary['end'])}: {summary['duration']:.1f} s, "
              f"{summary['ticks']} ticks, {summary['frames']} frames, "
              f"tick late p99 {1e3 * (timing['tick_late_p99'] or math.nan):.3f} ms, "
              f"frame to k p99 {1e3 * (p99 if p99 is not None else math.nan):.3f} ms "
              f"-> {args.log}")
    if result.end == "interrupted":
        return EXIT_INTERRUPTED
    return 0 if result.end == "duration" else EXIT_FAULT


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
                   help="output folder for trace.csv and summary.json, created if missing "
                        "(required; no default)")
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
    if end.startswith("robot_lost: "):
        return f"ended by a fault: the robot's connection was lost ({end[12:]})"
    if end.startswith("exception: "):
        return f"ended by a fault: {end[11:]}"
    return end
