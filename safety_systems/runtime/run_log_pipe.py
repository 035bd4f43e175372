"""The control loop's side of the run's log: records handed to the log writer process
(``run_log_writer``) through a pipe, without ever waiting.

The loop must not wait on a disk (a write can stall for seconds while the kernel flushes
its cache), nor on a console, nor on the writer. So the loop only copies each tick's and
each frame's record into a pipe to the writer process, whose end is non-blocking: a
record that does not fit is dropped there and then, and counted (``log_dropped`` in the
next tick's row, ``log`` in summary.json, a warning on the console); the pipe holds
:data:`PIPE_BYTES` (a few seconds of records) for the writer to catch up. A record is at
most ``PIPE_BUF`` bytes (4096 on Linux), so a write to the pipe puts all of it or none.
The counters of the summary (``run_tally``) are in memory shared with the writer, which
writes summary.json from them every second and prints the status line, so the loop
does no console or file input or output of its own while it runs.

**What fail-safe means here.** The log records what the safety function did; it is not
part of it. Nothing the loop decides depends on the log, and the robot is not stopped
for a log that falls behind or fails: a stop would make a slow disk a cause of stops
without making anyone safer, and waiting for the disk would delay the stops that do make
people safe. What fails safe is the record: a row that could not be kept is counted,
never silently missing, and every row that reached the writer is on the disk within the
flush period (a crash loses at most that) and synced within the sync period (a power
cut loses at most that).

Records: a header (payload length: uint32, kind: uint8) and the payload: :data:`START`
and :data:`BEGIN` (JSON, sent while the pipe is still blocking, before the loop
starts), :data:`TICK` and :data:`FRAME` (the /tick and /frame messages,
``sensing.run_log_format``), :data:`CLOSE` (JSON: how the run ended).
"""

import fcntl
import json
import mmap
import os
import select
import struct
import subprocess
import sys
from pathlib import Path

from safety_systems.runtime.child_process import start_without_ctrl_c
from safety_systems.runtime.run_tally import (
    LOG_DROPPED_FRAMES,
    LOG_DROPPED_TICKS,
    LOG_SENT,
    WRITER_FAILED,
    WRITER_STATE,
    RunTally,
)
from safety_systems.sensing.run_log_format import encode_frame, encode_tick

START, BEGIN, TICK, FRAME, CLOSE = range(5)
HEADER = struct.Struct("<IB")
PIPE_BUF = getattr(select, "PIPE_BUF", 4096)  # bytes a pipe writes whole
PIPE_BYTES = 4 << 20  # the pipe's capacity asked for (the kernel may give less: 1 MiB
#                      is what an unprivileged process gets; 64 KiB where it cannot ask)
F_SETPIPE_SZ, F_GETPIPE_SZ = 1031, 1032  # Linux fcntl commands
PUBLISH_EVERY = 50  # ticks between publishing the counters (0.1 s at 500 Hz)
CLOSE_WAIT = 60.0  # s to wait for the writer to finish its segment at the end


def _pipe_max() -> int:
    """The largest pipe an unprivileged process may ask for (Linux: 1 MiB by default)."""
    try:
        return int(open("/proc/sys/fs/pipe-max-size").read())
    except (OSError, ValueError):
        return 1 << 20


