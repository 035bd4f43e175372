"""The live runtime on one machine: real NatNet packets over 127.0.0.1, the same k as
simulate for a recorded approach, and speed 0 within a control period on every fault.

The runs that need the robot to move stream the recording through :func:`_far_mapping`:
the technician 1 m farther from the robot than recorded. The monitor bounds the whole
operator (``safety_systems.cell.human_body``): from the gloves and the head it puts the
trunk, lean allowed, within 1.96 m of the robot's capsules while the technician stands at
3 m, and iso.yaml's S is 2.41 m at every speed, so the recorded approach would hold the
robot still throughout (k = 0 on every tick, nothing to compare or to see stop)."""

import dataclasses
import json
import math
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from safety_systems.cell.human_body import SEGMENT_NAMES
from safety_systems.cli import main
from safety_systems.sensing.recording_files import read_recording
from safety_systems.sensing.recording_mapping import (
    find_operator,
    load_mapping,
    mapped_point,
    recorded_bodies,
)
from safety_systems.runtime.live_run import LiveOptions, log_columns, run_live
from safety_systems.runtime.mocap import BodyMap, MocapAddress, NatNetSource
from safety_systems.runtime.replay_server import serve, stream_frames
from safety_systems.runtime.robot_link import ModelRobot
from safety_systems.runtime.run_log_pipe import RunLogPipe
from safety_systems.runtime.safety_loop import SafetyLoop
from safety_systems.config.scenario import SensorConfig, load_controller_config, load_scenario
from safety_systems.diagrams.simulation import simulate
from safety_systems.sensing.run_log import read_run_log
from safety_systems.sensing.run_log_format import FORMAT_VERSION
from safety_systems.sensing.stops import STOP_REASONS
from safety_systems.config.resolved_cell import resolve

MODELS = Path(__file__).parents[2] / "models"
CSV = MODELS / "recordings" / "approach.csv"
MAPPING = MODELS / "recordings" / "approach_mapping.yaml"
SCENARIO = MODELS / "recordings" / "approach.yaml"
TRANSLATION = "translation: [0.6, -0.8, 0.0]"  # the mapping's, m
NAMED = "recording: approach.csv"  # the mapping's, relative to it
FAR = 1.0  # m farther along the cell's x (away from the robot) in :func:`_far_mapping`
PERIOD = 0.002  # s: the UR5e's control period
SLACK = 0.5  # s a tick may be late before the overrun watchdog acts, where it is not tested


def _trace(folder: Path) -> dict[str, np.ndarray]:
    """The run's /tick rows from every segment of its log, by column; stop reasons and
    segments by name ("" where none)."""
    segments = [read_run_log(p) for p in sorted(folder.glob("log-*.mcap"))]
    assert segments and all(s.finished for s in segments)
    ticks = np.concatenate([s.ticks for s in segments])
    sequence = np.concatenate([s.tick_sequence for s in segments])
    assert (sequence == np.arange(len(ticks))).all()  # every tick, in order
    out = {}
    for j, key in enumerate(segments[0].columns):
        column = ticks[:, j]
        if key == "stop_reason" or key.endswith((":nearest_true", ":nearest_measured")):
            words = STOP_REASONS if key == "stop_reason" else SEGMENT_NAMES
            out[key] = np.array([words[int(x)] if x == x else "" for x in column])
        else:
            out[key] = column
    return out


def _far_mapping(folder: Path, recording: Path = CSV) -> Path:
    """approach_mapping.yaml with the capture frame ``FAR`` m farther from the robot (see
    the module docstring), naming ``recording`` (its full path), written into ``folder``."""
    text = MAPPING.read_text()
    assert TRANSLATION in text and NAMED in text
    path = folder / "far_mapping.yaml"
    path.write_text(text.replace(TRANSLATION, f"translation: [{0.6 + FAR}, -0.8, 0.0]")
                    .replace(NAMED, f"recording: {recording}"))
    return path


def _far_scenario(folder: Path) -> Path:
    """approach.yaml on :func:`_far_mapping`, written into ``folder``."""
    text = SCENARIO.read_text()
    for name, path in (("recording: approach.csv", f"recording: {CSV}"),
                       ("mapping: approach_mapping.yaml",
                        f"mapping: {_far_mapping(folder)}")):
        assert name in text
        text = text.replace(name, path)
    path = folder / "far_approach.yaml"
    path.write_text(text)
    return path


def _run(tmp_path, params, mocap, *extra, robot="none", name="log"):
    code = main(["run", str(params), "--mocap", mocap, "--robot", robot, "--mapping",
                 str(_far_mapping(tmp_path)), "--log", str(tmp_path / name), "--quiet",
                 *extra])
    summary = json.loads((tmp_path / name / "summary.json").read_text())
    return code, _trace(tmp_path / name), summary


