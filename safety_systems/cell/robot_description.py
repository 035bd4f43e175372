"""Any serial arm from a URDF: its chain from a base link to a tool frame, as one record.

:func:`load_robot_description` reads the URDF's XML (Drake's parser must load the file
too), finds the chain and returns a frozen :class:`RobotDescription`. Units: metres,
radians, kilograms; prismatic joints metres.

Rules (our interpretation, stated once):

- **Base and tool.** The base is the tree's root unless named. The tool frame is a named
  link, else the chain's last link: from the base, follow the one child whose subtree holds
  a moving joint; where no child's does, follow a single fixed child (``flange``,
  ``tool0``); stop at a leaf, or where two children's subtrees hold moving joints (a
  gripper's fingers: the tool frame is the hand).
- **Bodies.** Body 0 is the base and every link welded to it (static: no capsule). Each
  moving joint on the path from base to tool (revolute, continuous, prismatic) starts body
  k = 1 ... n, whose frame is its child link's; links welded to it by fixed joints, on the
  path or beside it, belong to it (their geometry and mass move with it). A link behind a
  moving joint that is not on the chain (a finger) belongs to no body: it is listed in
  ``off_chain_links`` and not modelled (a tool or payload capsule must cover it).
- **Which links need a capsule.** Every link of bodies 1 ... n with collision geometry
  gets one. A link with neither collision geometry, visual geometry nor mass (a frame
  such as ``panda_link8``, ``flange``, ``tool0``) can strike no one: it is merged into its
  body and needs none. A moving link with visual geometry or mass but no collision
  geometry is refused: its extent is unknown, so no capsule can be fitted to it.
- **Mesh files.** A relative filename is read relative to the URDF's folder; ``file://``
  names a path; ``package://NAME/rest`` is NAME's folder in ``package_paths`` if given,
  else a folder NAME beside the URDF, else the URDF's own folder or its parent when so
  named. Nothing is downloaded.

Bad input raises :class:`InputError`, one line naming the file, the field, the value and
what is allowed (the CLI's exit code 2).
"""

import dataclasses
import hashlib
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from safety_systems.cell.collision_shapes import CollisionShape, origin_transform, read_collisions
from safety_systems.files.input_error import InputError

MOVING = {"revolute": 0, "continuous": 0, "prismatic": 1}  # joint type -> kind code
REVOLUTE, PRISMATIC = 0, 1


@dataclasses.dataclass(frozen=True, eq=False)
class RobotDescription:
    """A serial chain of n moving joints from ``base_link`` to ``tool_frame``.

    Per joint k (n): ``joint_names``, ``joint_types`` (revolute | continuous | prismatic),
    ``kinds`` (0 revolute or continuous, 1 prismatic), ``link_names`` (its child link:
    body k's frame), limits ``position_lower``/``position_upper`` (continuous: -inf/+inf),
    ``velocity_limit``, ``effort_limit`` (inf where the file gives none), ``X_parent``
    (n, 4, 4) the joint's frame in body k-1's frame (body 0: the base link's), ``axes``
    (n, 3) unit axes in the joint's frame; the joint moves body k by Rot(axis, q) or
    Trans(axis q). ``X_tool`` (4, 4) is the tool frame in body n's frame.

    Per body k = 1 ... n: ``masses`` (n,), ``coms`` (n, 3) in body frame, ``inertias``
    (n, 3, 3) about the centre of mass in body frame (its links' inertials combined).

    Per link with collision geometry on bodies 1 ... n (K): ``collision_links``,
    ``collision_bodies`` (K,) (1 ... n), ``collision_shapes`` (a tuple of shapes each,
    posed in its body's frame). ``static_links`` (body 0), ``off_chain_links`` (see the
    module docstring). ``sha256`` is the URDF file's."""

    urdf: Path
    sha256: str
    name: str
    base_link: str
    tool_frame: str
    joint_names: tuple[str, ...]
    joint_types: tuple[str, ...]
    kinds: np.ndarray
    link_names: tuple[str, ...]
    position_lower: np.ndarray
    position_upper: np.ndarray
    velocity_limit: np.ndarray
    effort_limit: np.ndarray
    X_parent: np.ndarray
    axes: np.ndarray
    X_tool: np.ndarray
    masses: np.ndarray
    coms: np.ndarray
    inertias: np.ndarray
    collision_links: tuple[str, ...]
    collision_bodies: np.ndarray
    collision_shapes: tuple[tuple[CollisionShape, ...], ...]
    static_links: tuple[str, ...]
    off_chain_links: tuple[str, ...]

    def __post_init__(self) -> None:
        for field in ("kinds", "position_lower", "position_upper", "velocity_limit",
                      "effort_limit", "X_parent", "axes", "X_tool", "masses", "coms",
                      "inertias", "collision_bodies"):
            value = np.array(getattr(self, field))
            value.setflags(write=False)
            object.__setattr__(self, field, value)

    @property
    def num_joints(self) -> int:
        return len(self.joint_names)


