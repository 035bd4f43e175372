"""ROS bags, read with ``rosbags`` (no ROS installation): rosbag2 folders (SQLite 3 or
MCAP storage), bare ``.mcap`` / ``.db3`` files where ``rosbags`` reads them, and ROS 1
``.bag`` files. Every time is a message's header stamp (when it was measured), never
its arrival in the bag.

- The robot's joints (:func:`read_joint_states`): a ``sensor_msgs/msg/JointState``
  topic (empty: the bag's only one); each message's positions by joint name, the robot
  model's joints in its order (other joints, a gripper's, are ignored).
- Recorded bodies (:func:`read_bag`, a recording reader of ``recording_files``): a
  mapping's ``recorded`` names a ``geometry_msgs/msg/PoseStamped`` topic (``/...``), a
  ``tf2_msgs/msg/TFMessage`` child frame (on ``/tf``), or a ``mocap4r2_msgs`` rigid
  body (``RigidBodies`` messages, by ``rigid_body_name``). Positions in metres (ROS's
  unit, REP 103) in the frame the messages name (``header.frame_id``): every mapped body
  must be in the same one, the capture frame the mapping's ``capture_to_cell`` places
  (REP 103 frames are z up: ``up_axis: z``). Bodies of one capture share its frame
  stamps; a body absent from a frame is untracked there.
"""

import hashlib
from collections.abc import Collection
from pathlib import Path

import numpy as np

from safety_systems.files.documents import read_input
from safety_systems.files.input_error import InputError
from safety_systems.sensing.recording import MAX_SAMPLES, Recording, check_recording

MAX_BAG_BYTES = 2 * 1024 * 1024 * 1024
JOINT_STATE = "sensor_msgs/msg/JointState"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
TF_TOPICS = ("/tf", "tf")
RIGID_BODIES = "mocap4r2_msgs/msg/RigidBodies"
# mocap4r2_msgs's message definitions (github.com/MOCAP4ROS2-Project/mocap4r2_msgs, msg/):
# a bag that does not carry its types' definitions (a SQLite 3 bag of ROS 2 Humble's
# rosbag2) is read with ROS 2 Humble's types and these.
MOCAP4R2_MSGS = {
    "mocap4r2_msgs/msg/Marker": "int8 USE_NAME=0\nint8 USE_INDEX=1\nint8 USE_BOTH=2\n"
                                "int8 id_type\nint32 marker_index\nstring marker_name\n"
                                "geometry_msgs/Point translation\n",
    "mocap4r2_msgs/msg/RigidBody": "string rigid_body_name\nMarker[] markers\n"
                                   "geometry_msgs/Pose pose\n",
    RIGID_BODIES: "std_msgs/Header header\nuint32 frame_number\n"
                  "mocap4r2_msgs/RigidBody[] rigidbodies\n",
}


def typestore():
    """ROS 2 Humble's message types and mocap4r2_msgs's (``MOCAP4R2_MSGS``): the types
    of a bag that carries no definitions of its own (one that does is read with its)."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    for name, text in MOCAP4R2_MSGS.items():
        store.register(get_types_from_msg(text, name))
    return store


def bag_files(path: str | Path) -> list[Path]:
    """The files of a bag: a folder's (metadata.yaml and its storage files), or the file."""
    path = Path(path)
    if path.is_dir():
        return sorted(p for p in path.iterdir() if p.is_file())
    return [path]


def bag_digest(path: str | Path) -> str:
    """The SHA-256 of a bag's bytes (a folder's files in name order), each file read as
    an input (named among a result's inputs with its own SHA-256)."""
    h = hashlib.sha256()
    for p in bag_files(path):
        h.update(read_input(p, max_bytes=MAX_BAG_BYTES))
    return h.hexdigest()


def _open(path: str | Path):
    """An open ``rosbags`` AnyReader of ``path``; raises InputError (one line)."""
    from rosbags.highlevel import AnyReader

    path = Path(path)
    if not path.exists():
        raise InputError("path", str(path), "an existing bag (a rosbag2 folder, or an .mcap, "
                         ".db3 or .bag file)")
    reader = AnyReader([path], default_typestore=typestore())
    try:
        reader.open()
    except Exception as e:  # noqa: BLE001 - rosbags' own message, as one line
        raise InputError("<bag>", " ".join(str(e).split()) or type(e).__name__,
                         "a ROS bag rosbags reads (a rosbag2 folder with metadata.yaml, an "
                         ".mcap, .db3 or ROS 1 .bag file)", file=str(path)) from None
    return reader


def _stamp(header) -> int:
    """A header's stamp in integer nanoseconds (a float of seconds since 1970 keeps only
    about 0.2 microseconds)."""
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


def seconds(stamps) -> np.ndarray:
    """Stamps (integer ns) as seconds after the first, each the float nearest its exact
    value."""
    stamps = np.asarray(stamps, dtype=np.int64)
    return (stamps - stamps[0]) / 1e9


def _messages(reader, connections, file: str):
    try:
        for connection, _, raw in reader.messages(connections=connections):
            yield connection, reader.deserialize(raw, connection.msgtype)
    except InputError:
        raise
    except Exception as e:  # noqa: BLE001 - a message rosbags cannot read, as one line
        raise InputError("<message>", " ".join(str(e).split()) or type(e).__name__,
                         "messages rosbags can deserialize", file=file) from None