def _serve_in_thread(**kw) -> tuple[threading.Thread, list]:
    announced: list = []
    thread = threading.Thread(target=serve, kwargs=dict(announce=announced.append, **kw),
                              daemon=True)
    thread.start()
    while not announced:
        time.sleep(0.01)
    return thread, announced


def _as_the_run(scenario, loaded, length: float):
    """``scenario`` for ``length`` s as ``run`` runs the certified parameters ``loaded``:
    their controller and robot (kinematic: the model robot follows the path exactly),
    the capture at their sensor's rate and latency, no noise (the stream carries the
    recording as it is)."""
    controller = loaded.controller
    return dataclasses.replace(
        scenario, duration=length, controller=controller,
        robot=dataclasses.replace(loaded.robot, mode="kinematic", cycles=scenario.robot.cycles),
        sensor=SensorConfig(rate_hz=controller.sensor.rate_hz, noise_std=0.0,
                            latency=controller.sensor.latency))


def test_natnet_packets_over_loopback_carry_the_recording(tmp_path):
    """Real NatNet-format UDP datagrams on 127.0.0.1, read by the natnet library: every
    body at the recording's position (float32), its gap flagged untracked; through the
    mapping, the recording's cell-frame truth."""
    rec = read_recording(CSV)
    thread, announced = _serve_in_thread(rec=rec, rate=20.0, start=5.8, duration=0.8,
                                         linger=0.2)
    port = int(announced[0].split()[1])
    source = NatNetSource(MocapAddress("natnet", "127.0.0.1", port, "127.0.0.1"),
                          time.monotonic)
    source.connect()
    frames, deadline = [], time.monotonic() + 5.0
    while len(frames) < 17 and time.monotonic() < deadline:
        time.sleep(0.01)
        frames += source.poll()
    source.close()
    thread.join(timeout=5.0)
    assert len(frames) == 17 and source.bad_packets == 0
    taus, p, _, tracked = stream_frames(rec, 20.0, 5.8, 17)
    mapping = load_mapping(MAPPING)
    bodies = BodyMap(mapping)
    truth = recorded_bodies(rec, mapping, find_operator(mapping, "", "name"))
    for f, (_, frame) in enumerate(frames):
        assert frame.suffix.timestamp == pytest.approx(taus[f], abs=1e-12)
        assert [b.id_num for b in frame.rigid_bodies] == [1, 2, 3]
        got = np.array([b.pos for b in frame.rigid_bodies])
        flags = np.array([b.tracking_valid for b in frame.rigid_bodies])
        np.testing.assert_array_equal(flags, tracked[f] > 0.5)
        np.testing.assert_allclose(got[flags], p[f][flags].astype(np.float32), rtol=0, atol=0)
        z, valid, ids = bodies.entries(frame.rigid_bodies)
        np.testing.assert_array_equal(ids, [1.0, 2.0, 3.0])
        sample = round(taus[f] * 100.0)  # 20 Hz frames fall on the 100 Hz samples
        np.testing.assert_allclose(z[flags], truth.raw[sample][flags], rtol=0, atol=2e-6)
    assert not tracked[:, 1].all() and tracked[:, 0].all()  # the left glove's gap


K_TOLERANCE = 2e-3  # NatNet carries positions as float32 and the robot's path follows
#                    the jittered k (seen: up to 1e-4)


def _same_band(t_sim, k_sim, t_run, k_run, width):
    """Ticks of the run whose k lies outside simulate's k within +-width s."""
    out = []
    for t, k in zip(t_run, k_run):
        window = (t_sim >= t - width) & (t_sim <= t + width)
        if window.any() and not (k_sim[window].min() - K_TOLERANCE <= k
                                 <= k_sim[window].max() + K_TOLERANCE):
            out.append((t, k))
    return out


@pytest.mark.parametrize("config", ["iso export", "seed_estimated.yaml", "iso by_speed",
                                    "seed ssm_pfl"])
