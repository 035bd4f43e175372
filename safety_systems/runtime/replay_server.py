"""``replay://``: a recording streamed as live NatNet packets over the loopback interface.

A small NatNet server (unicast, as Motive serves a unicast client): it waits on its
command port for a client's NAT_CONNECT, answers with NAT_SERVERINFO, then sends that
client a NAT_FRAMEOFDATA every 1/rate seconds (``natnet_packets``) with every rigid
body of the recording in the capture frame: frame i is the recording at time
start + i / rate (:func:`stream_frames`: linear between samples, as the simulator plays
a recording; a body is flagged untracked before its first tracked sample, after its
last and inside its recording's gaps), with that recording time as its timestamp.
``--bodies`` (a JSON object: recorded name -> streaming id, as ``run`` passes the
mapping's) streams those bodies only, read as the mapping reads them (``--units``,
``--truncated``; a skeleton export's hundreds of columns are not read), each with the
file's id or, where the file gives none (C3D points, BVH joints, markers), the given one.
Without it every body of the file is streamed, those without ids as 1, 2, ... in file
order. ``--untracked`` (a JSON object: recorded name -> [first, last] sample runs) streams
those samples as untracked, as the runtime passes what the mapping's ``implausible:
untracked`` reads so (a body held still before a jump: the sensor did not see it then).
Keep-alives and other requests are read and ignored.

For tests and demonstrations it can misbehave on purpose (times are recording times):
``stop`` (no frame from then on: the stream stops), ``garbage`` (a packet of random
bytes with a frame's message id, half a period after the frame at that time), ``late``
= T:D (the frame due at T is sent D seconds late, with its own timestamp, and the
frames due meanwhile are lost: a frame that comes late).

Run as ``python -m safety_systems.runtime.replay_server FILE [options]``; it prints
``port N`` on stdout once it listens, and exits after the last frame (plus ``linger``
seconds), when its client sends NAT_DISCONNECT, or when the runtime ends it (``run``
starts it in a process group of its own, ``runtime.child_process``, with
``--parent-death``: on Linux it is then ended when the runtime dies).
"""

import argparse
import dataclasses
import json
import math
import select
import socket
import sys
import time

import numpy as np

from safety_systems.sensing.recording import Recording, fill_gaps, gaps, span
from safety_systems.sensing.recording_files import read_recording
from safety_systems.sensing.recording import recorded_state_one
from safety_systems.runtime.natnet_packets import (
    NAT_CONNECT,
    NAT_DISCONNECT,
    frame_of_data,
    message_id,
    server_info,
)


START_DELAY = 0.3  # s from the server info to the first frame (the client's connect polls
#                   at 10 Hz; frames before it returns would queue up)


@dataclasses.dataclass(frozen=True)
class Misbehaviour:
    """Faults to stream on purpose (recording times, s; None: none)."""

    stop: float | None = None
    garbage: float | None = None
    late: tuple[float, float] | None = None


def stream_ids(rec: Recording, given: dict[str, int] | None = None) -> list[int]:
    """The rigid-body ids streamed: the file's; where it gives none, ``given``'s (by name)
    or 1, 2, ... (see the module docstring)."""
    if given is not None:
        return [i or int(given[n]) for n, i in zip(rec.names, rec.ids)]
    return list(rec.ids) if all(rec.ids) else list(range(1, len(rec.names) + 1))


def sample_runs(mask: np.ndarray) -> list[list[int]]:
    """The runs of True in ``mask`` (T,) as [first, last] sample indices."""
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return [[int(a), int(b)] for a, b in zip(starts, ends)]


def without_samples(rec: Recording, runs: dict[str, list]) -> Recording:
    """``rec`` with the samples ``runs`` names (recorded name -> [first, last] runs)
    untracked (NaN)."""
    positions, rotations = rec.positions.copy(), rec.rotations.copy()
    for name, spans in runs.items():
        k = rec.body(name)
        for a, b in spans:
            positions[a:b + 1, k] = np.nan
            rotations[a:b + 1, k] = np.nan
    return dataclasses.replace(rec, positions=positions, rotations=rotations)


