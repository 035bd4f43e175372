"""GestureSource and ZonesController, each alone (FixValue inputs, Eval outputs)."""

import math

import numpy as np
import pytest

from safety_systems.cell.joint_path import default_joint_path, joint_path_state
from safety_systems.config.scenario import ZonesConfig
from safety_systems.systems.gesture_source import GestureSource
from safety_systems.systems.zones_controller import ZonesController
from safety_systems.cell.ur5e import tool0_position
from safety_systems.planning.zones import GREEN, RED, YELLOW, recovery_step

PATH = default_joint_path()
CONFIG = ZonesConfig(green_distance=1.0, yellow_distance=0.5, green_speed=0.8, yellow_speed=0.4,
                     red_speed=0.1, max_acceleration=1.0, max_jerk=5.0, rate_hz=100.0)
DT = 1.0 / CONFIG.rate_hz
FAR = np.array([3.0, 0.0, 0.0])


def _tool(s):
    return tool0_position(joint_path_state(PATH, s)[0])


class Zones:
    """A ZonesController with two body slots, its inputs fixed (changeable between steps)."""

    def __init__(self, config=CONFIG, s=0.0):
        self.system = ZonesController(path=PATH, config=config, num_bodies=2)
        self.context = self.system.CreateDefaultContext()
        self.s = s
        self.set(bodies=[_tool(s) + FAR, _tool(s) + FAR], status=[1, 1])

    def set(self, *, bodies=None, status=None, fault=0.0, gesture=0.0):
        port = self.system.GetInputPort
        if bodies is not None:
            port("positions_estimated").FixValue(self.context, np.ravel(bodies).astype(float))
        if status is not None:
            port("track_status").FixValue(self.context, np.asarray(status, float))
        port("fault").FixValue(self.context, [fault])
        port("path_state").FixValue(self.context, [self.s, 1.0, 0.0])
        port("gesture").FixValue(self.context, [gesture])

    def step(self, n=1):
        """n periodic updates; the (k, zone, closest distance) trace."""
        out = []
        for _ in range(n):
            self.context.SetDiscreteState(
                self.system.EvalUniquePeriodicDiscreteUpdate(self.context))
            out.append([self.system.GetOutputPort(p).Eval(self.context)[0]
                        for p in ("path_speed_commanded", "zone", "closest_distance")])
        return np.array(out)


def test_gesture_source_latest_code_by_time():
    g = GestureSource(events=[(1.0, "stop"), (2.0, "resume"), (3.5, "start")])
    c = g.CreateDefaultContext()
    codes = []
    for t in (0.0, 0.999, 1.0, 1.5, 2.0, 3.0, 3.5, 100.0):
        c.SetTime(t)
        codes.append(g.GetOutputPort("gesture").Eval(c)[0])
    assert codes == [0, 0, 2, 2, 3, 3, 1, 1]
    empty = GestureSource(events=[])
    c = empty.CreateDefaultContext()
    c.SetTime(5.0)
    assert empty.GetOutputPort("gesture").Eval(c)[0] == 0


@pytest.mark.parametrize("events, match", [
    ([(1.0, "halt")], "command"),
    ([(1.0, "stop"), (1.0, "resume")], "events"),
    ([(2.0, "stop"), (1.0, "resume")], "events"),
])
def test_gesture_source_rejects_bad_events(events, match):
    with pytest.raises(ValueError, match=match):
        GestureSource(events=events)


def test_initial_outputs_are_at_rest():
    z = Zones()
    out = [z.system.GetOutputPort(p).Eval(z.context)[0]
           for p in ("path_speed_commanded", "zone", "closest_distance")]
    assert out[0] == 0.0 and out[1] == RED  # stopped until the first decision