def test_a_recorded_approach_gives_simulates_k_trace(tmp_path, exported_params, config):
    """iso.yaml as exported (certified), the seed's configuration as a plain file run with
    --unverified (its verification falsifies it: check refuses it), iso.yaml with S
    by speed (the model robot's rate into the override, as the simulator's path
    follower gives it), and the seed's on the whole robot under safety.mode ssm_pfl
    (each segment's power and force limiting cap); the technician 1 m farther away in both (:func:`_far_mapping`).
    The trace has simulate's columns: per operator the nearest segment's d and S, per
    body whether it was hidden (the left glove's gap)."""
    from safety_systems.runtime.params import load_certified_params

    if config == "iso export":
        params, extra = exported_params, ()
    elif config == "iso by_speed":
        params, extra = tmp_path / "by_speed.yaml", ("--unverified",)
        text = (MODELS / "configs" / "iso.yaml").read_text()
        params.write_text(text.replace("\nsafety:\n", "\nsafety:\n  stopping: by_speed\n"))
        assert load_controller_config(params).safety.stopping == "by_speed"
    elif config == "seed ssm_pfl":  # power and force limiting's caps, on the whole robot
        params, extra = tmp_path / "pfl.yaml", ("--unverified",)
        text = (MODELS / "configs" / "seed_estimated.yaml").read_text()
        params.write_text(text.replace("robot_geometry: tool_point", "robot_geometry: capsules")
                          .replace("\nsafety:\n", "\nsafety:\n  mode: ssm_pfl\n"))
        assert load_controller_config(params).safety.mode == "ssm_pfl"
    else:
        params, extra = MODELS / "configs" / config, ("--unverified",)
    loaded = load_certified_params(params, unverified=True)
    controller = loaded.controller
    start, length = 2.0, 6.0
    scenario = load_scenario(_far_scenario(tmp_path))
    scenario.operators[0].start = start
    sim = simulate(_as_the_run(scenario, loaded, length))
    k_sim = sim["override.path_speed_commanded"][:, 0]
    code, trace, summary = _run(tmp_path, params,
                                f"replay://{CSV}?start={start}&duration={length}",
                                "--max-overrun", str(SLACK), *extra)
    assert code == 0 and summary["end"] == "duration"
    assert summary["frames"] == round(length * controller.sensor.rate_hz) + 1
    # The run's clock is put on the scenario's by the first frame's capture time (the
    # recording time ``start``, which the scenario plays at t = 0).
    first = np.flatnonzero(np.isfinite(trace["frame_time"]))[0]
    assert trace["frames"][first] == 1  # no burst of queued frames at the start
    t0 = trace["frame_time"][first]
    t_run = trace["time"] - t0
    inside = (t_run >= 0.0) & (t_run <= length)
    assert inside.sum() > 0.9 * length / PERIOD
    assert 0.0 < k_sim.mean() < 1.0 and len(set(np.round(k_sim, 3))) >= 2  # k changes
    # Up to timing jitter of one frame (1 / rate), and whatever this machine added: the
    # run is real time, so on a loaded machine its ticks and frames come late; the band
    # widens by the lateness the trace itself records, no more (0 on an idle machine).
    period = 1.0 / controller.sensor.rate_hz
    frame_age = t_run[inside] - (trace["frame_time"][inside] - t0)
    late = max(0.0, np.nanmax(frame_age) - controller.sensor.latency - period)
    width = period + late + max(0.0, np.nanmax(trace["tick_late"][inside]))
    assert _same_band(sim.time, k_sim, t_run[inside], trace["k"][inside], width) == []
    # Not a band so wide that it holds anything: the run's k spends as long at 0.
    stopped_sim = np.mean(k_sim == 0.0)
    stopped_run = np.mean(trace["k"][inside] == 0.0)
    assert abs(stopped_sim - stopped_run) < 0.05
    # Measured over the whole operator: the nearest segment named, its d and S given
    # where the technician is tracked; the glove's gap is its own body's, hidden.
    nearest = set(trace["technician:nearest_measured"][inside])
    assert nearest - {""} <= set(SEGMENT_NAMES) and len(nearest - {""}) >= 2
    seen = trace["technician:nearest_measured"] != ""
    assert np.isfinite(trace["technician:d_measured"][seen]).all()
    assert np.isfinite(trace["technician:S"][seen]).all()
    assert np.isnan(trace["technician:d_true"]).all()  # not known live
    gap = trace["technician/left_glove:hidden"] > 0.5
    assert gap[inside].any() and not (trace["technician/right_glove:hidden"] > 0.5).any()
    assert summary["hidden_time"]["technician/left_glove"] == pytest.approx(
        gap.sum() * PERIOD)


