"""The log writer of ``safety-systems run``: a process of its own that writes the run's
log (``sensing.run_log_format``) as the loop feeds it (``run_log_pipe``).

It reads the loop's records from its standard input and writes them to the segment of
their time in the run (``log-0000.mcap``: the first ``segment_length`` seconds, then
the next file, and so on). Every :data:`FLUSH_PERIOD` it closes the chunk in progress
(compressed with zstd) and hands it to the operating system: from then on a crash of
the runtime, or a kill, does not lose it. Every :data:`SYNC_PERIOD` it syncs the file to
the device (fsync): from then on a power cut does not lose it either. A segment ends
with MCAP's summary and index (a file that every MCAP tool opens at once); a segment cut
short by a crash or a kill has every chunk written before the cut and no index
(``sensing.run_log`` reads it; Foxglove opens it by reading it whole; ``mcap recover``,
MCAP's command-line tool, writes its index).

Every :data:`SUMMARY_PERIOD` it rewrites summary.json (atomically) from the numbers the
loop keeps in memory shared with it (``run_tally``), so a run that is still going, or
was killed, has a summary at most that old; and it prints the status line (the loop
does no console output while it runs). When its input ends without the loop's last
record (the runtime was killed or crashed), it finishes the segment and writes
summary.json saying so. It ignores Ctrl-C, which is the runtime's to handle: the
runtime commands k = 0, then closes the log, and this process finishes the segment.
A write that fails (a full disk) ends that segment: its records are counted as lost
(``log.lost_to_errors``), a warning says so once, and a new segment is tried every
:data:`RETRY_PERIOD`.

Run as ``python -m safety_systems.runtime.run_log_writer FOLDER TALLY_FD TALLY_BYTES``.
"""

import collections
import json
import math
import mmap
import os
import select
import signal
import struct
import sys
import threading
import time
from pathlib import Path

from mcap.writer import CompressionType, Writer

from safety_systems.files.output_files import write_json
from safety_systems.runtime.run_log_pipe import BEGIN, CLOSE, FRAME, HEADER, START, TICK
from safety_systems.runtime.run_status import show_status
from safety_systems.runtime.run_tally import (
    WRITER_BYTES,
    WRITER_DONE,
    WRITER_ERRORS,
    WRITER_FAILED,
    WRITER_FRAMES,
    WRITER_LAG_MAX,
    WRITER_ROWS,
    WRITER_SEGMENTS,
    WRITER_STATE,
    RunTally,
    run_summary,
)
from safety_systems.sensing.run_log_format import (
    FORMAT_VERSION,
    FRAME_SCHEMA,
    FRAME_SCHEMA_TEXT,
    FRAME_TOPIC,
    LIBRARY,
    MESSAGE_ENCODING,
    METADATA_NAME,
    SCHEMA_ENCODING,
    TICK_SCHEMA,
    TICK_TOPIC,
    run_metadata,
    segment_name,
    tick_schema_text,
)

FLUSH_PERIOD = 0.25  # s: a chunk reaches the operating system at least this often
SYNC_PERIOD = 1.0  # s: the segment is synced to the device at least this often
SUMMARY_PERIOD = 1.0  # s between rewrites of summary.json
RETRY_PERIOD = 1.0  # s between tries at a new segment after a failed write
CHUNK_BYTES = 64 << 20  # chunks are closed at each flush; this only bounds a burst
READ_BYTES = 1 << 20
TIME = struct.Struct("<d")  # a message's first field, after CDR's header
KILLED = ("the runtime ended without closing its log (killed, or it crashed): the "
          "figures are the last it published, at most a second old")


class Segment:
    """One MCAP file of the log (see the module docstring)."""

    def __init__(self, path: Path, info: dict, columns: list[str]):
        self.path = path
        self.file = open(path, "xb")
        self.writer = Writer(self.file, chunk_size=CHUNK_BYTES,
                             compression=CompressionType.ZSTD)
        self.writer.start(profile="", library=f"{LIBRARY} {FORMAT_VERSION}")
        self.writer.add_metadata(METADATA_NAME, run_metadata(info))
        tick = self.writer.register_schema(TICK_SCHEMA, SCHEMA_ENCODING,
                                           tick_schema_text(columns).encode())
        frame = self.writer.register_schema(FRAME_SCHEMA, SCHEMA_ENCODING,
                                            FRAME_SCHEMA_TEXT.encode())
        self.channels = {
            TICK: self.writer.register_channel(TICK_TOPIC, MESSAGE_ENCODING, tick,
                                               {"columns": json.dumps(columns)}),
            FRAME: self.writer.register_channel(FRAME_TOPIC, MESSAGE_ENCODING, frame)}
        self.file.flush()
        _sync_folder(path.parent)

    def add(self, kind: int, payload: bytes, log_time: int, sequence: int) -> None:
        self.writer.add_message(self.channels[kind], log_time, payload, log_time,
                                sequence & 0xFFFFFFFF)

    def flush(self) -> None:
        self.writer.flush()

    def sync(self) -> None:
        os.fsync(self.file.fileno())

    def finish(self) -> int:
        """Writes the summary and index, syncs and closes; the file's size."""
        self.writer.finish()
        self.file.flush()
        self.sync()
        self.file.close()
        return self.path.stat().st_size

    def abandon(self) -> None:
        try:
            self.file.close()
        except OSError:
            pass


