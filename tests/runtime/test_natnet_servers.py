"""The NatNet client against servers as real Motive servers answer: a real Motive 2.1
(NatNet 3.0) server-info reply and frame (tests/data/natnet_motive2.1, cut from a real
session), a server that speaks NatNet 2.9 (refused: the client library misreads its
frames' times), and the keep-alives a polled client sends."""

import select
import socket
import struct
import threading
import time
from pathlib import Path

import pytest

from safety_systems.runtime.mocap import KEEP_ALIVE_PERIOD, MocapAddress, NatNetSource
from safety_systems.runtime.natnet_packets import (
    NAT_CONNECT,
    NAT_KEEPALIVE,
    message_id,
    server_info,
)

REAL = Path(__file__).parents[1] / "data" / "natnet_motive2.1"


class _Server:
    """A UDP server on 127.0.0.1 that answers NAT_CONNECT with ``info``, then sends
    ``frames`` to the client's address and counts its keep-alives until stopped."""

    def __init__(self, info: bytes, frames: tuple = ()):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.port = self.sock.getsockname()[1]
        self.info, self.frames = info, frames
        self.keep_alives, self.stop = [], False
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        client = None
        while not self.stop:
            ready, _, _ = select.select([self.sock], [], [], 0.05)
            if not ready:
                continue
            data, address = self.sock.recvfrom(65536)
            if message_id(data) == NAT_CONNECT and client is None:
                client = address
                self.sock.sendto(self.info, client)
                for frame in self.frames:  # (to the command socket: the client reads both)
                    self.sock.sendto(frame, client)
            elif message_id(data) == NAT_KEEPALIVE:
                self.keep_alives.append(time.monotonic())

    def close(self) -> None:
        self.stop = True
        self.thread.join(timeout=2.0)
        self.sock.close()


def _source(port: int) -> NatNetSource:
    return NatNetSource(MocapAddress("natnet", "127.0.0.1", port, "127.0.0.1"),
                        time.monotonic)


def test_a_real_motive_2_1_server_is_read():
    info = (REAL / "serverinfo_packet_v3.bin").read_bytes()
    assert struct.unpack_from("<H", info)[0] == 1  # NAT_SERVERINFO
    server = _Server(info, ((REAL / "mocapframe_packet_v3.bin").read_bytes(),))
    source = _source(server.port)
    try:
        source.connect()
        frames, deadline = [], time.monotonic() + 3.0
        while not frames and time.monotonic() < deadline:
            time.sleep(0.01)
            frames += source.poll()
    finally:
        source.close()
        server.close()
    assert source.bad_packets == 0 and len(frames) == 1
    frame = frames[0][1]
    # as the dataset's description and OptiTrack's SampleClient state for frame 162734
    assert frame.prefix.frame_number == 162734
    body = frame.rigid_bodies[0]
    assert body.id_num == 2
    assert body.pos == pytest.approx((0.1744466, 1.4471314, -0.7343040), abs=1e-6)
    assert body.rot == pytest.approx((-0.0546, 0.5099, 0.0437, -0.8574), abs=1e-4)
    assert frame.suffix.timestamp == pytest.approx(1356.12, abs=0.005)


@pytest.mark.parametrize("version", [(2, 9, 0, 0), (2, 5, 0, 0)])
def test_a_natnet_2_server_is_refused_in_one_line(version):
    server = _Server(server_info(natnet_version=version))
    source = _source(server.port)
    try:
        with pytest.raises(ConnectionError) as e:
            source.connect()
    finally:
        server.close()
    line = str(e.value)
    assert f"NatNet {version[0]}.{version[1]}" in line and "allowed: 3.0 to 4.1" in line
    assert "\n" not in line


def test_keep_alives_go_once_a_second_not_on_every_poll():
    server = _Server(server_info())
    source = _source(server.port)
    try:
        source.connect()
        after_connect = time.monotonic()
        polls, end = 0, after_connect + 2.5 * KEEP_ALIVE_PERIOD
        while time.monotonic() < end:
            source.poll()
            polls += 1
            time.sleep(0.002)  # the control loop's 500 Hz
        time.sleep(0.2)
    finally:
        source.close()
        server.close()
    sent = [t for t in server.keep_alives if t > after_connect]
    assert polls > 300
    assert 1 <= source.keep_alives <= 3 and len(sent) == source.keep_alives
