"""The Universal Robots e-Series and UR20/UR30: one record of published figures per robot.

Every UR arm has the same joint structure (standard DH, joints 2-4 parallel), so a robot
is its constants: DH d, a, alpha; link masses and centres of mass (in DH frame i); joint
ranges, speeds and torques; payload, reach and footprint. ``models/README.md`` names the
source of every figure. The UR5e's figures are not repeated here: its record reads
``safety_systems/cell/ur5e.py``, so they stay in one place. Each robot's URDF
(``models/<name>/<name>.urdf``) is written from its record by ``models/generate_urdf.py``.

Units: metres, radians, kilograms, seconds, newton metres.
"""

import dataclasses
import math
from pathlib import Path

import numpy as np

from safety_systems.cell import ur5e

MODELS = Path(__file__).resolve().parent.parent.parent / "models"
JOINT_NAMES = ur5e.JOINT_NAMES
LINK_NAMES = ("shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link",
              "wrist_2_link", "wrist_3_link")
_ALPHA = (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)  # every UR's
# Datasheets: +-360 deg on every joint; the elbow limited to +-180 deg here, as the UR5e's
# (self-collision beyond it; UR's ROS joint_limits.yaml limit it so too).
_RANGE = (2 * math.pi, 2 * math.pi, math.pi, 2 * math.pi, 2 * math.pi, 2 * math.pi)


def _six(name: str, field: str, values, *, positive: bool) -> tuple[float, ...]:
    out = tuple(float(v) for v in values)
    if len(out) != 6 or not all(math.isfinite(v) and (v > 0.0 or not positive) for v in out):
        raise ValueError(f"UrRobot {name!r}: {field} = {values!r}; need 6 finite numbers"
                         + (" > 0" if positive else ""))
    return out


@dataclasses.dataclass(frozen=True, kw_only=True)
class UrRobot:
    """One UR arm's published figures (see the module docstring for units and sources).

    ``link_coms`` are the centres of mass of links 1-6 in DH frames 1-6 (UR's table);
    ``position_upper`` the joint ranges (lower = -upper); ``footprint`` the base's
    diameter (datasheet), which sizes the URDF's simplified shapes."""

    name: str
    dh_d: tuple[float, ...]
    dh_a: tuple[float, ...]
    link_masses: tuple[float, ...]
    link_coms: tuple[tuple[float, float, float], ...]
    position_upper: tuple[float, ...]
    velocity_limits: tuple[float, ...]
    effort_limits: tuple[float, ...]
    payload: float
    reach: float
    footprint: float
    dh_alpha: tuple[float, ...] = _ALPHA

    def __post_init__(self) -> None:
        n = self.name
        for field, positive in (("dh_d", False), ("dh_a", False), ("dh_alpha", False),
                                ("link_masses", True), ("position_upper", True),
                                ("velocity_limits", True), ("effort_limits", True)):
            object.__setattr__(self, field, _six(n, field, getattr(self, field),
                                                 positive=positive))
        coms = tuple(tuple(float(x) for x in c) for c in self.link_coms)
        if len(coms) != 6 or any(len(c) != 3 or not all(map(math.isfinite, c)) for c in coms):
            raise ValueError(f"UrRobot {n!r}: link_coms = {self.link_coms!r}; need 6 points "
                             "(x, y, z) in metres")
        object.__setattr__(self, "link_coms", coms)
        for field in ("payload", "reach", "footprint"):
            value = getattr(self, field)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"UrRobot {n!r}: {field} = {value!r}; need a finite number > 0")

    @property
    def urdf(self) -> Path:
        """``models/<name>/<name>.urdf``."""
        return MODELS / self.name / f"{self.name}.urdf"


_DEG = math.radians
UR3E = UrRobot(
    name="ur3e", dh_d=(0.15185, 0.0, 0.0, 0.13105, 0.08535, 0.0921),
    dh_a=(0.0, -0.24355, -0.2132, 0.0, 0.0, 0.0),
    link_masses=(1.98, 3.4445, 1.437, 0.871, 0.805, 0.261),
    link_coms=((0.0, -0.02, 0.0), (0.13, 0.0, 0.1157), (0.05, 0.0, 0.0238),
               (0.0, 0.0, 0.01), (0.0, 0.0, 0.01), (0.0, 0.0, -0.02)),
    position_upper=_RANGE, velocity_limits=(_DEG(180),) * 3 + (_DEG(360),) * 3,
    effort_limits=(54.0, 54.0, 28.0, 9.0, 9.0, 9.0), payload=3.0, reach=0.5, footprint=0.128)
UR5E = UrRobot(
    name="ur5e", dh_d=ur5e.DH_D, dh_a=ur5e.DH_A, dh_alpha=ur5e.DH_ALPHA,
    link_masses=ur5e.LINK_MASSES, link_coms=ur5e.LINK_COMS,
    position_upper=tuple(ur5e.JOINT_POSITION_UPPER),
    velocity_limits=(ur5e.JOINT_VELOCITY_LIMIT,) * 6,
    effort_limits=tuple(ur5e.JOINT_EFFORT_LIMITS), payload=5.0, reach=0.85, footprint=0.149)