def _sync_folder(folder: Path) -> None:
    """Syncs a folder's entries (a new file's name survives a power cut)."""
    fd = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


class LogWriter:
    """The process's state: the run's description (``start``, ``begin``), the segment
    being written, the clocks of the next flush, sync and summary."""

    def __init__(self, folder: Path, start: dict, tally: RunTally):
        self.folder, self.start, self.tally = folder, start, tally
        self.columns = start["columns"]
        self.length = float(start["segment_length"])
        self.segment: Segment | None = None
        self.index = -1  # the segment's index (its time: index * length onward)
        self.sequence = {TICK: 0, FRAME: 0}
        self.bytes_done = 0  # of the finished segments
        self.unflushed = math.inf  # the loop time of the oldest record not yet flushed
        self.pending = {TICK: 0, FRAME: 0}  # records added since the last flush
        self.failed_at = -math.inf
        self.warned = False
        self.begin: dict = {}
        self.closed = False

    def now(self) -> float:
        """The loop's time now (s since it started)."""
        return time.monotonic() - self.begin["clock_start"]

    def record(self, kind: int, payload: bytes) -> None:
        t = TIME.unpack_from(payload, 4)[0]  # the tick's time, or the frame's arrival
        index = max(0, int(t // self.length)) if math.isfinite(t) else max(self.index, 0)
        if index > self.index or self.segment is None:
            self.open(max(index, self.index))
        self.sequence[kind] += 1
        if self.segment is None:
            self.tally.count[WRITER_ERRORS] += 1
            return
        log_time = self.begin["unix_start_ns"] + int(round(
            (t if math.isfinite(t) else self.now()) * 1e9))
        try:
            self.segment.add(kind, payload, max(log_time, 0), self.sequence[kind] - 1)
        except OSError as e:
            self.fail(e)
            self.tally.count[WRITER_ERRORS] += 1
            return
        self.tally.count[WRITER_ROWS if kind == TICK else WRITER_FRAMES] += 1
        self.pending[kind] += 1
        if math.isfinite(t):
            self.unflushed = min(self.unflushed, t)

    def open(self, index: int) -> None:
        """Ends the segment in progress and begins segment ``index`` (after a failure:
        at most every :data:`RETRY_PERIOD`)."""
        if self.segment is not None:
            self.finish_segment()
        if time.monotonic() - self.failed_at < RETRY_PERIOD:
            return
        self.index = index
        info = dict(self.start["metadata"], **self.begin, segment=index,
                    segment_start=index * self.length)
        try:
            self.segment = Segment(self.folder / segment_name(index), info, self.columns)
        except OSError as e:
            self.fail(e)
            return
        self.tally.count[WRITER_SEGMENTS] += 1

    def finish_segment(self) -> None:
        segment, self.segment = self.segment, None
        self.flush(segment)
        try:
            self.bytes_done += segment.finish()
        except OSError as e:
            self.fail(e)
            segment.abandon()
        self.tally.count[WRITER_BYTES] = self.bytes_done

    def fail(self, error: OSError) -> None:
        """A write failed: the segment ends there, and what it had not flushed is lost."""
        if self.segment is not None:
            self.segment.abandon()
            self.segment = None
        self.tally.count[WRITER_ROWS] -= self.pending[TICK]
        self.tally.count[WRITER_FRAMES] -= self.pending[FRAME]
        self.tally.count[WRITER_ERRORS] += self.pending[TICK] + self.pending[FRAME]
        self.pending = {TICK: 0, FRAME: 0}
        self.index += 1  # a new segment gets a new file
        self.failed_at = time.monotonic()
        if not self.warned:
            self.warned = True
            print(f"\nsafety-systems: warning: the run's log cannot be written in "
                  f"{self.folder} ({error.strerror or error}): its records are counted as "
                  "lost until a new segment can be written", file=sys.stderr, flush=True)

    def flush(self, segment: Segment | None = None) -> None:
        segment = segment or self.segment
        if segment is None:
            return
        try:
            segment.flush()
        except OSError as e:
            self.fail(e)
            return
        if math.isfinite(self.unflushed):
            age = self.now() - self.unflushed
            if age > self.tally.time[WRITER_LAG_MAX]:
                self.tally.time[WRITER_LAG_MAX] = age
        self.unflushed = math.inf
        self.pending = {TICK: 0, FRAME: 0}
        self.tally.count[WRITER_BYTES] = self.bytes_done + segment.file.tell()

    def sync(self) -> None:
        if self.segment is not None:
            try:
                self.segment.sync()
            except OSError as e:
                self.fail(e)

    def summary(self, end: str) -> None:
        if not self.start["shared_tally"] or not self.begin:
            return
        fixed = dict(self.start["fixed"], clock_start=self.begin["clock_start"])
        try:
            write_json(self.folder / "summary.json", run_summary(fixed, self.tally, end))
        except OSError:
            pass  # the next rewrite may succeed; the log's own figures say what failed


class _Input:
    """The loop's records from a file descriptor."""

    def __init__(self, fd: int):
        self.fd, self.buffer, self.ended = fd, bytearray(), False
        self.pending: collections.deque = collections.deque()

    def read(self, timeout: float | None) -> list[tuple[int, bytes]]:
        """The records that came within ``timeout`` s (None: until some come)."""
        if not self.pending and not self.ended:
            ready, _, _ = select.select([self.fd], [], [], timeout)
            if ready:
                data = os.read(self.fd, READ_BYTES)
                if not data:
                    self.ended = True
                self.buffer += data
        at = 0
        while len(self.buffer) - at >= HEADER.size:
            size, kind = HEADER.unpack_from(self.buffer, at)
            if len(self.buffer) - at - HEADER.size < size:
                break
            self.pending.append((kind, bytes(self.buffer[at + HEADER.size:
                                                         at + HEADER.size + size])))
            at += HEADER.size + size
        del self.buffer[:at]
        out = list(self.pending)
        self.pending.clear()
        return out

    def next(self, kind: int) -> bytes | None:
        """The next record, which must be of ``kind`` (None: the input ended, or the run
        was closed, first: it never began)."""
        while not self.pending and not self.ended:
            self.pending.extend(self.read(None))
        if not self.pending:
            return None
        k, payload = self.pending.popleft()
        if k == CLOSE:
            return None
        if k != kind:
            raise ValueError(f"record {k} where {kind} was due")
        return payload

    @property
    def done(self) -> bool:
        return self.ended and not self.pending


def main(argv: list[str] | None = None) -> int:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    folder, fd_tally, nbytes = (argv or sys.argv[1:])[:3]
    source = _Input(sys.stdin.fileno())
    payload = source.next(START)
    if payload is None:
        return 0  # the runtime ended before its loop was built: nothing to log
    start = json.loads(payload)
    fd_tally, nbytes = int(fd_tally), int(nbytes)
    bodies, width = start["tally_shape"]
    shared = mmap.mmap(fd_tally, nbytes) if fd_tally >= 0 else None
    tally = RunTally(bodies, width, shared, fresh=shared is None)
    writer = LogWriter(Path(folder), start, tally)
    payload = source.next(BEGIN)
    if payload is None:
        return 0
    writer.begin = json.loads(payload)
    done = threading.Event()
    if start["status"]:
        status = threading.Thread(target=show_status, daemon=True,
                                  args=(tally, start["trace_columns"], done))
        status.start()
    clock = time.monotonic
    next_flush = clock() + FLUSH_PERIOD
    next_sync, next_summary = clock() + SYNC_PERIOD, clock() + SUMMARY_PERIOD
    while not source.done:
        wait = max(0.0, min(next_flush, next_sync, next_summary) - clock())
        for kind, payload in source.read(wait):
            if kind in (TICK, FRAME):
                writer.record(kind, payload)
            elif kind == CLOSE:
                writer.closed = True
        now = clock()
        if now >= next_flush:
            writer.flush()
            next_flush = now + FLUSH_PERIOD
        if now >= next_sync:
            writer.sync()
            next_sync = now + SYNC_PERIOD
        if now >= next_summary:
            writer.summary("running")
            next_summary = now + SUMMARY_PERIOD
    done.set()
    if start["status"]:
        status.join(timeout=1.0)
    if writer.segment is not None:
        writer.finish_segment()
    tally.count[WRITER_STATE] = WRITER_DONE if not writer.warned else WRITER_FAILED
    if not writer.closed:
        writer.summary(KILLED)
    return 0  # (the shared block is unmapped as the process ends)


if __name__ == "__main__":
    sys.exit(main())
