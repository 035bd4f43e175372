"""The log writer process fed as the loop feeds it: segments by the run's time, records
on disk while the run goes, a summary kept current, a writer that falls behind or dies
counted and said, never waited for."""

import errno
import json
import os
import signal
import time

import numpy as np

from safety_systems.runtime import run_log_writer
from safety_systems.runtime.run_log_pipe import TICK, RunLogPipe
from safety_systems.runtime.run_log_writer import KILLED, LogWriter
from safety_systems.runtime.run_tally import RunTally
from safety_systems.sensing.run_log import read_run_log
from safety_systems.sensing.run_log_format import FORMAT_VERSION, encode_tick, tick_columns

TRACE = ["time", "k", "stop_reason", "frames"]
COLUMNS = tick_columns(TRACE, 1)
PERIOD = 0.002
WAIT = 60.0  # s: the most any wait below takes (a loaded machine); none is a figure


def _pipe(folder, segment_length=600.0):
    folder.mkdir(exist_ok=True)
    log = RunLogPipe(folder, width=len(COLUMNS), bodies=1)
    fixed = dict(fields={"params": "test"}, names=["op/head"], period=PERIOD, log={})
    log.start(dict(fixed=fixed, trace_columns=TRACE, columns=COLUMNS, status=False,
                   segment_length=segment_length,
                   metadata=dict(format=FORMAT_VERSION, columns=COLUMNS, bodies={})))
    log.begin({"clock_start": time.monotonic(), "unix_start_ns": time.time_ns()})
    return log


def _tick(log, i: int) -> None:
    row = np.array([PERIOD * i, 0.5, 1.0, i, 0.0, PERIOD * i, 0.1])
    log.tick(row)
    log.tally.tick(PERIOD * i, 1, 1e-5, np.zeros(4), np.zeros(1, bool))


def _wait_for(condition):
    deadline = time.monotonic() + WAIT
    while not condition():
        assert time.monotonic() < deadline, "the writer did not get there"
        time.sleep(0.05)


def _ticks(folder) -> tuple[np.ndarray, list]:
    logs = [read_run_log(p) for p in sorted(folder.glob("log-*.mcap"))]
    return np.concatenate([s.tick_sequence for s in logs]), logs


def test_segments_follow_the_runs_time_and_hold_every_tick(tmp_path):
    log = _pipe(tmp_path / "log", segment_length=1.0)
    for i in range(1750):  # 3.5 s of the run's time
        _tick(log, i)
    assert log.close({"end": "duration"}) == 0
    sequence, logs = _ticks(tmp_path / "log")
    assert [s.file.rsplit("/", 1)[1] for s in logs] == [f"log-000{i}.mcap" for i in range(4)]
    assert all(s.finished for s in logs)
    np.testing.assert_array_equal(sequence, np.arange(1750))
    for i, s in enumerate(logs):
        times = s.column("time")
        assert (times >= i).all() and (times < i + 1).all()
        assert s.info["segment"] == i and s.info["columns"] == COLUMNS
    figures = log.tally.log_figures()
    assert figures["writer"] == "closed" and figures["segments"] == 4
    assert figures["ticks_written"] == 1750 and figures["dropped_ticks"] == 0
    assert figures["bytes"] == sum(os.path.getsize(s.file) for s in logs)


def test_records_are_on_disk_and_the_summary_current_while_the_run_goes(tmp_path):
    """Before the run ends: the unfinished segment already holds the ticks fed (their
    chunks flushed), and summary.json says the run is going with the published count."""
    folder = tmp_path / "log"
    log = _pipe(folder)
    for i in range(500):
        _tick(log, i)
    log.publish()

    def written() -> int:
        try:
            return len(read_run_log(folder / "log-0000.mcap").ticks)
        except Exception:  # noqa: BLE001 - not there yet
            return 0

    _wait_for(lambda: written() == 500)
    assert not read_run_log(folder / "log-0000.mcap").finished
    _wait_for(lambda: (folder / "summary.json").exists())
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["end"] == "running" and summary["ticks"] == 500
    assert summary["params"] == "test"
    assert log.close({"end": "duration"}) == 0
    assert read_run_log(folder / "log-0000.mcap").finished


