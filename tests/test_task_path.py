"""Task-space polyline paths (``cartesian_path.polyline_path``) and ``TaskPathConfig``."""

import numpy as np
import pytest
from scipy.optimize import brentq

from safety_systems.cell.cartesian_path import polyline_path
from safety_systems.cell.joint_path import joint_path_state
from safety_systems.config.scenario import ScenarioError, load_scenario
from safety_systems.cell.ur5e import (
    dh_forward_kinematics,
    tool0_position,
    tool0_position_and_velocity,
)
from safety_systems.config.configuration import joint_path

# Seed 001's start and goal (10, 70, 15) and (70, 30, 5) cm, through a corner.
POINTS = np.array([[0.10, 0.70, 0.15], [0.40, 0.50, 0.15], [0.70, 0.30, 0.05]])
SPEED = 0.15
RPY = [np.pi, 0.0, 0.0]
SEED = np.radians([90.0, -90.0, 90.0, -90.0, -90.0, 0.0])
ARC = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(POINTS, axis=0), axis=1))])
LENGTH = ARC[-1]  # sqrt(0.13) + sqrt(0.14) m


@pytest.fixture(scope="module")
def path():
    return polyline_path(POINTS, speed=SPEED, rpy=RPY, seed=SEED, cycles=2, there_and_back=True)


def _tool(path, s):
    return tool0_position(joint_path_state(path, s)[0])


def _point_parameters(duration):
    """Path parameter of each point on the way out: minimum-jerk timing of the arc."""
    def h(tau):
        return tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)
    return np.array([brentq(lambda t, f=f: h(t) - f, 0.0, 1.0) if 0 < f < 1 else f
                     for f in ARC / LENGTH]) * duration


def test_timing(path):
    assert path.duration == pytest.approx(LENGTH / SPEED)
    assert path.cycle_time == pytest.approx(2.0 * path.duration)
    assert path.end == pytest.approx(2 * path.cycle_time)


def test_passes_through_the_points_out_and_back(path):
    s = _point_parameters(path.duration)
    ct = path.cycle_time
    for params in (s, 2 * path.duration - s, ct + s, 2 * ct - s):
        err = np.linalg.norm(_tool(path, params) - POINTS, axis=1)
        # End points are IK samples; the corner lies between samples (spline: < 1.5 mm).
        assert err[[0, 2]] == pytest.approx(0.0, abs=1e-6)
        assert err[1] < 1.5e-3


def test_tool_orientation_held(path):
    for q in joint_path_state(path, np.linspace(0.0, path.end, 97))[0]:
        assert dh_forward_kinematics(q)[:3, :3] == pytest.approx(np.diag([1.0, -1.0, -1.0]),
                                                                 abs=2e-3)


def test_rest_at_start_and_turning_points(path):
    d = path.duration
    turns = np.array([0.0, d, 2 * d, 3 * d, 4 * d])
    _, dq, _ = joint_path_state(path, turns)
    assert np.abs(dq).max() < 1e-9
    _, dq, _ = joint_path_state(path, turns[:-1] + d / 2)
    assert np.all(np.linalg.norm(dq, axis=1) > 0.1)  # moving in between


def test_way_back_retraces_the_way_out(path):
    d, ct = path.duration, path.cycle_time
    u = np.linspace(0.0, d, 41)
    q, dq, _ = joint_path_state(path, u)
    for s, sign in ((2 * d - u, -1), (ct + u, 1), (ct + 2 * d - u, -1)):
        q_b, dq_b, _ = joint_path_state(path, s)
        assert q_b == pytest.approx(q, abs=1e-12)
        assert dq_b == pytest.approx(sign * dq, abs=1e-12)
    assert joint_path_state(path, path.end)[0] == pytest.approx(q[0])  # ends at the start


def test_there_and_back_speed_profile(path):
    s = np.linspace(0.0, path.duration, 401)
    q, dq, _ = joint_path_state(path, s)
    v = np.linalg.norm(tool0_position_and_velocity(q, dq)[1], axis=1)
    assert v.max() == pytest.approx(1.875 * SPEED, rel=0.02)  # minimum-jerk peak
    assert np.trapezoid(v, s) == pytest.approx(LENGTH, rel=0.01)  # mean speed = SPEED


