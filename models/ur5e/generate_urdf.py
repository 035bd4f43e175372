"""Write ``ur5e.urdf`` from Universal Robots' published UR5e DH and mass data.

Run ``python models/ur5e/generate_urdf.py`` to regenerate the URDF beside this file.
Data sources are listed in ``README.md``. Link frames: each URDF link frame is the
standard-DH frame {i-1} turned by joint i, so every joint axis is the link's z axis and
``tool0`` is DH frame 6. Inertias come from uniform solid cylinders (see ``SHAPES``).
"""

import math
from pathlib import Path

import numpy as np

from safety_systems.cell import ur5e

# Single source of the published data: safety_systems/cell/ur5e.py.
A, D, ALPHA = ur5e.DH_A, ur5e.DH_D, ur5e.DH_ALPHA
MASSES, COMS = ur5e.LINK_MASSES, ur5e.LINK_COMS
JOINTS, POSITION_LIMITS = ur5e.JOINT_NAMES, ur5e.JOINT_POSITION_UPPER
VELOCITY_LIMIT, EFFORT_LIMITS = ur5e.JOINT_VELOCITY_LIMIT, ur5e.JOINT_EFFORT_LIMITS

LINKS = (
    "shoulder_link",
    "upper_arm_link",
    "forearm_link",
    "wrist_1_link",
    "wrist_2_link",
    "wrist_3_link",
)
# Inertia shapes (own assumption): a uniform solid cylinder per link,
# (radius, length, axis in the DH frame i), centred on the published centre of mass.
SHAPES = (
    (0.060, 0.15, "z"),
    (0.060, 0.425, "x"),
    (0.045, 0.392, "x"),
    (0.040, 0.12, "z"),
    (0.040, 0.12, "z"),
    (0.040, 0.05, "z"),
)


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


def link_xml(i: int) -> str:
    """Link i+1 in its URDF frame L = DH frame {i} turned by joint i+1."""
    R = rot_x(ALPHA[i])
    offset = np.array([A[i], 0.0, D[i]])  # DH frame i+1 origin in L
    com = offset + R @ np.array(COMS[i])
    radius, length, axis = SHAPES[i]
    inertia = R @ cylinder_inertia(MASSES[i], radius, length, axis) @ R.T
    inertia[np.abs(inertia) < 1e-12] = 0.0  # drop round-off from the rotation
    ixx, ixy, ixz, iyy, iyz, izz = (
        inertia[j, k] for j, k in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))
    )
    xml = f'  <link name="{LINKS[i]}">\n'
    xml += (
        f'    <inertial>\n      <origin xyz="{fmt(com)}" rpy="0 0 0"/>\n'
        f'      <mass value="{MASSES[i]}"/>\n'
        f'      <inertia ixx="{ixx:.9g}" ixy="{ixy:.9g}" ixz="{ixz:.9g}" iyy="{iyy:.9g}"'
        f' iyz="{iyz:.9g}" izz="{izz:.9g}"/>\n    </inertial>\n'
    )
    # Joint housing: cylinder along the joint axis (z of L).
    xml += geometry(
        LINKS[i], (0, 0, 0), (0, 0, 0), f'<cylinder radius="{radius:.3g}" length="0.12"/>'
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


def joint_xml(i: int) -> str:
    """Joint i+1: from the parent's URDF frame to DH frame {i}, then about z."""
    parent = "base_link" if i == 0 else LINKS[i - 1]
    xyz = (0.0, 0.0, 0.0) if i == 0 else (A[i - 1], 0.0, D[i - 1])
    rpy = (0.0, 0.0, 0.0) if i == 0 else (ALPHA[i - 1], 0.0, 0.0)
    lim = float(POSITION_LIMITS[i])
    return (
        f'  <joint name="{JOINTS[i]}" type="revolute">\n'
        f'    <parent link="{parent}"/>\n    <child link="{LINKS[i]}"/>\n'
        f'    <origin xyz="{fmt(xyz)}" rpy="{fmt(rpy)}"/>\n    <axis xyz="0 0 1"/>\n'
        f'    <limit lower="{-lim!r}" upper="{lim!r}" effort="{EFFORT_LIMITS[i]:g}"'
        f' velocity="{VELOCITY_LIMIT!r}"/>\n  </joint>\n'
        f'  <transmission name="{JOINTS[i]}_transmission">\n'
        "    <type>transmission_interface/SimpleTransmission</type>\n"
        f'    <joint name="{JOINTS[i]}">\n'
        "      <hardwareInterface>hardware_interface/EffortJointInterface</hardwareInterface>\n"
        f'    </joint>\n    <actuator name="{JOINTS[i]}_motor">\n'
        "      <mechanicalReduction>1</mechanicalReduction>\n    </actuator>\n"
        "  </transmission>\n"
    )


def make_urdf() -> str:
    xml = '<?xml version="1.0"?>\n<!-- Generated by generate_urdf.py; do not edit. -->\n'
    xml += '<robot name="ur5e">\n  <link name="base_link">\n'
    xml += geometry(
        "base_link", (0, 0, 0.04), (0, 0, 0), '<cylinder radius="0.075" length="0.08"/>'
    )
    xml += "  </link>\n"
    for i in range(6):
        xml += link_xml(i) + joint_xml(i)
    xml += (
        '  <link name="tool0"/>\n  <joint name="wrist_3_link-tool0_fixed_joint" type="fixed">\n'
        f'    <parent link="wrist_3_link"/>\n    <child link="tool0"/>\n'
        f'    <origin xyz="0 0 {D[5]!r}" rpy="0 0 0"/>\n  </joint>\n</robot>\n'
    )
    return xml


if __name__ == "__main__":
    out = Path(__file__).with_name("ur5e.urdf")
    out.write_text(make_urdf())
    print(f"wrote {out}")