def test_a_runtime_that_dies_leaves_a_finished_segment_and_a_summary_that_says_so(tmp_path):
    folder = tmp_path / "log"
    log = _pipe(folder)
    for i in range(300):
        _tick(log, i)
    log.publish()
    log.process.stdin.close()  # as the runtime's death closes it: no last record
    assert log.process.wait(timeout=WAIT) == 0
    segment = read_run_log(folder / "log-0000.mcap")
    assert segment.finished and len(segment.ticks) == 300
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["end"] == KILLED and summary["ticks"] == 300


def test_a_writer_that_falls_behind_costs_counted_records_never_a_wait(tmp_path):
    """The writer stopped (as a stalled disk would stop it): the loop's writes never
    wait; what the pipe cannot hold is dropped and counted, and the log's sequence
    numbers show exactly those gaps."""
    folder = tmp_path / "log"
    log = _pipe(folder)
    os.kill(log.process.pid, signal.SIGSTOP)
    try:
        i = 0
        while log.dropped_ticks < 100:
            _tick(log, i)
            i += 1
            assert i < 10_000_000
    finally:
        os.kill(log.process.pid, signal.SIGCONT)
    for _ in range(200):
        _tick(log, i)
        i += 1
    assert log.close({"end": "duration"}) == 0
    sequence, _ = _ticks(folder)
    assert len(sequence) == i - log.dropped_ticks
    assert log.tally.log_figures()["dropped_ticks"] == log.dropped_ticks
    gaps = np.diff(sequence) - 1
    assert gaps.sum() + (i - 1 - sequence[-1]) == log.dropped_ticks
    assert len(log.tally.log_figures()) and log.pipe_bytes >= 65536


def test_a_failed_write_counts_its_records_as_lost_and_a_new_segment_follows(tmp_path,
                                                                             monkeypatch,
                                                                             capsys):
    """A full disk: the segment being written ends, one warning says so, its records
    not yet flushed and those that come until a new segment begins are counted as lost,
    and the next segment is tried (here at once: the retry's wait is taken as passed)."""
    tally = RunTally(1, len(COLUMNS))
    start = dict(columns=COLUMNS, segment_length=600.0, shared_tally=False,
                 metadata=dict(format=FORMAT_VERSION, columns=COLUMNS, bodies={}))
    writer = LogWriter(tmp_path, start, tally)
    writer.begin = {"clock_start": time.monotonic(), "unix_start_ns": 0}
    for i in range(10):
        writer.record(TICK, encode_tick(np.full(len(COLUMNS), PERIOD * i)))

    def full(*args):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(run_log_writer.Segment, "add", full)
    for i in range(10, 15):
        writer.record(TICK, encode_tick(np.full(len(COLUMNS), PERIOD * i)))
    monkeypatch.undo()
    writer.failed_at = -np.inf  # the retry's wait has passed
    for i in range(15, 20):
        writer.record(TICK, encode_tick(np.full(len(COLUMNS), PERIOD * i)))
    writer.finish_segment()
    err = capsys.readouterr().err
    assert err.count("cannot be written") == 1 and "No space left on device" in err
    figures = tally.log_figures()
    assert figures["lost_to_errors"] == 15 and figures["ticks_written"] == 5
    second = read_run_log(tmp_path / "log-0001.mcap")
    assert second.finished
    np.testing.assert_array_equal(second.tick_sequence, np.arange(15, 20))
    first = read_run_log(tmp_path / "log-0000.mcap")  # abandoned before its first flush
    assert not first.finished and len(first.ticks) == 0


def test_a_run_closed_before_its_loop_began_writes_no_segment(tmp_path):
    """The runtime stopped between describing the run and starting its loop (an error,
    Ctrl-C): the writer ends quietly, with no segment."""
    folder = tmp_path / "log"
    folder.mkdir()
    log = RunLogPipe(folder, width=len(COLUMNS), bodies=1)
    log.start(dict(fixed=dict(fields={}, names=["op/head"], period=PERIOD, log={}),
                   trace_columns=TRACE, columns=COLUMNS, status=False, segment_length=600.0,
                   metadata=dict(format=FORMAT_VERSION, columns=COLUMNS, bodies={})))
    assert log.close({"end": "exception: before the loop"}) == 0
    assert not list(folder.glob("log-*.mcap"))
