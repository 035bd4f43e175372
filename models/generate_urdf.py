"""Write each UR arm's URDF from its published figures (``safety_systems/cell/ur_family.py``).

Run ``python models/generate_urdf.py [NAME ...]`` to regenerate ``models/<name>/<name>.urdf``
for the named robots (default: all six). Sources are listed in ``models/README.md`` (the
UR5e's in ``models/ur5e/README.md``). Link frames: each URDF link frame is the standard-DH
frame {i-1} turned by joint i, so every joint axis is the link's z axis and ``tool0`` is
DH frame 6. Inertias come from uniform solid cylinders (see ``shapes``).

The UR5e's URDF comes out byte for byte as it was when this script wrote only it.
"""

import math
import sys
from pathlib import Path

import numpy as np

from safety_systems.cell.ur_family import JOINT_NAMES, LINK_NAMES, UR_ROBOTS, UrRobot

# Inertia shapes of the UR5e (own assumption): a uniform solid cylinder per link,
# (radius, length, axis in the DH frame i), centred on the published centre of mass.
UR5E_SHAPES = (
    (0.060, 0.15, "z"),
    (0.060, 0.425, "x"),
    (0.045, 0.392, "x"),
    (0.040, 0.12, "z"),
    (0.040, 0.12, "z"),
    (0.040, 0.05, "z"),
)
UR5E_FOOTPRINT = 0.149  # m, the UR5e's base diameter (datasheet)
UR5E_A = (-0.425, -0.3922)  # m, the UR5e's a2, a3 (ur5e.DH_A[1:3])


def scale(robot: UrRobot) -> float:
    """The size of ``robot``'s simplified shapes relative to the UR5e's: the ratio of the
    base footprints (datasheets); exactly 1 for the UR5e."""
    return robot.footprint / UR5E_FOOTPRINT


def shapes(robot: UrRobot) -> tuple:
    """(radius, length, axis) per link (own rule): the UR5e's shapes, radii and the
    lengths of the joint links scaled by :func:`scale`, the upper arm's and forearm's
    lengths by the ratio of the robot's a2, a3 to the UR5e's (1 for the UR5e)."""
    s = scale(robot)
    out = []
    for i, (radius, length, axis) in enumerate(UR5E_SHAPES):
        stretch = robot.dh_a[i] / UR5E_A[i - 1] if i in (1, 2) else s
        out.append((radius * s, length * stretch, axis))
    return tuple(out)


def rot_x(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def cylinder_inertia(mass: float, radius: float, length: float, axis: str) -> np.ndarray:
    """Rotational inertia of a solid cylinder about its centre, axis along ``axis``."""
    axial = 0.5 * mass * radius**2
    transverse = mass * (3 * radius**2 + length**2) / 12.0
    diag = [transverse] * 3
    diag["xyz".index(axis)] = axial
    return np.diag(diag)


def fmt(values) -> str:
    return " ".join(f"{float(v)!r}" for v in values)


def geometry(name: str, xyz, rpy, shape: str) -> str:
    return "".join(
        f'    <{tag}>\n      <origin xyz="{fmt(xyz)}" rpy="{fmt(rpy)}"/>\n'
        f"      <geometry>{shape}</geometry>\n    </{tag}>\n"
        for tag in ("visual", "collision")
    )


def link_xml(robot: UrRobot, i: int) -> str:
    """Link i+1 in its URDF frame L = DH frame {i} turned by joint i+1."""
    A, D, LINKS = robot.dh_a, robot.dh_d, LINK_NAMES
    R = rot_x(robot.dh_alpha[i])
    offset = np.array([A[i], 0.0, D[i]])  # DH frame i+1 origin in L
    com = offset + R @ np.array(robot.link_coms[i])
    radius, length, axis = shapes(robot)[i]
    inertia = R @ cylinder_inertia(robot.link_masses[i], radius, length, axis) @ R.T
    inertia[np.abs(inertia) < 1e-12] = 0.0  # drop round-off from the rotation
    ixx, ixy, ixz, iyy, iyz, izz = (
        inertia[j, k] for j, k in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))
    )
    xml = f'  <link name="{LINKS[i]}">\n'
    xml += (
        f'    <inertial>\n      <origin xyz="{fmt(com)}" rpy="0 0 0"/>\n'
        f'      <mass value="{robot.link_masses[i]}"/>\n'
        f'      <inertia ixx="{ixx:.9g}" ixy="{ixy:.9g}" ixz="{ixz:.9g}" iyy="{iyy:.9g}"'
        f' iyz="{iyz:.9g}" izz="{izz:.9g}"/>\n    </inertial>\n'
    )
    # Joint housing: cylinder along the joint axis (z of L).
    housing = 0.12 * scale(robot)
    xml += geometry(
        LINKS[i], (0, 0, 0), (0, 0, 0),
        f'<cylinder radius="{radius:.3g}" length="{housing:.3g}"/>',
    )
    if A[i] != 0.0:  # arm tube along x from joint i+1 to joint i+2
        xml += geometry(
            LINKS[i],
            (A[i] / 2, 0, D[i]),
            (0, math.pi / 2, 0),
            f'<cylinder radius="{radius * 0.75:.3g}" length="{abs(A[i]):.4g}"/>',
        )
    elif D[i] != 0.0:  # offset along z to the next joint
        xml += geometry(
            LINKS[i],
            (0, 0, D[i] / 2),
            (0, 0, 0),
            f'<cylinder radius="{radius * 0.9:.3g}" length="{abs(D[i]):.4g}"/>',
        )
    return xml + "  </link>\n"


