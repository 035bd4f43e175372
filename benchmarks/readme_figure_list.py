"""The figures of the README and the documentation's pages that come from runs: where each
stands, which run gives it, and its noise (read by ``benchmarks/readme_figures.py``; see
its docstring).

A pattern finds its figure in exactly one place of all the pages: the words around it, with
its number as the group ``v`` (``NUM``; a space matches any white space). Noise:
``"exact"`` for what the code decides (the page prints it rounded: it must equal the
run's value at the digits printed), ``"text"`` for a word (a chosen mode), or a relative
band for what the machine and its load move (wall and CPU times, rates): the page's
figure within that fraction of the run's.
"""

import dataclasses
import typing
from pathlib import Path

MODELS = Path(__file__).resolve().parent.parent / "models"
NUM = r"(?P<v>[-+]?[0-9](?:[0-9,]*[0-9])?(?:\.[0-9]+)?)"  # a comma after it is not its own
TIME_NOISE = 0.5  # wall and CPU seconds: another run on a machine with other work on it


@dataclasses.dataclass(frozen=True)
class Figure:
    name: str
    pattern: str
    get: typing.Callable[[dict], float]
    noise: typing.Any = "exact"
    scale: float = 1.0  # the page's unit per the run's (100 for a percentage)

    def value(self, data: dict) -> typing.Any:
        x = self.get(data)
        return str(x) if self.noise == "text" else float(x) * self.scale


def _at(x, path: str, what: str):
    """``x`` followed down ``path``, keys joined by "/" (list items by their index)."""
    for key in path.split("/"):
        x = x[int(key)] if isinstance(x, list) else x[key]
    if x is None:
        raise TypeError(f"{what}: {path} is null")
    return x


def _source(get, *sources: tuple[str, str]):
    """``get``, marked with what it reads: ("runs", id), ("probes", name), ("bench", name)."""
    get.sources = sources
    return get


def run(name: str, path: str) -> typing.Callable[[dict], typing.Any]:
    """A recorded run's figure: ``path`` into its record (``wall``, ``cpu``, ``exit``,
    ``files/summary/task_time``, ...)."""
    return _source(lambda data: _at(data["runs"][name], path, name), ("runs", name))


def bench(name: str, path: str) -> typing.Callable[[dict], typing.Any]:
    """A benchmark's figure, from its ``--json`` file (``benchmarks/results/NAME.json``)."""
    return _source(lambda data: _at(data[name], path, name), ("bench", name))


def probe(name: str) -> typing.Callable[[dict], typing.Any]:
    """A figure computed in process by ``PROBES[name]`` (a proof, a distance: seconds)."""
    return _source(lambda data: _at(data["probes"], name, "probes"), ("probes", name))


def _iso_with(**safety):
    """iso.yaml with these safety fields."""
    from safety_systems.config.scenario import load_controller_config

    iso = load_controller_config(MODELS / "configs" / "iso.yaml")
    return dataclasses.replace(iso, safety=dataclasses.replace(iso.safety, **safety))


def _default_space():
    from verification.spaces.space import load_space

    return load_space(MODELS / "spaces" / "default.yaml")


def _needed_allowance(robot_speed: str) -> float:
    """Z_d + Z_r the separation proof asks of iso.yaml over the default space, with this
    robot speed in S."""
    from verification.proof.theorems import prove_separation
    from verification.spaces.space import space_cell

    config = _iso_with(robot_uncertainty=0.0, robot_speed=robot_speed)
    space = _default_space()
    return prove_separation(space_cell(config, space), space).needed_allowance


def _screen_example() -> float:
    """The full-speed distance of iso.yaml with T_r 0.1 s, C 0, Z_r 0.38 m, if both
    proofs hold over the default space (NaN if not)."""
    from verification.proof.theorems import prove, prove_separation
    from verification.spaces.space import space_cell
    from verification.tune.tuner import full_speed_distance

    config = _iso_with(reaction_time=0.1, intrusion_distance=0.0, robot_uncertainty=0.38)
    space = _default_space()
    cell = space_cell(config, space)
    proved = prove(cell, space).proved and prove_separation(cell, space).proved
    return full_speed_distance(cell) if proved else float("nan")


def _iso_full_speed_distance() -> float:
    from safety_systems.config.resolved_cell import resolve
    from verification.tune.tuner import full_speed_distance

    return full_speed_distance(resolve(_iso_with()))


# Figures computed in process, in seconds: ``run`` records them and the tests compute them
# again on the code they test.
PROBES = {
    "allowance_directed": lambda: _needed_allowance("directed"),
    "allowance_fastest_point": lambda: _needed_allowance("fastest_point"),
    "screen_example_distance": _screen_example,
    "iso_full_speed_distance": _iso_full_speed_distance,
}


def both(a, b) -> typing.Callable[[dict], float]:
    """The figure two runs share (NaN, which agrees with nothing, where they differ)."""
    def get(data: dict) -> float:
        x, y = a(data), b(data)
        return x if x == y else float("nan")
    return _source(get, *a.sources, *b.sources)


SUMMARY, REPORT = "files/summary", "files/report"
CONTACT, SEPARATION = f"{REPORT}/properties/contact", f"{REPORT}/properties/separation"

