"""The live run's log (``safety-systems run --log DIR``): its layout, written once.

A run's log is a folder of MCAP files (https://mcap.dev), one per segment of the run:
``log-0000.mcap`` holds the ticks of the loop's first ``segment_length`` seconds,
``log-0001.mcap`` the next, and so on (:func:`segment_name`). Each segment is a whole
MCAP file that Foxglove, PlotJuggler and the ROS 2 tools open: a Metadata record
:data:`METADATA_NAME` first (the run: its columns, its bodies' names, the mapping's
text, the clocks; :func:`run_metadata`), then two channels whose messages are ROS 2
``.msg`` definitions (schema encoding ``ros2msg``) serialised as CDR (little endian, the
ROS 2 encoding):

- ``/tick`` (:data:`TICK_SCHEMA`): one message per control tick, a ``float64`` per
  column: the trace's columns (``live_run.trace_header``: time, k, stop_reason, per
  operator d, S and the nearest segment, per body whether it was hidden, frame_time,
  frames, bad_packets, tick_late), then ``log_dropped``, then the robot's joints as read
  (``robot_time`` and ``q_0`` ... ``q_{n-1}``). Field names are the columns' with
  every character that a ``.msg`` field may not hold turned into ``_``
  (:func:`field_names`); the schema's comments and the metadata give the columns.
  The message's sequence number is the tick's index in the run.
- ``/frame`` (:data:`FRAME_SCHEMA`): one message per NatNet frame, as received: its
  arrival, its capture time on the runtime's clock (both in seconds since the loop
  started), its NatNet timestamp and frame number, the time from its arrival to the k
  commanded for it, and every rigid body of the frame (streaming id, position and
  orientation in the capture frame as streamed, float32 as NatNet carries them, and
  whether it was tracked). The sequence number counts the frames.

A message's log time is the wall clock (Unix time, ns) at its time in the run, so a
viewer's timeline shows when it happened. Stop reasons and segments are codes:
``sensing.stops.STOP_REASONS`` and ``cell.human_body.SEGMENT_NAMES`` by index.
"""

import json
import re
import struct

import numpy as np

FORMAT_VERSION = "1"
METADATA_NAME = "safety_systems.run"
LIBRARY = "safety-systems run log"  # the start of a segment's Header library (the writer's)
SEGMENT_PATTERN = "log-*.mcap"
TICK_TOPIC, FRAME_TOPIC = "/tick", "/frame"
TICK_SCHEMA, FRAME_SCHEMA = "safety_systems/msg/Tick", "safety_systems/msg/Frame"
SCHEMA_ENCODING, MESSAGE_ENCODING = "ros2msg", "cdr"
CDR_LE = b"\x00\x01\x00\x00"  # CDR encapsulation header: plain CDR, little endian
# /frame's scalars, in order (float64 each)
FRAME_SCALARS = ("arrival", "capture_time", "timestamp", "frame_number", "frame_to_k",
                 "bodies_received")
FRAME_ARRAYS = ("x", "y", "z", "qx", "qy", "qz", "qw")  # float32 per body
MAX_FRAME_BODIES = 100  # bodies of a frame logged (a larger frame: its first 100)
LOG_COLUMNS = ("log_dropped",)  # after the trace's columns
ROBOT_TIME = "robot_time"

FRAME_SCHEMA_TEXT = """\
# One NatNet frame as safety-systems run received it (capture frame, as streamed).
float64 arrival          # s since the loop started: when the runtime read it
float64 capture_time     # s since the loop started: its capture time on the runtime's clock
float64 timestamp        # s: the frame's NatNet timestamp (the server's clock)
float64 frame_number     # the frame's NatNet frame number
float64 frame_to_k       # s from its arrival to the k commanded for it
float64 bodies_received  # rigid bodies in the frame (the first 100 are logged)
int32[] id               # each rigid body's streaming id
float32[] x              # position, capture frame, in the stream's unit (Motive: m)
float32[] y
float32[] z
float32[] qx             # orientation, unit quaternion
float32[] qy
float32[] qz
float32[] qw
uint8[] tracked          # 1 where the body was tracked in the frame
"""


def segment_name(index: int) -> str:
    """The file name of segment ``index`` (0 first)."""
    return f"log-{index:04d}.mcap"


def tick_columns(trace: list[str], joints: int) -> list[str]:
    """The /tick message's columns: the trace's, the log's, the robot's."""
    return [*trace, *LOG_COLUMNS, ROBOT_TIME, *(f"q_{j}" for j in range(joints))]


