"""The link capsules of a Universal Robots arm, fitted to its URDF's collision cylinders
along the DH axes: link k's capsule lies on the segment P_k -> P_{k+1} between DH origins
(``ur_kinematics``' points), extended over its cylinders, its radius the farthest rim
point from that axis rounded up to ``RADIUS_STEP``. The UR5e's are ``robot_geometry``'s
(fitted at import); ``robot_model`` fits every UR's the same way.
"""

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

RADIUS_STEP = 0.0005  # m; fitted radii are rounded up to it
_RIM_SAMPLES = 1 << 14  # per rim circle; the sampling error is bounded below


def _rim_bounds(m, u, w, r, e):
    """(lowest, highest projection onto unit e, largest squared distance from the line
    through 0 along e) of the circle m + r (cos s u + sin s w). The squared distance is
    g(s) = C + a1 cos s + b1 sin s + a2 cos 2s + b2 sin 2s, sampled every 2 pi / n; as
    g' = 0 at its maximum and |g''| <= |(a1, b1)| + 4 |(a2, b2)|, the true maximum exceeds
    the sampled one by at most that bound times (pi / n)^2 / 2, which is added."""
    P = np.eye(3) - np.outer(e, e)
    Pm, Pu, Pw = P @ m, P @ u, P @ w
    a1, b1 = 2 * r * (Pm @ Pu), 2 * r * (Pm @ Pw)
    a2, b2 = r * r * (Pu @ Pu - Pw @ Pw) / 2, r * r * (Pu @ Pw)
    s = np.arange(_RIM_SAMPLES) * (2 * math.pi / _RIM_SAMPLES)
    g = (Pm @ Pm + r * r * (Pu @ Pu + Pw @ Pw) / 2 + a1 * np.cos(s) + b1 * np.sin(s)
         + a2 * np.cos(2 * s) + b2 * np.sin(2 * s))
    g_max = g.max() + (math.hypot(a1, b1) + 4 * math.hypot(a2, b2)) * (
        math.pi / _RIM_SAMPLES) ** 2 / 2
    spread = r * math.hypot(u @ e, w @ e)
    return m @ e - spread, m @ e + spread, g_max


def fit_ur_link_capsules(urdf: Path, dh_d, dh_a) -> tuple[tuple[str, ...], tuple]:
    """The moving links' names, from the base out, and their (a, b, t0, t1, radius) of a
    UR arm's ``urdf`` written from DH ``dh_d``, ``dh_a`` (``models/generate_urdf.py``): the
    axis P_k -> P_{k+1} (in link k's URDF frame, DH frame {k} turned by joint k+1: from
    the origin to the next joint's origin, which must be (a_k, 0, d_k)), extended over its
    collision cylinders' projections, the radius the largest distance of their rim circles
    from the axis (containing the rims contains the cylinders, their convex hulls),
    rounded up to ``RADIUS_STEP`` (within 1 nm of a step counts as on it: round-off)."""
    root = ET.parse(urdf).getroot()
    links = {link.get("name"): link for link in root.findall("link")}
    joint_of = {joint.find("parent").get("link"): joint for joint in root.findall("joint")}
    names, fitted, name = [], [], "base_link"  # a chain: one child joint per link
    for k in range(6):
        name = joint_of[name].find("child").get("link")
        names.append(name)
        end = np.array([float(x) for x in joint_of[name].find("origin").get("xyz").split()])
        if not np.allclose(end, [dh_a[k], 0.0, dh_d[k]], rtol=0.0, atol=1e-12):
            raise ValueError(f"{urdf}: the joint after {name} is at {end}, not at (a, 0, d) "
                             "of the robot's DH data: regenerate the URDF")
        length = float(np.linalg.norm(end))
        e = end / length
        low, high, g_max = 0.0, length, 0.0
        for collision in links[name].iter("collision"):
            cylinder = collision.find("geometry/cylinder")
            if cylinder is None:
                raise ValueError(f"{urdf}: a collision shape of {name} is not a cylinder")
            origin = collision.find("origin")
            c = np.array([float(x) for x in origin.get("xyz").split()])
            roll, pitch, yaw = (float(x) for x in origin.get("rpy").split())
            axis = np.array([math.cos(yaw) * math.sin(pitch) * math.cos(roll)
                             + math.sin(yaw) * math.sin(roll),
                             math.sin(yaw) * math.sin(pitch) * math.cos(roll)
                             - math.cos(yaw) * math.sin(roll),
                             math.cos(pitch) * math.cos(roll)])  # Rz Ry Rx e_z
            r, half = float(cylinder.get("radius")), float(cylinder.get("length")) / 2
            u = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
            u /= np.linalg.norm(u)
            for m in (c - half * axis, c + half * axis):
                lo, hi, g = _rim_bounds(m, u, np.cross(axis, u), r, e)
                low, high, g_max = min(low, lo), max(high, hi), max(g_max, g)
        steps = math.ceil((math.sqrt(g_max) - 1e-9) / RADIUS_STEP)
        fitted.append((k, k + 1, float(low / length), float(high / length),
                       steps / round(1 / RADIUS_STEP)))
    return tuple(names), tuple(fitted)