# Runs the pages' prose quotes beyond their code blocks: (id, command), run after them.
EXTRA_RUNS = (
    ("inspection-deployed-100", ".venv/bin/safety-systems simulate "
                                "models/scenarios/inspection.yaml --config "
                                "out/deploy/params.yaml --out out/inspection-deployed-100 "
                                "--duration 100"),
    ("ewaste", ".venv/bin/safety-systems simulate models/scenarios/ewaste_sorting.yaml "
               "--out out/ewaste"),
    ("verify-recording-previous", ".venv/bin/safety-systems verify "
                                  "models/configs/iso_previous.yaml --space "
                                  "models/spaces/recording.yaml --out "
                                  "out/verify-recording-previous --budget 64"),
    ("verify-recording-iso", ".venv/bin/safety-systems verify models/configs/iso.yaml "
                             "--space models/spaces/recording.yaml --out "
                             "out/verify-recording-iso --budget 64"),
    ("verify-tuned", ".venv/bin/safety-systems verify models/configs/tuned.yaml --space "
                     "models/spaces/default.yaml --out out/verify-tuned"),
    ("inspection-seed", ".venv/bin/safety-systems simulate "
                        "models/scenarios/inspection_seed.yaml --out out/inspection-seed"),
    ("inspection-banded", ".venv/bin/safety-systems simulate "
                          "models/scenarios/inspection_banded.yaml --out out/inspection-banded"),
)

def chosen(name: str) -> typing.Callable[[dict], typing.Any]:
    return bench("bench_tune", f"chosen/values/{name}")


def scaled(get, factor: float) -> typing.Callable[[dict], float]:
    return _source(lambda data: get(data) * factor, *get.sources)


def exposure(task: str, which: str) -> typing.Callable[[dict], float]:
    """bench_tune's exposure of ``task``: the seconds a body is within iso.yaml's
    full-speed distance (``which`` "iso") or a reference distance ("1.5", "1.0")."""
    def get(data: dict) -> float:
        rows = data["bench_tune"]["exposure"][task]
        if which == "iso":
            return rows[0]["seconds"]
        return next(r["seconds"] for r in rows if abs(r["distance"] - float(which)) < 1e-12)
    return _source(get, ("bench", "bench_tune"))


TUNE, TEXT = "bench_tune", r"(?P<v>[a-z_]+)"

# The benchmarks ``run --only NAME`` runs (argv after the interpreter; ``--json`` added).
BENCHES = {
    "bench_tune": ["benchmarks/bench_tune.py", "--workers", "1"],
    "bench_tune_pfl": ["benchmarks/bench_tune.py", "--tune", "models/tune/ssm_pfl.yaml",
                       "--helmet", "--workers", "2", "--out", "out/bench_tune_pfl"],
    "bench_verify": ["benchmarks/bench_verify.py"],
    "bench_simulate": ["benchmarks/bench_simulate.py"],
    "bench_runtime": ["benchmarks/bench_runtime.py"],
    "bench_levers": ["benchmarks/bench_levers.py", "--latencies", "0.02", "0.005",
                     "--path-stops-sets", "gloves", "gloves+helmet+belt+elbows", "full suit"],
    "bench_tune_banded": ["benchmarks/bench_tune.py", "--workers", "1", "--lever",
                          "gloves+helmet+belt+elbows", "120", "0.005"],
    "bench_tune_banded_stops": ["benchmarks/bench_tune.py", "--workers", "1", "--lever",
                                "gloves+helmet+belt+elbows", "120", "0.005", "--path-stops"],
    "bench_new_robot": ["benchmarks/bench_new_robot.py"],
}
LEVERS, NEW_ROBOT, BANDED = "bench_levers", "bench_new_robot", "bench_tune_banded"
LEVER_SETS = ("gloves", "gloves+helmet", "gloves+helmet+chest", "gloves+helmet+belt",
              "gloves+helmet+elbows", "gloves+helmet+belt+elbows", "full suit")
LEVER_SENSING = ((20.0, 0.02), (120.0, 0.02), (240.0, 0.02), (20.0, 0.005), (120.0, 0.005),
                 (240.0, 0.005))  # the columns of tuning.md's table
LEVER_STOPPING_SETS = ("gloves", "gloves+helmet+belt+elbows", "full suit")
VERIFY, SIMULATE, RUNTIME = "bench_verify", "bench_simulate", "bench_runtime"
THREE_BALL, ISSUE_33 = "9273221", "177f5a8"  # bench_verify's commits, measured beside


def ratio(a, b) -> typing.Callable[[dict], float]:
    """``a``'s figure over ``b``'s."""
    return _source(lambda data: a(data) / b(data), *a.sources, *b.sources)


def verdict(get, goal: float) -> typing.Callable[[dict], str]:
    """"met" where ``get``'s figure is at most ``goal``, else "missed"."""
    return _source(lambda data: "met" if get(data) <= goal else "missed", *get.sources)


def search(config: str, budget: int, who: str, what: str) -> typing.Callable[[dict], float]:
    """bench_verify's first-counterexample figure: ``config`` (seed, subtle, contact) at
    ``budget``, ``who`` (ours, UniformRandom, DualAnnealing), ``what`` (falsified,
    median_evaluations, median_cpu, within_ours_cpu)."""
    return bench(VERIFY, f"search/{config}/{budget}/{who}/{what}")


EXAMPLE_STOPS, PATH_STOPS = "0.7 x the placeholder", "the paths' (derived)"


def lever_row(sensor_set: str, rate: float, latency: float, what: str,
              stopping: bool | str = False) -> typing.Callable[[dict], float]:
    """bench_levers' row of that lever, with the stopping data named ``stopping`` (True:
    the example, the placeholder at 0.7) or without (False): ``what`` (total_lost,
    reduction, ...)."""
    name = EXAMPLE_STOPS if stopping is True else stopping or ""

    def get(data: dict) -> float:
        return next(r[what] for r in data[LEVERS]["rows"]
                    if r["lever"] == dict(r["lever"], sensor_set=sensor_set, rate_hz=rate,
                                          latency=latency)
                    and r["lever"].get("stopping_name", "") == name)
    return _source(get, ("bench", LEVERS))


