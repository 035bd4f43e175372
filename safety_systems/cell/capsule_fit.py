"""One capsule per moving link, fitted to all of the link's collision geometry, and an
independent check that each capsule encloses its link's geometry.

A capsule is the set of points within ``radius`` metres of the segment from ``ends[0]``
to ``ends[1]`` (both in its body's frame). It is convex, so it holds a shape when it holds
the balls of :func:`collision_shapes.bounding_points` (mesh vertices, box corners, spheres,
capsule ends, the corners of polygons circumscribed about cylinder rims).

The fit (:func:`fit_capsule`), for an axis line (point o, unit direction d): the radius R
is the largest distance of any ball's centre from the line plus its radius; with R fixed,
the ends are pulled in as far as every ball allows: a ball (centre at t along the line,
rho from it, radius r) needs the ends to reach t -+ sqrt((R - r)^2 - rho^2). The line is
chosen to make the capsule's volume least: Nelder-Mead from each start (the points'
principal axes through their centroid, and the joint-to-joint line when the body has one),
the best kept. R is then rounded up to ``RADIUS_STEP`` (as the UR5e's fit,
``robot_geometry``) and the ends recomputed for it, 1 pm inside every bound.

The check (:func:`enclosure_slack`) recomputes, from the shapes alone, the distance of every
vertex, box corner, sphere and capsule end, and of the corners of a 4096-gon circumscribed
about every cylinder rim (a convex function's maximum over a polygon is at a corner, and
the polygon holds the rim), to the capsule's segment: the slack R - (distance + r) is
>= 0 where the shape is inside.
"""

import dataclasses
import math

import numpy as np
from scipy.optimize import minimize
from scipy.spatial import ConvexHull, QhullError

from safety_systems.cell.collision_shapes import _circumscribed_rim, bounding_points

RADIUS_STEP = 0.0005  # m; fitted radii are rounded up to it
CHECK_RIM_CORNERS = 4096  # corners of the polygons the check circumscribes about rims
_INSIDE = 1e-12  # m; the fitted ends stay this far inside every ball's bound


@dataclasses.dataclass(frozen=True, eq=False)
class LinkCapsules:
    """K capsules: link ``names``, ``bodies`` (K,) (1 ... n, as the RobotDescription's),
    ``ends`` (K, 2, 3) in the body's frame and ``radius`` (K,), metres."""

    names: tuple[str, ...]
    bodies: np.ndarray
    ends: np.ndarray
    radius: np.ndarray

    def __post_init__(self) -> None:
        for field, kind in (("bodies", np.int64), ("ends", float), ("radius", float)):
            value = np.array(getattr(self, field), dtype=kind)
            value.setflags(write=False)
            object.__setattr__(self, field, value)
        K = len(self.names)
        if self.bodies.shape != (K,) or self.ends.shape != (K, 2, 3) or self.radius.shape != (K,):
            raise ValueError(f"LinkCapsules of {K} names: bodies {self.bodies.shape}, ends "
                             f"{self.ends.shape}, radius {self.radius.shape}; need (K,), "
                             "(K, 2, 3), (K,)")


def _ends_for(t, rho, r, R):
    """(t0, t1) of the shortest segment on the line within R - r of every ball, or None."""
    h = np.sqrt(np.maximum((R - r - _INSIDE) ** 2 - rho * rho, 0.0))
    t0, t1 = float(np.min(t + h)), float(np.max(t - h))
    return (t0, t1) if t0 <= t1 else None


def _capsule_on_line(o, d, centres, radii):
    """(volume, a, b, R) of the least capsule on the line o + t d (d unit) holding the balls."""
    rel = centres - o
    t = rel @ d
    rho = np.linalg.norm(rel - np.outer(t, d), axis=1)
    R = float(np.max(rho + radii))
    ends = _ends_for(t, rho, radii, R)
    if ends is None:  # every ball fits in one sphere on the line: its centre, mid-range
        m = 0.5 * (float(np.min(t + np.sqrt(np.maximum(R * R - rho * rho, 0.0))))
                   + float(np.max(t - np.sqrt(np.maximum(R * R - rho * rho, 0.0)))))
        R = float(np.max(np.linalg.norm(centres - (o + m * d), axis=1) + radii))
        ends = (m, m)
    a, b = o + ends[0] * d, o + ends[1] * d
    return math.pi * R * R * (ends[1] - ends[0]) + 4.0 / 3.0 * math.pi * R**3, a, b, R