class RunLogPipe:
    """Starts the writer process for the log folder ``folder`` (it loads while the
    runtime connects) and feeds it: :meth:`start`, :meth:`begin`, then every tick and
    frame, then :meth:`close`. ``width``: a /tick row's columns; ``bodies``: the
    tracked bodies (the tally's)."""

    def __init__(self, folder: Path, *, width: int, bodies: int):
        self.width = width
        self.tally_bytes = RunTally.nbytes(bodies, width)
        self._fd_tally = os.memfd_create("safety-systems-tally") if hasattr(
            os, "memfd_create") else -1
        if self._fd_tally >= 0:
            os.ftruncate(self._fd_tally, self.tally_bytes)
            self._map = mmap.mmap(self._fd_tally, self.tally_bytes)
            self.tally = RunTally(bodies, width, self._map)
        else:  # no shared memory: the summary is written at the end only
            self._map = None
            self.tally = RunTally(bodies, width)
        self.process = start_without_ctrl_c(
            [sys.executable, "-m", "safety_systems.runtime.run_log_writer", str(folder),
             str(self._fd_tally), str(self.tally_bytes)],
            stdin=subprocess.PIPE, pass_fds=(self._fd_tally,) if self._fd_tally >= 0 else ())
        self._fd = self.process.stdin.fileno()
        for size in (PIPE_BYTES, _pipe_max()):
            try:
                fcntl.fcntl(self._fd, F_SETPIPE_SZ, size)
                break
            except OSError:
                pass  # above the kernel's limit for this process: the next, or the default
        try:
            self.pipe_bytes = fcntl.fcntl(self._fd, F_GETPIPE_SZ)
        except OSError:
            self.pipe_bytes = 65536
        self.sent = self.dropped_ticks = self.dropped_frames = 0
        self.writer_gone = self.started = False
        self._ticks = 0

    def start(self, info: dict) -> None:
        """The run's description (JSON: its columns, bodies, segment length, summary.json's
        fixed fields, the log's metadata; ``run_log_writer`` reads it)."""
        info = dict(info, tally_shape=[self.tally.bodies, self.width],
                    pipe_bytes=self.pipe_bytes, shared_tally=self._map is not None)
        self._blocking(START, json.dumps(info).encode())
        self.started = True

    def _blocking(self, kind: int, payload: bytes) -> None:
        os.set_blocking(self._fd, True)
        try:
            os.write(self._fd, HEADER.pack(len(payload), kind) + payload)
        except BrokenPipeError:
            self.writer_gone = True

    def begin(self, info: dict) -> None:
        """The loop starts now (``info``: its clocks); from here on nothing waits."""
        self._blocking(BEGIN, json.dumps(info).encode())
        os.set_blocking(self._fd, False)

    def _send(self, kind: int, payload: bytes) -> bool:
        if self.writer_gone:
            return False
        try:
            os.write(self._fd, HEADER.pack(len(payload), kind) + payload)
        except BlockingIOError:  # the pipe is full: the writer is behind
            return False
        except BrokenPipeError:  # the writer ended
            self.writer_gone = True
            return False
        self.sent += 1
        return True

    def tick(self, row) -> None:
        """A /tick row (``width`` values)."""
        if not self._send(TICK, encode_tick(row)):
            self.dropped_ticks += 1
        self._ticks += 1
        if self._ticks % PUBLISH_EVERY == 0:
            self.publish(row)

    def frame(self, scalars, ids, positions, rotations, tracked) -> None:
        """A /frame message's fields (``run_log_format.encode_frame``)."""
        if not self._send(FRAME, encode_frame(scalars, ids, positions, rotations, tracked)):
            self.dropped_frames += 1

    @property
    def dropped(self) -> int:
        return self.dropped_ticks + self.dropped_frames

    def publish(self, row=None) -> None:
        """The counters into the shared block (the writer reads them)."""
        t = self.tally
        t.set(LOG_SENT, self.sent)
        t.set(LOG_DROPPED_TICKS, self.dropped_ticks)
        t.set(LOG_DROPPED_FRAMES, self.dropped_frames)
        t.publish()
        if row is not None:
            t.row[:] = row

    def close(self, end: dict) -> int | None:
        """Ends the log: the last counters, then :data:`CLOSE` (how the run ended), then
        waits for the writer to finish its segment; its exit code (None if it had to be
        killed)."""
        self.publish()
        if self.started and not self.writer_gone:
            self._blocking(CLOSE, json.dumps(end).encode())
        try:
            self.process.stdin.close()
        except BrokenPipeError:
            pass
        try:
            code = self.process.wait(timeout=CLOSE_WAIT)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
            code = None
        if code != 0:
            self.tally.count[WRITER_STATE] = WRITER_FAILED
        return code

    def release(self) -> None:
        """Frees the shared block (after the last summary was taken from it)."""
        if self._map is not None:
            self.tally = RunTally(self.tally.bodies, self.tally.width, bytearray(self._map),
                                  fresh=False)  # a copy, for late readers
            self._map.close()
            os.close(self._fd_tally)
            self._map = None
