"""The planners of seed 001: IAPF with its escape, the GDA baseline, Eq. 5's
optimisation and RRT*; and the path metrics."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from safety_systems.planning.path_metrics import (
    bending_energy,
    bending_energy_and_gradient,
    dense_points,
    length_gradient,
    min_clearance,
    path_length,
    resample,
    time_to_goal,
)
from safety_systems.planning.path_optimisation import plan_optimised
from safety_systems.planning.planners import plan_gda, plan_iapf
from safety_systems.planning.rrt_star import plan_rrt_star
from safety_systems.planning.task_space import (
    Cylinder,
    Obstacles,
    PlannerSettings,
    TaskScene,
    clearance,
    load_scene,
    obstacle_set,
    validate_scene,
    workspace_bounds,
)

PAPER = Path(__file__).parents[1] / "models" / "scenes" / "paper.yaml"
CAPPED_RRT = {"rrt_time": 30.0, "rrt_max_iterations": 600}  # repeatable, time-independent


def _capped(scene: TaskScene) -> TaskScene:
    return dataclasses.replace(scene, planner=dataclasses.replace(scene.planner, **CAPPED_RRT))


@pytest.fixture(scope="module")
def paper():
    scene = _capped(load_scene(PAPER))
    iapf = plan_iapf(scene)
    return scene, {"IAPF": iapf, "IAPF+opt": plan_optimised(scene, iapf),
                   "GDA": plan_gda(scene), "RRT*": plan_rrt_star(scene)}


def u_trap() -> TaskScene:
    """Tall cylinders in a U open towards the start, the goal straight behind its
    bottom, start and goal at one height: a true local minimum of plain APF at the
    bottom of the U, symmetric about y = 0.3 and flat in z."""
    wall = [(0.45, y) for y in np.arange(0.15, 0.451, 0.05)]
    arms = [(x, y) for x in (0.30, 0.35, 0.40) for y in (0.15, 0.45)]
    scene = TaskScene(name="u_trap", start=[0.20, 0.30, 0.20], goal=[0.70, 0.30, 0.20],
                      obstacles=Obstacles(cylinders=[
                          Cylinder(x=float(x), y=float(y), radius=0.03, height=0.40)
                          for x, y in wall + arms]),
                      planner=PlannerSettings())
    validate_scene(scene)
    return scene


def _keeps_clearance(points, scene):
    """Dense (0.5 mm) check along every segment, not only at the vertices."""
    return min_clearance(points, obstacle_set(scene.obstacles), spacing=0.0005)


@pytest.mark.parametrize("name", ["IAPF", "IAPF+opt", "RRT*"])
def test_paths_reach_the_goal_and_keep_the_clearance_bound(paper, name):
    scene, paths = paper
    path = paths[name]
    assert path.reached_goal, path.note
    np.testing.assert_allclose(path.points[0], scene.start)
    np.testing.assert_allclose(path.points[-1], scene.goal)
    assert _keeps_clearance(path.points, scene) >= scene.planner.clearance
    low, high = workspace_bounds(scene)
    assert (path.points >= low - 1e-9).all() and (path.points <= high + 1e-9).all()


def test_iapf_steps_are_bounded_and_no_segment_cuts_an_obstacle(paper):
    scene, paths = paper
    steps = np.linalg.norm(np.diff(paths["IAPF"].points, axis=0), axis=1)
    assert steps.max() <= scene.planner.step + 1e-12
    # The dense check sees what vertices alone would miss: a chord through O1 does not pass.
    chord = np.array([[0.25, 0.55, 0.1], [0.35, 0.55, 0.1]])
    assert clearance(chord, obstacle_set(scene.obstacles)).min() > 0.0
    assert _keeps_clearance(chord, scene) < 0.0


def test_optimised_path_is_no_longer_and_less_bent_than_its_iapf_start(paper):
    scene, paths = paper
    spacing = scene.planner.metric_spacing
    iapf, opt = paths["IAPF"].points, paths["IAPF+opt"].points
    assert path_length(opt) <= path_length(iapf)
    assert bending_energy(resample(opt, spacing)) < bending_energy(resample(iapf, spacing))
    # ...and it runs to the goal sooner at the same tool limits.
    p = scene.planner
    assert (time_to_goal(resample(opt, spacing), p.max_tool_speed, p.max_tool_acceleration)
            < time_to_goal(resample(iapf, spacing), p.max_tool_speed,
                           p.max_tool_acceleration))


def test_gda_reaches_the_goal_on_the_paper_scene_but_more_slowly(paper):
    scene, paths = paper
    p, spacing = scene.planner, scene.planner.metric_spacing
    assert paths["GDA"].reached_goal

    def t(name):
        return time_to_goal(resample(paths[name].points, spacing), p.max_tool_speed,
                            p.max_tool_acceleration)

    assert t("GDA") > t("IAPF+opt")


def test_escape_leaves_the_local_minimum_that_traps_plain_apf():
    scene = u_trap()
    gda = plan_gda(scene)
    assert not gda.reached_goal and "trapped" in gda.note
    assert np.linalg.norm(gda.points[-1] - scene.goal) > 0.25  # stuck inside the U
    assert gda.points[-1][0] < 0.45
    iapf = plan_iapf(scene)
    assert iapf.reached_goal, iapf.note
    assert iapf.escapes >= 1
    assert _keeps_clearance(iapf.points, scene) >= scene.planner.clearance
    # Without the escape (no attempts allowed) the IAPF is trapped too.
    no_escape = dataclasses.replace(scene, planner=dataclasses.replace(
        scene.planner, escape_attempts=0))
    assert not plan_iapf(no_escape).reached_goal


def test_escape_is_repeatable_for_a_seed():
    scene = u_trap()
    np.testing.assert_array_equal(plan_iapf(scene).points, plan_iapf(scene).points)


def test_rrt_star_is_repeatable_for_a_seed_with_an_iteration_cap():
    scene = dataclasses.replace(_capped(load_scene(PAPER)), planner=dataclasses.replace(
        _capped(load_scene(PAPER)).planner, rrt_max_iterations=150))
    a, b = plan_rrt_star(scene), plan_rrt_star(scene)
    np.testing.assert_array_equal(a.points, b.points)
    other = plan_rrt_star(dataclasses.replace(scene, planner=dataclasses.replace(
        scene.planner, seed=7)))
    assert a.points.shape != other.points.shape or not np.array_equal(a.points, other.points)


def test_bending_energy_and_length_gradients_match_finite_differences():
    rng = np.random.default_rng(5)
    p = np.cumsum(rng.uniform(0.005, 0.02, size=(12, 3)), axis=0)
    _, grad = bending_energy_and_gradient(p)
    np.testing.assert_allclose(grad, _numeric_gradient(bending_energy, p), rtol=1e-5,
                               atol=1e-6)
    np.testing.assert_allclose(length_gradient(p), _numeric_gradient(path_length, p),
                               rtol=1e-6, atol=1e-9)


def _numeric_gradient(f, p, h=1e-7):
    """Central differences of the scalar f over every entry of the points p (K, 3)."""
    steps = np.eye(p.size).reshape(p.size, *p.shape) * h
    return np.array([(f(p + e) - f(p - e)) / (2 * h) for e in steps]).reshape(p.shape)


def test_bending_energy_of_a_circular_arc_is_its_integral():
    # An arc of radius R through angle theta: integral of kappa^2 ds = theta / R, less
    # the two end half-segments (no vertex there): a fraction 1 / (K - 1) of it.
    radius, theta, k = 0.1, np.pi / 2, 400
    angles = np.linspace(0.0, theta, k)
    arc = radius * np.column_stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)])
    assert bending_energy(arc) == pytest.approx(theta / radius * (k - 2) / (k - 1), rel=1e-4)
    assert bending_energy(np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0.0]])) == 0.0


def test_time_to_goal_on_a_line_and_round_a_corner():
    line = resample(np.array([[0.0, 0, 0], [0.5, 0, 0]]), 0.005)
    # Trapezoid: accelerate to 0.25 m/s in 0.25 s over 3.125 cm, cruise, brake.
    assert time_to_goal(line, 0.25, 1.0) == pytest.approx(0.5 / 0.25 + 0.25 / 1.0, rel=1e-9)
    short = resample(np.array([[0.0, 0, 0], [0.04, 0, 0]]), 0.005)  # never reaches 0.25
    assert time_to_goal(short, 0.25, 1.0) == pytest.approx(2 * np.sqrt(0.04 / 1.0))
    corner = resample(np.array([[0.0, 0, 0], [0.25, 0, 0], [0.25, 0.25, 0]]), 0.005)
    assert time_to_goal(corner, 0.25, 1.0) > time_to_goal(line, 0.25, 1.0) + 0.1


def test_dense_points_cover_every_segment():
    points = np.array([[0.0, 0, 0], [0.01, 0, 0], [0.01, 0.003, 0]])
    dense = dense_points(points, 0.001)
    assert len(dense) == 1 + 10 + 3
    assert np.linalg.norm(np.diff(dense, axis=0), axis=1).max() <= 0.001 + 1e-15
