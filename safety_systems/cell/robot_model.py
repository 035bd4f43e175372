"""The cell's robot as one record: its joints and limits, its kinematics as plain arrays,
its rigid points and the capsules between them, and its placeholder stopping data.

Every robot is a set of rigid points (``model_points`` computes them and their
velocities J(q) v, compiled) and capsules between two points each
(``robot_geometry.Capsules``). The last two points are always tool0 (the tool flange)
and the tool tip, ``tool_length`` metres along tool0's z axis. Two kinds:

- ``KIND_UR``, a Universal Robots arm (``ur_family``): the closed form of
  ``ur_kinematics`` from its DH constants ``dh = (d1, a2, a3, d4, d5, d6)``; points
  P0 ... P7 (the DH origins, tool0 = P6, the tip P7); link capsule k on P_k -> P_{k+1},
  fitted to the URDF's cylinders by ``ur_capsules`` (the UR5e's exactly
  ``robot_geometry``'s).
- ``KIND_CHAIN``, any serial arm from its URDF (``robot_description``): the chain's
  forward kinematics (``chain_kinematics``); one capsule per link with collision geometry
  (``capsule_fit``), its two ends the rigid points 2 j and 2 j + 1 on the link's body,
  then tool0 (the description's tool frame) and the tip.

Both kinds carry the chain arrays (``X_parent``, ``axes``, ``kinds``, ``X_tool``) and
the point layout (``point_bodies``, ``point_local``: every point but the last two, as a
position in a body's frame; body 0 is the base): a UR's P_k is body k + 1's origin.

``reach_bound``: the longest distance of tool0 from any joint axis that moves it, bounded
by the link lengths: for joint j, the part of the first offset after it that is not along
its axis, then the lengths of the later offsets and of the tool frame's (a UR's: the sum
of |a| and d2 ... d6, as the proofs have it). ``point_reach``: the same bound for every
point but the tip (whose bound is tool0's plus the tool length). ``base_reach``: how far
from the base origin any point but the tip gets (a UR's: ``reach_bound`` + d1, as the
proofs have it; a chain's: the lengths of the offsets from the base to the point).
"""

import dataclasses
import functools
import hashlib
from pathlib import Path

import numpy as np

from safety_systems.cell import ur_family
from safety_systems.cell.capsule_fit import fit_link_capsules
from safety_systems.cell.placeholder_stops import PLACEHOLDER_STOPS
from safety_systems.cell.robot_description import load_robot_description
from safety_systems.cell.ur_capsules import fit_ur_link_capsules
from safety_systems.cell.ur_kinematics import ur_dh
from safety_systems.files.input_error import InputError

KIND_UR, KIND_CHAIN = 0, 1
DEFAULT_ROBOT = "ur5e"
UR_CAPSULE_NAMES = ("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3")
PANDA_URDF = ur_family.MODELS / "panda" / "panda.urdf"
# The robots shipped in models/, by name: every UR (closed form) and the Panda (a chain).
SHIPPED = {**{name: robot.urdf for name, robot in ur_family.UR_ROBOTS.items()},
           "panda": PANDA_URDF}


@dataclasses.dataclass(frozen=True, eq=False)
class RobotModel:
    """One robot (see the module docstring). Units: metres, radians, seconds, newton
    metres. Arrays are stored read-only.

    ``link_capsules``: (a, b, t0, t1, radius) of each link's capsule over the points,
    named ``link_names``; ``placeholder``: the key of its placeholder stopping data in
    ``placeholder_stops.PLACEHOLDER_STOPS``, or None (none for this robot)."""

    name: str
    urdf: Path
    sha256: str
    kind: int
    base_link: str
    tool_frame: str
    joint_names: tuple[str, ...]
    position_lower: np.ndarray
    position_upper: np.ndarray
    velocity_limit: np.ndarray
    effort_limit: np.ndarray
    dh: np.ndarray
    X_parent: np.ndarray
    axes: np.ndarray
    kinds: np.ndarray
    X_tool: np.ndarray
    point_bodies: np.ndarray
    point_local: np.ndarray
    link_names: tuple[str, ...]
    link_capsules: tuple[tuple[int, int, float, float, float], ...]
    reach_bound: float
    point_reach: np.ndarray
    base_reach: float
    placeholder: str | None

    def __post_init__(self) -> None:
        for field, kind in (("position_lower", float), ("position_upper", float),
                            ("velocity_limit", float), ("effort_limit", float),
                            ("dh", float), ("X_parent", float), ("axes", float),
                            ("kinds", np.int64), ("X_tool", float),
                            ("point_bodies", np.int64), ("point_local", float),
                            ("point_reach", float)):
            value = np.ascontiguousarray(getattr(self, field), dtype=kind)
            value.setflags(write=False)
            object.__setattr__(self, field, value)

    @property
    def n(self) -> int:
        """The number of joints."""
        return len(self.joint_names)

    @property
    def num_points(self) -> int:
        """The number of rigid points: the layout's, then tool0 and the tip."""
        return self.point_bodies.size + 2

    @property
    def tool0(self) -> int:
        """tool0's point index."""
        return self.num_points - 2

    @property
    def tip(self) -> int:
        """The tool tip's point index."""
        return self.num_points - 1