def _root(file: Path):
    try:
        root = ET.parse(file).getroot()
    except (ET.ParseError, OSError) as error:
        raise InputError("robot", f"{file} ({' '.join(str(error).split())})",
                         "a URDF file (XML with a <robot> root)", file=file) from error
    if root.tag != "robot":
        raise InputError("robot", f"root element <{root.tag}>", "a URDF file (XML with a "
                         "<robot> root)", file=file)
    return root


def _drake_loads(file: Path, packages: dict[str, Path]) -> None:
    """Refuses a file that Drake's parser does not load (a URDF Drake cannot use)."""
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant

    plant = MultibodyPlant(0.0)  # kept alive while the parser uses it
    parser = Parser(plant)
    for name, folder in packages.items():
        parser.package_map().Add(name, str(folder))
    try:
        parser.AddModels(str(file))
    except Exception as error:
        raise InputError("robot", ' '.join(str(error).split()),
                         "a URDF file that Drake's parser loads", file=file) from error


def _resolver(file: Path, package_paths: dict[str, Path] | None, used: dict[str, Path]):
    def resolve(filename: str, field: str) -> Path:
        if filename.startswith("package://"):
            package, _, rest = filename[len("package://"):].partition("/")
            folders = ([Path(package_paths[package])] if package_paths and
                       package in package_paths else
                       [file.parent / package] + [p for p in (file.parent, file.parent.parent)
                                                  if p.name == package])
            for folder in folders:
                if folder.is_dir():
                    used[package] = folder
                    return folder / rest
            raise InputError(field, filename, f"a package folder named {package!r} beside the "
                             "URDF or given in package_paths (nothing is downloaded)", file=file)
        if filename.startswith("file://"):
            return Path(filename[len("file://"):])
        if "://" in filename or not filename:
            raise InputError(field, filename, "a relative path, file:// or package:// name",
                             file=file)
        return file.parent / filename

    return resolve


def _limits(joint, kind: str, *, file: Path) -> tuple[float, float, float, float]:
    name, limit = joint.get("name"), joint.find("limit")
    values = {}
    for attribute in ("lower", "upper", "velocity", "effort"):
        text = None if limit is None else limit.get(attribute)
        try:
            values[attribute] = math.inf if text is None else float(text)
        except ValueError as error:
            raise InputError(f"joint {name}.limit.{attribute}", text, "a number", file=file
                             ) from error
    if kind == "continuous":
        values["lower"], values["upper"] = -math.inf, math.inf
    elif limit is None or limit.get("lower") is None or limit.get("upper") is None:
        raise InputError(f"joint {name}.limit", None if limit is None else limit.attrib,
                         "lower and upper position limits (a revolute or prismatic joint)",
                         file=file)
    if not values["lower"] <= values["upper"]:
        raise InputError(f"joint {name}.limit", limit.attrib, "lower <= upper", file=file)
    return values["lower"], values["upper"], values["velocity"], values["effort"]


