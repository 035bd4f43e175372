"""Task-space scenes for the path planners (seed 001, Sections 2.2 and 3): start, goal,
static obstacles and planner settings, and the signed distance rho_i to each obstacle.

Typed YAML loaded strictly with :func:`safety_systems.config.scenario.load_typed` and range
checked by :func:`validate_scene`; every problem is a
:class:`safety_systems.files.input_error.InputError` naming the field. Metres, in the UR5e's
base frame (base at the origin, z up, the table at z = 0). This module must not use
``from __future__ import annotations`` (it breaks Drake's YAML loader).

The seed's Task_Space_Mapping (Section 2.2) builds a binary obstacle map from Mask
R-CNN segmentation; here the obstacles are given as shapes: spheres, axis-aligned boxes
and vertical cylinders standing on the table.
"""

import dataclasses as dc
import typing
from pathlib import Path

import numpy as np

from safety_systems.files.documents import load_document
from safety_systems.files.ranges import SEED_MAX, check_limits, number
from safety_systems.files.input_error import InputError
from safety_systems.cell.ur5e import DH_D

UR5E_REACH = 0.85  # m, from the shoulder (datasheet reach)
UR5E_SHOULDER = np.array([0.0, 0.0, DH_D[0]])  # m, base frame
MAX_EXTENT = 2.0  # m, any coordinate of a scene


@dc.dataclass
class Sphere:
    """A sphere: ``centre`` (m) and ``radius`` (m)."""

    name: str = ""
    centre: list[float] = number([0.0, 0.0, 0.0], ge=-MAX_EXTENT, le=MAX_EXTENT, unit="m")
    radius: float = number(0.03, gt=0.0, le=MAX_EXTENT, unit="m")


@dc.dataclass
class Box:
    """An axis-aligned box: ``centre`` (m) and ``half_sizes`` along x, y, z (m)."""

    name: str = ""
    centre: list[float] = number([0.0, 0.0, 0.0], ge=-MAX_EXTENT, le=MAX_EXTENT, unit="m")
    half_sizes: list[float] = number([0.03, 0.03, 0.03], gt=0.0, le=MAX_EXTENT, unit="m")


@dc.dataclass
class Cylinder:
    """A vertical cylinder standing on the table: axis at (``x``, ``y``) (m), from z = 0
    up to ``height`` (m), of ``radius`` (m)."""

    name: str = ""
    x: float = number(0.0, ge=-MAX_EXTENT, le=MAX_EXTENT, unit="m")
    y: float = number(0.0, ge=-MAX_EXTENT, le=MAX_EXTENT, unit="m")
    radius: float = number(0.03, gt=0.0, le=MAX_EXTENT, unit="m")
    height: float = number(0.20, gt=0.0, le=MAX_EXTENT, unit="m")


@dc.dataclass
class Obstacles:
    """Static obstacles. Their order (spheres, then boxes, then cylinders) numbers them
    O1, O2, ... where a name is empty, and is the order the obstacle-count sweep keeps."""

    spheres: list[Sphere] = dc.field(default_factory=list)
    boxes: list[Box] = dc.field(default_factory=list)
    cylinders: list[Cylinder] = dc.field(default_factory=list)