def stream_frames(rec: Recording, rate: float, start: float, count: int
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(timestamps (F,), positions (F, B, 3), rotations (F, B, 4), tracked (F, B)) of
    ``count`` frames from recording time ``start`` at ``rate`` Hz, capture frame (see
    the module docstring)."""
    filled = fill_gaps(rec.times, rec.positions)
    ok = np.all(np.isfinite(rec.positions), axis=2)
    spans = np.array([span(rec.times, ok[:, b]) for b in range(ok.shape[1])])
    holes = [gaps(rec.times, ok[:, b]) for b in range(ok.shape[1])]
    B = len(rec.names)
    taus = start + np.arange(count) / rate
    p, r, tracked = np.empty((count, B, 3)), np.empty((count, B, 4)), np.zeros((count, B))
    v, present = np.empty((B, 3)), np.empty(B)
    for f, tau in enumerate(taus):
        recorded_state_one(rec.times, filled, spans, tau, p[f], v, present)
        near = min(int(np.searchsorted(rec.times, tau)), rec.times.size - 1)
        r[f] = rec.rotations[near]
        for b in range(B):
            hidden = any(a < tau < z for a, z in holes[b])
            tracked[f, b] = present[b] > 0.5 and not hidden
    return taus, p, r, tracked


def serve(rec: Recording, *, rate: float, start: float = 0.0, duration: float | None = None,
          host: str = "127.0.0.1", port: int = 0, misbehave: Misbehaviour = Misbehaviour(),
          linger: float = 1.0, wait: float = 30.0, announce=print,
          ids: dict[str, int] | None = None) -> int:
    """Serves one client (see the module docstring; ``ids``: streaming ids by name for
    bodies the file gives none); returns the frames sent."""
    end = rec.times[-1] if duration is None else min(rec.times[-1], start + duration)
    count = int(math.floor((end - start) * rate + 1e-9)) + 1
    taus, p, r, tracked = stream_frames(rec, rate, start, count)
    ids = stream_ids(rec, ids)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind((host, port))
    announce(f"port {sock.getsockname()[1]}")
    client = _wait_for_client(sock, wait)
    if client is None:
        return 0
    sock.sendto(server_info(), client)
    t0 = time.monotonic() + START_DELAY
    sent, rng = 0, np.random.default_rng(0)
    late_frame, late_until = None, -math.inf
    if misbehave.late is not None:
        late_frame = int(np.argmax(taus >= misbehave.late[0]))
        late_until = taus[late_frame] + misbehave.late[1]
    for f in range(count):
        tau = taus[f]
        if misbehave.stop is not None and tau >= misbehave.stop:
            break
        if late_frame is not None and late_frame < f and tau < late_until:
            continue  # lost while the late frame was held
        delay = misbehave.late[1] if f == late_frame else 0.0
        if not _sleep_until(sock, t0 + (tau - start) + delay):
            return sent  # the client left
        sock.sendto(frame_of_data(f + 1, float(tau), ids, p[f], r[f], tracked[f]), client)
        sent += 1
        if misbehave.garbage is not None and tau <= misbehave.garbage < tau + 1.0 / rate:
            _sleep_until(sock, t0 + (tau - start) + 0.5 / rate)
            junk = rng.integers(0, 256, 60, dtype=np.uint8).tobytes()
            sock.sendto((7).to_bytes(2, "little") + (60).to_bytes(2, "little") + junk,
                        client)
    _sleep_until(sock, time.monotonic() + linger)
    sock.close()
    return sent


def _wait_for_client(sock: socket.socket, wait: float):
    deadline = time.monotonic() + wait
    while time.monotonic() < deadline:
        ready, _, _ = select.select([sock], [], [], max(0.0, deadline - time.monotonic()))
        if ready:
            data, address = sock.recvfrom(65536)
            if message_id(data) == NAT_CONNECT:
                return address
    return None


def _sleep_until(sock: socket.socket, when: float) -> bool:
    """Waits until ``when`` reading (and ignoring) requests; False if the client left."""
    while True:
        left = when - time.monotonic()
        if left <= 0.0:
            return True
        ready, _, _ = select.select([sock], [], [], left)
        if ready:
            data, _ = sock.recvfrom(65536)
            if message_id(data) == NAT_DISCONNECT:
                return False


def _end_with_parent() -> None:
    """Asks Linux to send this process SIGTERM when its parent ends (prctl
    PR_SET_PDEATHSIG); elsewhere nothing."""
    import ctypes
    import ctypes.util
    import signal

    try:
        ctypes.CDLL(ctypes.util.find_library("c"), use_errno=True).prctl(1, signal.SIGTERM)
    except (OSError, AttributeError):
        pass


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="replay_server", description=__doc__.split("\n")[0])
    parser.add_argument("recording")
    parser.add_argument("--rate", type=float, default=20.0)
    parser.add_argument("--start", type=float, default=0.0)
    parser.add_argument("--duration", type=float)
    parser.add_argument("--port", type=int, default=0)
    parser.add_argument("--stop", type=float)
    parser.add_argument("--garbage", type=float)
    parser.add_argument("--late", type=float, nargs=2)
    parser.add_argument("--linger", type=float, default=1.0)
    parser.add_argument("--bodies", type=json.loads)
    parser.add_argument("--units", default="")
    parser.add_argument("--truncated", default="refuse")
    parser.add_argument("--untracked", type=json.loads, default={})
    parser.add_argument("--parent-death", action="store_true",
                        help="end when the process that started it ends (Linux)")
    return parser.parse_args(argv)


def streamed_recording(args: argparse.Namespace) -> Recording:
    """The recording as the server streams it (see the module docstring)."""
    rec = read_recording(args.recording, None if args.bodies is None else list(args.bodies),
                         truncated=args.truncated, units=args.units)
    return without_samples(rec, args.untracked)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.parent_death:
        _end_with_parent()
    rec = streamed_recording(args)
    misbehave = Misbehaviour(args.stop, args.garbage, tuple(args.late) if args.late else None)
    serve(rec, rate=args.rate, start=args.start, duration=args.duration, port=args.port,
          misbehave=misbehave, linger=args.linger,
          announce=lambda line: print(line, flush=True), ids=args.bodies)
    return 0


if __name__ == "__main__":
    sys.exit(main())