def test_a_runs_log_replayed_by_simulate_gives_the_k_the_run_commanded(tmp_path,
                                                                         exported_params):
    """A live run is a recording: its log's first segment, named as a scenario's
    recorded operator (with the run's own mapping), replays through simulate's whole
    diagram and gives the k the run commanded, within one frame (and the lateness the
    run itself records); the log holds every frame the run counted, once."""
    from safety_systems.runtime.params import load_certified_params

    start, length = 2.0, 6.0
    code, trace, summary = _run(tmp_path, exported_params,
                                f"replay://{CSV}?start={start}&duration={length}",
                                "--max-overrun", str(SLACK))
    assert code == 0 and summary["end"] == "duration"
    segment = read_run_log(tmp_path / "log" / "log-0000.mcap")
    assert segment.finished and len(segment.frames) == summary["frames"]
    np.testing.assert_array_equal(segment.frame_sequence, np.arange(summary["frames"]))
    text = SCENARIO.read_text()
    for name, path in (("recording: approach.csv", f"recording: {segment.file}"),
                       ("mapping: approach_mapping.yaml",
                        f"mapping: {_far_mapping(tmp_path, segment.file)}")):
        assert name in text
        text = text.replace(name, path)
    (tmp_path / "replay.yaml").write_text(text)
    loaded = load_certified_params(exported_params)
    controller = loaded.controller
    sim = simulate(_as_the_run(load_scenario(tmp_path / "replay.yaml"), loaded, length))
    k_sim = sim["override.path_speed_commanded"][:, 0]
    assert 0.0 < k_sim.mean() < 1.0 and len(set(np.round(k_sim, 3))) >= 2  # k changes
    t0 = segment.frames[0, 1]  # the first frame's capture time: the recording's time 0
    t_run = trace["time"] - t0
    inside = (t_run >= 0.0) & (t_run <= length - 0.1)
    period = 1.0 / controller.sensor.rate_hz
    frame_age = t_run[inside] - (trace["frame_time"][inside] - t0)
    late = max(0.0, np.nanmax(frame_age) - controller.sensor.latency - period)
    width = period + late + max(0.0, np.nanmax(trace["tick_late"][inside]))
    assert _same_band(sim.time, k_sim, t_run[inside], trace["k"][inside], width) == []
    assert abs(np.mean(k_sim == 0.0) - np.mean(trace["k"][inside] == 0.0)) < 0.05


def _iso_timeout() -> float:
    return resolve(load_controller_config(MODELS / "configs" / "iso.yaml")).frame_timeout


def test_the_stream_stopping_gives_k_0_within_a_control_period(tmp_path, exported_params):
    code, trace, _ = _run(tmp_path, exported_params, f"replay://{CSV}?stop=1.0&duration=2.0",
                          "--max-overrun", str(SLACK))
    assert code == 0
    age = trace["time"] - trace["frame_time"]
    stale = ~(age <= _iso_timeout())
    moving_before = (trace["k"] > 0) & ~stale
    assert moving_before.any()
    after = trace["time"] > trace["time"][moving_before].max()
    assert stale[after].all()  # it never came back
    assert (trace["k"][stale] == 0.0).all()
    assert set(trace["stop_reason"][stale & after]) == {"stale_frame"}
    # The first stale tick is the first tick due past the frame's timeout: its due time
    # (its start less its own lateness, which the overrun watchdog bounds and this
    # test does not: a loaded machine delays a whole tick) within a period of it.
    first = np.flatnonzero(stale & after)[0]
    last_good = trace["frame_time"][first]
    due = trace["time"][first] - trace["tick_late"][first]
    assert due - (last_good + _iso_timeout()) <= PERIOD + 1e-6
    assert trace["time"][first - 1] - last_good <= _iso_timeout()


def test_a_garbage_packet_gives_k_0_at_once_until_a_good_frame(tmp_path, exported_params):
    code, trace, summary = _run(tmp_path, exported_params, f"replay://{CSV}?garbage=1.0"
                                "&duration=2.0", "--max-overrun", str(SLACK))
    assert code == 0 and summary["bad_packets"] >= 1
    first = np.flatnonzero(np.diff(trace["bad_packets"]) > 0)[0] + 1
    assert trace["k"][first - 1] > 0.0  # moving before it
    assert trace["k"][first] == 0.0 and trace["stop_reason"][first] == "bad_packet"
    # Back once the next good frame came (frames count up after the garbage).
    later = np.flatnonzero(trace["frames"] > trace["frames"][first])[0]
    assert trace["stop_reason"][later] != "bad_packet"
    assert (trace["k"][first:later] == 0.0).all()


