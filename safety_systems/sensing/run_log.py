"""Reading a live run's log (``sensing.run_log_format``): one segment at a time, whole or
cut short, and as a recording.

A segment is read record by record from its start. A segment that its writer finished
ends with MCAP's footer; one cut short (the runtime or the machine stopped while it was
written, or a copy taken while the run goes on) ends anywhere, even inside a record: it
is read up to the last whole record before the cut (a record's length is in its first
bytes), and a chunk whose bytes are not those its checksum says (a crash can leave a
file's last blocks unwritten) ends it there too. So a reader of a log cut at any byte
gets every tick and frame of every chunk written before the cut: every record the
writer flushed, which is every record but those of its last flush period (0.25 s).
:func:`read_run_log` says whether the segment was finished (``finished``).

As a recording (:func:`read_run_recording`, the reader registry's for ``.mcap``), a
segment gives the frames its run received, as ``simulate`` and ``verify`` read a Motive
export: the rigid bodies by the names the run's mapping gave their streaming ids (its
``recorded`` names; a body of another id is ``id<N>``), positions and orientations in
the capture frame as streamed (NaN where a body was not tracked or not in the frame),
at the frames' capture times on the runtime's clock (from the segment's first frame; a
frame whose capture time is not after the one before it, which the run's tracker
refused as a bad time, is left out). Like an export cut short, a segment that was not
finished is refused unless the mapping says ``truncated: use`` (then its whole chunks
are read, with a warning line). The robot's joints as the run logged them are the
/tick rows' ``robot_time`` and ``q_*`` columns (:meth:`RunLogSegment.joints`).
"""

import dataclasses
import io
import struct
import warnings
from collections.abc import Collection
from pathlib import Path

import numpy as np
from mcap.exceptions import McapError
from mcap.records import Channel, Chunk, Header, Message, Metadata, Schema
from mcap.stream_reader import StreamReader, breakup_chunk

from safety_systems.files.documents import read_input
from safety_systems.files.input_error import InputError
from safety_systems.sensing.recording import TRUNCATED, Recording, check_recording
from safety_systems.sensing.run_log_format import (
    FORMAT_VERSION,
    FRAME_SCALARS,
    FRAME_TOPIC,
    LIBRARY,
    METADATA_NAME,
    ROBOT_TIME,
    TICK_TOPIC,
    decode_frame,
    decode_ticks,
    read_metadata,
)

MAGIC = b"\x89MCAP0\r\n"
FOOTER, CHUNK = 0x02, 0x06  # MCAP opcodes
RECORD = struct.Struct("<BQ")
MAX_SEGMENT_BYTES = 2 << 30


@dataclasses.dataclass(frozen=True, eq=False)
class RunLogSegment:
    """One segment of a run's log: the run (``info``, the Metadata record's), the /tick
    rows (``ticks`` (T, W) by ``columns``, their sequence numbers: the ticks' indices in
    the run) and the /frame messages (``frames`` (F, 6) by ``run_log_format
    .FRAME_SCALARS``, sequence numbers, and per frame its bodies: rows
    ``body_start[f]:body_start[f + 1]`` of ``ids``, ``bodies`` (x y z qx qy qz qw) and
    ``tracked``); ``finished``: whether the segment ends with its footer."""

    file: str
    info: dict
    columns: tuple[str, ...]
    ticks: np.ndarray
    tick_sequence: np.ndarray
    frames: np.ndarray
    frame_sequence: np.ndarray
    body_start: np.ndarray
    ids: np.ndarray
    bodies: np.ndarray
    tracked: np.ndarray
    finished: bool

    def column(self, name: str) -> np.ndarray:
        """A /tick column, by its name; raises KeyError."""
        return self.ticks[:, self.columns.index(name)]

    def joints(self) -> tuple[np.ndarray, np.ndarray]:
        """The robot's joints as the run read them: (its times (T,), q (T, n))."""
        q = [j for j, c in enumerate(self.columns) if c.startswith("q_")]
        return self.column(ROBOT_TIME), self.ticks[:, q]