def joint_xml(robot: UrRobot, i: int) -> str:
    """Joint i+1: from the parent's URDF frame to DH frame {i}, then about z."""
    A, D, ALPHA, LINKS, JOINTS = (robot.dh_a, robot.dh_d, robot.dh_alpha, LINK_NAMES,
                                  JOINT_NAMES)
    parent = "base_link" if i == 0 else LINKS[i - 1]
    xyz = (0.0, 0.0, 0.0) if i == 0 else (A[i - 1], 0.0, D[i - 1])
    rpy = (0.0, 0.0, 0.0) if i == 0 else (ALPHA[i - 1], 0.0, 0.0)
    lim = float(robot.position_upper[i])
    return (
        f'  <joint name="{JOINTS[i]}" type="revolute">\n'
        f'    <parent link="{parent}"/>\n    <child link="{LINKS[i]}"/>\n'
        f'    <origin xyz="{fmt(xyz)}" rpy="{fmt(rpy)}"/>\n    <axis xyz="0 0 1"/>\n'
        f'    <limit lower="{-lim!r}" upper="{lim!r}" effort="{robot.effort_limits[i]:g}"'
        f' velocity="{robot.velocity_limits[i]!r}"/>\n  </joint>\n'
        f'  <transmission name="{JOINTS[i]}_transmission">\n'
        "    <type>transmission_interface/SimpleTransmission</type>\n"
        f'    <joint name="{JOINTS[i]}">\n'
        "      <hardwareInterface>hardware_interface/EffortJointInterface</hardwareInterface>\n"
        f'    </joint>\n    <actuator name="{JOINTS[i]}_motor">\n'
        "      <mechanicalReduction>1</mechanicalReduction>\n    </actuator>\n"
        "  </transmission>\n"
    )


def make_urdf(robot: UrRobot) -> str:
    """The URDF of ``robot``, as text."""
    s = scale(robot)
    xml = '<?xml version="1.0"?>\n<!-- Generated by generate_urdf.py; do not edit. -->\n'
    xml += f'<robot name="{robot.name}">\n  <link name="base_link">\n'
    xml += geometry(
        "base_link", (0, 0, 0.04 * s), (0, 0, 0),
        f'<cylinder radius="{0.075 * s:.3g}" length="{0.08 * s:.3g}"/>',
    )
    xml += "  </link>\n"
    for i in range(6):
        xml += link_xml(robot, i) + joint_xml(robot, i)
    xml += (
        '  <link name="tool0"/>\n  <joint name="wrist_3_link-tool0_fixed_joint" type="fixed">\n'
        f'    <parent link="wrist_3_link"/>\n    <child link="tool0"/>\n'
        f'    <origin xyz="0 0 {robot.dh_d[5]!r}" rpy="0 0 0"/>\n  </joint>\n</robot>\n'
    )
    return xml


def write_urdfs(names) -> list[Path]:
    """Writes ``models/<name>/<name>.urdf`` of each robot named; returns the paths."""
    out = []
    for name in names:
        robot = UR_ROBOTS[name]
        robot.urdf.parent.mkdir(exist_ok=True)
        robot.urdf.write_text(make_urdf(robot))
        out.append(robot.urdf)
    return out


if __name__ == "__main__":
    for path in write_urdfs(sys.argv[1:] or UR_ROBOTS):
        print(f"wrote {path}")
