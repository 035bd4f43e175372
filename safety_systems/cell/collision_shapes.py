"""A URDF link's collision geometry: the shapes as records, and the points that bound them.

Shapes: box, sphere, cylinder, capsule (Drake's URDF extension) and meshes (STL, OBJ, DAE,
read with trimesh; ``<mesh scale>`` honoured). Each shape is kept with its pose X_BG in its
body's frame (the link's frame, or the frame of the moving link it is welded to).

:func:`bounding_points` turns shapes into balls (centre, radius) whose convex hull
contains them: a mesh's vertices and a box's corners (radius 0: the convex hull of the
vertices contains the solid), a sphere (itself), a capsule (its two end spheres), a
cylinder (each rim circle replaced by the regular polygon circumscribed about it, whose
corners lie r / cos(pi / n) from the axis: the polygon contains the circle). A convex set
(a capsule) holding every ball holds the shapes.
"""

import dataclasses
import math
from pathlib import Path

import numpy as np

from safety_systems.files.input_error import InputError

RIM_CORNERS = 64  # corners of the polygon circumscribed about a cylinder's rim
KINDS = ("box", "sphere", "cylinder", "capsule", "mesh")


@dataclasses.dataclass(frozen=True, eq=False)
class CollisionShape:
    """One collision shape of link ``link``: ``kind`` (one of ``KINDS``), its pose X_BG
    (4, 4) in its body's frame, and its size in metres: ``size`` (box: 3 edge lengths;
    sphere: radius; cylinder, capsule: radius, length) or ``vertices`` (mesh: (m, 3), in
    the shape's frame, scale applied) and the mesh ``file``."""

    link: str
    kind: str
    X_BG: np.ndarray
    size: tuple[float, ...] = ()
    vertices: np.ndarray | None = None
    file: str = ""

    def moved(self, X_AB: np.ndarray) -> "CollisionShape":
        """This shape with its pose in frame A, X_AG = X_AB X_BG."""
        return dataclasses.replace(self, X_BG=np.asarray(X_AB) @ self.X_BG)


