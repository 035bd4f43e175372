"""NatNet packets as a Motive server sends them (the server side; the runtime reads them
with the ``natnet`` client library, which has no writer).

Written for NatNet 4.1 (Motive 3.x; the seed's Motive 3.1.0), little-endian, as the
NatNet SDK's description of the stream lays them out: a message id (uint16) and the
payload's size in bytes (uint16), then the payload. A frame of data holds the frame
number, then each data set as a count and (from 4.1) its size in bytes: marker sets,
unlabelled markers, rigid bodies (id, position, orientation quaternion x y z w, mean
marker error, a parameter word whose bit 0 says the body is tracked), skeletons,
assets, labelled markers, force plates and devices (this writer sends rigid bodies
only), then the suffix: timecode, timecode subframe, the timestamp (float64 s), three
high-resolution stamps (uint64 ticks) and a parameter word.
"""

import struct

import numpy as np

NAT_CONNECT, NAT_SERVERINFO, NAT_REQUEST_MODELDEF, NAT_FRAMEOFDATA = 0, 1, 4, 7
NAT_KEEPALIVE, NAT_DISCONNECT = 10, 9
NATNET_VERSION = (4, 1, 0, 0)
SERVER_VERSION = (3, 1, 0, 0)
CLOCK_HZ = 10_000_000  # ticks per second of the high-resolution stamps
_BODY = struct.Struct("<I3f4ffH")
_EMPTY = struct.pack("<II", 0, 0)  # a data set with no items (count, size)


def _message(message_id: int, payload: bytes) -> bytes:
    if len(payload) > 0xFFFF:
        raise ValueError(f"a NatNet payload of {len(payload)} bytes: at most 65535")
    return struct.pack("<HH", message_id, len(payload)) + payload


def server_info(app_name: str = "safety-systems replay", *, data_port: int = 1511,
                natnet_version: tuple = NATNET_VERSION) -> bytes:
    """NAT_SERVERINFO: the application's name (256 bytes), its version, the NatNet
    version, the stamps' clock frequency, the data port, multicast (no) and its group."""
    name = app_name.encode("utf-8")[:255].ljust(256, b"\0")
    payload = (name + bytes(SERVER_VERSION) + bytes(natnet_version)
               + struct.pack("<QHB", CLOCK_HZ, data_port, 0) + bytes([239, 255, 42, 99]))
    return _message(NAT_SERVERINFO, payload)


def frame_of_data(frame_number: int, timestamp: float, ids, positions, rotations, tracked,
                  *, transmit_ticks: int = 0) -> bytes:
    """NAT_FRAMEOFDATA of rigid bodies ``ids`` (B,) at ``positions`` (B, 3, m, capture
    frame) with ``rotations`` (B, 4, x y z w) and ``tracked`` (B,) flags; an untracked
    body is sent with its flag clear and zeros, as Motive does."""
    bodies = bytearray()
    for i, p, q, ok in zip(ids, positions, rotations, tracked):
        ok = bool(ok) and bool(np.all(np.isfinite(p)))
        q = q if ok and np.all(np.isfinite(q)) else (0.0, 0.0, 0.0, 1.0)
        p = p if ok else (0.0, 0.0, 0.0)
        bodies += _BODY.pack(int(i), *map(float, p), *map(float, q), 0.0, 1 if ok else 0)
    stamp = int(round(timestamp * CLOCK_HZ))
    payload = (struct.pack("<I", frame_number) + _EMPTY + _EMPTY
               + struct.pack("<II", len(ids), len(bodies)) + bytes(bodies)
               + _EMPTY * 5  # skeletons, assets, labelled markers, force plates, devices
               + struct.pack("<IIdQQQH", 0, 0, timestamp, stamp, stamp,
                             transmit_ticks or stamp, 0))
    return _message(NAT_FRAMEOFDATA, payload)


def message_id(packet: bytes) -> int:
    """The message id of a packet (-1 if it is too short to have one)."""
    return struct.unpack_from("<H", packet)[0] if len(packet) >= 4 else -1