def test_one_way_line_has_uniform_tool_speed():
    ends = POINTS[1:]
    line = polyline_path(ends, speed=0.1, rpy=RPY, seed=SEED)
    length = np.linalg.norm(ends[1] - ends[0])
    assert line.duration == pytest.approx(length / 0.1) and line.end == line.duration
    s = np.linspace(0.05, 0.95, 37) * line.duration
    q, dq, _ = joint_path_state(line, s)
    p, v = tool0_position_and_velocity(q, dq)
    assert np.linalg.norm(v, axis=1) == pytest.approx(0.1, rel=1e-3)
    assert v / 0.1 == pytest.approx(np.tile((ends[1] - ends[0]) / length, (37, 1)), abs=2e-3)
    assert p == pytest.approx(ends[0] + np.outer(s * 0.1 / length, ends[1] - ends[0]), abs=1e-4)


@pytest.mark.parametrize("points", [
    [[2.0, 0.0, 0.0], [2.5, 0.0, 0.0]],          # out of reach from the start
    [[0.40, 0.50, 0.15], [1.50, 0.50, 0.15]],    # runs out of reach on the way
])
def test_unreachable_points_raise(points):
    with pytest.raises(ValueError, match="no inverse kinematics"):
        polyline_path(points, speed=0.1, rpy=RPY, seed=SEED)


@pytest.mark.parametrize("kw, match", [
    (dict(points=[[0.4, 0.5, 0.15]]), "points"),
    (dict(points=[[0.4, 0.5], [0.7, 0.3]]), "points"),
    (dict(speed=0.0), "speed"),
    (dict(points=[[0.4, 0.5, 0.15]] * 2), "length"),
])
def test_bad_arguments_raise(kw, match):
    args = dict(points=POINTS[1:], speed=0.1, rpy=RPY, seed=SEED) | kw
    with pytest.raises(ValueError, match=match):
        polyline_path(**args)


SCENARIO = """
robot:
  cycles: 2
  path:
    task_path: {file: points.yaml, speed: 0.15}
operators:
- name: a
  bodies: [{name: l, point: hand_left, offset: [0, 0.2, 0]},
           {name: r, point: hand_right, offset: [0, -0.2, 0]}]
  waypoints: [{time: 0, position: [2, 0, 1]}]
"""


def _write(tmp_path, points_text):
    cell = tmp_path / "cell"
    cell.mkdir()
    (cell / "scenario.yaml").write_text(SCENARIO)
    if points_text is not None:
        (cell / "points.yaml").write_text(points_text)
    return cell / "scenario.yaml"


def test_load_scenario_reads_points_relative_to_the_scenario(tmp_path, monkeypatch, path):
    scenario_file = _write(tmp_path, "points: " + str(POINTS.tolist()) + "\n")
    monkeypatch.chdir(tmp_path)  # not the scenario's folder
    s = load_scenario("cell/scenario.yaml")
    task = s.robot.path.task_path
    assert task.points == POINTS.tolist() and task.speed == 0.15
    assert load_scenario(scenario_file.resolve()).robot.path.task_path.points == task.points
    built = joint_path(s.robot)  # there and back, robot.cycles times
    assert (built.there_and_back, built.cycles) == (True, 2)
    assert built.end == pytest.approx(path.end)
    s_grid = np.linspace(0.0, path.end, 23)
    assert _tool(built, s_grid) == pytest.approx(_tool(path, s_grid), abs=1e-6)


@pytest.mark.parametrize("points_text, field", [
    ("points: [[0.1, 0.7, 0.15]]\n", "robot.path.task_path.file"),
    ("points: []\n", "robot.path.task_path.file"),
    ("points: [[0.1, 0.7], [0.4, 0.5]]\n", "robot.path.task_path.points"),
    ("points: [[0.1, 0.7, 0.15], [0.4, 0.5, 0.15, 1.0]]\n", "robot.path.task_path.points"),
])
def test_short_file_or_bad_points_name_the_field(tmp_path, points_text, field):
    with pytest.raises(ScenarioError) as e:
        load_scenario(_write(tmp_path, points_text))
    assert e.value.field == field


@pytest.mark.parametrize("points_text", [None, "points: [[0.1, x, 0.15], [0.4, 0.5, 0.1]]\n"])
def test_missing_or_unparsable_file_names_the_field(tmp_path, points_text):
    with pytest.raises(ScenarioError) as e:
        load_scenario(_write(tmp_path, points_text))
    assert e.value.field.startswith("robot.path.task_path")