def whole_records(data: bytes) -> tuple[int, bool]:
    """(the length of ``data``'s first bytes that hold whole records, whether they end
    with the footer and the closing magic)."""
    at = len(MAGIC)
    while at + RECORD.size <= len(data):
        opcode, length = RECORD.unpack_from(data, at)
        if opcode == 0 or at + RECORD.size + length > len(data):  # 0: no opcode (zeros)
            break
        at += RECORD.size + length
        if opcode == FOOTER:
            return at, data[at:at + len(MAGIC)] == MAGIC
    return at, False


def is_run_log(path: str | Path) -> bool:
    """Whether an MCAP file is a segment of a run's log (its Header, the record after
    the magic, names this project's writer as its library) rather than another MCAP
    file (a rosbag2 bag's, profile ``ros2``). Reads its first kilobytes only; False for
    anything that is not an MCAP file with a readable Header."""
    try:
        with open(path, "rb") as f:
            head = f.read(4096)
    except OSError:
        return False
    if head[:len(MAGIC)] != MAGIC:
        return False
    try:
        record = next(iter(StreamReader(io.BytesIO(head), skip_magic=False).records))
    except (McapError, struct.error, StopIteration, ValueError):
        return False
    return isinstance(record, Header) and record.library.startswith(LIBRARY)


def read_run_log(path: str | Path) -> RunLogSegment:
    """One segment of a run's log, whole or cut short (see the module docstring);
    raises InputError (one line) for a file that is not one."""
    return parse_run_log(read_input(path, max_bytes=MAX_SEGMENT_BYTES), str(path))


def parse_run_log(data: bytes, file: str) -> RunLogSegment:
    """:func:`read_run_log` of a segment's bytes (``file``: its name, for messages)."""
    if data[:len(MAGIC)] != MAGIC:
        raise InputError("<file>", data[:8], "a run's log segment: an MCAP file "
                         "(safety-systems run --log writes them)", file=file)
    end, finished = whole_records(data)
    info, schemas, channels = None, {}, {}
    payloads: dict[str, list] = {TICK_TOPIC: [], FRAME_TOPIC: []}
    sequences: dict[str, list] = {TICK_TOPIC: [], FRAME_TOPIC: []}

    def take(record) -> None:
        nonlocal info
        if isinstance(record, Metadata) and record.name == METADATA_NAME:
            info = read_metadata(record.metadata)
        elif isinstance(record, Schema):
            schemas[record.id] = record
        elif isinstance(record, Channel):
            channels[record.id] = record
        elif isinstance(record, Message) and record.channel_id in channels:
            topic = channels[record.channel_id].topic
            if topic in payloads:
                payloads[topic].append(record.data)
                sequences[topic].append(record.sequence)

    reader = StreamReader(io.BytesIO(data[:end + (len(MAGIC) if finished else 0)]),
                          emit_chunks=True)
    try:
        for record in reader.records:
            if isinstance(record, Chunk):
                try:
                    inner = breakup_chunk(record, validate_crc=True)
                except Exception as e:  # noqa: BLE001 - its checksum, its decompression
                    if finished:
                        raise InputError("<chunk>", str(e), "chunks whose checksums hold",
                                         file=file) from None
                    break  # a chunk a crash left unwritten: the cut is here
                for r in inner:
                    take(r)
            else:
                take(record)
    except (McapError, struct.error) as e:  # (a cut file ends inside its last record)
        if finished:
            raise InputError("<file>", str(e), "a whole MCAP file", file=file) from None
    if info is None or info.get("format") != FORMAT_VERSION:
        raise InputError("<metadata>", None if info is None else info.get("format"),
                         f"a run's log of format {FORMAT_VERSION} (a Metadata record "
                         f"{METADATA_NAME!r})", file=file)
    columns = tuple(info["columns"])
    try:
        ticks = decode_ticks(payloads[TICK_TOPIC], len(columns))
        frames = [decode_frame(p) for p in payloads[FRAME_TOPIC]]
    except (ValueError, struct.error) as e:
        raise InputError("<message>", str(e), "/tick and /frame messages of the run's "
                         "columns", file=file) from None
    counts = [f[1].size for f in frames]
    return RunLogSegment(
        file=file, info=info, columns=columns, ticks=ticks,
        tick_sequence=np.array(sequences[TICK_TOPIC], dtype=np.int64),
        frames=np.array([f[0] for f in frames]).reshape(len(frames), len(FRAME_SCALARS)),
        frame_sequence=np.array(sequences[FRAME_TOPIC], dtype=np.int64),
        body_start=np.concatenate([[0], np.cumsum(counts, dtype=np.int64)]),
        ids=np.concatenate([f[1] for f in frames] or [np.zeros(0, int)]),
        bodies=np.concatenate([f[2] for f in frames] or [np.zeros((0, 7))]),
        tracked=np.concatenate([f[3] for f in frames] or [np.zeros(0, bool)]),
        finished=finished)


