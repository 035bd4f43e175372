"""Rigid-body frames from a NatNet server (Motive, or ``replay_server``), received with
the ``natnet`` client library, and turned into the tracker's entries.

The client runs in unicast mode and is polled from the control loop: the loop waits on
the client's sockets (:meth:`NatNetSource.sockets`) until its next tick and, when a
packet comes, reads it as the library's ``update_sync`` does (which parses it and hands
each frame to :meth:`NatNetSource._on_frame` with its arrival time), but sends the
server a keep-alive once a second, not on every poll. A server speaking NatNet before
3.0 is refused when connecting (:data:`NATNET_VERSIONS`). A packet the library cannot
parse raises inside it; that is counted as a bad packet (the watchdog stops the robot
until a good frame follows).

Capture times (:class:`FrameClock`): a frame's NatNet timestamp is on the server's
clock. The runtime puts it on its own (monotonic) clock as timestamp + offset -
latency, where the offset is the smallest arrival - timestamp seen, allowed to rise by
at most ``DRIFT`` s per s (so two clocks drifting apart by up to 100 ppm are followed,
while a frame delayed in transit shows its true age) and latency is the configured
sensor latency (the quickest delivery is taken to have the latency verification
assumed). A frame that arrives late therefore carries an old capture time and the
tracker's frame-timeout rule (``tracks.tracker_fault``) treats it as stale.
"""

import dataclasses
import math
import urllib.parse

import numpy as np

from safety_systems.files.input_error import InputError
from safety_systems.sensing.pivots import body_points
from safety_systems.sensing.recording_mapping import RecordingMapping, to_cell
from safety_systems.sensing.sensor_faults import UNKNOWN_ID_BASE

DRIFT = 1e-4  # s/s: how fast the capture clock's offset may rise (100 ppm)
NATNET_PORT = 1510  # Motive's command port
# The NatNet versions whose frames the client library reads whole (Motive 2.0 on). Before
# 3.0 (Motive 1.5-1.10: NatNet 2.5-2.10) a frame carries a latency field ahead of its
# timecode that natnet 0.3.0 does not read, so every later field, the timestamp among
# them, is misread (seen on real Motive 1.x frames: 0.0, -9.3e61, -2.3e226 s).
NATNET_VERSIONS = ((3, 0), (4, 1))
KEEP_ALIVE_PERIOD = 1.0  # s: a unicast client's keep-alive to the server, at most this often


@dataclasses.dataclass(frozen=True)
class MocapAddress:
    """Where frames come from: a NatNet server, or a recording to replay over loopback
    (``replay://FILE?start=S&rate=HZ&stop=T&garbage=T&late=T:D``)."""

    kind: str  # "natnet" | "replay"
    host: str = "127.0.0.1"
    port: int = NATNET_PORT
    local: str = "127.0.0.1"
    file: str = ""
    options: tuple = ()  # (name, value) pairs of a replay


REPLAY_OPTIONS = ("start", "rate", "stop", "garbage", "late", "duration")


def parse_mocap(url: str) -> MocapAddress:
    """``natnet://HOST[:PORT][?local=IP]`` or ``replay://FILE[?options]``; raises
    InputError."""
    allowed = "natnet://HOST[:PORT][?local=IP] or replay://FILE[?start=S&rate=HZ]"
    parts = urllib.parse.urlsplit(url)
    query = urllib.parse.parse_qsl(parts.query, keep_blank_values=True)
    if parts.scheme == "natnet":
        try:
            port = parts.port or NATNET_PORT
        except ValueError:
            raise InputError("--mocap", url, allowed) from None
        if not parts.hostname or any(k != "local" for k, _ in query):
            raise InputError("--mocap", url, allowed)
        return MocapAddress("natnet", parts.hostname, port, dict(query).get("local", "0.0.0.0"))
    if parts.scheme == "replay":
        file = parts.netloc + parts.path
        if not file:
            raise InputError("--mocap", url, allowed)
        for key, value in query:
            if key not in REPLAY_OPTIONS:
                raise InputError("--mocap", key, f"replay options {', '.join(REPLAY_OPTIONS)}")
            try:
                numbers = [float(x) for x in value.split(":")]
            except ValueError:
                raise InputError(f"--mocap {key}", value, "seconds (late: T:D)") from None
            if not all(math.isfinite(x) and x >= 0 for x in numbers) or \
                    len(numbers) != (2 if key == "late" else 1):
                raise InputError(f"--mocap {key}", value, "seconds >= 0 (late: T:D)")
        return MocapAddress("replay", file=file, options=tuple(query))
    raise InputError("--mocap", url, allowed)


class FrameClock:
    """Capture times on the runtime's clock (see the module docstring)."""

    def __init__(self, latency: float):
        self.latency = float(latency)
        self.offset = math.nan
        self._last = math.nan

    def capture_time(self, timestamp: float, arrival: float) -> float:
        gap = arrival - timestamp
        if math.isnan(self.offset):
            self.offset = gap
        else:
            self.offset = min(self.offset + DRIFT * max(arrival - self._last, 0.0), gap)
        self._last = arrival
        return timestamp + self.offset - self.latency


