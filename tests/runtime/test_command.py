"""``safety-systems run`` as a person or a crash meets it: what it says while it starts,
Ctrl-C before or during the loop (k = 0, what it has written, exit 130), and a kill
(SIGKILL) that leaves every row up to at most a second before it on the disk.

Each test runs the command in a process of its own (a session of its own, as a terminal
runs it: Ctrl-C and a kill reach the runtime, its log writer and its replay server)."""

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

from safety_systems.sensing.run_log import read_run_log

from .test_live import CSV, SLACK, _far_mapping, _host, _messages, _rtde_server

WAIT = 300.0  # s: the most a wait below takes (a loaded machine); none is a figure


def children(pid: int) -> list[int]:
    with open(f"/proc/{pid}/task/{pid}/children") as f:
        return [int(x) for x in f.read().split()]


def _as_a_terminals_job() -> None:
    """Ctrl-C's disposition as a terminal's foreground job has it: a suite started in the
    background of a non-interactive shell (``cmd &``) inherits SIGINT ignored, and the
    command would then never see the Ctrl-C these tests send."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


class _Run:
    """The command in its own session, its stderr read as it comes."""

    def __init__(self, tmp_path: Path, params, mocap: str, *extra, robot: str = "none"):
        self.log = tmp_path / "log"
        self.process = subprocess.Popen(
            [sys.executable, "-m", "safety_systems.cli", "run", str(params), "--mocap", mocap,
             "--robot", robot, "--mapping", str(_far_mapping(tmp_path)), "--log",
             str(self.log), "--max-overrun", str(SLACK), *extra],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True,
            preexec_fn=_as_a_terminals_job)
        self.err = b""
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for chunk in iter(lambda: os.read(self.process.stderr.fileno(), 4096), b""):
            self.err += chunk

    def wait_for(self, condition) -> None:
        deadline = time.monotonic() + WAIT
        while not condition():
            assert self.process.poll() is None, self.text()
            assert time.monotonic() < deadline, self.text()
            time.sleep(0.02)

    def summary(self) -> dict:
        try:
            return json.loads((self.log / "summary.json").read_text())
        except (OSError, ValueError):
            return {}

    def signal(self, number: int) -> None:
        """``number`` to the command's process group, as a terminal sends Ctrl-C (its
        helpers are in groups of their own: it ends them)."""
        os.killpg(self.process.pid, number)

    def kill_all(self) -> None:
        """SIGKILL to the runtime and its helper processes, one after the other at once
        (a crash of the whole machine's worth: none finishes anything)."""
        pids = [self.process.pid] + children(self.process.pid)
        for pid in pids:
            os.kill(pid, signal.SIGKILL)

    def end(self) -> int:
        code = self.process.wait(timeout=WAIT)
        self._reader.join(timeout=WAIT)
        return code

    def text(self) -> str:
        return self.err.decode(errors="replace")


def test_a_kill_mid_run_leaves_every_row_up_to_a_second_before_it(tmp_path, exported_params):
    """SIGKILL to the runtime, its log writer and its replay server, mid-run: the log's segment,
    never finished, reads back every tick from the first, none missing, up to at most
    one second (of the run's clock) before the kill; every frame likewise."""
    run = _Run(tmp_path, exported_params, f"replay://{CSV}?duration=20", "--quiet")
    run.wait_for(lambda: run.summary().get("ticks", 0) >= 1500)  # 3 s into the loop
    time.sleep(0.4)
    killed = time.monotonic()
    run.kill_all()
    assert run.end() == -signal.SIGKILL
    summary = run.summary()
    assert summary["end"] == "running"  # the last the writer said: it was killed too
    segment = read_run_log(run.log / "log-0000.mcap")
    assert not segment.finished
    ticks = len(segment.ticks)
    np.testing.assert_array_equal(segment.tick_sequence, np.arange(ticks))
    np.testing.assert_array_equal(segment.frame_sequence, np.arange(len(segment.frames)))
    kill_time = killed - summary["clock_start"]  # on the run's clock
    assert segment.column("time")[-1] >= kill_time - 1.0
    assert summary["ticks"] >= 1500  # the summary the writer kept current until the kill


def test_ctrl_c_in_the_loop_commands_k_0_finishes_the_log_and_exits_130(tmp_path,
                                                                       exported_params):
    """Ctrl-C (SIGINT to the whole session, as a terminal sends it) while the loop runs
    a UR over RTDE: the slider's last value is 0, the segment is finished, the summary
    says interrupted, exit 130. And the run said what it did while it started."""
    host = _host()
    server = _rtde_server(host)
    try:
        run = _Run(tmp_path, exported_params, f"replay://{CSV}?duration=20",
                   robot=f"ur-rtde://{host}")
        run.wait_for(lambda: run.summary().get("ticks", 0) >= 1000)
        run.signal(signal.SIGINT)
        code = run.end()
    finally:
        messages = _messages(server)
    assert code == 130, run.text()
    sliders = [m["values"]["speed_slider_fraction"] for m in messages
               if m.get("values", {}).get("speed_slider_mask") == 1]
    assert max(sliders) > 0.0 and sliders[-1] == 0.0
    summary = run.summary()
    assert summary["end"] == "interrupted" and summary["log"]["writer"] == "closed"
    segment = read_run_log(run.log / "log-0000.mcap")
    assert segment.finished and len(segment.ticks) == summary["ticks"]
    text = run.text()
    for said in ("run: loading...", "run: reading the parameters", "run: loading the compiled "
                 "safety loop", "run: connecting...", "run: ready after",
                 "waiting for the first frame", "run: first frame after"):
        assert said in text, said
    assert "Traceback" not in text  # Ctrl-C reaches the runtime only (not its helpers)
    assert set(summary["startup"]) >= {"loading_modules", "parameters", "safety_loop",
                                        "connecting"}


def test_ctrl_c_while_connecting_writes_what_it_has_and_exits_130(tmp_path, exported_params):
    """Ctrl-C before the loop (here while the replay server starts): nothing runs, the
    summary says when it was interrupted, no segment was begun, exit 130."""
    run = _Run(tmp_path, exported_params, f"replay://{CSV}?duration=20")
    run.wait_for(lambda: b"run: connecting..." in run.err)
    run.signal(signal.SIGINT)
    assert run.end() == 130, run.text()
    summary = run.summary()
    assert summary["end"] == "interrupted while connecting" and summary["ticks"] == 0
    assert not list(run.log.glob("log-*.mcap"))
    assert "safety-systems: interrupted while connecting" in run.text()
    assert "Traceback" not in run.text()


def test_a_folder_with_an_earlier_runs_log_is_refused(tmp_path, exported_params):
    (tmp_path / "log").mkdir()
    (tmp_path / "log" / "log-0000.mcap").write_bytes(b"an earlier run")
    run = _Run(tmp_path, exported_params, f"replay://{CSV}?duration=1", "--quiet")
    assert run.end() == 2
    lines = run.text().strip().splitlines()
    assert len(lines) == 1 and "--log" in lines[0] and "log-0000.mcap" in lines[0]
    assert (tmp_path / "log" / "log-0000.mcap").read_bytes() == b"an earlier run"


def test_a_replay_streams_what_the_mapping_reads_as_untracked_as_untracked(tmp_path):
    """A Motive export whose stick_right is held still and then jumps (issue 48), mapped
    with implausible: untracked: run's replay server streams the held samples as
    untracked (the sensor did not see the body then), as simulate reads them, not as
    fresh positions where the body was not."""
    import pytest

    from safety_systems.runtime.command import replay_argv, replay_untracked
    from safety_systems.runtime.replay_server import (
        parse_args,
        stream_frames,
        streamed_recording,
    )
    from safety_systems.sensing.recording_files import read_recording
    from safety_systems.sensing.recording_mapping import load_mapping, mapped_names
    from tests.sensing.motive_holds import HOLDS, held_export

    csv = held_export(tmp_path / "held.csv")
    (tmp_path / "map.yaml").write_text(
        "capture_to_cell: {up_axis: y}\nimplausible: untracked\noperators:\n- name: w\n"
        "  bodies:\n  - {recorded: stick_right, name: r, point: hand_right}\n"
        "  - {recorded: stick_left, name: l, point: hand_left}\n")
    mapping = load_mapping(tmp_path / "map.yaml")
    rec = read_recording(csv, mapped_names(mapping))
    with pytest.warns(UserWarning, match="held still"):
        untracked = replay_untracked(rec, mapping)
    assert untracked == {"stick_right": [[a + 1, b - 1] for a, b in HOLDS]}
    rate = 1.0 / float(np.median(np.diff(rec.times)))  # a frame on every sample
    k = rec.body("stick_right")
    for runs, hidden in ((untracked, True), (None, False)):
        args = parse_args(replay_argv(str(csv), {}, rate, mapping, runs)[3:])
        streamed = streamed_recording(args)
        _, p, _, tracked = stream_frames(streamed, rate, 0.0, rec.times.size)
        for a, b in HOLDS:
            inside = slice(a + 2, b - 1)  # clear of the edges' rounding
            assert not tracked[inside, k].any() if hidden else tracked[inside, k].all()
            assert tracked[a - 1, k] and tracked[b + 1, k]
            if hidden:  # crossed on the straight line, not held at frame a's position
                assert np.all(np.linalg.norm(p[inside, k] - rec.positions[a, k], axis=1)
                              > 1e-6)
        assert tracked[:, 1 - k].all()  # stick_left, which never froze