def origin_transform(element, *, file: Path, field: str) -> np.ndarray:
    """X (4, 4) of a URDF ``<origin xyz rpy>`` (missing: identity): R = Rz(y) Ry(p) Rx(r)."""
    X = np.eye(4)
    if element is None:
        return X
    xyz = _numbers(element.get("xyz", "0 0 0"), 3, file=file, field=f"{field}.origin.xyz")
    roll, pitch, yaw = _numbers(element.get("rpy", "0 0 0"), 3, file=file,
                                field=f"{field}.origin.rpy")
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    X[:3, :3] = [[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                 [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                 [-sp, cp * sr, cp * cr]]
    X[:3, 3] = xyz
    return X


def _numbers(text: str | None, count: int, *, file: Path, field: str) -> tuple[float, ...]:
    try:
        values = tuple(float(x) for x in (text or "").split())
    except ValueError:
        values = ()
    if len(values) != count or not all(map(math.isfinite, values)):
        raise InputError(field, text, f"{count} finite numbers", file=file)
    return values


def _positive(element, attribute: str, *, file: Path, field: str) -> float:
    (value,) = _numbers(element.get(attribute), 1, file=file, field=f"{field}.{attribute}")
    if value <= 0.0:
        raise InputError(f"{field}.{attribute}", value, "a length > 0 metres", file=file)
    return value


def mesh_vertices(path: Path, scale: tuple[float, float, float], *, file: Path,
                  field: str) -> np.ndarray:
    """The vertices (m, 3) of the mesh file ``path`` (STL, OBJ or DAE, read by trimesh;
    a scene's parts placed by its transforms) times ``scale``."""
    import trimesh

    if not path.is_file():
        raise InputError(field, str(path), "an existing mesh file (STL, OBJ or DAE)", file=file)
    if path.suffix.lower() not in (".stl", ".obj", ".dae"):
        raise InputError(field, str(path), "a mesh file ending .stl, .obj or .dae", file=file)
    try:
        mesh = trimesh.load(str(path), force="mesh")
        vertices = np.asarray(mesh.vertices, dtype=float)
    except Exception as error:
        raise InputError(field, f"{path} ({' '.join(str(error).split())})",
                         "a mesh file trimesh reads (STL, OBJ or DAE)", file=file) from error
    if vertices.ndim != 2 or vertices.shape[0] == 0 or not np.all(np.isfinite(vertices)):
        raise InputError(field, str(path), "a mesh with finite vertices", file=file)
    return vertices * np.asarray(scale, dtype=float)


def read_collisions(link, *, file: Path, resolve) -> tuple[CollisionShape, ...]:
    """The collision shapes of URDF ``<link>`` element ``link``, posed in the link's frame;
    ``resolve(filename, field)`` turns a mesh filename into a path."""
    name = link.get("name")
    shapes = []
    for k, collision in enumerate(link.findall("collision")):
        field = f"link {name}.collision[{k}]"
        X = origin_transform(collision.find("origin"), file=file, field=field)
        geometry = collision.find("geometry")
        shape = None if geometry is None or len(geometry) == 0 else geometry[0]
        kind = None if shape is None else shape.tag
        if kind == "box":
            size = _numbers(shape.get("size"), 3, file=file, field=f"{field}.box.size")
            if min(size) <= 0.0:
                raise InputError(f"{field}.box.size", size, "3 lengths > 0 metres", file=file)
            shapes.append(CollisionShape(name, kind, X, size))
        elif kind == "sphere":
            shapes.append(CollisionShape(name, kind, X, (_positive(
                shape, "radius", file=file, field=f"{field}.sphere"),)))
        elif kind in ("cylinder", "capsule"):
            shapes.append(CollisionShape(name, kind, X, (
                _positive(shape, "radius", file=file, field=f"{field}.{kind}"),
                _positive(shape, "length", file=file, field=f"{field}.{kind}"))))
        elif kind == "mesh":
            scale = _numbers(shape.get("scale", "1 1 1"), 3, file=file,
                             field=f"{field}.mesh.scale")
            path = resolve(shape.get("filename") or "", f"{field}.mesh.filename")
            shapes.append(CollisionShape(
                name, kind, X, vertices=mesh_vertices(path, scale, file=file,
                                                      field=f"{field}.mesh.filename"),
                file=str(path)))
        else:
            raise InputError(f"{field}.geometry", kind, f"one of {', '.join(KINDS)}", file=file)
    return tuple(shapes)


def _circumscribed_rim(centre, u, w, radius, corners=RIM_CORNERS) -> np.ndarray:
    """Corners (corners, 3) of the regular polygon circumscribed about the circle
    centre + radius (cos s u + sin s w): radius / cos(pi / corners) from the centre."""
    s = np.arange(corners) * (2 * math.pi / corners)
    reach = radius / math.cos(math.pi / corners)
    return centre + reach * (np.outer(np.cos(s), u) + np.outer(np.sin(s), w))


def bounding_points(shapes) -> tuple[np.ndarray, np.ndarray]:
    """(centres (m, 3), radii (m,)) of balls in the shapes' body frame whose convex hull
    contains every shape (see the module docstring)."""
    centres, radii = [np.empty((0, 3))], [np.empty(0)]
    for shape in shapes:
        R, p = shape.X_BG[:3, :3], shape.X_BG[:3, 3]
        if shape.kind == "mesh":
            local, r = shape.vertices, 0.0
        elif shape.kind == "box":
            half = np.array(shape.size) / 2
            local = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)]
                             ) * half
            r = 0.0
        elif shape.kind == "sphere":
            local, r = np.zeros((1, 3)), shape.size[0]
        elif shape.kind == "capsule":
            r, half = shape.size[0], shape.size[1] / 2
            local = np.array([[0.0, 0.0, -half], [0.0, 0.0, half]])
        else:  # cylinder along its z axis
            r, half = shape.size[0], shape.size[1] / 2
            local = np.vstack([_circumscribed_rim(np.array([0.0, 0.0, z]), np.array([1.0, 0, 0]),
                                                  np.array([0.0, 1.0, 0.0]), r)
                               for z in (-half, half)])
            r = 0.0
        centres.append(local @ R.T + p)
        radii.append(np.full(len(local), float(r)))
    return np.vstack(centres), np.concatenate(radii)
