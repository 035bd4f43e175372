"""A shift of the live runtime, shortened to an hour: memory, log and stops over a long run.

    python benchmarks/bench_soak.py [--duration S] [--bodies N] [--frame-rate HZ]
                                    [--segment S] [--json PATH]

``safety-systems run`` (models/configs/iso.yaml, ``--robot none``, ``run``'s default
real-time priority where the machine grants it) runs its 500 Hz loop for ``--duration``
seconds (default 3600: an hour, in real time) with N rigid bodies (default 10: five
operators of two gloves) streamed at the frame rate (default 120 Hz) by its replay
server, as bench_runtime.py streams them (the same walk to and fro, sampled at 10 Hz in
the recording and interpolated by the server). It prints, beside the bounds of issue 49:

- resident memory (``VmRSS``) of the runtime's process and of its log writer, sampled
  every 10 s: the slope of a straight line fitted after the first five minutes (a
  quarter of a shorter run; bound: 10 MB per hour) and the spread of the samples then;
- the log: its segments (one per ``--segment`` s), bytes per hour, every segment
  finished, every tick and frame the run counted read back from it in order (none
  missing, none twice), and the records the loop could not hand to the writer;
- the stops: no overrun stop (on a machine whose other work leaves the loop's core be),
  the tick lateness and frame-to-k percentiles of the whole run.

The run is real time, not faster: the loop's clock is the machine's, so a faster replay
would be a different loop. ``--duration 600`` gives a shortened run's figures.
"""

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from bench_runtime import ROOT, write_inputs  # noqa: E402

MEMORY_SLOPE_BOUND = 10.0  # MB per hour
WARM_UP = 300.0  # s of the run before memory is taken as settled (a quarter of a shorter run)
SAMPLE_PERIOD = 10.0  # s between memory samples


def rss_mb(pid: int) -> float | None:
    """A process' resident memory (MB), None once it has ended."""
    try:
        for line in open(f"/proc/{pid}/status"):
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        return None
    return None


def children(pid: int) -> list[int]:
    try:
        return [int(x) for x in open(f"/proc/{pid}/task/{pid}/children").read().split()]
    except OSError:
        return []


def command_line(pid: int) -> str:
    try:
        return open(f"/proc/{pid}/cmdline").read().replace("\0", " ")
    except OSError:
        return ""


def steal_seconds() -> float:
    """CPU time the host took from this (virtual) machine's cores so far (/proc/stat's
    steal, summed over the cores), s; NaN where unknown."""
    try:
        fields = open("/proc/stat").readline().split()
        return int(fields[8]) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return math.nan


def slope_per_hour(times: np.ndarray, values: np.ndarray) -> float:
    """The least-squares slope of ``values`` over ``times`` (s), per hour."""
    if len(times) < 2:
        return math.nan
    return float(np.polyfit(times, values, 1)[0] * 3600.0)