def _banded_figures() -> tuple:
    """The main job with the banded set (tuning.md)."""
    held = f"{SUMMARY}/held/separation"
    return (
        Figure("banded_held", r"is held on separation stops for " + NUM + " s",
               run("inspection-banded", f"{held}/time")),
        Figure("banded_held_segment", r"s, all of them by the " + TEXT + " while",
               _source(lambda data: next(iter(run("inspection-banded", f"{held}/by_segment")(
                   data))), ("runs", "inspection-banded")), "text"),
        Figure("banded_margin", r"its least separation margin while moving is \+" + NUM
               + " m", run("inspection-banded", f"{SUMMARY}/min_separation_margin")),
    )


def _robot_log_figures() -> tuple:
    """The worked cell from a robot log (how-to/robot-logs.md)."""
    return (
        Figure("robot_log_task_time", r"The 9 s log takes " + NUM + " s:",
               run("robot-log", f"{SUMMARY}/task_time")),
        Figure("robot_log_held", r"the robot waits on separation stops for " + NUM
               + r" s while the technician", run("robot-log", f"{SUMMARY}/held/separation/time")),
        Figure("robot_log_separation", r"never moves within " + NUM + " m of them",
               run("robot-log", f"{SUMMARY}/min_separation_while_moving")),
    )


def _soak_figures() -> tuple:
    """The soak benchmark's figures (how-to/live-run.md), from bench_soak.json."""
    soak = "bench_soak"
    return (
        Figure("soak_load", r"one-minute load " + NUM + " at its start, the tail",
               bench(soak, "load_1min")),
        Figure("soak_steal", r"the host took " + NUM + " s of the machine's CPU, steal",
               bench(soak, "steal_seconds")),
        Figure("soak_runtime_mb", r"the runtime's resident memory was " + NUM + " MB",
               bench(soak, "memory/runtime_end_mb")),
        Figure("soak_runtime_slope", r"a slope\s+of " + NUM + " MB per hour",
               bench(soak, "memory/runtime_slope_mb_per_hour")),
        Figure("soak_writer_mb", r"the log writer's " + NUM + " MB",
               bench(soak, "memory/writer_end_mb")),
        Figure("soak_writer_slope", r"the log writer's [0-9.]+ MB, \+" + NUM
               + r" MB per\s+hour", bench(soak, "memory/writer_slope_mb_per_hour")),
        Figure("soak_segments", NUM + " segments of 600 s", bench(soak, "log/segments")),
        Figure("soak_mb_hour", r"segments of 600 s, " + NUM + " MB per hour",
               bench(soak, "log/mb_per_hour")),
        Figure("soak_ticks", r"and all\s+" + NUM + " ticks", bench(soak, "log/read_back/ticks")),
        Figure("soak_frames", r"ticks and " + NUM + " frames the run counted",
               bench(soak, "log/read_back/frames")),
        Figure("soak_flush", r"at most " + NUM + r" s after\s+its time",
               bench(soak, "log/flush_age_max")),
        Figure("soak_late_p50", r"tick lateness " + NUM + " ms at p50",
               bench(soak, "timing/tick_late_p50"), scale=1000.0),
        Figure("soak_late_p99", r"ms at p50, " + NUM + " ms at p99 and",
               bench(soak, "timing/tick_late_p99"), scale=1000.0),
        Figure("soak_late_max", r"ms at p99 and " + NUM + " ms at most",
               bench(soak, "timing/tick_late_max"), scale=1000.0),
        Figure("soak_k_p99", r"frame\s+to k " + NUM + " ms at p99",
               bench(soak, "timing/frame_to_k_p99"), scale=1000.0),
        Figure("soak_overruns", r"overrun stops: " + NUM + ", against a bound of 0",
               bench(soak, "protective_stops/overrun/count")),
    )