def _flipped_bvh(path: Path, frames: int = 80, extra_joints: int = 70) -> None:
    """A BVH at 20 Hz in cm: an operator standing, its right arm flipped by 180 deg for
    the one frame at t = 2.0 s (the hand 1.6 m out and back: 32 m/s), and
    ``extra_joints`` unmapped joints (more bodies than a recording may hold)."""
    def joint(name, offset, child):
        return (f"JOINT {name}\n{{\nOFFSET {offset}\nCHANNELS 3 Zrotation Xrotation "
                f"Yrotation\n{child}\n}}")
    end = "End Site\n{\nOFFSET 0.0 0.0 10.0\n}"
    joints = [joint("Head", "0.0 0.0 70.0", end),
              joint("RightShoulder", "0.0 -20.0 50.0", joint("RightHand", "0.0 -60.0 0.0", end))]
    joints += [joint(f"Extra{i}", "0.0 0.0 1.0", end) for i in range(extra_joints)]
    rows = [f"0.0 250.0 100.0 0 0 0 0 0 0 {180.0 if f == 40 else 0.0} 0 0 0 0 0"
            + " 0 0 0" * extra_joints for f in range(frames)]
    path.write_text("HIERARCHY\nROOT Hips\n{\nOFFSET 0.0 0.0 0.0\nCHANNELS 6 Xposition "
                    "Yposition Zposition Zrotation Xrotation Yrotation\n" + "\n".join(joints)
                    + f"\n}}\nMOTION\nFrames: {frames}\nFrame Time: 0.05\n"
                    + "\n".join(rows) + "\n")


def test_a_capture_glitch_replayed_live_is_gated_like_any_outlier(tmp_path, exported_params,
                                                                    capsys):
    """A BVH joint flipped for one frame, streamed as live NatNet (ids from the mapping,
    the file has none; only the mapped joints read, though the file holds more than a
    recording may): the reader's warning names it, and live the tracker's gate rejects
    that frame, a protective stop that ends with the next clean frame."""
    _flipped_bvh(tmp_path / "flip.bvh")
    (tmp_path / "map.yaml").write_text(
        "capture_to_cell: {up_axis: z}\nunits: cm\noperators:\n- name: a\n  bodies:\n"
        "  - {recorded: RightHand, name: hand, point: hand_right, streaming_id: 1, "
        "at_point: true}\n"  # (a BVH joint is the body point itself)
        "  - {recorded: Head, name: head, point: head, streaming_id: 2, at_point: true}\n")
    code = main(["run", str(exported_params), "--mocap",
                 f"replay://{tmp_path / 'flip.bvh'}?duration=3.5", "--robot", "none",
                 "--mapping", str(tmp_path / "map.yaml"), "--log", str(tmp_path / "log"),
                 "--quiet", "--max-overrun", str(SLACK)])
    err = capsys.readouterr().err
    assert code == 0
    assert "warning: " in err and "RightHand: 1 sample(s) from t = 2 s read as untracked" in err
    trace = _trace(tmp_path / "log")
    summary = json.loads((tmp_path / "log" / "summary.json").read_text())
    assert summary["frames"] >= 60 and summary["protective_stops"]["gate"]["count"] == 1
    # the summary names every input it read, with its SHA-256
    inputs = summary["provenance"]["inputs"]
    for path in (exported_params, exported_params.parent / "certificate.json",
                 tmp_path / "map.yaml", tmp_path / "flip.bvh"):
        assert len(inputs[str(path)]) == 64, path
    rejected = np.flatnonzero(np.diff(trace["rejected_gate"]) > 0) + 1
    assert rejected.size == 1
    first = rejected[0]
    assert trace["stop_reason"][first] == "gate" and trace["k"][first] == 0.0
    assert trace["frames"][first] == 41  # the frame at t = 2.0 s (frames count from 1)
    later = np.flatnonzero(trace["frames"] > trace["frames"][first])[0]
    assert trace["stop_reason"][later] != "gate"
    assert (trace["stop_reason"][first:later] == "gate").all()


def test_a_late_frame_is_stale_and_does_not_restart_the_robot(tmp_path, exported_params):
    code, trace, _ = _run(tmp_path, exported_params, f"replay://{CSV}?late=1.0:0.32"
                          "&duration=2.0", "--max-overrun", str(SLACK))
    assert code == 0
    timeout = _iso_timeout()
    age = trace["time"] - trace["frame_time"]
    stale = ~(age <= timeout)
    assert (trace["k"][stale] == 0.0).all() and stale.any()
    # The late frame was processed (frames counted) while it was already stale: k
    # stayed 0 from its arrival to the next frame.
    arrivals = np.flatnonzero(np.diff(trace["frames"]) > 0) + 1
    gaps = np.diff(trace["time"][arrivals])
    late = arrivals[np.argmax(gaps) + 1]  # the frame after the longest silence
    assert age[late] > timeout and trace["k"][late] == 0.0
    nxt = arrivals[arrivals > late][0]
    assert (trace["k"][late:nxt] == 0.0).all()
    assert trace["k"][nxt:].max() > 0.0  # a fresh frame lets it go again