def read_back(folder: Path) -> dict:
    """Every segment of the log read back: counts, order, sizes."""
    from safety_systems.sensing.run_log import read_run_log

    ticks = frames = 0
    in_order, finished, per_segment, worst = True, True, [], []
    for path in sorted(folder.glob("log-*.mcap")):
        segment = read_run_log(path)
        in_order &= bool(np.array_equal(segment.tick_sequence,
                                        ticks + np.arange(len(segment.ticks))))
        in_order &= bool(np.array_equal(segment.frame_sequence,
                                        frames + np.arange(len(segment.frames))))
        late, times = segment.column("tick_late"), segment.column("time")
        for i in np.argsort(np.nan_to_num(late, nan=-1.0))[-5:]:
            worst.append((float(times[i]), float(late[i])))
        ticks += len(segment.ticks)
        frames += len(segment.frames)
        finished &= segment.finished
        per_segment.append({"file": path.name, "bytes": path.stat().st_size,
                            "ticks": len(segment.ticks), "frames": len(segment.frames)})
    worst = sorted(worst, key=lambda x: -x[1])[:5]
    return {"ticks": ticks, "frames": frames, "in_order": in_order, "finished": finished,
            "segments": per_segment, "latest_ticks": worst}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--duration", type=float, default=3600.0, help="s (default 3600)")
    parser.add_argument("--bodies", type=int, default=10)
    parser.add_argument("--frame-rate", type=float, default=120.0, help="Hz (default 120)")
    parser.add_argument("--segment", type=float, default=600.0,
                        help="s of the run per log segment (default 600)")
    parser.add_argument("--json", type=Path, default=None,
                        help="also write the figures printed to this JSON file")
    args = parser.parse_args()
    load = os.getloadavg()[0]
    steal = steal_seconds()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        recording, mapping = write_inputs(folder, args.bodies, args.duration, rate=10.0)
        log = folder / "log"
        argv = [sys.executable, "-m", "safety_systems.cli", "run",
                str(ROOT / "models" / "configs" / "iso.yaml"), "--unverified", "--mocap",
                f"replay://{recording}?rate={args.frame_rate}&duration={args.duration}",
                "--robot", "none", "--mapping", str(mapping), "--log", str(log), "--quiet",
                "--log-segment", str(args.segment)]
        process = subprocess.Popen(argv, stderr=subprocess.PIPE, text=True)
        samples: list[tuple[float, float, float]] = []  # (run time, runtime MB, writer MB)
        clock_start = None
        while process.poll() is None:
            time.sleep(SAMPLE_PERIOD)
            if clock_start is None:
                try:
                    clock_start = json.loads((log / "summary.json").read_text())["clock_start"]
                except (OSError, ValueError, KeyError):
                    continue
            writer = [c for c in children(process.pid) if "run_log_writer" in command_line(c)]
            own, theirs = rss_mb(process.pid), rss_mb(writer[0]) if writer else None
            if own is not None and theirs is not None:
                samples.append((time.monotonic() - clock_start, own, theirs))
        err = process.stderr.read()
        code = process.returncode
        steal = steal_seconds() - steal
        summary = json.loads((log / "summary.json").read_text())
        back = read_back(log)
    t, own, theirs = (np.array(x) for x in zip(*samples)) if samples else ([], [], [])
    warm_up = min(WARM_UP, 0.25 * args.duration)
    settled = np.asarray(t) >= warm_up
    memory = {
        "samples": len(samples), "warm_up": warm_up,
        "runtime_start_mb": float(own[0]) if len(own) else None,
        "runtime_end_mb": float(own[-1]) if len(own) else None,
        "runtime_slope_mb_per_hour": slope_per_hour(t[settled], own[settled]),
        "runtime_spread_mb": float(np.ptp(own[settled])) if settled.any() else None,
        "writer_end_mb": float(theirs[-1]) if len(theirs) else None,
        "writer_slope_mb_per_hour": slope_per_hour(t[settled], theirs[settled]),
        "writer_spread_mb": float(np.ptp(theirs[settled])) if settled.any() else None,
    }
    hours = summary["duration"] / 3600.0
    written = summary["log"]
    overruns = summary["protective_stops"]["overrun"]["count"]
    timing = summary["timing"]
    print(f"scheduling: {summary['scheduling']}")
    print(f"run: exit {code}, {summary['end']}, {summary['duration']:.0f} s, "
          f"{summary['ticks']} ticks, {summary['frames']} frames of {args.bodies} bodies at "
          f"{args.frame_rate:g} Hz (one-minute load at its start {load:.1f})")
    for who in ("runtime", "writer"):
        slope = memory[f"{who}_slope_mb_per_hour"]
        print(f"memory, {who}: {memory[f'{who}_end_mb']:.0f} MB at the end, slope after "
              f"{warm_up:.0f} s {slope:+.2f} MB/h, spread {memory[f'{who}_spread_mb']:.1f} "
              f"MB  bound {MEMORY_SLOPE_BOUND:g} MB/h: "
              + ("met" if abs(slope) <= MEMORY_SLOPE_BOUND else "NOT MET"))
    expected_segments = math.ceil(summary["duration"] / args.segment)
    print(f"log: {len(back['segments'])} segments of {args.segment:g} s (expected "
          f"{expected_segments}), {written['bytes'] / 1e6 / hours:.0f} MB per hour, all "
          f"finished: {back['finished']}; read back {back['ticks']} ticks and "
          f"{back['frames']} frames in order: {back['in_order']} (the run counted "
          f"{summary['ticks']} and {summary['frames']}); records dropped "
          f"{written['dropped_ticks'] + written['dropped_frames']}, lost "
          f"{written['lost_to_errors']}; the oldest record reached the disk cache "
          f"{written['flush_age_max']:.2f} s after its time at most")
    print("the latest ticks (run time s, late ms): " + ", ".join(
        f"{t:.1f} s {1e3 * x:.2f}" for t, x in back["latest_ticks"]))
    print(f"the host took {steal:.1f} s of CPU from this machine's cores (steal) during the "
          "run: while it does, the whole machine stops, the loop with it")
    print(f"overrun stops: {overruns} (bound 0); tick late p50 "
          f"{1e3 * timing['tick_late_p50']:.3f} ms, p99 {1e3 * timing['tick_late_p99']:.3f} "
          f"ms, max {1e3 * timing['tick_late_max']:.2f} ms; frame to k p99 "
          f"{1e3 * timing['frame_to_k_p99']:.3f} ms")
    if code != 0:
        print(err, file=sys.stderr)
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({
            "duration": args.duration, "bodies": args.bodies, "frame_rate": args.frame_rate,
            "segment": args.segment, "load_1min": load, "steal_seconds": steal, "exit": code,
            "end": summary["end"],
            "scheduling": summary["scheduling"], "ticks": summary["ticks"],
            "frames": summary["frames"], "memory": memory,
            "memory_bound_mb_per_hour": MEMORY_SLOPE_BOUND,
            "log": {**written, "mb_per_hour": written["bytes"] / 1e6 / hours,
                    "expected_segments": expected_segments, "read_back": back},
            "protective_stops": summary["protective_stops"], "timing": timing}, indent=1)
            + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
