"""The robot side of the runtime: a UR over RTDE (``ur-rtde``), or a model of it.

``ur-rtde://HOST[?timeout=S&stop_register=N]`` (:class:`UrRtdeRobot`): joint positions
from ``RTDEReceiveInterface`` (``actual_q`` and the controller's ``timestamp``, at the
control rate) and k as the speed slider through ``RTDEIOInterface.setSpeedSlider``. The
slider is sent every tick, so a robot program that sets an RTDE watchdog on
``speed_slider_fraction`` (URScript ``rtde_set_watchdog``) stops the robot when the
runtime goes silent. A protective stop: the IO interface has no command for one, so
with ``stop_register=N`` the runtime sets input integer register N to 1 on any fault
stop (0 otherwise), for a robot program thread to call ``protective_stop()`` on; without
it the slider at 0 is all the runtime can do. The connection is lost when the interface
says so or when the controller's timestamp has not advanced for ``timeout`` s.

``none`` (:class:`ModelRobot`): no robot. The verified robot's path is followed at the
commanded k by the simulator's own PathFollower step (``braking.path_follower_step`` and
``joint_path.joint_path_state``), so the monitor sees a robot that moves as the
simulated one would; what would have been commanded is logged.

**The robot's speed now** (``rate_bound``, which S by speed needs: ``safety.stopping:
by_speed``). The model robot's path rate is known exactly. A UR's is bounded from what
the runtime told it: the largest k sent within the stopping data's full-speed stopping
time (its ``braking`` table; before that long has passed since the first command, the
slider's earlier setting is unknown and the bound is 1). This is sound only if the
robot slows to a lower slider setting at least as fast as the stopping data says: a
premise the runtime trusts (the same stopping data the proofs trust), not one it checks.
"""

import collections
import ctypes
import dataclasses
import math
import time
import urllib.parse

import numpy as np

from safety_systems.cell.braking import path_follower_step
from safety_systems.cell.braking import stopping_time as table_stopping_time
from safety_systems.files.input_error import InputError
from safety_systems.cell.joint_path import joint_path_state
from safety_systems.cell.robot_model import KIND_UR
from safety_systems.config.configuration import joint_path
from safety_systems.config.resolved_cell import ResolvedCell

ROBOT_TIMEOUT = 0.02  # s without a new RTDE sample before the robot counts as lost


class RobotLost(Exception):
    """The robot's connection is gone (or its data stale)."""


@dataclasses.dataclass(frozen=True)
class RobotAddress:
    kind: str  # "ur-rtde" | "none"
    host: str = ""
    timeout: float = ROBOT_TIMEOUT
    stop_register: int | None = None


def parse_robot(url: str) -> RobotAddress:
    """``ur-rtde://HOST[?timeout=S&stop_register=N]`` or ``none``; raises InputError."""
    allowed = "ur-rtde://HOST[?timeout=S&stop_register=N] or none"
    if url == "none":
        return RobotAddress("none")
    parts = urllib.parse.urlsplit(url)
    if parts.scheme != "ur-rtde" or not parts.hostname or parts.port or parts.path:
        raise InputError("--robot", url, allowed)
    options = dict(urllib.parse.parse_qsl(parts.query))
    if set(options) - {"timeout", "stop_register"}:
        raise InputError("--robot", url, allowed)
    try:
        timeout = float(options.get("timeout", ROBOT_TIMEOUT))
        register = int(options["stop_register"]) if "stop_register" in options else None
    except ValueError:
        raise InputError("--robot", url, allowed) from None
    if not 0.001 <= timeout <= 1.0:
        raise InputError("--robot timeout", timeout, "0.001 <= timeout <= 1 s")
    if register is not None and not (18 <= register <= 22 or 42 <= register <= 46):
        raise InputError("--robot stop_register", register, "18 to 22 (or 42 to 46)")
    return RobotAddress("ur-rtde", parts.hostname, timeout, register)


class ModelRobot:
    """``--robot none``: the verified path followed at the commanded k (see the module
    docstring), the path, control rate and stopping data of the resolved ``cell``'s
    robot; its time advances one control period per :meth:`step`."""

    name = "none (model of the verified path)"

    def __init__(self, cell: ResolvedCell):
        robot, table = cell.robot, cell.braking
        self.path = joint_path(robot)
        self._brakes = (table.speed_fraction, table.deceleration, robot.acceleration_limit)
        self._dt = 1.0 / robot.control_rate_hz
        self.s, self.rate, self.time = 0.0, 0.0, 0.0
        self.sent = math.nan  # what the robot was last told
        self._warm_up()

    def _warm_up(self) -> None:
        """Calls the compiled path functions once (loading them from the cache would
        make the loop's first ticks late: 2-4 ms seen), leaving the state as new."""
        fractions, deceleration, acceleration = self._brakes
        joint_path_state(self.path, 0.0)
        path_follower_step(0.0, 0.0, 0.0, self.path.end, 1.0, self._dt, fractions,
                           deceleration, acceleration, 1.0)

    def read(self) -> tuple[np.ndarray, float]:
        """(joint positions (n,), the robot's time of them)."""
        return np.array(joint_path_state(self.path, self.s)[0]), self.time

    def command(self, k: float) -> None:
        self.sent = k

    def rate_bound(self) -> float:
        """The model's path rate now (exact: it is the simulator's path follower)."""
        return self.rate

    def advance_to(self, t: float) -> None:
        """Control periods at the last command (the PathFollower's update) until the
        model's time reaches ``t`` (the loop's time: when the loop skips ticks, the model
        robot keeps moving, as a real one would)."""
        fractions, deceleration, acceleration = self._brakes
        while self.time < t - 1e-9:
            self.s, self.rate = path_follower_step(self.s, self.rate, self.sent if math.isfinite(
                self.sent) else 0.0, self.path.end, 1.0, self._dt, fractions, deceleration,
                acceleration, 1.0)
            self.time += self._dt

    def protective_stop(self, on: bool) -> None:
        pass

    def close(self) -> None:
        self.sent = 0.0