def _lever_figures() -> tuple:
    """The levers' table in tuning.md (every cell's time lost and its reduction), and the
    figures around it and in the speed page."""
    out = []
    rows = [(name, name, False) for name in LEVER_SETS] + [
        (name, name + ", stops at 0.7", True) for name in LEVER_STOPPING_SETS] + [
        (name, name + ", the paths' stops", PATH_STOPS) for name in LEVER_STOPPING_SETS]
    for name, label, stopping in rows:
        for i, (rate, latency) in enumerate(LEVER_SENSING):
            cell = (r"\| " + label.replace("+", r"\+") + r" \|(?: [^|]+ \|){" + str(i)
                    + "} ")
            key = f"{label}_{rate:g}_{latency:g}"
            out.append(Figure(f"lever_lost_{key}", cell + NUM + " s",
                              lever_row(name, rate, latency, "total_lost", stopping)))
            out.append(Figure(f"lever_reduction_{key}", cell + r"[0-9.]+ s \(" + NUM + r"%\)",
                              lever_row(name, rate, latency, "reduction", stopping),
                              scale=100.0))
    return tuple(out) + (
        Figure("levers_iso_lost", r"against `iso.yaml`'s " + NUM + " s lost on the tasks "
               "as written", bench(LEVERS, "iso_lost")),
        Figure("levers_wall", r"78\s+rows, each fitted, proved and run on the seed's two "
               r"tasks\) took " + NUM + " s", bench(LEVERS, "wall"), TIME_NOISE),
        Figure("levers_table_wall", NUM + r" s for the 78 rows of the\s+three tables",
               bench(LEVERS, "wall"), TIME_NOISE),
        Figure("levers_banded_path", r"with the banded set at 120 Hz and 5 ms they\s+take the "
               r"time lost to " + NUM + "% less", lever_row(
                   "gloves+helmet+belt+elbows", 120.0, 0.005, "reduction", PATH_STOPS),
               scale=100.0),
        Figure("levers_best_stopping", r"with the example stopping data " + NUM + "%",
               lever_row("full suit", 240.0, 0.005, "reduction", True), scale=100.0),
        Figure("levers_banded_stopping", r"and 5 ms goes from [0-9.]+% to " + NUM + "%",
               lever_row("gloves+helmet+belt+elbows", 120.0, 0.005, "reduction", True),
               scale=100.0),
        Figure("levers_best", r"a full suit at 240 Hz and 5 ms, loses " + NUM
               + "% less time", lever_row("full suit", 240.0, 0.005, "reduction"),
               scale=100.0),
        Figure("levers_banded", r"the banded set at 120 Hz and 5 ms: " + NUM + "%",
               lever_row("gloves+helmet+belt+elbows", 120.0, 0.005, "reduction"),
               scale=100.0),
        Figure("banded_tune_lost", NUM + r" s lost against `iso.yaml`'s [0-9.]+ s on the "
               "same worn tasks", bench(BANDED, "table/chosen/total_lost_time")),
        Figure("banded_tune_iso", r"s lost against `iso.yaml`'s " + NUM + " s on the same "
               "worn tasks", bench(BANDED, "table/iso.yaml/total_lost_time")),
        Figure("banded_tune_reduction", r"on the same worn tasks \(" + NUM + "% less",
               bench(BANDED, "reduction"), scale=100.0),
        Figure("banded_tune_wall", r"120 0.005`, " + NUM + " s here",
               bench(BANDED, "wall"), TIME_NOISE),
        Figure("stops_tune_wall", r"120 0.005 --path-stops`, " + NUM + " s here",
               bench("bench_tune_banded_stops", "wall"), TIME_NOISE),
        Figure("stops_tune_lost", NUM + r" s lost on the\s+seed's two tasks worn with the "
               "banded set", bench("bench_tune_banded_stops", "table/chosen/total_lost_time")),
        Figure("stops_tune_reduction", NUM + r"% less than `iso.yaml` on the same worn\s+tasks "
               "and", bench("bench_tune_banded_stops", "reduction"), scale=100.0),
        Figure("stops_tune_written", r"and " + NUM + r"% less than `iso.yaml` on the tasks as "
               r"written \(issue", bench("bench_tune_banded_stops", "reduction_as_written"),
               scale=100.0),
        Figure("pfl_off_reduction", r"\| PFL off \(`models/tune/ssm.yaml`\) \| " + NUM
               + "% less", bench("bench_tune_pfl", "ssm_only/reduction"), scale=100.0),
        Figure("pfl_on_reduction", r"\| PFL on \(`models/tune/ssm_pfl.yaml`\) \| " + NUM
               + "% less", bench("bench_tune_pfl", "reduction"), scale=100.0),
        Figure("pfl_fastest_lost", r"\(`models/configs/pfl.yaml`\) lost\s+" + NUM + " s",
               bench("bench_tune_pfl", "fastest_pfl/total_lost_time")),
        Figure("new_robot_first", r"its\s+first verify took " + NUM + " s of CPU",
               bench(NEW_ROBOT, "runs/new robot (5 joints), first/cpu"), TIME_NOISE),
        Figure("new_robot_second", r"s of CPU and its second " + NUM + " s",
               bench(NEW_ROBOT, "runs/new robot (5 joints), second/cpu"), TIME_NOISE),
        Figure("new_robot_ratio", r"a ratio of \*\*" + NUM + r"\*\*",
               bench(NEW_ROBOT, "ratio"), TIME_NOISE),
    )