def field_names(columns: list[str]) -> list[str]:
    """A ``.msg`` field name per column (lower case letters, digits and single ``_``
    between them, beginning with a letter), unique: ``technician:d_measured`` ->
    ``technician_d_measured``, ``op/left_glove:hidden`` -> ``op_left_glove_hidden``."""
    out: list[str] = []
    for column in columns:
        name = re.sub(r"[^a-z0-9]+", "_", column.lower()).strip("_") or "column"
        if not name[0].isalpha():
            name = "c_" + name
        base, n = name, 2
        while name in out:
            name, n = f"{base}_{n}", n + 1
        out.append(name)
    return out


def tick_schema_text(columns: list[str]) -> str:
    """The /tick message's ``.msg`` definition: a float64 per column."""
    lines = ["# One control tick of safety-systems run: the columns of its trace, the log's",
             "# count of records dropped, the robot's joints as read. NaN: no value."]
    lines += [f"float64 {f}  # {c}" for f, c in zip(field_names(columns), columns)]
    return "\n".join(lines) + "\n"


def encode_tick(row: np.ndarray) -> bytes:
    """A /tick message: the row's values as float64, CDR."""
    return CDR_LE + np.asarray(row, dtype="<f8").tobytes()


def decode_ticks(payloads: list[bytes], width: int) -> np.ndarray:
    """(T, width) rows of /tick messages; raises ValueError on a message of another
    size or encapsulation."""
    size = len(CDR_LE) + 8 * width
    if any(len(p) != size for p in payloads):
        raise ValueError(f"a /tick message of other than {size} bytes")
    raw = np.frombuffer(b"".join(payloads), dtype=np.uint8).reshape(len(payloads), size)
    if raw.size and not np.all(raw[:, :4] == np.frombuffer(CDR_LE, dtype=np.uint8)):
        raise ValueError("a /tick message not in little-endian CDR")
    return raw[:, 4:].copy().view("<f8").reshape(len(payloads), width).astype(float)


def encode_frame(scalars, ids, positions, rotations, tracked) -> bytes:
    """A /frame message: ``scalars`` (:data:`FRAME_SCALARS`), then per body its id,
    position (3,), orientation (x, y, z, w) and tracked flag (n bodies, at most
    :data:`MAX_FRAME_BODIES`). CDR: the scalars, then each sequence as its uint32
    length and its elements (every element 4-byte aligned after the scalars)."""
    n = len(ids)
    count = struct.pack("<I", n)
    columns = np.empty((7, n), dtype="<f4")
    columns[:3] = np.asarray(positions, dtype=float).reshape(n, 3).T
    columns[3:] = np.asarray(rotations, dtype=float).reshape(n, 4).T
    parts = [CDR_LE, np.asarray(scalars, dtype="<f8").tobytes(), count,
             np.asarray(ids, dtype="<i4").tobytes()]
    for column in columns:
        parts += [count, column.tobytes()]
    parts += [count, np.asarray(tracked, dtype=np.uint8).tobytes()]
    return b"".join(parts)


def decode_frame(payload: bytes) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(scalars (6,), ids (n,), columns (n, 7): x y z qx qy qz qw, tracked (n,)) of a
    /frame message; raises ValueError where it does not hold what its lengths say."""
    if payload[:4] != CDR_LE:
        raise ValueError("a /frame message not in little-endian CDR")
    at = 4 + 8 * len(FRAME_SCALARS)
    scalars = np.frombuffer(payload, "<f8", len(FRAME_SCALARS), 4).astype(float)
    out = []
    for kind in ["<i4"] + ["<f4"] * len(FRAME_ARRAYS) + ["u1"]:
        (n,), at = struct.unpack_from("<I", payload, at), at + 4
        size = np.dtype(kind).itemsize * n
        if n > MAX_FRAME_BODIES or at + size > len(payload) or (out and n != out[0].size):
            raise ValueError("a /frame message whose sequences do not fit it")
        out.append(np.frombuffer(payload, kind, n, at))
        at += size
    if at != len(payload):
        raise ValueError("a /frame message longer than its sequences")
    return (scalars, out[0].astype(int), np.stack(out[1:-1], axis=1).astype(float),
            out[-1].astype(bool))


def run_metadata(info: dict) -> dict[str, str]:
    """The Metadata record's strings: each value of ``info`` as JSON."""
    return {key: json.dumps(value) for key, value in info.items()}


def read_metadata(strings: dict[str, str]) -> dict:
    """:func:`run_metadata`'s ``info`` back; raises ValueError."""
    return {key: json.loads(value) for key, value in strings.items()}