def read_run_recording(path: str | Path, bodies: Collection[str] | None = None, *,
                       truncated: str = "refuse") -> Recording:
    """A segment of a run's log as a recording (see the module docstring); raises
    InputError. ``bodies``: the names to read (None: all)."""
    if truncated not in TRUNCATED:
        raise ValueError(f"truncated={truncated!r}: allowed {' | '.join(TRUNCATED)}")
    log = read_run_log(path)
    file = str(path)
    if not log.finished:
        said = (f"{file}: a run's log segment that was not finished (the run was killed, "
                f"or is still writing it): {log.frames.shape[0]} frames in its whole chunks")
        if truncated != "use":
            raise InputError("<footer>", "none", "a finished segment (the run's later "
                             "segments are; `truncated: use` in the mapping reads the whole "
                             "chunks of this one)", file=file)
        warnings.warn(said + "; those are used", stacklevel=3)
    known = {int(i): str(n) for i, n in log.info["bodies"].items()}
    ids = sorted(set(log.ids.tolist()))
    names = [known.get(i, f"id{i}") for i in ids]
    keep = [j for j, n in enumerate(names) if bodies is None or n in set(bodies)]
    if not keep:
        raise InputError("<bodies>", sorted(bodies or []), f"bodies of the run: {names}",
                         file=file)
    capture = log.frames[:, 1] if log.frames.size else np.zeros(0)
    order = np.zeros(capture.size, dtype=bool)  # frames kept: capture times increasing
    latest = -np.inf
    for f, c in enumerate(capture):
        if c > latest:
            order[f], latest = True, c
    frame_of = np.repeat(np.arange(capture.size), np.diff(log.body_start))
    column = {ids[j]: k for k, j in enumerate(keep)}
    col = np.array([column.get(int(i), -1) for i in log.ids], dtype=int)
    kept = np.flatnonzero(order)
    row_of = np.full(capture.size, -1)
    row_of[kept] = np.arange(kept.size)
    use = (col >= 0) & (row_of[frame_of] >= 0) if col.size else np.zeros(0, bool)
    positions = np.full((kept.size, len(keep), 3), np.nan)
    rotations = np.full((kept.size, len(keep), 4), np.nan)
    seen = use & log.tracked
    positions[row_of[frame_of[seen]], col[seen]] = log.bodies[seen, :3]
    rotations[row_of[frame_of[seen]], col[seen]] = log.bodies[seen, 3:]
    times = capture[kept] - (capture[kept][0] if kept.size else 0.0)
    return check_recording(Recording(
        file=file, times=times, names=tuple(names[j] for j in keep),
        ids=tuple(ids[j] for j in keep), positions=positions, rotations=rotations))