def _speed_figures() -> tuple:
    """The figures of the "Speed" page, from bench_verify, bench_simulate and
    bench_runtime (each ``--json``), and bench_tune's reduction."""
    cell = bench(VERIFY, "throughput/whole_cell")
    ref = bench(VERIFY, f"throughput/commits/{ISSUE_33}/whole_cell")
    three = bench(VERIFY, f"throughput/commits/{THREE_BALL}/whole_cell")
    alone = bench(VERIFY, "throughput/loop_alone/whole_cell")
    share = _source(lambda data: 100.0 * (1.0 - cell(data) / alone(data)), *cell.sources)
    drake = bench(VERIFY, "throughput/drake")
    out = [
        Figure("speed_iso_rate", r"The batched evaluator runs " + NUM + " scenarios per second "
               "on iso.yaml's contact terms", bench(VERIFY, "throughput/iso"), TIME_NOISE),
        Figure("speed_busy_rate", r"on iso.yaml's contact terms and " + NUM + " with estimated "
               "human speeds", bench(VERIFY, "throughput/busy"), TIME_NOISE),
        Figure("speed_tool_rate", r"its 12 segments, against the tool\) " + NUM + ";",
               bench(VERIFY, "throughput/tool_point"), TIME_NOISE),
        Figure("speed_drake_rate", r"Drake diagram " + NUM + " per second, so the batch",
               drake, TIME_NOISE),
        Figure("speed_batch_over_drake", r"so the batch runs " + NUM + " times the diagram",
               ratio(cell, drake)),
        Figure("speed_issue_33_rate", r"177f5a8 gives " + NUM + " there", ref, TIME_NOISE),
        Figure("speed_issue_33_ratio", r"this code runs \*\*" + NUM + r"x\*\* of it",
               ratio(cell, ref)),
        Figure("speed_three_ball_rate", r"last commit \(9273221\) gives " + NUM + ", so",
               three, TIME_NOISE),
        Figure("speed_price", r"the whole operator's price is " + NUM + r"x \(issue 31",
               ratio(three, cell)),
        Figure("speed_loop_alone_rate", r"measured in the same run\) runs " + NUM
               + r" scenarios per second", alone, TIME_NOISE),
        Figure("speed_loop_alone_ratio", r"\*\*" + NUM + r"x\*\* of 177f5a8's figure",
               ratio(alone, ref)),
        Figure("speed_properties_share", r"the properties take " + NUM + r"% of this code's",
               share),
        Figure("speed_kinematic", r"the inspection scenario, best of three\): " + NUM
               + "x real time", bench(SIMULATE, "real_time_kinematic"), TIME_NOISE),
        Figure("speed_dynamic", r"\(goal 100x\) and " + NUM + "x in `dynamic` mode",
               bench(SIMULATE, "real_time_dynamic"), TIME_NOISE),
        Figure("speed_kinematic_10s", r"its first ten seconds " + NUM + "x in `kinematic` mode",
               bench(SIMULATE, "real_time_kinematic_10s"), TIME_NOISE),
        Figure("speed_floor_idle", r"the loop's parts at that rate\) run " + NUM
               + "x real time", bench(SIMULATE, "floor_idle_4"), TIME_NOISE),
        Figure("speed_floor_plant", r"controller beside those four " + NUM + "x",
               bench(SIMULATE, "floor_plant_4"), TIME_NOISE),
        Figure("speed_monitor_us", r"against the 7 capsules take " + NUM
               + " us per tick", bench(SIMULATE, "monitor_us_7_capsules"), TIME_NOISE),
        Figure("speed_confirm", r"a quarter second after the violation, took " + NUM
               + r" s of wall time \(goal 1 s\)", bench(VERIFY, "search/subtle/200/confirm/wall"),
               TIME_NOISE),
        Figure("speed_proof", r"iso.yaml's proof over the default space took " + NUM + " s",
               bench(VERIFY, "proof/proof_alone_wall"), TIME_NOISE),
        Figure("speed_tune_reduction", r"`bench_tune.py`: " + NUM + "% less time lost",
               bench(TUNE, "reduction"), scale=100.0),
        Figure("pfl_tune_reduction", r"with power and force limiting among its choices, "
               + NUM + "% less time lost", bench("bench_tune_pfl", "reduction"), scale=100.0),
        Figure("pfl_tune_ssm_only", r"the SSM-only tune of the same run: " + NUM + "%",
               bench("bench_tune_pfl", "ssm_only/reduction"), scale=100.0),
        Figure("pfl_tune_goal", r"\(goal 50%: " + TEXT + r"\)",
               _source(lambda data: "met" if data["bench_tune_pfl"]["met"] else "missed",
                       ("bench", "bench_tune_pfl")), "text"),
        Figure("pfl_tune_mode", r"The tune chose `safety.mode: " + TEXT + "`",
               bench("bench_tune_pfl", "chosen/values/safety.mode"), "text"),
        Figure("speed_runtime_policy", r"20 s\), scheduled `" + TEXT + "`",
               bench(RUNTIME, "scheduling/policy"), "text"),
        Figure("speed_load", r"in an earlier run, the load " + NUM + " when",
               bench(SIMULATE, "load_1min")),
        Figure("speed_verify_load", r"pinned to one core, its one-minute load " + NUM
               + " at its start", bench(VERIFY, "load_1min")),
        Figure("speed_tick_verdict", r"\(goal p99 0.5 ms: " + TEXT + "; the largest",
               verdict(bench(RUNTIME, "tick_late_p99"), 0.5e-3), "text"),
        Figure("speed_frame_verdict", r"\(goal p99 1 ms: " + TEXT + r"\)",
               verdict(bench(RUNTIME, "frame_to_k_p99"), 1e-3), "text"),
        Figure("speed_tick_p50", r"a tick started late by " + NUM + " ms at p50",
               bench(RUNTIME, "tick_late_p50"), TIME_NOISE, 1e3),
        Figure("speed_tick_p99", r"late by [0-9.]+ ms at p50 and " + NUM + " ms at p99",
               bench(RUNTIME, "tick_late_p99"), TIME_NOISE, 1e3),
        Figure("speed_tick_max", r"the largest " + NUM + " ms; a tick more than 5 ms",
               bench(RUNTIME, "tick_late_max"), TIME_NOISE, 1e3),
        Figure("speed_tick_p99_at_once", r"\(as before issue 49, when a frame's work made the "
               r"next tick late\) gave a p99 of " + NUM + " ms",
               bench(RUNTIME, "frames_at_once/tick_late_p99"), TIME_NOISE, 1e3),
        Figure("speed_runtime_load", r"gave a p99 of [0-9.]+ ms\s+\(at one-minute load "
               + NUM + r"\)", bench(RUNTIME, "load_1min")),
        Figure("speed_frame_p50", r"arrival to its new k took " + NUM + " ms at p50",
               bench(RUNTIME, "frame_to_k_p50"), TIME_NOISE, 1e3),
        Figure("speed_frame_p99", r"new k took [0-9.]+ ms at p50 and " + NUM + " ms at p99",
               bench(RUNTIME, "frame_to_k_p99"), TIME_NOISE, 1e3),
    ]
    for kind, what in (("margins", "a margin scoring"), ("dangers", "a reduced-model score"),
                       ("drake", "a whole Drake run")):
        out.append(Figure(f"speed_cost_{kind}", what + " " + NUM + r"(\s+simulations)?,",
                          bench(VERIFY, f"costs/iso/{kind}"), TIME_NOISE))
    out.append(Figure("speed_cost_simulation", r"a simulation " + NUM + " ms of CPU",
                      bench(VERIFY, "costs/iso/simulation_cpu_ms"), TIME_NOISE))
    anchors = {"subtle": ("this project falsified it on", "psy-taliro's UniformRandom on"),
               "contact": ("this project found contact on",
                           "psy-taliro's UniformRandom found it on")}
    for config, (mine, theirs) in anchors.items():
        at = f"`benchmarks/{config}_unsafe.yaml`.{{0,900}}?"
        out += [
            Figure(f"speed_{config}_200_ours", at + mine + " " + NUM + " of 10 seeds at budget",
                   search(config, 200, "ours", "falsified")),
            Figure(f"speed_{config}_200_evaluations", at + "at budget 200, after a median "
                   + NUM + " simulation-equivalents",
                   search(config, 200, "ours", "median_evaluations")),
            Figure(f"speed_{config}_200_cpu", at + "simulation-equivalents and " + NUM
                   + r" s of\s+CPU \(goal 1 s\)", search(config, 200, "ours", "median_cpu"),
                   TIME_NOISE),
            Figure(f"speed_{config}_4096_ours", at + r"\(goal 1 s\), and on " + NUM
                   + " of 10 seeds at 4096", search(config, 4096, "ours", "falsified")),
            Figure(f"speed_{config}_4096_cpu", at + r"of 10 seeds at 4096 \(a median " + NUM
                   + " s", search(config, 4096, "ours", "median_cpu"), TIME_NOISE),
            Figure(f"speed_{config}_200_uniform", at + theirs + " " + NUM,
                   search(config, 200, "UniformRandom", "falsified")),
            Figure(f"speed_{config}_200_annealing", at + "DualAnnealing (?:found it )?on " + NUM
                   + " of 10 seeds at 200", search(config, 200, "DualAnnealing", "falsified")),
            Figure(f"speed_{config}_4096_uniform", at + "of 10 seeds at 200, on " + NUM
                   + " and", search(config, 4096, "UniformRandom", "falsified")),
            Figure(f"speed_{config}_4096_annealing", at + "of 10 seeds at 200, on [0-9]+ and "
                   + NUM + " of 10 at 4096", search(config, 4096, "DualAnnealing", "falsified")),
            Figure(f"speed_{config}_4096_uniform_cpu", at + "on the same seed on " + NUM
                   + " and", search(config, 4096, "UniformRandom", "within_ours_cpu")),
            Figure(f"speed_{config}_4096_annealing_cpu", at + "on the same seed on [0-9]+ and "
                   + NUM + " of", search(config, 4096, "DualAnnealing", "within_ours_cpu")),
        ]
    return tuple(out)