@dc.dataclass
class PlannerSettings:
    """Settings of the three planners and of the path metrics.

    Field (Eqs. 2-4): ``k_att`` K_att, ``k_rep`` K_rep (seed Section 3.1: 0.03, 0.1),
    ``d_goal`` d*_goal (m, Eq. 2e; the seed gives no value, we take 10 cm), ``zeta``
    the safety threshold zeta_i of Eq. 3b (m from the obstacle's surface, where
    repulsion starts; Table VII: 4-6 cm), ``d_factor_n`` the exponent n (the seed gives
    no value; we take 2) and ``d_factor`` the flag of Eq. 3a; ``field_unit`` (m) the
    unit of every length in Eqs. 2-3 (the seed's centimetres; see
    ``safety_systems.planning.potential_field``). GDA baseline: ``gda_k_att``, ``gda_k_rep``
    (Section 3.3: 1/150 and 900, with d_0 = zeta), no d_factor.
    Descent: ``step`` (m, the largest step), ``max_iterations``; local-minimum escape
    (IAPF only): ``escape_attempts`` wall-following tries of at most ``escape_steps``
    steps each, the tangent drawn from ``numpy.random.default_rng(seed)`` when the goal
    gives none. Optimisation (Eq. 5a): ``omega1`` (per m of length), ``omega2`` (m, per
    unit of bending energy, which is in 1/m), ``opt_points`` control points of the
    optimised cubic B-spline.
    ``clearance``: the hard bound (m from every obstacle's surface) that the IAPF, the
    optimised path and RRT* all keep (see ``safety_systems.planning.path_optimisation``).
    ``workspace_margin``: the bounds L(t), U(t) of Section 2.4: the box around start,
    goal and obstacles grown by this much (m), never below the table (z >= 0).
    RRT* (OMPL): ``rrt_time`` budget (s), ``rrt_max_iterations`` (None: no cap; a cap
    makes a seeded run repeatable), ``rrt_range`` (m, the longest edge).
    Timing: ``max_tool_speed`` (m/s), ``max_tool_acceleration`` (m/s^2) and the arc
    length spacing (m) at which every path is resampled for its metrics.
    The seed gives none of the other values; ours: clearance 2 cm (half the smallest
    zeta of Table VII), omega1 = 1, omega2 = 1 mm (the path stays close to the
    shortest one and smooth), steps of 5 mm, 0.25 m/s (ISO 10218-1's reduced speed) and
    1 m/s^2 for the tool.
    """

    k_att: float = number(0.03, gt=0.0, le=1e6)
    k_rep: float = number(0.1, gt=0.0, le=1e6)
    d_goal: float = number(0.10, gt=0.0, le=MAX_EXTENT, unit="m")
    zeta: float = number(0.04, gt=0.0, le=MAX_EXTENT, unit="m")
    d_factor_n: float = number(2.0, ge=0.0, le=4.0)
    d_factor: bool = True
    field_unit: float = number(0.01, gt=0.0, le=1.0, unit="m")
    gda_k_att: float = number(1.0 / 150.0, gt=0.0, le=1e6)
    gda_k_rep: float = number(900.0, gt=0.0, le=1e6)
    step: float = number(0.005, gt=0.0, le=MAX_EXTENT, unit="m")
    max_iterations: int = number(2000, ge=1, le=10**6)
    escape_attempts: int = number(4, ge=0, le=100)
    escape_steps: int = number(600, ge=1, le=10**5)
    omega1: float = number(1.0, ge=0.0, le=1e6, unit="1/m")
    omega2: float = number(0.001, ge=0.0, le=1e6, unit="m")
    opt_points: int = number(12, ge=4, le=100)
    clearance: float = number(0.02, gt=0.0, le=MAX_EXTENT, unit="m")
    workspace_margin: float = number(0.10, ge=0.0, le=MAX_EXTENT, unit="m")
    rrt_time: float = number(1.0, gt=0.0, le=600.0, unit="s")
    rrt_max_iterations: typing.Optional[int] = number(None, ge=1, le=10**7)
    rrt_range: float = number(0.2, gt=0.0, le=MAX_EXTENT, unit="m")
    max_tool_speed: float = number(0.25, gt=0.0, le=3.0, unit="m/s")
    max_tool_acceleration: float = number(1.0, gt=0.0, le=100.0, unit="m/s^2")
    metric_spacing: float = number(0.005, gt=0.0, le=MAX_EXTENT, unit="m")
    seed: int = number(0, ge=0, le=SEED_MAX)


@dc.dataclass
class TaskScene:
    """A planning problem: ``start`` and ``goal`` tool positions (m, UR5e base frame),
    obstacles and planner settings."""

    name: str = ""
    start: list[float] = number([0.0, 0.0, 0.0], ge=-MAX_EXTENT, le=MAX_EXTENT, unit="m")
    goal: list[float] = number([0.0, 0.0, 0.0], ge=-MAX_EXTENT, le=MAX_EXTENT, unit="m")
    obstacles: Obstacles = dc.field(default_factory=Obstacles)
    planner: PlannerSettings = dc.field(default_factory=PlannerSettings)


@dc.dataclass(frozen=True)
class ObstacleSet:
    """The obstacles as arrays, in the order of :class:`Obstacles` (for vectorised maths)."""

    names: tuple[str, ...]
    sphere_centres: np.ndarray  # (S, 3)
    sphere_radii: np.ndarray  # (S,)
    box_centres: np.ndarray  # (B, 3)
    box_half_sizes: np.ndarray  # (B, 3)
    cylinder_axes: np.ndarray  # (C, 2) x, y
    cylinder_radii: np.ndarray  # (C,)
    cylinder_heights: np.ndarray  # (C,)

    def __len__(self) -> int:
        return len(self.names)