def reach_bounds(X_parent: np.ndarray, axes: np.ndarray, X_tool: np.ndarray,
                 bodies: np.ndarray, local: np.ndarray) -> np.ndarray:
    """For each point (a position ``local`` in body ``bodies``, 0 ... n), a bound on its
    distance from any joint axis that moves it (see the module docstring; 0 on the
    base), metres."""
    n = len(X_parent)
    offsets = [np.asarray(X_parent[k][:3, 3]) for k in range(n)]  # body k's next joint
    out = np.zeros(len(bodies))
    for i, (body, x) in enumerate(zip(bodies, local)):
        for j in range(int(body)):  # joint j moves body j + 1 and beyond
            chain = offsets[j + 1:body] + [np.asarray(x)]
            first = chain[0] - (chain[0] @ axes[j]) * axes[j]
            out[i] = max(out[i], float(np.linalg.norm(first)
                                       + sum(np.linalg.norm(c) for c in chain[1:])))
    return out


def base_reach(X_parent: np.ndarray, bodies: np.ndarray, local: np.ndarray) -> float:
    """A bound on the points' distance from the base origin (``local`` positions in bodies
    ``bodies``): the lengths of the joint offsets from the base to the body, then the
    point's, the largest over the points, metres."""
    lengths = [float(np.linalg.norm(X[:3, 3])) for X in X_parent]
    return max(sum(lengths[:int(body)]) + float(np.linalg.norm(x))
               for body, x in zip(bodies, local))


def _ur_model(name: str) -> RobotModel:
    robot = ur_family.ur_robot(name)
    description = load_robot_description(robot.urdf, tool_frame="tool0")
    _, rows = fit_ur_link_capsules(robot.urdf, robot.dh_d, robot.dh_a)  # (URDF link names)
    bodies, local = np.array([0, 2, 3, 4, 5, 6]), np.zeros((6, 3))  # P_k: body k + 1's origin
    tool = np.array([description.X_tool[:3, 3]])
    reach = reach_bounds(description.X_parent, description.axes, description.X_tool,
                         np.r_[bodies, 6], np.r_[local, tool])
    reach_bound = sum(abs(a) for a in robot.dh_a) + sum(robot.dh_d[1:])
    return RobotModel(
        name=name, urdf=robot.urdf, sha256=description.sha256, kind=KIND_UR,
        base_link=description.base_link, tool_frame="tool0", joint_names=ur_family.JOINT_NAMES,
        position_lower=-np.array(robot.position_upper), position_upper=robot.position_upper,
        velocity_limit=robot.velocity_limits, effort_limit=robot.effort_limits,
        dh=ur_dh(robot.dh_d, robot.dh_a), X_parent=description.X_parent,
        axes=description.axes, kinds=description.kinds, X_tool=description.X_tool,
        point_bodies=bodies, point_local=local, link_names=UR_CAPSULE_NAMES,
        link_capsules=rows, reach_bound=reach_bound, point_reach=reach,
        base_reach=reach_bound + robot.dh_d[0],
        placeholder=name if name in PLACEHOLDER_STOPS else None)