UR10E = UrRobot(
    name="ur10e", dh_d=(0.1807, 0.0, 0.0, 0.17415, 0.11985, 0.11655),
    dh_a=(0.0, -0.6127, -0.57155, 0.0, 0.0, 0.0),
    link_masses=(7.369, 13.051, 3.989, 2.1, 1.98, 0.615),
    link_coms=((0.021, 0.0, 0.027), (0.38, 0.0, 0.158), (0.24, 0.0, 0.068),
               (0.0, 0.007, 0.018), (0.0, 0.007, 0.018), (0.0, 0.0, -0.026)),
    position_upper=_RANGE, velocity_limits=(_DEG(120),) * 2 + (_DEG(180),) * 4,
    effort_limits=(330.0, 330.0, 150.0, 54.0, 54.0, 54.0), payload=12.5, reach=1.3,
    footprint=0.19)
UR16E = UrRobot(
    name="ur16e", dh_d=(0.1807, 0.0, 0.0, 0.17415, 0.11985, 0.11655),
    dh_a=(0.0, -0.4784, -0.36, 0.0, 0.0, 0.0),
    link_masses=(7.369, 10.45, 4.321, 2.18, 2.033, 0.907),
    link_coms=((0.0, -0.016, 0.03), (0.302, 0.0, 0.16), (0.194, 0.0, 0.065),
               (0.0, -0.009, 0.011), (0.0, 0.018, 0.012), (0.0, 0.0, -0.044)),
    position_upper=_RANGE, velocity_limits=(_DEG(120),) * 2 + (_DEG(180),) * 4,
    effort_limits=(330.0, 330.0, 150.0, 54.0, 54.0, 54.0), payload=16.0, reach=0.9,
    footprint=0.19)
UR20 = UrRobot(
    name="ur20", dh_d=(0.2363, 0.0, 0.0, 0.201, 0.1593, 0.1543),
    dh_a=(0.0, -0.862, -0.7287, 0.0, 0.0, 0.0),
    link_masses=(16.343, 29.632, 7.879, 3.054, 3.126, 0.846),
    link_coms=((0.0, -0.061, 0.0062), (0.5226, 0.0, 0.2098), (0.3234, 0.0, 0.0604),
               (0.0, -0.0026, 0.0393), (0.0, 0.0024, 0.0379), (0.0, -0.0003, -0.0318)),
    position_upper=_RANGE, velocity_limits=(_DEG(120),) * 2 + (_DEG(150),) + (_DEG(210),) * 3,
    effort_limits=(738.0, 738.0, 433.0, 107.0, 107.0, 107.0), payload=20.0, reach=1.75,
    footprint=0.245)
UR30 = UrRobot(
    name="ur30", dh_d=(0.2363, 0.0, 0.0, 0.201, 0.1593, 0.1543),
    dh_a=(0.0, -0.637, -0.5037, 0.0, 0.0, 0.0),
    link_masses=(16.343, 28.542, 7.156, 3.054, 3.126, 0.926),
    link_coms=((-0.0001, -0.06, 0.0069), (0.3894, 0.0, 0.2103), (0.2257, 0.0, 0.0629),
               (0.0, -0.0048, 0.0353), (0.0, 0.0046, 0.0341), (0.0, 0.0, -0.0293)),
    position_upper=_RANGE, velocity_limits=(_DEG(120),) * 2 + (_DEG(150),) + (_DEG(210),) * 3,
    effort_limits=(738.0, 738.0, 433.0, 107.0, 107.0, 107.0), payload=30.0, reach=1.3,
    footprint=0.245)

UR_ROBOTS = {r.name: r for r in (UR3E, UR5E, UR10E, UR16E, UR20, UR30)}


def ur_robot(name: str) -> UrRobot:
    """The record of UR arm ``name`` (one of ``UR_ROBOTS``)."""
    if name not in UR_ROBOTS:
        raise ValueError(f"robot = {name!r}; allowed: {', '.join(UR_ROBOTS)}")
    return UR_ROBOTS[name]


def dh_frames(robot: UrRobot, q: np.ndarray) -> np.ndarray:
    """Poses of DH frames {0} ... {6} of ``robot`` in its base frame, ``(..., 7, 4, 4)``,
    at joint positions q (..., 6): T_i = Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i), chained (the
    reference product, slow; ``ur5e.dh_frames`` is this for the UR5e)."""
    q = np.asarray(q, dtype=float)
    ct, st = np.cos(q), np.sin(q)
    ca, sa = np.cos(robot.dh_alpha), np.sin(robot.dh_alpha)
    a, d = np.array(robot.dh_a), np.array(robot.dh_d)
    links = np.zeros(q.shape + (4, 4))
    links[..., 0, 0], links[..., 0, 1], links[..., 0, 2] = ct, -st * ca, st * sa
    links[..., 1, 0], links[..., 1, 1], links[..., 1, 2] = st, ct * ca, -ct * sa
    links[..., 0, 3], links[..., 1, 3] = a * ct, a * st
    links[..., 2, 1], links[..., 2, 2], links[..., 2, 3] = sa, ca, d
    links[..., 3, 3] = 1.0
    frames = np.empty(q.shape[:-1] + (7, 4, 4))
    frames[..., 0, :, :] = np.eye(4)
    for i in range(6):
        frames[..., i + 1, :, :] = frames[..., i, :, :] @ links[..., i, :, :]
    return frames