def _inertial(link, *, file: Path) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, centre of mass, inertia about it) of a link in its frame (none: zeros)."""
    inertial = link.find("inertial")
    if inertial is None or inertial.find("mass") is None:
        return 0.0, np.zeros(3), np.zeros((3, 3))
    field = f"link {link.get('name')}.inertial"
    X = origin_transform(inertial.find("origin"), file=file, field=field)
    (mass,) = (float(inertial.find("mass").get("value", "nan")),)
    element = inertial.find("inertia")
    i = {k: float(element.get(k, "0")) if element is not None else 0.0
         for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    I_C = np.array([[i["ixx"], i["ixy"], i["ixz"]], [i["ixy"], i["iyy"], i["iyz"]],
                    [i["ixz"], i["iyz"], i["izz"]]])
    if not (math.isfinite(mass) and mass >= 0.0 and np.all(np.isfinite(I_C))):
        raise InputError(field, inertial.find("mass").attrib, "a finite mass >= 0 and a "
                         "finite inertia", file=file)
    R = X[:3, :3]
    return mass, X[:3, 3], R @ I_C @ R.T


def _default_tool(base: str, children: dict, moves: dict) -> str:
    link = base
    while children[link]:
        moving = [j for j in children[link] if moves[j.find("child").get("link")]]
        if len(moving) > 1:
            break
        if moving:
            link = moving[0].find("child").get("link")
        elif len(children[link]) == 1:
            link = children[link][0].find("child").get("link")
        else:
            break
    return link


def load_robot_description(urdf: str | Path, *, tool_frame: str | None = None,
                           base_link: str | None = None,
                           package_paths: dict[str, str | Path] | None = None
                           ) -> RobotDescription:
    """The chain of ``urdf`` from ``base_link`` (default: the root) to ``tool_frame``
    (default: the chain's last link), by the rules of the module docstring."""
    file = Path(urdf).resolve()
    root = _root(file)
    sha256 = hashlib.sha256(file.read_bytes()).hexdigest()
    links = {link.get("name"): link for link in root.findall("link")}
    joints = root.findall("joint")
    parent_joint = {j.find("child").get("link"): j for j in joints}
    children = {name: [] for name in links}
    for j in joints:
        for end in ("parent", "child"):
            if j.find(end) is None or j.find(end).get("link") not in links:
                raise InputError(f"joint {j.get('name')}.{end}", None if j.find(end) is None
                                 else j.find(end).get("link"), "a link of the file", file=file)
        children[j.find("parent").get("link")].append(j)
    roots = [name for name in links if name not in parent_joint]
    if len(roots) != 1:
        raise InputError("robot", f"root links {roots}", "a tree of links with one root",
                         file=file)
    base = roots[0] if base_link is None else base_link
    if base not in links:
        raise InputError("base_link", base, f"a link of the file ({', '.join(links)})",
                         file=file)

    moves: dict[str, bool] = {}  # whether a link's subtree (joint into it included) moves

    def subtree_moves(link: str) -> bool:
        if link not in moves:
            own = parent_joint.get(link)
            moves[link] = (own is not None and own.get("type") != "fixed") | any(
                subtree_moves(j.find("child").get("link")) for j in children[link])
        return moves[link]

    for name in links:
        subtree_moves(name)
    tool = _default_tool(base, children, moves) if tool_frame is None else tool_frame
    if tool not in links:
        raise InputError("tool_frame", tool, f"a link of the file ({', '.join(links)})",
                         file=file)
    path, link = [], tool  # joints from base to tool
    while link != base:
        if link not in parent_joint:
            raise InputError("tool_frame", tool, f"a link below base link {base!r} (no chain "
                             f"from {base!r} to {tool!r})", file=file)
        path.append(parent_joint[link])
        link = path[-1].find("parent").get("link")
    path.reverse()
    for j in path:
        if j.get("type") not in MOVING and j.get("type") != "fixed":
            raise InputError(f"joint {j.get('name')}.type", j.get("type"), "revolute, "
                             "continuous, prismatic or fixed on the chain", file=file)
    chain = [j for j in path if j.get("type") in MOVING]
    if not chain:
        raise InputError("tool_frame", tool, f"a link moved by a joint (no moving joint from "
                         f"{base!r} to {tool!r})", file=file)
    on_chain = {id(j) for j in chain}

    # Bodies: walk the tree from the base through fixed joints and chain joints.
    body_of, X_body = {base: 0}, {base: np.eye(4)}
    X_parent, todo, off_chain = [None] * len(chain), [base], []
    index = {id(j): k for k, j in enumerate(chain)}
    while todo:
        link = todo.pop()
        edges = [(j, "down") for j in children[link]]
        if link in parent_joint:
            edges.append((parent_joint[link], "up"))
        for j, way in edges:
            other = j.find("child" if way == "down" else "parent").get("link")
            if other in body_of:
                continue
            X = origin_transform(j.find("origin"), file=file, field=f"joint {j.get('name')}")
            if j.get("type") == "fixed":
                body_of[other] = body_of[link]
                X_body[other] = X_body[link] @ (X if way == "down" else np.linalg.inv(X))
                todo.append(other)
            elif id(j) in on_chain and way == "down":
                k = index[id(j)]
                X_parent[k] = X_body[link] @ X
                body_of[other], X_body[other] = k + 1, np.eye(4)
                todo.append(other)
            else:
                off_chain.append(other)
    off_links = []
    while off_chain:  # everything behind an off-chain moving joint
        link = off_chain.pop()
        off_links.append(link)
        off_chain.extend(j.find("child").get("link") for j in children[link]
                         if j.find("child").get("link") not in body_of)

    n = len(chain)
    axes, limits = np.empty((n, 3)), np.empty((n, 4))
    for k, j in enumerate(chain):
        axis = j.find("axis")
        a = np.array(origin_axis(axis, file=file, field=f"joint {j.get('name')}.axis"))
        axes[k] = a / np.linalg.norm(a)
        limits[k] = _limits(j, j.get("type"), file=file)

    used: dict[str, Path] = {}
    resolve = _resolver(file, {k: Path(v) for k, v in (package_paths or {}).items()}, used)
    masses, coms, inertias = np.zeros(n), np.zeros((n, 3)), np.zeros((n, 3, 3))
    first_moments = np.zeros((n, 3))
    collision_links, collision_bodies, collision_shapes = [], [], []
    parts = {k: [] for k in range(1, n + 1)}
    for name, body in body_of.items():
        if body == 0:
            continue
        element = links[name]
        mass, com, I_C = _inertial(element, file=file)
        R, p = X_body[name][:3, :3], X_body[name][:3, 3]
        parts[body].append((mass, R @ com + p, R @ I_C @ R.T))
        shapes = read_collisions(element, file=file, resolve=resolve)
        if shapes:
            collision_links.append(name)
            collision_bodies.append(body)
            collision_shapes.append(tuple(s.moved(X_body[name]) for s in shapes))
        elif element.find("visual") is not None or mass > 0.0:
            raise InputError(f"link {name}.collision", None, "collision geometry on a moving "
                             "link with visual geometry or mass (it could strike someone: a "
                             "capsule needs its extent)", file=file)
    for body, items in parts.items():
        k = body - 1
        masses[k] = sum(m for m, _, _ in items)
        first_moments[k] = sum((m * c for m, c, _ in items), np.zeros(3))
        coms[k] = first_moments[k] / masses[k] if masses[k] > 0.0 else 0.0
        for m, c, I_C in items:  # parallel axes to the body's centre of mass
            d = c - coms[k]
            inertias[k] += I_C + m * (d @ d * np.eye(3) - np.outer(d, d))
    _drake_loads(file, used | {k: Path(v) for k, v in (package_paths or {}).items()})
    return RobotDescription(
        urdf=file, sha256=sha256, name=root.get("name", ""), base_link=base, tool_frame=tool,
        joint_names=tuple(j.get("name") for j in chain),
        joint_types=tuple(j.get("type") for j in chain),
        kinds=np.array([MOVING[j.get("type")] for j in chain], dtype=np.int64),
        link_names=tuple(j.find("child").get("link") for j in chain),
        position_lower=limits[:, 0], position_upper=limits[:, 1], velocity_limit=limits[:, 2],
        effort_limit=limits[:, 3], X_parent=np.array(X_parent), axes=axes,
        X_tool=X_body[tool], masses=masses, coms=coms, inertias=inertias,
        collision_links=tuple(collision_links),
        collision_bodies=np.array(collision_bodies, dtype=np.int64),
        collision_shapes=tuple(collision_shapes),
        static_links=tuple(name for name, body in body_of.items() if body == 0),
        off_chain_links=tuple(off_links))


def origin_axis(element, *, file: Path, field: str) -> tuple[float, float, float]:
    """A URDF ``<axis xyz>`` (missing: (1, 0, 0), URDF's default), refused if zero."""
    text = "1 0 0" if element is None else element.get("xyz", "1 0 0")
    try:
        values = tuple(float(x) for x in text.split())
    except ValueError:
        values = ()
    if len(values) != 3 or not all(map(math.isfinite, values)) or not any(values):
        raise InputError(field, text, "3 finite numbers, not all 0", file=file)
    return values
