"""A loopback RTDE server speaking the part of the protocol ``ur-rtde`` uses for the
speed slider and joint positions (the robot side of the runtime's tests; run as a
process: ur-rtde's calls hold the GIL, so a server in the same process would starve).

Messages (big-endian; header: uint16 size, uint8 type): 'V' protocol version (accepted),
'v' controller version (5.11.0.0), 'O' output setup (a double frequency and variable
names; types from ``OUTPUTS``, else NOT_FOUND), 'I' input setup (types from
``input_type``; recipe ids 1, 2, ... in order), 'S' start (output data packages 'U' at
the requested frequency), 'U' input data (decoded by its recipe and logged), 'P' pause.
The robot's joints follow the default path at the latest speed slider fraction
(``ModelRobot``). Every input data package is printed as a JSON line on stdout
(``{"t": ..., "values": {...}}``); ``--drop-at T`` closes the connections T seconds
after the first start.
"""

import argparse
import json
import socket
import struct
import sys
import threading
import time

OUTPUTS = {"timestamp": ("DOUBLE", "d"), "actual_q": ("VECTOR6D", "6d")}
FORMATS = {"INT32": "i", "UINT32": "I", "DOUBLE": "d", "UINT8": "B"}


_SAY = threading.Lock()


def say(message: dict) -> None:
    """One JSON line on stdout; the connection and stream threads all write, and print's
    text and newline could otherwise interleave between them."""
    with _SAY:
        print(json.dumps(message), flush=True)


def input_type(name: str) -> str:
    if name.startswith("input_int_register_"):
        return "INT32"
    if name.startswith("input_double_register_") or name in (
            "speed_slider_fraction", "standard_analog_output_0", "standard_analog_output_1"):
        return "DOUBLE"
    if name == "speed_slider_mask":
        return "UINT32"
    return "UINT8"


class Server:
    def __init__(self, host: str, drop_at: float | None):
        from safety_systems.config.resolved_cell import resolve
        from safety_systems.config.scenario import ControllerConfig
        from safety_systems.runtime.robot_link import ModelRobot

        self.robot = ModelRobot(resolve(ControllerConfig()))
        self.slider = 0.0
        self.lock = threading.Lock()
        self.recipes: list[list[str]] = []
        self.started = None
        self.drop_at = drop_at
        self.connections: list[socket.socket] = []
        self.outputs: dict = {}  # connection -> (frequency, output names)
        self.paused: set = set()
        self.listener = socket.socket()
        self.listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.listener.bind((host, 30004))
        self.listener.listen(8)

    def serve(self) -> None:
        say({"listening": True})
        while True:
            conn, _ = self.listener.accept()
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self.connections.append(conn)
            say({"accepted": len(self.connections)})
            threading.Thread(target=self.handle, args=(conn,), daemon=True).start()

    def send(self, conn, kind: str, payload: bytes) -> None:
        conn.sendall(struct.pack(">HB", len(payload) + 3, ord(kind)) + payload)

    def handle(self, conn: socket.socket) -> None:
        try:
            self.receive(conn)
        finally:  # every package it sent was printed before this
            say({"closed": True})

    def receive(self, conn: socket.socket) -> None:
        buffer = b""
        while True:
            try:
                data = conn.recv(65536)
            except OSError:
                return
            if not data:
                return
            buffer += data
            while len(buffer) >= 3:
                size, kind = struct.unpack(">HB", buffer[:3])
                if len(buffer) < size:
                    break
                payload, buffer = buffer[3:size], buffer[size:]
                self.message(conn, chr(kind), payload)

    def message(self, conn, kind: str, payload: bytes) -> None:
        if kind == "P":  # as the controller: no data package after the pause's reply
            self.paused.add(conn)
        if kind in "VSP":
            self.send(conn, kind, b"\x01")
            if kind == "S":
                if self.started is None:
                    self.started = time.monotonic()
                self.paused.discard(conn)
                if conn in self.outputs:  # data packages only for an output recipe
                    threading.Thread(target=self.stream, args=(conn,), daemon=True).start()
        elif kind == "v":
            self.send(conn, kind, struct.pack(">IIII", 5, 11, 0, 0))
        elif kind == "O":
            frequency = struct.unpack(">d", payload[:8])[0]
            names = [n for n in payload[8:].decode().split(",") if n]
            self.outputs[conn] = (frequency, names)
            types = [OUTPUTS.get(n, ("NOT_FOUND",))[0] for n in names]
            self.send(conn, kind, b"\x01" + ",".join(types).encode())
        elif kind == "I":
            names = [n for n in payload.decode().split(",") if n]
            self.recipes.append(names)
            self.send(conn, kind, bytes([len(self.recipes)])
                      + ",".join(input_type(n) for n in names).encode())
        elif kind == "U":
            names = self.recipes[payload[0] - 1]
            fmt = ">" + "".join(FORMATS[input_type(n)] for n in names)
            values = dict(zip(names, struct.unpack(fmt, payload[1:])))
            with self.lock:
                if values.get("speed_slider_mask") == 1:
                    self.slider = values["speed_slider_fraction"]
            say({"t": time.monotonic(), "values": values})

    def stream(self, conn) -> None:
        frequency, outputs = self.outputs[conn]
        period = 1.0 / frequency
        next_time = time.monotonic()
        while conn not in self.paused:
            now = time.monotonic()
            if self.drop_at is not None and now - self.started >= self.drop_at:
                for c in self.connections:
                    try:
                        c.shutdown(socket.SHUT_RDWR)
                        c.close()
                    except OSError:
                        pass
                say({"dropped": now})
                return
            with self.lock:
                self.robot.command(self.slider)
                self.robot.advance_to(self.robot.time + period)
                q, t = self.robot.read()
            values = {"timestamp": struct.pack(">d", t), "actual_q": struct.pack(">6d", *q)}
            try:
                self.send(conn, "U", b"\x01" + b"".join(values[n] for n in outputs))
            except OSError:
                return
            next_time += period
            time.sleep(max(0.0, next_time - time.monotonic()))


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("host")
    parser.add_argument("--drop-at", type=float)
    args = parser.parse_args()
    Server(args.host, args.drop_at).serve()
    return 0


if __name__ == "__main__":
    sys.exit(main())