class _Faulty(ModelRobot):
    """A model robot whose ``read`` sleeps once (an overrun) or raises (an error)."""

    def __init__(self, *args, sleep_at=None, raise_at=None):
        super().__init__(*args)
        self.reads, self.sleep_at, self.raise_at, self.commands = 0, sleep_at, raise_at, []

    def read(self):
        self.reads += 1
        if self.reads == self.sleep_at:
            time.sleep(0.03)
        if self.reads == self.raise_at:
            raise ZeroDivisionError("injected")
        return super().read()

    def command(self, k):
        self.commands.append(k)
        super().command(k)


def _live(folder, robot_kw, duration=1.5):
    """run_live itself (not the command line) on a faulty model robot; (its result, the
    robot, the log's ticks by column)."""
    config = load_controller_config(MODELS / "configs" / "iso.yaml")
    mapping = load_mapping(MAPPING)
    thread, announced = _serve_in_thread(rec=read_recording(CSV), rate=20.0,
                                         duration=duration + 0.5, linger=0.2)
    source = NatNetSource(MocapAddress("natnet", "127.0.0.1", int(announced[0].split()[1]),
                                       "127.0.0.1"), time.monotonic)
    source.connect()
    from safety_systems.config.scenario import RobotConfig

    cell = resolve(config, RobotConfig())
    robot = _Faulty(cell, **robot_kw)
    names = [f"{o.name}/{b.name}" for o in mapping.operators for b in o.bodies]
    loop = SafetyLoop(cell, [[mapped_point(b) for b in o.bodies] for o in mapping.operators],
                      [o.name for o in mapping.operators])
    trace, columns = log_columns(loop, names, 6)
    folder.mkdir()
    log = RunLogPipe(folder, width=len(columns), bodies=len(names))
    log.start(dict(fixed=dict(fields={}, names=names, period=PERIOD, log={}),
                   trace_columns=trace, columns=columns, status=False, segment_length=600.0,
                   metadata=dict(format=FORMAT_VERSION, columns=columns, bodies={})))
    result = run_live(loop, BodyMap(mapping), names, source, robot, latency=0.02, period=PERIOD,
                      log=log, options=LiveOptions(duration=duration, max_overrun=0.01))
    assert log.close({"end": result.end}) == 0
    thread.join(timeout=5.0)
    return result, robot, _trace(folder)


def test_an_overrun_and_an_error_give_k_0(tmp_path):
    result, robot, trace = _live(tmp_path / "overrun", dict(sleep_at=300))
    late = trace["tick_late"] > 0.01
    assert late.any()
    i = np.flatnonzero(late)[0]
    assert trace["k"][i] == 0.0 and trace["stop_reason"][i] == "overrun"
    assert robot.commands[-1] == 0.0
    result, robot, trace = _live(tmp_path / "error", dict(raise_at=400))
    assert result.end.startswith("exception: ZeroDivisionError")
    assert trace["stop_reason"][-1] == "exception"
    assert robot.commands[-1] == 0.0 and robot.sent == 0.0
    assert len(trace["k"]) < 420  # it stopped there


def _altered(tmp_path, exported_params, how: str) -> Path:
    import shutil

    folder = tmp_path / how
    shutil.copytree(exported_params.parent, folder)
    params = folder / "params.yaml"
    if how == "changed":  # d_min 0.3 -> 0.2: a different controller than the certified one
        text = params.read_text()
        assert "controller.safety.d_min: 0.3\n" in text
        params.write_text(text.replace("controller.safety.d_min: 0.3\n",
                                       "controller.safety.d_min: 0.2\n"))
    elif how == "no certificate":
        (folder / "certificate.json").unlink()
    elif how == "plain configuration":
        params.write_text((MODELS / "configs" / "iso.yaml").read_text())
    return params


@pytest.mark.parametrize("how", ["changed", "no certificate", "plain configuration"])
def test_run_refuses_what_check_refuses(tmp_path, exported_params, capsys, how):
    params = _altered(tmp_path, exported_params, how)
    code_check = main(["check", str(params)])
    line_check = capsys.readouterr().err.strip()
    assert code_check != 0
    argv = ["run", str(params), "--mocap", f"replay://{CSV}?duration=0.3", "--robot", "none",
            "--mapping", str(MAPPING), "--log", str(tmp_path / "log"), "--quiet"]
    code = main(argv)
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and code in (1, 2)
    if how != "plain configuration":  # check names the file's kind first for a plain one
        assert code == code_check and err.startswith(line_check)
    assert not (tmp_path / "log").exists()
    assert main(argv + ["--unverified"]) == 0
    assert "UNVERIFIED" in capsys.readouterr().err
    summary = json.loads((tmp_path / "log" / "summary.json").read_text())
    assert summary["certified"] is False


def test_run_accepts_what_check_accepts(tmp_path, exported_params, capsys):
    code, _, summary = _run(tmp_path, exported_params, f"replay://{CSV}?duration=0.3")
    assert code == 0 and summary["certified"] is True
    assert "UNVERIFIED" not in capsys.readouterr().err