class UrRtdeRobot:
    """A UR over RTDE through ``ur-rtde`` (see the module docstring)."""

    def __init__(self, address: RobotAddress, frequency: float, stop_window: float):
        import rtde_io
        import rtde_receive

        self.name = f"ur-rtde://{address.host}"
        self._timeout = address.timeout
        self._register = address.stop_register
        self._now = time.monotonic
        try:
            self._receive = rtde_receive.RTDEReceiveInterface(
                address.host, frequency, ["timestamp", "actual_q"])
            self._io = rtde_io.RTDEIOInterface(address.host)
        except RuntimeError as e:
            raise ConnectionError(f"no RTDE server answered at {address.host}:30004 ({e})"
                                  ) from None
        self._stamp, self._seen = -math.inf, self._now()
        self.sent = math.nan
        self.lost = False  # the robot's state no longer comes (RobotLost was raised)
        self._io_broken = False  # the IO interface refused a command: nothing more is sent
        self._window = float(stop_window)
        self._sent_log = collections.deque()  # (time, k) of the commands, see rate_bound

    def read(self) -> tuple[np.ndarray, float]:
        """(actual joint positions, the controller's timestamp); raises RobotLost."""
        if self.lost or not self._receive.isConnected():
            self.lost = True
            raise RobotLost("the RTDE connection is closed")
        stamp = self._receive.getTimestamp()
        now = self._now()
        if stamp != self._stamp:
            self._stamp, self._seen = stamp, now
        elif now - self._seen > self._timeout:
            self.lost = True
            raise RobotLost(f"no new RTDE sample for {now - self._seen:.3f} s")
        q = np.array(self._receive.getActualQ(), dtype=float)
        if q.shape != (6,):
            self.lost = True
            raise RobotLost(f"actual_q of {q.size} values")
        return q, stamp

    def command(self, k: float) -> None:
        """k to the speed slider. Sent while the IO interface takes it, whether or not
        the robot's state still comes: a receive side that went quiet (RobotLost) is not
        a reason to leave the slider where it was, so the loop's k = 0 still goes out."""
        self.sent = k
        self._sent_log.append((self._now(), float(k)))
        if not self._io_broken:
            try:
                self._io.setSpeedSlider(float(k))
            except RuntimeError:
                self._io_broken = self.lost = True

    def rate_bound(self) -> float:
        """The largest k sent within the full-speed stopping time (the module
        docstring), 1 when not yet known."""
        return sent_rate_bound(self._sent_log, self._now(), self._window)

    def advance_to(self, t: float) -> None:
        pass

    def protective_stop(self, on: bool) -> None:
        if self._register is not None and not self._io_broken:
            try:
                self._io.setInputIntRegister(self._register, 1 if on else 0)
            except RuntimeError:
                self._io_broken = self.lost = True

    def close(self) -> None:
        """Slider to 0 (never left where it was), then disconnect."""
        self.command(0.0)
        self.protective_stop(True)
        for interface in (self._io, self._receive):
            try:
                interface.disconnect()
            except RuntimeError:
                _keep_alive(interface)


def sent_rate_bound(sent: collections.deque, now: float, window: float) -> float:
    """A bound on the path rate at ``now`` from the commands ``sent`` ((time, k), oldest
    first): the largest k in effect at any time in [now - window, now] (the one sent
    last before now - window, and every later one), clipped to [0, 1]; 1 when no
    command is older than the window or any is not a number. Drops the commands no
    longer needed."""
    while len(sent) >= 2 and sent[1][0] <= now - window:
        sent.popleft()
    if not sent or sent[0][0] > now - window:
        return 1.0
    ks = [k for _, k in sent]
    if not all(math.isfinite(k) for k in ks):
        return 1.0
    return min(max(max(ks), 0.0), 1.0)


def _keep_alive(interface) -> None:
    """Never destroys ``interface``: ur-rtde 1.6's interfaces disconnect again in their
    destructor, and after a broken connection that throws there, which aborts the
    process (std::terminate; seen with RTDEIOInterface after the robot's side closed).
    One reference is added and never released, so the object lives until the process
    ends and the operating system closes its socket."""
    ctypes.pythonapi.Py_IncRef(ctypes.py_object(interface))


def connect_robot(address: RobotAddress, cell: ResolvedCell):
    """The robot at ``address``: the model of the resolved ``cell``'s robot, or its UR
    over RTDE (its rate bound's window the cell's full-speed stopping time)."""
    if address.kind == "none":
        return ModelRobot(cell)
    model = cell.model
    if model.kind != KIND_UR:  # (RTDE speaks to Universal Robots' controllers only)
        raise InputError("--robot", f"{address.kind}://", f"none for the {model.name} (RTDE "
                         "drives UR arms only; another arm: --robot none, the monitor alone)")
    window = float(table_stopping_time(cell.braking, 1.0))
    return UrRtdeRobot(address, cell.robot.control_rate_hz, window)