def _chain_model(urdf: Path, tool_frame: str, name: str) -> RobotModel:
    d = load_robot_description(urdf, tool_frame=tool_frame or None)
    capsules = fit_link_capsules(d)
    K = len(capsules.names)
    bodies = np.repeat(capsules.bodies, 2)
    local = capsules.ends.reshape(2 * K, 3)
    reach = reach_bounds(d.X_parent, d.axes, d.X_tool, np.r_[bodies, d.num_joints],
                         np.r_[local, d.X_tool[None, :3, 3]])
    name = name or d.name or urdf.stem
    shipped = SHIPPED.get(name)
    # A shipped robot's placeholder serves its own description only: the same file's text
    # (by SHA-256, wherever it was copied to) and its tool frame.
    placeholder = (name if name in PLACEHOLDER_STOPS and shipped is not None
                   and hashlib.sha256(shipped.read_bytes()).hexdigest() == d.sha256
                   and tool_frame in ("", d.tool_frame) else None)
    return RobotModel(
        name=name, urdf=urdf, sha256=d.sha256, kind=KIND_CHAIN, base_link=d.base_link,
        tool_frame=d.tool_frame, joint_names=d.joint_names, position_lower=d.position_lower,
        position_upper=d.position_upper, velocity_limit=d.velocity_limit,
        effort_limit=d.effort_limit, dh=np.zeros(0), X_parent=d.X_parent, axes=d.axes,
        kinds=d.kinds, X_tool=d.X_tool, point_bodies=bodies, point_local=local,
        link_names=capsules.names,
        link_capsules=tuple((2 * j, 2 * j + 1, 0.0, 1.0, float(r))
                            for j, r in enumerate(capsules.radius)),
        reach_bound=float(reach[-1]), point_reach=reach,
        base_reach=base_reach(d.X_parent, np.r_[bodies, d.num_joints],
                              np.r_[local, d.X_tool[None, :3, 3]]),
        placeholder=placeholder)


@functools.lru_cache(maxsize=16)
def _cached(name: str, urdf: str, tool_frame: str, sha256: str = "") -> RobotModel:
    """The model (made once per name, file, tool frame and the file's SHA-256: a file
    edited since is read again)."""
    if not urdf:
        if name in ur_family.UR_ROBOTS:
            if tool_frame not in ("", "tool0"):
                raise InputError("robot.tool_frame", tool_frame, "empty or tool0 on a UR arm "
                                 "(its closed-form kinematics end at tool0)")
            return _ur_model(name)
        return _chain_model(SHIPPED[name].resolve(), tool_frame, name)
    return _chain_model(Path(urdf), tool_frame, name)


def robot_model(name: str = "", *, urdf: str | Path = "", tool_frame: str = "") -> RobotModel:
    """The model of a shipped robot ``name`` (``SHIPPED``; empty: the UR5e) or of the arm
    in ``urdf`` (a chain, named ``name`` or by the file), its tool frame ``tool_frame``
    (empty: tool0 on a UR, else the description's rule). Made once per process.

    Raises ``InputError`` (one line: the field, the value, what is allowed) for an
    unknown name, a missing or unusable URDF, or a tool frame it does not have."""
    if not urdf:
        name = name or DEFAULT_ROBOT
        if name not in SHIPPED:
            raise InputError("robot.model", name, f"one of {', '.join(SHIPPED)} (or a URDF "
                             "file in robot.urdf)")
        return _cached(name, "", tool_frame)
    file = Path(urdf).resolve()
    if not file.is_file():
        raise InputError("robot.urdf", str(urdf), "an existing URDF file")
    return _cached(name, str(file), tool_frame, hashlib.sha256(file.read_bytes()).hexdigest())


def default_model() -> RobotModel:
    """The UR5e's model: the project's robot unless a scenario names another."""
    return robot_model(DEFAULT_ROBOT)


def placeholder_name(model: RobotModel) -> str:
    """The robot whose placeholder stopping data serves ``model``; raises ``InputError``
    when it has none (a robot from an arbitrary URDF: measured data is needed)."""
    if model.placeholder is None:
        raise InputError("controller.braking", "empty", f"the stopping data measured on the "
                         f"{model.name} (no built-in placeholder for a robot from a URDF)")
    return model.placeholder


def is_ur5e(model: RobotModel) -> bool:
    """Whether ``model`` is the UR5e's (the robot every UR5e-only feature needs)."""
    return model.kind == KIND_UR and model.name == DEFAULT_ROBOT