@pytest.mark.parametrize("end, words", [
    ("duration", "ended when its duration was up"), ("interrupted", "interrupted (Ctrl-C)"),
    ("robot_lost: no samples for 0.02 s",
     "ended by a fault: the robot's connection was lost (no samples for 0.02 s)"),
    ("exception: ValueError: x", "ended by a fault: ValueError: x"),
])
def test_the_last_line_says_how_the_run_ended_in_words(end, words):
    from safety_systems.runtime.command import end_words

    assert end_words(end) == words


@pytest.mark.parametrize("argv, field", [
    (["--mocap", "udp://x"], "--mocap"), (["--robot", "ur-rtde://"], "--robot"),
    (["--mocap", f"replay://{CSV}?late=1"], "late"), (["--duration", "-1"], "--duration"),
    (["--priority", "100"], "--priority"), (["--priority", "-1"], "--priority"),
])
def test_bad_options_are_one_line(tmp_path, exported_params, capsys, argv, field):
    base = {"--mocap": f"replay://{CSV}", "--robot": "none"}
    base.update(dict(zip(argv[::2], argv[1::2])))
    rest = [x for kv in base.items() for x in kv]
    extra = argv if argv[0] in ("--duration", "--priority") else []
    code = main(["run", str(exported_params), *rest, "--mapping", str(MAPPING), "--log",
                 str(tmp_path / "log"), "--quiet", *extra])
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and field in err


# ------------------------------------------------------------------ the robot over RTDE

def _rtde_server(host: str, *extra) -> tuple:
    """The loopback server, its stdout read as it comes (a full pipe would block it)."""
    server = subprocess.Popen([sys.executable, str(Path(__file__).parent / "rtde_loopback.py"),
                               host, *extra], stdout=subprocess.PIPE, text=True)
    assert json.loads(server.stdout.readline()) == {"listening": True}
    lines: list = []
    reader = threading.Thread(target=lambda: lines.extend(server.stdout), daemon=True)
    reader.start()
    return server, lines, reader


def _messages(server, wait: float = 30.0) -> list[dict]:
    """What the loopback server printed: once every connection it accepted has closed
    (every package the runtime sent is then printed; at most ``wait`` s), it is ended."""
    process, lines, reader = server
    deadline = time.monotonic() + wait
    while time.monotonic() < deadline:
        said = [json.loads(line) for line in list(lines) if line.strip()]
        accepted = max((m["accepted"] for m in said if "accepted" in m), default=0)
        if sum("closed" in m for m in said) >= accepted:
            break
        time.sleep(0.05)
    process.terminate()
    process.wait(timeout=10)
    reader.join(timeout=10)
    return [json.loads(line) for line in lines if line.strip()]


def _host() -> str:
    """A loopback address of its own (ur-rtde always uses port 30004)."""
    rng = np.random.default_rng()
    return f"127.0.{rng.integers(1, 250)}.{rng.integers(2, 250)}"


def test_ur_rtde_commands_the_slider_and_leaves_it_at_0(tmp_path, exported_params):
    host = _host()
    server = _rtde_server(host)
    try:
        code, trace, summary = _run(tmp_path, exported_params, f"replay://{CSV}?duration=2.5",
                                    "--max-overrun", str(SLACK), robot=f"ur-rtde://{host}")
    finally:
        messages = _messages(server)
    assert code == 0 and summary["robot"] == f"ur-rtde://{host}"
    sliders = [m["values"]["speed_slider_fraction"] for m in messages
               if m.get("values", {}).get("speed_slider_mask") == 1]
    assert len(sliders) >= len(trace["k"])  # every tick, and at once on frames
    assert sliders[-1] == 0.0  # never left where it was
    assert max(sliders) > 0.0 and set(np.round(sliders, 9)) == set(np.round(trace["k"], 9))
    # The monitor saw the robot move: its joint positions came over RTDE.
    assert np.nanmax(trace["robot_speed"]) > 0.01


def test_the_robot_disconnecting_gives_k_0_within_a_control_period(tmp_path, exported_params):
    host = _host()
    server = _rtde_server(host, "--drop-at", "1.2")
    try:
        code, trace, summary = _run(tmp_path, exported_params, f"replay://{CSV}?duration=2.0",
                                    "--max-overrun", str(SLACK),
                                    robot=f"ur-rtde://{host}?timeout=0.02")
    finally:
        messages = _messages(server)
    dropped = next(m["dropped"] for m in messages if "dropped" in m) - summary["clock_start"]
    assert code == 3 and summary["end"].startswith("robot_lost")
    lost = trace["stop_reason"] == "robot_lost"
    first = np.flatnonzero(lost)[0]
    assert lost[first:].all() and (trace["k"][first:] == 0.0).all()
    assert (trace["k"][:first] > 0.0).any()
    # Seen at the first tick after the connection closed, or at the latest once the
    # robot's samples are a timeout old (ur-rtde notices a closed socket on its next read).
    assert trace["time"][first] - dropped <= 0.02 + PERIOD + 1e-3


