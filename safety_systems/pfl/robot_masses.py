"""The mass of a robot's moving parts from its description's inertials, and its effective
mass in ISO/TS 15066's sense (Annex A, Eq. A.4: m_R = M / 2 + m_L).

**Moving parts** (the M of Eq. A.4): every link the robot's joints move, by the rules of
``cell/robot_description.py``: the bodies 1 ... n of the chain (each moving joint's child
link and the links welded to it) and the links behind a moving joint off the chain (a
gripper's fingers). The base and the links welded to it (body 0) do not move and do not
count. A UR's URDF (written from its record by ``models/generate_urdf.py``) carries the
six link masses of UR's published dynamics table and a massless base, so its moving mass
is the table's sum; the Panda's carries the inertials of ``models/panda/README.md``.

**One mass for every link.** Eq. A.4 gives the robot one effective mass, half its moving
mass plus the payload, whichever of its links strikes; that is what :func:`effective_mass`
computes. A per-link variant (the links from the striking one outward, plus the payload)
is not offered: the mass a contact on link i meets is the arm's reflected inertia along
the contact's direction, which depends on the posture and on the drives' rotor inertias
(behind gearboxes, absent from a URDF), and a sum of outward link masses bounds it neither
way; it would be a smaller figure with no clause behind it. :func:`link_masses` lists the
moving bodies' masses for reports.

Units: kilograms.
"""

import functools
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from safety_systems.cell.robot_description import load_robot_description
from safety_systems.cell.robot_model import RobotModel
from safety_systems.files.input_error import InputError
from safety_systems.pfl.contact_speed import robot_effective_mass


@functools.lru_cache(maxsize=16)
def _masses(urdf: Path, sha256: str, base_link: str, tool_frame: str
            ) -> tuple[tuple[float, ...], float]:
    """(masses of bodies 1 ... n, total mass of the off-chain moving links) of a
    description (read once per file, its SHA-256 and frames)."""
    d = load_robot_description(urdf, tool_frame=tool_frame, base_link=base_link)
    off_chain = set(d.off_chain_links)
    extra = 0.0
    for link in ET.parse(d.urdf).getroot().findall("link"):
        mass = link.find("inertial/mass")
        if link.get("name") not in off_chain or mass is None:
            continue
        try:
            value = float(mass.get("value", "nan"))
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and value >= 0.0):
            raise InputError(f"link {link.get('name')}.inertial.mass", mass.attrib,
                             "a finite mass >= 0", file=d.urdf)
        extra += value
    return tuple(float(m) for m in d.masses), extra


def link_masses(model: RobotModel) -> np.ndarray:
    """The masses of the moving bodies 1 ... n of ``model``'s chain (each joint's child
    link with the links welded to it), kilograms, from its URDF's inertials."""
    return np.array(_masses(model.urdf, model.sha256, model.base_link, model.tool_frame)[0])


def moving_mass(model: RobotModel) -> float:
    """M of Eq. A.4: the total mass of ``model``'s moving parts, kilograms (the moving
    bodies and the links moved off the chain, such as fingers; not the base)."""
    bodies, off_chain = _masses(model.urdf, model.sha256, model.base_link, model.tool_frame)
    return float(sum(bodies) + off_chain)


def effective_mass(model: RobotModel, payload: float) -> float:
    """m_R = M / 2 + m_L (ISO/TS 15066 Eq. A.4): ``model``'s effective mass, kilograms,
    with the effective payload ``payload`` (tooling and workpiece, kilograms)."""
    return float(robot_effective_mass(moving_mass(model), payload))
