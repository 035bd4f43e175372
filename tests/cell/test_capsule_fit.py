"""Capsules fitted to every shipped robot enclose every link's collision geometry, and the
check fails when a vertex or a primitive is moved outside its capsule."""

import dataclasses
import functools

import numpy as np
import pytest

from safety_systems.cell import ur_family
from safety_systems.cell.capsule_fit import (
    RADIUS_STEP,
    enclosure_slack,
    fit_capsule,
    fit_link_capsules,
    shape_slack,
)
from safety_systems.cell.collision_shapes import CollisionShape
from safety_systems.cell.robot_description import load_robot_description

ROBOTS = {**{name: robot.urdf for name, robot in ur_family.UR_ROBOTS.items()},
          "panda": ur_family.MODELS / "panda" / "panda.urdf"}


@functools.cache
def fitted(name):
    description = load_robot_description(ROBOTS[name])
    return description, fit_link_capsules(description)


@pytest.mark.parametrize("name", list(ROBOTS))
def test_every_link_inside_its_capsule(name):
    description, capsules = fitted(name)
    slack = enclosure_slack(description, capsules)
    assert capsules.names == description.collision_links
    assert np.all(slack >= 0.0), dict(zip(capsules.names, slack))
    steps = capsules.radius / RADIUS_STEP
    np.testing.assert_allclose(steps, np.round(steps), rtol=0, atol=1e-9)


def _outside(shape, a, b, radius):
    """``shape`` with one vertex (mesh) or its whole self (primitive) moved 1 mm beyond
    the capsule, away from the segment."""
    mid = (a + b) / 2
    if shape.kind == "mesh":
        vertices = shape.vertices.copy()
        R, p = shape.X_BG[:3, :3], shape.X_BG[:3, 3]
        world = vertices @ R.T + p
        j = int(np.argmax(np.linalg.norm(world - mid, axis=1)))
        e = np.cross(b - a, [0.0, 0.0, 1.0]) if np.linalg.norm(np.cross(b - a, [0, 0, 1])) > 1e-6 \
            else np.array([1.0, 0.0, 0.0])
        e /= np.linalg.norm(e)
        target = mid + (radius + 0.001) * e
        vertices[j] = R.T @ (target - p)
        return dataclasses.replace(shape, vertices=vertices)
    X = shape.X_BG.copy()
    X[:3, 3] += (b - a) + np.sign(b - a + 1e-9) * (radius + 0.001)  # beyond the far end
    return dataclasses.replace(shape, X_BG=X)


@pytest.mark.parametrize("name", ["ur5e", "panda"])
def test_check_fails_on_geometry_moved_outside(name):
    """Mutated geometry: one link's shape moved (a mesh vertex, or a UR cylinder) beyond its
    capsule makes that link's slack negative, and only that link's."""
    description, capsules = fitted(name)
    j = len(capsules.names) // 2
    shapes = list(description.collision_shapes[j])
    shapes[0] = _outside(shapes[0], capsules.ends[j, 0], capsules.ends[j, 1], capsules.radius[j])
    mutated = dataclasses.replace(description, collision_shapes=(
        *description.collision_shapes[:j], tuple(shapes), *description.collision_shapes[j + 1:]))
    slack = enclosure_slack(mutated, capsules)
    assert slack[j] < -0.0009
    assert np.all(np.delete(slack, j) >= 0.0)


def test_primitive_slacks_are_exact():
    """Box corners, a sphere and a capsule primitive: the slack is radius minus the extreme
    distance, derived by hand for a capsule along z from 0 to 1."""
    a, b, X = np.zeros(3), np.array([0.0, 0.0, 1.0]), np.eye(4)
    box = CollisionShape("l", "box", X, (0.2, 0.4, 0.4))
    assert shape_slack(box, a, b, 0.5) == pytest.approx(0.5 - np.sqrt(0.1**2 + 0.2**2 + 0.2**2), abs=1e-15)
    X_up = X.copy()
    X_up[:3, 3] = (0.3, 0.0, 1.1)
    sphere = CollisionShape("l", "sphere", X_up, (0.1,))
    assert shape_slack(sphere, a, b, 0.5) == pytest.approx(0.5 - np.hypot(0.3, 0.1) - 0.1)
    X_mid = X.copy()
    X_mid[:3, 3] = (0.1, 0.0, 0.5)
    capsule = CollisionShape("l", "capsule", X_mid, (0.2, 1.4))  # ends 0.2 beyond a and b
    assert shape_slack(capsule, a, b, 0.5) == pytest.approx(0.5 - np.hypot(0.1, 0.2) - 0.2)
    cylinder = CollisionShape("l", "cylinder", X, (0.25, 1.0))  # rims at z = +-0.5
    assert shape_slack(cylinder, a, b, 0.6) == pytest.approx(0.6 - np.hypot(0.25, 0.5), abs=1e-6)
    assert shape_slack(cylinder, a, b, 0.6) <= 0.6 - np.hypot(0.25, 0.5)  # sound: never more


def test_fit_encloses_random_balls_and_is_tight():
    """Random point clouds and balls: the fitted capsule holds all of them (distance to
    its segment + ball radius <= radius), and is no wider than a step beyond the widest
    ball's distance from the fitted axis."""
    rng = np.random.default_rng(11)
    for _ in range(20):
        centres = rng.normal(size=(40, 3)) * rng.uniform(0.01, 0.3, 3)
        radii = np.where(rng.random(40) < 0.2, rng.uniform(0, 0.05, 40), 0.0)
        a, b, r = fit_capsule(centres, radii)
        e = b - a
        t = np.clip((centres - a) @ e / max(e @ e, 1e-300), 0, 1)
        d = np.linalg.norm(centres - (a + np.outer(t, e)), axis=1)
        assert np.all(d + radii <= r)
        assert r - np.max(d + radii) < RADIUS_STEP + 1e-9


def test_ur5e_capsules_near_the_cylinder_fit():
    """The generic fit on the UR5e's cylinders: radii within 1 mm of robot_geometry's
    DH-axis fit (not identical: a different axis search and a polygon about each rim)."""
    from safety_systems.cell.robot_geometry import model_link_capsules

    _, capsules = fitted("ur5e")
    old = np.array([c[4] for c in model_link_capsules()])
    assert np.all(np.abs(capsules.radius - old) <= 0.001), (capsules.radius, old)
