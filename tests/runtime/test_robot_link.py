"""``UrRtdeRobot``'s commands when one side of RTDE fails: the receive side going quiet
(no new sample within the timeout) leaves the IO interface sending, so the loop's k = 0
reaches the slider; the IO interface refusing a command stops further sends."""

import collections
import math

import pytest

from safety_systems.runtime.robot_link import RobotLost, UrRtdeRobot


class _Receive:
    """A receive interface whose timestamp never moves on: its samples stopped."""

    def isConnected(self):
        return True

    def getTimestamp(self):
        return 1.0

    def getActualQ(self):
        return [0.0] * 6


class _Io:
    def __init__(self, refuse: bool = False):
        self.sliders, self.refuse = [], refuse

    def setSpeedSlider(self, k):
        if self.refuse:
            raise RuntimeError("the connection is closed")
        self.sliders.append(k)


def _robot(io) -> UrRtdeRobot:
    robot = UrRtdeRobot.__new__(UrRtdeRobot)  # the interfaces given, not connected
    clock = iter([0.0, 0.0, 1.0] + [2.0] * 100)
    robot._receive, robot._io, robot._now = _Receive(), io, lambda: next(clock)
    robot._timeout, robot._register, robot._window = 0.02, None, 0.5
    robot._stamp, robot._seen, robot.sent = -math.inf, 0.0, math.nan
    robot.lost, robot._io_broken, robot._sent_log = False, False, collections.deque()
    return robot


def test_a_quiet_receive_side_still_lets_k_0_reach_the_slider():
    io = _Io()
    robot = _robot(io)
    robot.read()  # the first sample
    robot.command(1.0)
    with pytest.raises(RobotLost, match="no new RTDE sample"):
        robot.read()  # 1 s later, the same timestamp
    assert robot.lost
    robot.command(0.0)  # what the loop sends once the robot is lost
    assert io.sliders == [1.0, 0.0]


def test_an_io_interface_that_refuses_is_not_sent_to_again():
    io = _Io(refuse=True)
    robot = _robot(io)
    robot.command(0.0)
    assert robot.lost
    io.refuse = False
    robot.command(0.0)
    assert io.sliders == []