FIGURES = (
    # The README's main job: what the inspection scenario shows.
    Figure("main_job_held", r"they lean in \(held " + NUM + " s, by the",
           run("inspection", f"{SUMMARY}/held/separation/time")),
    Figure("main_job_task_time", r"its 7 cycles end at " + NUM + " s of the",
           run("inspection", f"{SUMMARY}/task_time")),
    Figure("main_job_margin", r"its least separation margin was \+" + NUM + " m",
           run("inspection", f"{SUMMARY}/min_separation_margin")),
    Figure("seed_job_held", r"it holds the robot " + NUM + " s and does not finish",
           run("inspection-seed", f"{SUMMARY}/held/separation/time")),
    Figure("seed_job_held_tuning", r"the robot is held " + NUM + r" s and does not\s+finish",
           run("inspection-seed", f"{SUMMARY}/held/separation/time")),
    # The README's tune paragraph: what power and force limiting buys (bench_tune's PFL run).
    Figure("readme_pfl_reduction", r"the tune lost " + NUM + "% less time than iso.yaml and",
           bench("bench_tune_pfl", "reduction"), scale=100.0),
    Figure("readme_pfl_mode", r"iso.yaml and chose `" + TEXT + "`: at the robot's trusted",
           bench("bench_tune_pfl", "chosen/values/safety.mode"), "text"),
    # The README's test command (the fast selection), as walked through (run --only tests).
    Figure("tests_minutes", r"tests marked slow, took " + NUM + " min of wall time",
           scaled(run("tests", "wall"), 1.0 / 60.0), TIME_NOISE),
    # The tutorial: the first verify of a fresh clone compiles; the second is the run itself.
    Figure("first_verify_wall", r"the first `verify` below took " + NUM + " s of wall time",
           run("verify-iso", "wall"), TIME_NOISE),
    Figure("first_verify_cpu", r"s of wall time \(" + NUM + r" s of CPU\) on a fresh clone",
           run("verify-iso", "cpu"), TIME_NOISE),
    Figure("second_verify_wall", r"on a fresh clone and " + NUM + r" s \([0-9.]+ s of CPU\) "
           "the second time", run("verify-iso#2", "wall"), TIME_NOISE),
    Figure("second_verify_cpu", r"on a fresh clone and [0-9.]+ s \(" + NUM + r" s of CPU\) "
           "the second time", run("verify-iso#2", "cpu"), TIME_NOISE),
    # The separation invariant broken without contact, in a shipped scenario.
    Figure("ewaste_margin", r"the e-waste sorting cell's run does \(`min_separation_margin` "
           + NUM + " m", run("ewaste", f"{SUMMARY}/min_separation_margin")),
    Figure("ewaste_clearance", r"the e-waste sorting cell's run does .{0,200}?no contact: "
           "its smallest clearance while the robot moves is " + NUM + " m",
           run("ewaste", f"{SUMMARY}/min_separation_while_moving")),
    # verify's examples.
    Figure("verify_iso_exit", r"The first proves \(exit " + NUM, run("verify-iso#2", "exit")),
    Figure("verify_iso_wall", r"The first proves \(exit 0, " + NUM + " s here once compiled",
           run("verify-iso#2", "wall"), TIME_NOISE),
    Figure("verify_previous_exit", r"the other two falsify the previous behaviour \(exit "
           + NUM + " each", both(run("verify-elbow", "exit"), run("verify-occluded", "exit"))),
    Figure("verify_occluded_wall", r"right after the first `verify`: " + NUM + " s for the "
           "first, the occluded", run("verify-occluded", "wall"), TIME_NOISE),
    Figure("verify_elbow_wall", r"s for the first, the occluded approach, and " + NUM
           + " s for the elbow", run("verify-elbow", "wall"), TIME_NOISE),
    # Export, check and load: the certified parameters on the inspection task.
    Figure("deployed_held", r"they hold the robot still for " + NUM
           + " s", run("inspection-deployed-100", f"{SUMMARY}/stopped_time")),
    Figure("deployed_task_time", r"and its 7 cycles need " + NUM + r" s \(`--duration 100`",
           run("inspection-deployed-100", f"{SUMMARY}/task_time")),
    Figure("deployed_main_held", r"stops only when they\s+lean in \(held " + NUM + r" s\)",
           run("inspection-deployed-main", f"{SUMMARY}/held/separation/time")),
    Figure("deployed_main_task_time", r"its 7 cycles end at " + NUM + " s, as in",
           run("inspection-deployed-main", f"{SUMMARY}/task_time")),
    Figure("live_held", r"the run was\s+held by separation stops for " + NUM + " s",
           run("live-approach", f"{SUMMARY}/held/separation/time"), TIME_NOISE),
    # The scenario space around a recording.
    Figure("recording_wall", r"With a budget of 64 \(" + NUM + " s of wall time here",
           run("verify-recording", "wall"), TIME_NOISE),
    Figure("recording_cpu", r"s of wall time here, " + NUM + " s of CPU",
           run("verify-recording", "cpu"), TIME_NOISE),
    Figure("recording_separation_at", r"the separation\s+invariant at simulation " + NUM,
           run("verify-recording", f"{SEPARATION}/simulations_to_first_counterexample")),
    Figure("recording_contact_at", r"contact at simulation " + NUM + r" \(",
           run("verify-recording", f"{CONTACT}/simulations_to_first_counterexample")),
    Figure("recording_contact", r"contact at simulation [0-9]+ \([^)]*?" + NUM + r" m\)",
           run("verify-recording", f"{CONTACT}/min_robustness")),
    Figure("recording_previous", r"`iso_previous.yaml` fails the separation invariant \("
           + NUM + " m", run("verify-recording-previous", f"{SEPARATION}/min_robustness")),
    Figure("recording_previous_at", r"`iso_previous.yaml` fails the separation invariant "
           r"\([-0-9.]+ m,\s+at simulation " + NUM,
           run("verify-recording-previous", f"{SEPARATION}/simulations_to_first_counterexample")),
    Figure("recording_iso_contact", r"`iso.yaml` passes both \(smallest robustness " + NUM
           + " m", run("verify-recording-iso", f"{CONTACT}/min_robustness")),
    Figure("recording_iso_separation", r"`iso.yaml` passes both \(smallest robustness "
           r"[0-9.]+ m and " + NUM + " m", run("verify-recording-iso",
                                                f"{SEPARATION}/min_robustness")),
    Figure("recording_iso_vacuous", r"m and [0-9.]+ m; " + NUM + "% of the scenarios vacuous",
           run("verify-recording-iso", f"{CONTACT}/vacuous/evaluated/share"), scale=100.0),
    # tune: bench_tune's run and the configuration it chose (shipped as tuned.yaml).
    Figure("tune_wall", r"`--workers 1`, " + NUM + " s here", bench(TUNE, "wall"), TIME_NOISE),
    Figure("tune_proofs", r"s here, " + NUM + " proofs", bench(TUNE, "counts/proofs")),
    Figure("tune_simulations", r"proofs, " + NUM + " simulations and",
           bench(TUNE, "counts/simulations")),
    Figure("tune_task_runs", r"simulations and " + NUM + " task runs counted",
           bench(TUNE, "counts/task_runs")),
    Figure("chosen_human_speed", r"the chosen configuration \(human speed `" + TEXT + "`",
           chosen("safety.human_speed"), "text"),
    Figure("chosen_stopping", r"`stopping: " + TEXT + "`, `robot_speed",
           chosen("safety.stopping"), "text"),
    Figure("chosen_robot_speed", r"`robot_speed: " + TEXT + "`, frame timeout",
           chosen("safety.robot_speed"), "text"),
    Figure("chosen_frame_timeout", r"fastest_point`, frame timeout " + NUM + " s, T_r",
           chosen("tracker.frame_timeout")),
    Figure("chosen_reaction_time", r"frame timeout [0-9.]+ s, T_r " + NUM + " s, C",
           chosen("safety.reaction_time")),
    Figure("chosen_intrusion", r"s, T_r [0-9.]+ s, C " + NUM + ", Z_r",
           chosen("safety.intrusion_distance")),
    Figure("chosen_z_r", r", C [0-9.]+, Z_r " + NUM + " m, ΔS",
           chosen("safety.robot_uncertainty")),
    Figure("chosen_delta_s", r"m, ΔS " + NUM + ", d_min", chosen("safety.delta_s")),
    Figure("chosen_d_min", r", d_min " + NUM + " m, velocity process noise",
           chosen("safety.d_min")),
    Figure("chosen_noise", r"velocity process noise " + NUM + r" \(m/s\)\^2\),",
           chosen("tracker.velocity_process_noise")),
    Figure("chosen_lost", r"and\s+loses " + NUM + " s over the two tasks",
           bench(TUNE, "table/chosen/total_lost_time")),
    Figure("iso_lost", r"s over the two tasks against `iso.yaml`'s " + NUM + " s",
           bench(TUNE, "table/iso.yaml/total_lost_time")),
    Figure("tune_reduction", r"\*\*" + NUM + "% less, goal", bench(TUNE, "reduction"),
           scale=100.0),
    Figure("iso_lost_again", r"`iso.yaml` loses more too \(" + NUM + " s",
           bench(TUNE, "table/iso.yaml/total_lost_time")),
    Figure("held_inspection", r"holds the robot on a separation stop for " + NUM
           + " s of the inspection", bench(TUNE, "held/inspection/separation_stop")),
    Figure("held_co_kitting", r"s of the inspection and " + NUM + " s of the co-kitting run",
           bench(TUNE, "held/co_kitting/separation_stop")),
    Figure("held_true_inspection", r"the true nearest segment is then " + NUM + " m and",
           bench(TUNE, "held/inspection/true_nearest_median")),
    Figure("held_true_co_kitting", r"the true nearest segment is then [0-9.]+ m and " + NUM
           + r" m away \(median\)", bench(TUNE, "held/co_kitting/true_nearest_median")),
    Figure("iso_full_speed_distance", r"\(`iso.yaml`: " + NUM + " m; the chosen",
           bench(TUNE, "full_speed_distance/iso.yaml")),
    Figure("chosen_full_speed_distance", r"m; the chosen: " + NUM + r" m\)",
           bench(TUNE, "full_speed_distance/chosen")),
    Figure("exposure_iso_distance", r"some segment of an operator is within " + NUM
           + " m of it", bench(TUNE, "full_speed_distance/iso.yaml")),
    Figure("exposure_inspection", r"m of it for " + NUM + r" s \(inspection\)",
           exposure("inspection", "iso")),
    Figure("exposure_co_kitting", r"s \(inspection\) and " + NUM + r" s\s+\(co-kitting\)",
           exposure("co_kitting", "iso")),
    Figure("exposure_1_5_inspection", r"within 1.5 m for " + NUM + " s and",
           exposure("inspection", "1.5")),
    Figure("exposure_1_5_co_kitting", r"within 1.5 m for [0-9.]+ s and " + NUM + " s",
           exposure("co_kitting", "1.5")),
    Figure("exposure_1_0_inspection", r"still within 1.0 m for " + NUM + " s and",
           exposure("inspection", "1.0")),
    Figure("exposure_1_0_co_kitting", r"still within 1.0 m for [0-9.]+ s and " + NUM + " s",
           exposure("co_kitting", "1.0")),
    # Proofs and distances (PROBES).
    Figure("allowance_fastest_point", r"separation invariant's proof then asks for about "
           + NUM + r" m of Z_d \+ Z_r", probe("allowance_fastest_point")),
    Figure("allowance_directed", r"m of Z_d \+ Z_r on the default space instead of " + NUM
           + " m", probe("allowance_directed")),
    Figure("screen_example_distance", r"both prove with a full-speed\s+distance of " + NUM
           + " m", probe("screen_example_distance")),
    Figure("export_s", r"while the technician works near it \(S is " + NUM + " m",
           probe("iso_full_speed_distance")),
    # The tutorial's tune command, as walked through.
    Figure("tune_run_minutes", r"The command above took " + NUM + " min of wall time",
           scaled(run("tune", "wall"), 1.0 / 60.0), TIME_NOISE),
    Figure("tune_run_lost", r"chose a proved configuration that loses " + NUM + " s",
           run("tune", "files/tune/table/0/total_lost_time")),
    Figure("tune_run_reduction", r"loses [0-9.]+ s over the two tasks \(" + NUM
           + "% less than `iso.yaml`", run("tune", "files/tune/lost_time_reduction_vs_iso"),
           scale=100.0),
    # tune over the recording space (Drake runs only), the Panda's verify.
    Figure("tune_recording_minutes", r"in the Drake diagram \(a recording space has no batched "
           r"evaluator\), " + NUM + " min of wall time",
           scaled(run("tune-recording", "wall"), 1.0 / 60.0), TIME_NOISE),
    Figure("tune_recording_lost", r"It chose a configuration that loses " + NUM + " s",
           run("tune-recording", "files/tune/table/0/total_lost_time")),
    Figure("tune_recording_reduction", r"s over the two tasks, " + NUM + "% less than `iso.yaml`, "
           "which is passed, not proved, over this space",
           run("tune-recording", "files/tune/lost_time_reduction_vs_iso"), scale=100.0),
    Figure("verify_panda_exit", r"It proves both properties \(exit " + NUM,
           run("verify-panda", "exit")),
    Figure("verify_panda_wall", r"It proves both properties \(exit 0\) in " + NUM + " s here",
           run("verify-panda", "wall"), TIME_NOISE),
    # tune: the shipped tuned.yaml re-verified.
    Figure("tuned_verify_seconds", r"--out DIR`, " + NUM + " s here",
           run("verify-tuned", "wall"), TIME_NOISE),
    Figure("tuned_contact_margin", r"s here:\s+contact margin " + NUM + " m",
           run("verify-tuned", f"{CONTACT}/proof/margin_at_worst_corner")),
    Figure("tuned_separation_margin", r"s here:\s+contact margin [0-9.]+ m, separation "
           + NUM + " m", run("verify-tuned", f"{SEPARATION}/proof/margin_at_worst_corner")),
) + _speed_figures() + _lever_figures() + _banded_figures() + _soak_figures() + _robot_log_figures()
