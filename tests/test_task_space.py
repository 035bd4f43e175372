"""Task-space scenes: strict loading, range checks, and the obstacle distances."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed

from safety_systems.config.scenario import ScenarioError
from safety_systems.planning.task_space import (
    Box,
    Cylinder,
    Obstacles,
    Sphere,
    TaskScene,
    clearance,
    load_scene,
    obstacle_set,
    signed_distances,
    validate_scene,
    workspace_bounds,
)

PAPER = Path(__file__).parents[1] / "models" / "scenes" / "paper.yaml"


def test_paper_scene_in_metres():
    s = load_scene(PAPER)
    assert s.start == [0.10, 0.70, 0.15] and s.goal == [0.70, 0.30, 0.05]
    assert [(c.x, c.y, c.height) for c in s.obstacles.cylinders] == [
        (0.30, 0.55, 0.20), (0.25, 0.30, 0.20), (0.52, 0.50, 0.20), (0.55, 0.20, 0.20)]
    assert all(c.radius == 0.03 for c in s.obstacles.cylinders)
    assert s.planner.k_att == 0.03 and s.planner.k_rep == 0.1
    assert obstacle_set(s.obstacles).names == ("O1", "O2", "O3", "O4")
    # 72.8 cm straight, as the seed's Table VIII paths of 78-80 cm suggest.
    assert np.linalg.norm(np.subtract(s.goal, s.start)) == pytest.approx(0.728, abs=1e-3)
    assert yaml_load_typed(schema=TaskScene, data=yaml_dump_typed(s)) == s


def _scene(text: str, tmp_path) -> TaskScene:
    path = tmp_path / "scene.yaml"
    path.write_text(text)
    return load_scene(path)


OK = "start: [0.1, 0.7, 0.15]\ngoal: [0.7, 0.3, 0.05]\n"


@pytest.mark.parametrize("text, field", [
    (OK + "obstacles: {cones: []}\n", "obstacles.cones"),
    (OK + "planner: {k_att: x}\n", "planner.k_att"),
    (OK + "planner: {k_rep: -0.1}\n", "planner.k_rep"),
    (OK + "planner: {clearance: 0.05}\n", "planner.clearance"),
    (OK + "planner: {step: 0.05}\n", "planner.step"),
    (OK + "planner: {seed: -1}\n", "planner.seed"),
    (OK + "planner: {opt_points: 2}\n", "planner.opt_points"),
    (OK + "obstacles: {cylinders: [{x: 0.3, y: 0.5, radius: 0}]}\n",
     "obstacles.cylinders[0].radius"),
    (OK + "obstacles: {boxes: [{centre: [0.3, 0.5, 0.1], half_sizes: [0.1, 0.1]}]}\n",
     "obstacles.boxes[0].half_sizes"),
    (OK + "obstacles: {spheres: [{centre: [0.1, 0.7, 0.16], radius: 0.02}]}\n", "start"),
    ("start: [0.1, 0.7, 0.15]\ngoal: [0.9, 0.3, 0.05]\n", "goal"),  # out of reach
    ("start: [0.1, 0.7, -0.1]\ngoal: [0.7, 0.3, 0.05]\n", "start"),  # under the table
    ("start: [0.1, 0.7]\ngoal: [0.7, 0.3, 0.05]\n", "start"),
])
def test_bad_values_name_the_field(tmp_path, text, field):
    with pytest.raises(ScenarioError) as e:
        _scene(text, tmp_path)
    assert e.value.field == field
    assert "allowed" in str(e.value) and "\n" not in str(e.value)


def test_reach_is_checked_from_the_shoulder():
    s = load_scene(PAPER)
    validate_scene(dataclasses.replace(s, goal=[0.84, 0.0, 0.1625]))
    with pytest.raises(ScenarioError, match="reach"):
        validate_scene(dataclasses.replace(s, goal=[0.86, 0.0, 0.1625]))


OBSTACLES = obstacle_set(Obstacles(
    spheres=[Sphere(centre=[0.3, 0.2, 0.3], radius=0.05)],
    boxes=[Box(centre=[0.5, 0.0, 0.1], half_sizes=[0.05, 0.1, 0.02])],
    cylinders=[Cylinder(x=0.0, y=0.5, radius=0.04, height=0.2)]))


def test_distances_by_hand():
    points = np.array([
        [0.3, 0.2, 0.4],  # 5 cm above the sphere
        [0.5, 0.0, 0.15],  # 3 cm above the box's top face
        [0.58, 0.13, 0.1],  # off the box's vertical edge by (3, 3) cm
        [0.5, 0.0, 0.1],  # the box's centre: 2 cm inside
        [0.1, 0.5, 0.1],  # 6 cm from the cylinder's side
        [0.0, 0.5, 0.25],  # 5 cm above its top
        [0.07, 0.5, 0.24],  # off its rim by (3, 4) cm
    ])
    rho, _ = signed_distances(points, OBSTACLES)
    expected = [0.05, 0.03, np.hypot(0.03, 0.03), -0.02, 0.06, 0.05, 0.05]
    found = [rho[0, 0], rho[1, 1], rho[2, 1], rho[3, 1], rho[4, 2], rho[5, 2], rho[6, 2]]
    np.testing.assert_allclose(found, expected, atol=1e-12)
    np.testing.assert_allclose(clearance(points[:1], OBSTACLES), [0.05])


def test_distance_gradients_match_finite_differences():
    rng = np.random.default_rng(1)
    points = rng.uniform([-0.1, -0.2, 0.0], [0.7, 0.7, 0.4], size=(400, 3))
    _, grad = signed_distances(points, OBSTACLES)
    h = 1e-7
    numeric = np.stack([(signed_distances(points + h * e, OBSTACLES)[0]
                         - signed_distances(points - h * e, OBSTACLES)[0]) / (2 * h)
                        for e in np.eye(3)], axis=-1)
    # Away from the kinks (edges, rims, medial surfaces) the two agree.
    smooth = np.abs(numeric - grad).max(axis=-1) < 1e-4
    assert smooth.mean() > 0.97
    np.testing.assert_allclose(np.linalg.norm(grad[smooth], axis=-1), 1.0, atol=1e-6)
    for k in range(3):  # every shape has points on both sides of its surface
        assert smooth[:, k].sum() > 300
    # Inside points count too: the gradient points to the nearest face.
    inside = np.array([[0.5, 0.0, 0.11], [0.0, 0.5, 0.1], [0.31, 0.2, 0.3]])
    rho_in, grad_in = signed_distances(inside, OBSTACLES)
    assert (rho_in[[0, 1, 2], [1, 2, 0]] < 0).all()
    np.testing.assert_allclose(grad_in[0, 1], [0, 0, 1], atol=1e-12)


def test_workspace_bounds_hold_everything_above_the_table():
    s = load_scene(PAPER)
    low, high = workspace_bounds(s)
    assert low[2] == 0.0
    assert (low <= np.minimum(s.start, s.goal)).all()
    assert (high >= np.maximum(s.start, s.goal)).all()
    assert high[2] >= 0.2 + s.planner.workspace_margin - 1e-12