class BodyMap:
    """Streaming ids to the tracker's body slots (ids 1..N in the mapping's order) and
    the capture-to-cell transform: a NatNet frame's rigid bodies as tracker entries."""

    def __init__(self, mapping: RecordingMapping):
        self.capture_to_cell = mapping.capture_to_cell
        self.slots = {}
        self.pivots = {}  # streaming id -> its pivot offset (sensing.pivots)
        for k, o in enumerate(mapping.operators):
            for b in o.bodies:
                if not b.streaming_id:
                    raise InputError(f"operators[{k}].bodies[{b.name}].streaming_id", 0,
                                     "the body's NatNet streaming id (the live stream "
                                     "names bodies by id)")
                self.slots[b.streaming_id] = len(self.slots) + 1
                if len(b.pivot):
                    self.pivots[b.streaming_id] = np.array(b.pivot, dtype=float)
        self.ignore = set(mapping.ignore_ids)

    def entries(self, bodies) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(z (E, 3) cell frame, valid (E,), ids (E,)) of a frame's rigid bodies (each
        with ``id_num``, ``pos``, ``rot`` (x, y, z, w) and ``tracking_valid``), each at
        the body point it marks (its mapping's pivot, ``sensing.pivots``: a body whose
        orientation is not known is non-finite, and the tracker stops on it); an
        unmapped, not ignored id is passed on as an unknown id (the tracker stops on
        it)."""
        kept = [b for b in bodies if b.id_num not in self.ignore]
        z = np.array([b.pos for b in kept], dtype=float).reshape(-1, 3)
        for e, b in enumerate(kept):  # at the body point it marks (NaN: no orientation)
            if b.id_num in self.pivots:
                z[e] = body_points(z[e], np.asarray(b.rot, dtype=float), self.pivots[b.id_num])
        valid = np.array([1.0 if b.tracking_valid is not False else 0.0 for b in kept])
        ids = np.array([float(self.slots.get(b.id_num, UNKNOWN_ID_BASE + b.id_num))
                        for b in kept])
        return to_cell(self.capture_to_cell, z), valid, ids


class NatNetSource:
    """A NatNet client (``natnet`` library, unicast) polled from the control loop."""

    def __init__(self, address: MocapAddress, clock_now):
        from natnet import NatNetClient

        self._now = clock_now
        self.client = NatNetClient(server_ip_address=address.host,
                                   local_ip_address=address.local,
                                   command_port=address.port, use_multicast=False)
        self.client.on_data_frame_received_event.handlers.append(self._on_frame)
        self.frames: list = []  # (arrival, DataFrame), oldest first
        self.bad_packets = 0
        self.keep_alives = 0  # sent from poll
        self._kept_alive = -math.inf

    def connect(self, timeout: float = 5.0) -> None:
        """Connects; raises ConnectionError (one line) where no server answers or the
        server speaks a NatNet version outside :data:`NATNET_VERSIONS`."""
        try:
            self.client.connect(timeout=timeout)
        except (TimeoutError, OSError) as e:
            raise ConnectionError(f"no NatNet server answered at {self.client.server_ip_address}"
                                  f":{self.client.command_port} ({type(e).__name__})") from None
        version = self.client.protocol_version
        low, high = NATNET_VERSIONS
        spoken = None if version is None else (version.major, version.minor)
        if spoken is None or not low <= spoken <= high:
            said = "none" if spoken is None else f"{spoken[0]}.{spoken[1]}"
            self.close()
            raise ConnectionError(
                f"the NatNet server at {self.client.server_ip_address}:"
                f"{self.client.command_port} speaks NatNet {said}; allowed: "
                f"{low[0]}.{low[1]} to {high[0]}.{high[1]} (Motive 2.0 on: before 3.0 the "
                "client library misreads every frame's time)")
        self._kept_alive = self._now()

    def sockets(self) -> list:
        """The client's sockets, to wait on (natnet 0.3.0 keeps them private)."""
        return [s for s in (self.client._NatNetClient__command_socket,
                            self.client._NatNetClient__data_socket) if s is not None]

    def _on_frame(self, frame) -> None:
        self.frames.append((self._now(), frame))

    def poll(self) -> list:
        """Reads every packet waiting; returns the new frames [(arrival, frame)] (a packet
        the library cannot parse counts in ``bad_packets``). A keep-alive goes to the
        server at most every :data:`KEEP_ALIVE_PERIOD` (the library's ``update_sync``
        sends one on every call: at the loop's rate, hundreds a second)."""
        for _ in range(64):  # each failure leaves the rest of the packets queued
            try:
                self._read()
                break
            except Exception:  # noqa: BLE001 - any parse failure is a bad packet
                self.bad_packets += 1
        frames, self.frames = self.frames, []
        return frames

    def _read(self) -> None:
        """``update_sync`` (natnet 0.3.0) with its keep-alives spaced out."""
        c = self.client
        read = c._NatNetClient__process_socket
        data, command = c._NatNetClient__data_socket, c._NatNetClient__command_socket
        if data is None or command is None:
            return
        while read(data):
            pass
        now = self._now()
        keep = now - self._kept_alive >= KEEP_ALIVE_PERIOD
        if keep:
            self._kept_alive = now
            self.keep_alives += 1
        while read(command, send_keep_alive=keep):
            keep = False

    def close(self) -> None:
        try:
            self.client.shutdown()
        except OSError:
            pass