def test_far_body_green_rise_matches_recovery_step():
    z = Zones()
    trace = z.step(150)
    assert np.all(trace[:, 1] == GREEN)
    assert trace[:, 2] == pytest.approx(np.linalg.norm(FAR))
    k, rate, expected = 0.0, 0.0, []
    for _ in range(150):  # the wrapper and the plain function agree
        k, rate = recovery_step(k, rate, CONFIG.green_speed, DT,
                                max_acceleration=CONFIG.max_acceleration,
                                max_jerk=CONFIG.max_jerk)
        expected.append(k)
    assert trace[:, 0] == pytest.approx(expected, abs=1e-12)
    ks = np.concatenate([[0.0], trace[:, 0]])
    assert ks[1] == pytest.approx(CONFIG.max_jerk * DT**2)  # a gentle start
    assert np.all(np.diff(ks) >= 0) and np.diff(ks).max() <= CONFIG.max_acceleration * DT + 1e-12
    arrive = int(np.argmax(ks >= CONFIG.green_speed))
    assert np.all(np.abs(np.diff(ks, 2)[:arrive - 2]) <= CONFIG.max_jerk * DT**2 + 1e-12)
    assert ks[-1] == CONFIG.green_speed and ks.max() == CONFIG.green_speed


@pytest.mark.parametrize("s", [0.0, 2.0])
def test_body_in_red_zone_caps_speed(s):
    z = Zones(s=s)
    near = _tool(s) + [0.3, 0.0, 0.0]
    z.set(bodies=[near, _tool(s) + FAR], status=[1, 1])
    trace = z.step(100)
    assert np.all(trace[:, 1] == RED)
    assert np.all(trace[:, 0] <= CONFIG.red_speed) and trace[-1, 0] == CONFIG.red_speed
    assert trace[-1, 2] == pytest.approx(0.3)


def test_yellow_zone_and_immediate_drop():
    z = Zones()
    z.step(150)
    z.set(bodies=[_tool(0.0) + [0.0, 0.7, 0.0], _tool(0.0) + FAR])
    k, zone, d = z.step(1)[0]
    assert (k, zone) == (CONFIG.yellow_speed, YELLOW) and d == pytest.approx(0.7)
    z.set(bodies=[_tool(0.0) + [0.0, 0.0, 0.5], _tool(0.0) + FAR])  # exactly yellow_distance
    k, zone, d = z.step(1)[0]
    assert (k, zone) == (CONFIG.red_speed, RED)


def test_stop_gesture_holds_and_resume_recovers():
    z = Zones()
    z.step(150)
    z.set(gesture=2.0)
    trace = z.step(50)
    assert np.all(trace[:, 0] == 0.0)
    assert np.all(trace[:, 1] == GREEN)  # the zone still comes from the distance
    z.set(gesture=3.0)
    trace = z.step(150)
    assert trace[0, 0] == pytest.approx(CONFIG.max_jerk * DT**2)  # bounded-jerk restart
    assert trace[-1, 0] == CONFIG.green_speed
    z.set(gesture=2.0)
    z.step(1)
    z.set(gesture=1.0)  # start also releases the hold
    assert z.step(150)[-1, 0] == CONFIG.green_speed


@pytest.mark.parametrize("fault, status", [(1.0, [1, 1]), (0.0, [1, 3]), (0.0, [3, 0])])
def test_fault_or_lost_track_stops(fault, status):
    z = Zones()
    z.step(150)
    z.set(fault=fault, status=status)
    trace = z.step(20)
    assert np.all(trace[:, 0] == 0.0) and np.all(trace[:, 1] == RED)


def test_closest_distance_counts_only_usable_bodies():
    tool = _tool(0.0)
    z = Zones()
    offsets = np.array([[0.2, 0.0, 0.0], [0.6, 0.3, -0.2]])  # second: sqrt(0.49) = 0.7
    for status, expected in (([1, 1], 0.2), ([2, 1], 0.2), ([0, 1], 0.7), ([1, 0], 0.2),
                             ([0, 0], math.inf)):
        z.set(bodies=tool + offsets, status=status)
        assert z.step(1)[0, 2] == pytest.approx(expected)
    z.set(bodies=[[np.nan] * 3, tool + offsets[1]], status=[1, 1])  # no position: unusable
    k, zone, d = z.step(1)[0]
    assert d == pytest.approx(0.7) and zone == YELLOW
    z.set(bodies=[[np.nan] * 3, tool + offsets[1]], status=[0, 0])
    assert z.step(1)[0, 1] == GREEN  # nobody tracked: green