def _frame(d):
    d = d / np.linalg.norm(d)
    u = np.cross(d, [1.0, 0.0, 0.0] if abs(d[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    return d, u, np.cross(d, u)


def _reduced(centres, radii):
    """The balls whose convex hull is the same: the hull's vertices of the point balls."""
    points = radii == 0.0
    if np.count_nonzero(points) >= 5:
        try:
            keep = ConvexHull(centres[points]).vertices
            centres = np.vstack([centres[points][keep], centres[~points]])
            radii = np.concatenate([np.zeros(keep.size), radii[~points]])
        except QhullError:  # flat or degenerate: keep them all
            pass
    return centres, radii


def fit_capsule(centres: np.ndarray, radii: np.ndarray, *, axis_hints=(),
                step: float = RADIUS_STEP) -> tuple[np.ndarray, np.ndarray, float]:
    """(a, b, radius): a capsule holding every ball (centres (m, 3), radii (m,), metres),
    its axis line chosen for least volume from the principal axes and the lines in
    ``axis_hints`` ((point, direction) pairs), its radius rounded up to ``step`` (see
    the module docstring)."""
    centres, radii = _reduced(np.asarray(centres, float), np.asarray(radii, float))
    centroid = centres.mean(axis=0)
    spread = centres - centroid
    starts = [(centroid, axis) for axis in (np.linalg.svd(spread)[2] if len(centres) > 1
                                            else np.eye(3))]
    starts += [(np.asarray(p, float), np.asarray(d, float)) for p, d in axis_hints]
    best = None
    for o0, d0 in starts:
        d0, u, w = _frame(d0)

        def volume(x, o0=o0, d0=d0, u=u, w=w):
            d = d0 + x[0] * u + x[1] * w
            return _capsule_on_line(o0 + x[2] * u + x[3] * w, d / np.linalg.norm(d),
                                    centres, radii)[0]

        x = minimize(volume, np.zeros(4), method="Nelder-Mead",
                     options={"xatol": 1e-7, "fatol": 1e-12, "maxiter": 2000}).x
        if volume(x) > volume(np.zeros(4)):
            x = np.zeros(4)
        d = d0 + x[0] * u + x[1] * w
        candidate = _capsule_on_line(o0 + x[2] * u + x[3] * w, d / np.linalg.norm(d),
                                     centres, radii)
        if best is None or candidate[0] < best[0]:
            best = candidate
    _, a, b, R = best
    R_step = math.ceil(R / step - 1e-9) * step
    if R_step < R:
        R_step += step
    length = float(np.linalg.norm(b - a))
    d = (b - a) / length if length > 0.0 else np.array([0.0, 0.0, 1.0])
    rel = centres - a
    t = rel @ d
    rho = np.linalg.norm(rel - np.outer(t, d), axis=1)
    ends = _ends_for(t, rho, radii, R_step)
    if ends is None:
        ends = (0.5 * length, 0.5 * length)
    return a + ends[0] * d, a + ends[1] * d, float(R_step)


def _segment_distances(points, a, b):
    """Distances (m,) of points (m, 3) from the segment ab."""
    e = b - a
    ee = float(e @ e)
    t = np.zeros(len(points)) if ee == 0.0 else np.clip((points - a) @ e / ee, 0.0, 1.0)
    return np.linalg.norm(points - (a + np.outer(t, e)), axis=1)


def _joint_line(description, body: int):
    """(point, direction) from body's origin to the next joint's origin, or None."""
    if body >= description.num_joints:
        end = description.X_tool[:3, 3]
    else:
        end = description.X_parent[body][:3, 3]
    return None if np.linalg.norm(end) < 1e-6 else (np.zeros(3), end)


def fit_link_capsules(description, *, step: float = RADIUS_STEP) -> LinkCapsules:
    """One capsule per link with collision geometry on the chain's moving bodies of a
    :class:`RobotDescription`, in its body's frame (:func:`fit_capsule`; the
    joint-to-joint line of the body is one of the starts)."""
    ends, radius = [], []
    for body, shapes in zip(description.collision_bodies, description.collision_shapes):
        centres, radii = bounding_points(shapes)
        line = _joint_line(description, int(body))
        a, b, r = fit_capsule(centres, radii, axis_hints=() if line is None else (line,),
                              step=step)
        ends.append((a, b))
        radius.append(r)
    return LinkCapsules(description.collision_links, description.collision_bodies,
                        np.array(ends).reshape(-1, 2, 3), np.array(radius))


def shape_slack(shape, a: np.ndarray, b: np.ndarray, radius: float) -> float:
    """The least of radius - (distance to segment ab + own radius) over one shape's
    vertices, corners, spheres and the corners of 4096-gons circumscribed about its rims
    (metres; >= 0: the shape is inside the capsule)."""
    R, p = shape.X_BG[:3, :3], shape.X_BG[:3, 3]
    if shape.kind == "mesh":
        local, r = shape.vertices, 0.0
    elif shape.kind == "box":
        local = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
                         ) * (np.array(shape.size) / 2)
        r = 0.0
    elif shape.kind == "sphere":
        local, r = np.zeros((1, 3)), shape.size[0]
    elif shape.kind == "capsule":
        local, r = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.0]]) * shape.size[1] / 2, shape.size[0]
    else:
        half = shape.size[1] / 2
        local = np.vstack([_circumscribed_rim(np.array([0.0, 0.0, z]), np.array([1.0, 0, 0]),
                                              np.array([0.0, 1.0, 0.0]), shape.size[0],
                                              CHECK_RIM_CORNERS) for z in (-half, half)])
        r = 0.0
    return float(radius - np.max(_segment_distances(local @ R.T + p, a, b) + r))


def enclosure_slack(description, capsules: LinkCapsules) -> np.ndarray:
    """The worst slack (K,), metres, of each capsule over its link's collision shapes
    (:func:`shape_slack`): >= 0 everywhere means every capsule encloses its link."""
    by_link = dict(zip(description.collision_links, description.collision_shapes))
    return np.array([min(shape_slack(s, capsules.ends[j, 0], capsules.ends[j, 1],
                                     float(capsules.radius[j])) for s in by_link[name])
                     for j, name in enumerate(capsules.names)])