def test_parameters_certified_as_passed_are_run_with_checks_warning(exported_params, capsys,
                                                                    monkeypatch):
    """check accepts a passed verdict and says it is weaker; run says so too."""
    import verification.deploy.certificate as certificate
    from safety_systems.runtime.params import load_certified_params, warn_unverified

    real = certificate.check(exported_params)
    passed = dataclasses.replace(real, verdict="passed", line=real.line + "; passed is weaker")
    monkeypatch.setattr(certificate, "check", lambda path: passed)
    params = load_certified_params(exported_params)
    assert params.certified and params.verdict == "passed"
    warn_unverified(params)
    assert capsys.readouterr().err.strip() == f"safety-systems: warning: {passed.line}"


@pytest.mark.skipif(not hasattr(os, "sched_getscheduler"), reason="no POSIX scheduling")
def test_the_loop_runs_at_real_time_priority_when_it_may_and_restores_it(tmp_path,
                                                                       exported_params):
    # The summary says which scheduling the loop had; a real-time priority is the run's
    # only (the process' policy afterwards is what it was), or its refusal is recorded.
    policy = os.sched_getscheduler(0)
    code, _, summary = _run(tmp_path, exported_params, f"replay://{CSV}?duration=0.3",
                            "--priority", "20")
    assert code == 0
    scheduling = summary["scheduling"]
    assert scheduling["policy"] in ("fifo", "normal")
    if scheduling["policy"] == "fifo":
        assert scheduling["priority"] == 20
    else:
        assert "SCHED_FIFO priority 20" in scheduling["refused"]
    assert os.sched_getscheduler(0) == policy
    code, _, summary = _run(tmp_path, exported_params, f"replay://{CSV}?duration=0.3",
                            "--priority", "0", name="normal")
    assert code == 0 and summary["scheduling"] == {"policy": "normal", "priority": 0}


def test_the_rate_bound_from_the_commands_sent_is_the_largest_k_in_the_window():
    from collections import deque

    from safety_systems.runtime.robot_link import sent_rate_bound

    window = 0.53
    sent = deque([(0.0, 0.2)])
    assert sent_rate_bound(sent, 0.5, window) == 1.0  # the slider before 0.0: unknown
    sent.extend([(0.6, 0.9), (0.7, 0.3), (1.0, 0.1)])
    assert sent_rate_bound(sent, 1.1, window) == 0.9  # 0.9 was in effect at 0.6-0.7
    assert sent_rate_bound(sent, 1.25, window) == 0.3  # 0.9 gave way at 0.7 < 1.25 - 0.53
    assert list(sent)[0] == (0.7, 0.3)  # what no later bound needs is dropped
    assert sent_rate_bound(sent, 2.0, window) == 0.1
    sent.append((2.1, math.nan))
    assert sent_rate_bound(sent, 2.2, window) == 1.0  # a NaN sent: full speed
    assert sent_rate_bound(deque(), 5.0, window) == 1.0


def test_run_refuses_a_body_whose_pivot_is_unknown_beyond_the_certified_proof(
        tmp_path, exported_params, capsys):
    """Issue 46: a mapping that neither gives a helmet's pivot nor says it is at the head's
    centre leaves its point up to 0.15 m off, which the certificate's space (pivot_offset
    0) did not allow for: run refuses it in one line naming the body's field; with the
    pivot given (or --unverified, saying so) it runs."""
    text = MAPPING.read_text()
    unknown = tmp_path / "unknown.yaml"
    unknown.write_text(text.replace("point: head, streaming_id: 3, at_point: true",
                                    "point: head, streaming_id: 3"))
    argv = ["run", str(exported_params), "--mocap", f"replay://{CSV}?duration=0.3", "--robot",
            "none", "--log", str(tmp_path / "log"), "--quiet", "--mapping"]
    assert main(argv + [str(unknown)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "operators[0].bodies[2].pivot" in err and "0.15 m" in err
    assert not (tmp_path / "log").exists()
    given = tmp_path / "given.yaml"
    given.write_text(text.replace("point: head, streaming_id: 3, at_point: true",
                                  "point: head, streaming_id: 3, pivot: [0.0, -0.12, 0.0]"))
    assert main(argv + [str(given)]) == 0