def read_joint_states(path: str | Path, joint_names: tuple[str, ...], topic: str = ""):
    """(times (T,) s, q (T, n) rad, message numbers (T,), SHA-256) of a bag's JointState
    ``topic``: header stamps, the positions of ``joint_names`` (``cell.robot_log`` makes
    its ``JointLog`` of them); raises InputError naming the bag, the message and the
    field."""
    file = str(path)
    digest = bag_digest(path)
    reader = _open(path)
    try:
        states = [c for c in reader.connections if c.msgtype == JOINT_STATE]
        topics = sorted({c.topic for c in states})
        if topic:
            states = [c for c in states if c.topic == topic]
        if not states or (not topic and len(topics) > 1):
            raise InputError("path.log.topic", topic or "empty", f"a {JOINT_STATE} topic of "
                             f"the bag ({topics or 'it has none'}; empty only when it has "
                             "one)", file=file)
        times, q, rows = [], [], []
        for k, (_, msg) in enumerate(_messages(reader, states, file), start=1):
            names = list(msg.name)
            missing = [n for n in joint_names if n not in names]
            if missing:
                raise InputError(f"message {k}: name", names, f"the robot's joints "
                                 f"{list(joint_names)} (missing {missing[0]})", file=file)
            position = np.asarray(msg.position, dtype=float)
            if position.size != len(names):
                raise InputError(f"message {k}: position", position.size, f"one position per "
                                 f"name ({len(names)})", file=file)
            times.append(_stamp(msg.header))
            q.append([position[names.index(n)] for n in joint_names])
            rows.append(k)
            if k > MAX_SAMPLES:
                raise InputError("<messages>", k, f"at most {MAX_SAMPLES:,}", file=file)
    finally:
        reader.close()
    if len(times) < 2:
        raise InputError("<messages>", len(times), f"2 or more {JOINT_STATE} messages",
                         file=file)
    return seconds(times), np.array(q, dtype=float), np.array(rows), digest


def _pose(p) -> tuple[list[float], list[float]]:
    return ([p.position.x, p.position.y, p.position.z],
            [p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w])


def _samples(reader, bodies: list[str], file: str) -> dict:
    """{body: [(stamp, frame, position, rotation), ...]} of the wanted ``bodies``."""
    wanted = set(bodies)
    out = {b: [] for b in bodies}
    conns = [c for c in reader.connections
             if (c.msgtype == POSE_STAMPED and c.topic in wanted)
             or (c.msgtype == TF_MESSAGE and c.topic in TF_TOPICS)
             or c.msgtype == RIGID_BODIES]
    for c, msg in _messages(reader, conns, file):
        if c.msgtype == POSE_STAMPED:
            out[c.topic].append((_stamp(msg.header), msg.header.frame_id, *_pose(msg.pose)))
        elif c.msgtype == TF_MESSAGE:
            for x in msg.transforms:
                if x.child_frame_id in wanted:
                    tr, ro = x.transform.translation, x.transform.rotation
                    out[x.child_frame_id].append((_stamp(x.header), x.header.frame_id,
                                                  [tr.x, tr.y, tr.z], [ro.x, ro.y, ro.z, ro.w]))
        else:
            for rb in msg.rigidbodies:
                if rb.rigid_body_name in wanted:
                    out[rb.rigid_body_name].append((_stamp(msg.header), msg.header.frame_id,
                                                    *_pose(rb.pose)))
    return out


def read_bag(path: str | Path, bodies: Collection[str] | None = None, *,
             truncated: str = "refuse") -> Recording:
    """A bag's bodies as a :class:`Recording` (see the module docstring): ``bodies`` the
    names to read (None: every PoseStamped topic); ``truncated`` is not used (a bag's
    length is its messages'). Raises InputError."""
    file = str(path)
    bag_digest(path)  # readable, and named among the inputs
    reader = _open(path)
    try:
        if bodies is None:
            bodies = sorted({c.topic for c in reader.connections if c.msgtype == POSE_STAMPED})
        bodies = list(bodies)
        if not bodies:
            raise InputError("<bodies>", "none", f"{POSE_STAMPED} topics, TF child frames or "
                             "mocap4r2 rigid bodies to read", file=file)
        found = _samples(reader, bodies, file)
    finally:
        reader.close()
    frames: dict = {}  # {frame: the first body found in it}
    for name, rows in found.items():
        if not rows:
            raise InputError("<bodies>", name, f"a {POSE_STAMPED} topic, a {TF_MESSAGE} child "
                             "frame or a mocap4r2 rigid body of the bag", file=file)
        stamps = np.array([r[0] for r in rows], dtype=np.int64)
        bad = np.flatnonzero(np.diff(stamps) <= 0)
        if bad.size:
            raise InputError(f"{name}: message {bad[0] + 2}: header.stamp",
                             int(stamps[bad[0] + 1]), f"later than the previous message's "
                             f"({int(stamps[bad[0]])} ns): a repeated or decreasing stamp",
                             file=file)
        for r in rows:
            frames.setdefault(r[1], name)
    if len(frames) != 1:
        raise InputError("header.frame_id", ", ".join(f"{b} in {f!r}" for f, b in
                                                      sorted(frames.items())),
                         "one frame for every mapped body (the capture frame the mapping's "
                         "capture_to_cell places)", file=file)
    times = np.unique(np.concatenate([np.array([r[0] for r in rows], dtype=np.int64)
                                      for rows in found.values()]))
    if times.size > MAX_SAMPLES:
        raise InputError("<frames>", times.size, f"at most {MAX_SAMPLES:,} frames", file=file)
    positions = np.full((times.size, len(bodies), 3), np.nan)
    rotations = np.full((times.size, len(bodies), 4), np.nan)
    for b, name in enumerate(bodies):
        rows = found[name]
        at = np.searchsorted(times, [r[0] for r in rows])
        positions[at, b] = [r[2] for r in rows]
        rotations[at, b] = [r[3] for r in rows]
    positions[~np.all(np.isfinite(positions), axis=2)] = np.nan
    return check_recording(Recording(file, seconds(times), tuple(bodies), (0,) * len(bodies),
                                     positions, rotations))
