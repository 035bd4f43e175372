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

from .test_live import _trace

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


def _captured_session() -> tuple[dict, list]:
    """From the real Motive 2.1 session (traffic.pcapng): the server's command replies by
    the message id they answer, in order, and its frames of data with their capture
    times (s from the first)."""
    import dpkt

    replies: dict = {}
    frames = []
    answers = {1: 0, 3: 2, 5: 4, 13: 12, 100: 2}  # reply id -> request id (100: unknown)
    with open(REAL / "traffic.pcapng", "rb") as f:
        for ts, buf in dpkt.pcapng.Reader(f):
            ip = dpkt.ethernet.Ethernet(buf).data
            if not isinstance(ip, dpkt.ip.IP) or not isinstance(ip.data, dpkt.udp.UDP):
                continue
            udp = ip.data
            payload = bytes(udp.data)
            mid = message_id(payload)
            if udp.sport == 1511 and mid == 7:
                frames.append((ts, payload))
            elif udp.sport == 1510 and mid in answers:
                replies.setdefault(answers[mid], []).append(payload)
    t0 = frames[0][0]
    return replies, [(float(ts - t0), p) for ts, p in frames]


class _Motive21:
    """A loopback server answering as the captured Motive 2.1 did: each request by the
    captured reply to it (in the captured order, the last repeated), then the captured
    frames at their captured times to the client."""

    def __init__(self):
        self.replies, self.frames = _captured_session()
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.port = self.sock.getsockname()[1]
        self.stop, self.sent = False, 0
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        client, start, used = None, None, {}
        while not self.stop:
            if start is not None and self.sent < len(self.frames):
                wait = max(0.0, start + self.frames[self.sent][0] - time.monotonic())
            else:
                wait = 0.05
            ready, _, _ = select.select([self.sock], [], [], wait)
            if ready:
                data, address = self.sock.recvfrom(65536)
                mid = message_id(data)
                if mid in self.replies:
                    n = used.get(mid, 0)
                    self.sock.sendto(self.replies[mid][min(n, len(self.replies[mid]) - 1)],
                                     address)
                    used[mid] = n + 1
                    if mid == NAT_CONNECT and client is None:
                        client, start = address, time.monotonic() + 0.3
                continue
            if start is not None and self.sent < len(self.frames):
                self.sock.sendto(self.frames[self.sent][1], client)
                self.sent += 1

    def close(self) -> None:
        self.stop = True
        self.thread.join(timeout=2.0)
        self.sock.close()


def test_the_real_motive_2_1_session_is_replayed_through_run(tmp_path, exported_params):
    """`run` against a server answering as the captured Motive 2.1 did, with its 518
    captured frames at their captured 120 Hz, the rigid body mapped as an operator's
    head: every frame read (none bad), their times good (no frame goes stale while they
    flow), the body measured."""
    import json

    from safety_systems.cli import main

    server = _Motive21()
    assert len(server.frames) == 518
    (tmp_path / "map.yaml").write_text(
        "capture_to_cell: {up_axis: y, translation: [1.6, 0.0, 0.0]}\n"
        "operators:\n- name: visitor\n  bodies:\n"
        # the session's one rigid body, its pivot given (about a helmet's above the head)
        "  - {recorded: body2, name: head, point: head, streaming_id: 2, "
        "pivot: [0.0, -0.12, 0.0]}\n")
    try:
        code = main(["run", str(exported_params), "--mocap",
                     f"natnet://127.0.0.1:{server.port}?local=127.0.0.1", "--robot", "none",
                     "--mapping", str(tmp_path / "map.yaml"), "--log", str(tmp_path / "log"),
                     "--duration", "5.5", "--quiet"])
    finally:
        server.close()
    assert code == 0
    summary = json.loads((tmp_path / "log" / "summary.json").read_text())
    assert summary["bad_packets"] == 0
    assert summary["frames"] == server.sent == 518
    trace = _trace(tmp_path / "log")
    flowing = (0.5 < trace["time"]) & (trace["time"] < 4.0) & (10 < trace["frames"]) & (
        trace["frames"] < 518)
    # While the frames flow their times are good (no frame goes stale) and the monitor
    # measures the body: its head 0.56 m from the robot, inside iso.yaml's S (2.41 m),
    # so the robot model is held by the separation rule; after the last frame, by the
    # stale-frame rule. k is 0 throughout.
    assert flowing.sum() > 1000
    # (a loaded machine may also overrun a tick: the watchdog's stop, not the stream's)
    reasons = set(trace["stop_reason"][flowing])
    assert "separation" in reasons and reasons <= {"separation", "overrun"}
    assert (trace["visitor:d_measured"][flowing] < trace["visitor:S"][flowing]).all()
    # After the last frame the stale-frame rule holds it (the watchdog's overrun stop,
    # which the log names instead while it holds, may also show on a loaded machine).
    after = (trace["frames"] == 518) & (trace["time"] > 5.0)
    assert after.any()
    assert "stale_frame" in set(trace["stop_reason"][after])
    assert set(trace["stop_reason"][after]) <= {"stale_frame", "overrun"}
    assert (trace["k"] == 0.0).all()