def obstacle_set(obstacles: Obstacles) -> ObstacleSet:
    """The arrays of ``obstacles``; empty names become O1, O2, ... by position."""
    o = obstacles
    given = [s.name for s in o.spheres] + [b.name for b in o.boxes] + [c.name for c in o.cylinders]
    return ObstacleSet(
        names=tuple(n or f"O{i + 1}" for i, n in enumerate(given)),
        sphere_centres=np.array([s.centre for s in o.spheres], dtype=float).reshape(-1, 3),
        sphere_radii=np.array([s.radius for s in o.spheres], dtype=float),
        box_centres=np.array([b.centre for b in o.boxes], dtype=float).reshape(-1, 3),
        box_half_sizes=np.array([b.half_sizes for b in o.boxes], dtype=float).reshape(-1, 3),
        cylinder_axes=np.array([[c.x, c.y] for c in o.cylinders], dtype=float).reshape(-1, 2),
        cylinder_radii=np.array([c.radius for c in o.cylinders], dtype=float),
        cylinder_heights=np.array([c.height for c in o.cylinders], dtype=float))


def _box_distance(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed distance of a centred box from offsets q (..., D) - half sizes, and its
    gradient in q (the sign of the offset is applied by the caller)."""
    outside = np.maximum(q, 0.0)
    norm = np.sqrt((outside * outside).sum(axis=-1))
    top = q.max(axis=-1)
    inside_grad = (q == top[..., None]).astype(float)  # the face nearest from inside
    grad = np.where(norm[..., None] > 0.0, outside / np.maximum(norm, 1e-300)[..., None],
                    inside_grad / inside_grad.sum(axis=-1, keepdims=True))
    return norm + np.minimum(top, 0.0), grad


def signed_distances(points: np.ndarray, obstacles: ObstacleSet
                     ) -> tuple[np.ndarray, np.ndarray]:
    """rho_i (P, N): signed distance (m) of each point (P, 3) from each obstacle's
    surface (negative inside), and its gradient d rho_i / d point (P, N, 3).

    Sphere: |p - c| - r. Box: the exact box distance. Cylinder: the exact distance from
    a finite vertical cylinder over 0 <= z <= height, a 2-D box distance in (radial,
    vertical) coordinates. Gradients are one-sided where the distance has a kink (box
    edges, the cylinder's rim, the centre of a sphere).
    """
    p = np.atleast_2d(np.asarray(points, dtype=float))
    o = obstacles
    rhos, grads = [], []
    if len(o.sphere_radii):
        v = p[:, None, :] - o.sphere_centres[None]
        r = np.sqrt((v * v).sum(axis=-1))
        rhos.append(r - o.sphere_radii)
        unit = v / np.maximum(r, 1e-300)[..., None]
        unit[r == 0.0] = (0.0, 0.0, 1.0)
        grads.append(unit)
    if len(o.box_centres):
        v = p[:, None, :] - o.box_centres[None]
        rho, g = _box_distance(np.abs(v) - o.box_half_sizes[None])
        rhos.append(rho)
        grads.append(np.where(v < 0.0, -g, g))
    if len(o.cylinder_radii):
        v = p[:, None, :2] - o.cylinder_axes[None]
        r = np.sqrt((v * v).sum(axis=-1))
        half = 0.5 * o.cylinder_heights
        dz = p[:, 2:3] - half
        q = np.stack([r - o.cylinder_radii, np.abs(dz) - half], axis=-1)
        rho, g = _box_distance(q)
        grad = np.empty(rho.shape + (3,))
        grad[..., :2] = g[..., :1] * v / np.maximum(r, 1e-300)[..., None]
        grad[..., :2][r == 0.0] = (g[..., 0][r == 0.0])[:, None] * np.array([1.0, 0.0])
        grad[..., 2] = np.where(dz < 0.0, -g[..., 1], g[..., 1])
        rhos.append(rho)
        grads.append(grad)
    if not rhos:
        return np.zeros((len(p), 0)), np.zeros((len(p), 0, 3))
    if len(rhos) == 1:
        return rhos[0], grads[0]
    return np.concatenate(rhos, axis=1), np.concatenate(grads, axis=1)


def clearance(points: np.ndarray, obstacles: ObstacleSet) -> np.ndarray:
    """(P,) the smallest rho_i over the obstacles (m; +inf without obstacles)."""
    rho, _ = signed_distances(points, obstacles)
    return rho.min(axis=1) if rho.shape[1] else np.full(len(rho), np.inf)


def workspace_bounds(scene: TaskScene) -> tuple[np.ndarray, np.ndarray]:
    """L, U (3,) each: the box around start, goal and obstacles, grown by the margin;
    z never below the table."""
    o = obstacle_set(scene.obstacles)
    lo = [np.asarray(scene.start), np.asarray(scene.goal)]
    hi = list(lo)
    lo += [o.sphere_centres - o.sphere_radii[:, None], o.box_centres - o.box_half_sizes]
    hi += [o.sphere_centres + o.sphere_radii[:, None], o.box_centres + o.box_half_sizes]
    r = o.cylinder_radii[:, None]
    lo.append(np.column_stack([o.cylinder_axes - r, np.zeros(len(r))]))
    hi.append(np.column_stack([o.cylinder_axes + r, o.cylinder_heights]))
    m = scene.planner.workspace_margin
    low = np.vstack([np.reshape(a, (-1, 3)) for a in lo]).min(axis=0) - m
    high = np.vstack([np.reshape(a, (-1, 3)) for a in hi]).max(axis=0) + m
    low[2] = max(low[2], 0.0)
    return low, high


def _check(ok: bool, field: str, value: typing.Any, allowed: str) -> None:
    if not ok:
        raise InputError(field, value, allowed)


def _point(field: str, value: list[float]) -> None:
    _check(len(value) == 3, field, value, f"3 numbers in m, each within +-{MAX_EXTENT}")


def validate_scene(scene: TaskScene) -> None:
    """Ranges (``check_limits``) and checks between fields; raises
    :class:`InputError` naming the field."""
    check_limits(scene)
    for name in ("start", "goal"):
        value = getattr(scene, name)
        _point(name, value)
        _check(value[2] >= 0.0, name, value, "a point above the table (z >= 0)")
        reach = float(np.linalg.norm(np.asarray(value) - UR5E_SHOULDER))
        _check(reach <= UR5E_REACH, name, value,
               f"a point within the UR5e's reach ({UR5E_REACH} m from the shoulder at "
               f"z = {UR5E_SHOULDER[2]} m; this one is {reach:.3f} m)")
    _check(scene.start != scene.goal, "goal", scene.goal, "a point other than the start")
    o = scene.obstacles
    for i, s in enumerate(o.spheres):
        _point(f"obstacles.spheres[{i}].centre", s.centre)
    for i, b in enumerate(o.boxes):
        _point(f"obstacles.boxes[{i}].centre", b.centre)
        _check(len(b.half_sizes) == 3, f"obstacles.boxes[{i}].half_sizes", b.half_sizes,
               "3 numbers > 0 in m")
    names = obstacle_set(o).names
    _check(len(set(names)) == len(names), "obstacles", list(names), "unique obstacle names")
    _validate_planner(scene.planner)
    obstacles = obstacle_set(o)
    bound = scene.planner.clearance
    for name in ("start", "goal"):
        gap = float(clearance(np.array([getattr(scene, name)]), obstacles)[0])
        _check(gap >= bound, name, getattr(scene, name),
               f"a point at least planner.clearance = {bound} m from every obstacle "
               f"(this one is {gap:.4f} m)")


def _validate_planner(p: PlannerSettings) -> None:
    f = "planner"
    _check(p.clearance < p.zeta, f"{f}.clearance", p.clearance,
           f"less than planner.zeta ({p.zeta} m): the field must act before the bound")
    _check(p.step <= p.clearance, f"{f}.step", p.step,
           f"at most planner.clearance ({p.clearance} m)")
    _check(p.omega1 + p.omega2 > 0.0, f"{f}.omega1", p.omega1, "omega1 + omega2 > 0")


def load_scene(path: str | Path) -> TaskScene:
    """Load and validate a scene file; raises :class:`InputError`."""
    return load_document(path, TaskScene, validate_scene)
