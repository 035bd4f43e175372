"""Ellipsoid models of the robot and the operators, and the danger index (seed 004).

Chan and Tsai, "Collision-Free Speed Alteration Strategy for Human Safety in
Human-Robot Coexistence Environments", IEEE Access 2020 (``shared/seeds/004_*``):
every robot link and every part of the operator's upper body is an ellipsoid (Eqs.
1-5), and the danger index of a pair is DI = 1 / F (Eq. 7), with F <= 1 when the pair
collides (Eq. 6), so DI >= 1 means a collision.

An ellipsoid here is (centre c, rotation R, semi-axes r): the points x with
|diag(1/r) R^T (x - c)| <= 1. Shapes: centres (..., 3), rotations (..., 3, 3), semi-axes
(..., 3); everything broadcasts over leading axes.

Our method for F (the seed follows Hwang et al.'s transformation, which it does not
spell out): F = (d / (h1 + h2))^2, where d is the distance between the centres and h1,
h2 are the ellipsoids' support functions along the line joining them,
h(u) = |diag(r) R^T u|. If F > 1 the plane normal to that line separates the two, so
a pair reported apart (DI < 1) never overlaps. For spheres it is exact:
DI = ((r1 + r2) / d)^2, and DI = 1 when they touch. For other ellipsoids it is
conservative: DI >= 1 can also mean "close, and not proven apart".
"""

import dataclasses
import math

import numba
import numpy as np

from safety_systems.cell.robot_geometry import LINK_SEGMENTS
from safety_systems.cell.ur5e import dh_frames


@dataclasses.dataclass(frozen=True)
class Ellipsoids:
    """A set of ellipsoids (see the module docstring for the shapes)."""

    centres: np.ndarray
    rotations: np.ndarray
    semi_axes: np.ndarray

    def moved(self, displacement: np.ndarray) -> "Ellipsoids":
        """The same ellipsoids translated by ``displacement`` (..., 3)."""
        return Ellipsoids(self.centres + displacement, self.rotations, self.semi_axes)


def support(rotations: np.ndarray, semi_axes: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Support function h(u) = max over the ellipsoid of (x - c) . u, for unit u."""
    local = np.matmul(u[..., None, :], rotations)[..., 0, :]  # (R^T u)^T
    return np.sqrt(np.sum((semi_axes * local) ** 2, axis=-1))


def scaled_frames(e: Ellipsoids) -> np.ndarray:
    """S = diag(r) R^T of each ellipsoid (..., 3, 3): h(u)^2 = u^T M u = |S u|^2 with the
    shape matrix M = R diag(r^2) R^T."""
    return e.semi_axes[..., :, None] * np.swapaxes(e.rotations, -1, -2)


@numba.njit(cache=True)
def _danger_pairs(ca, Sa, cb, Sb, out):
    """out[l, i, j] = DI of (a_li, b_lj) from centres (L, n, 3) and scaled frames
    (L, n, 3, 3), compiled: (|S_a x| + |S_b x|)^2 / d^4 with x the centre offset."""
    for lead in range(ca.shape[0]):
        for i in range(ca.shape[1]):
            for j in range(cb.shape[1]):
                x0 = cb[lead, j, 0] - ca[lead, i, 0]
                x1 = cb[lead, j, 1] - ca[lead, i, 1]
                x2 = cb[lead, j, 2] - ca[lead, i, 2]
                d2 = x0 * x0 + x1 * x1 + x2 * x2
                if not d2 > 0.0:  # coincident (or undefined) centres: a collision
                    out[lead, i, j] = np.inf
                    continue
                qa = 0.0
                qb = 0.0
                for k in range(3):
                    ya = Sa[lead, i, k, 0] * x0 + Sa[lead, i, k, 1] * x1 + Sa[lead, i, k, 2] * x2
                    yb = Sb[lead, j, k, 0] * x0 + Sb[lead, j, k, 1] * x1 + Sb[lead, j, k, 2] * x2
                    qa += ya * ya
                    qb += yb * yb
                root = np.sqrt(qa) + np.sqrt(qb)
                out[lead, i, j] = root * root / (d2 * d2)


def danger_index(a: Ellipsoids, b: Ellipsoids) -> np.ndarray:
    """DI of every pair (a_i, b_j), shape (..., n_a, n_b); Eq. 7 with F as in the module.

    With the centre offset x (length d) and u = x / d, h(u) = |S x| / d (S = diag(r) R^T,
    :func:`scaled_frames`), so DI = ((h1 + h2) / d)^2 = (|S_1 x| + |S_2 x|)^2 / d^4,
    which needs no per-pair rotation; the pairs are looped over in compiled code.
    Coincident (or NaN) centres give DI = inf (a collision).
    """
    lead = np.broadcast_shapes(a.centres.shape[:-2], b.centres.shape[:-2])
    n_a, n_b = a.centres.shape[-2], b.centres.shape[-2]

    def flat(e: Ellipsoids, n: int) -> tuple[np.ndarray, np.ndarray]:
        c = np.broadcast_to(e.centres, lead + (n, 3)).reshape(-1, n, 3)
        S = np.broadcast_to(scaled_frames(e), lead + (n, 3, 3)).reshape(-1, n, 3, 3)
        return np.ascontiguousarray(c, dtype=float), np.ascontiguousarray(S, dtype=float)

    out = np.empty((math.prod(lead), n_a, n_b))
    _danger_pairs(*flat(a, n_a), *flat(b, n_b), out)
    return out.reshape(lead + (n_a, n_b))


def segment_ellipsoids(start: np.ndarray, end: np.ndarray, radius: np.ndarray) -> Ellipsoids:
    """Ellipsoids around segments start -> end (..., 3): centred at the midpoint, semi-axis
    half the length plus ``radius`` along the segment and ``radius`` across it.

    The axes across are completed to a right-handed orthonormal frame by the branch-free
    construction of Duff et al., "Building an Orthonormal Basis, Revisited" (JCGT 6(1),
    2017); which pair is picked does not matter, the ellipsoid being round across."""
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    axis = end - start
    length = np.sqrt(np.einsum("...i,...i->...", axis, axis))
    x = axis / np.where(length > 0.0, length, 1.0)[..., None]
    x[..., 0] += length == 0.0  # a point: any axis, here e_x
    x0, x1, x2 = x[..., 0], x[..., 1], x[..., 2]
    sign = np.copysign(1.0, x2)
    a = -1.0 / (sign + x2)
    b = x0 * x1 * a
    rotations = np.empty(x.shape + (3,))  # columns: the ellipsoid's axes in the world
    rotations[..., 0] = x
    rotations[..., 0, 1] = 1.0 + sign * x0 * x0 * a
    rotations[..., 1, 1] = sign * b
    rotations[..., 2, 1] = -sign * x0
    rotations[..., 0, 2] = b
    rotations[..., 1, 2] = sign + x1 * x1 * a
    rotations[..., 2, 2] = -x1
    radius = np.asarray(radius, dtype=float)
    semi = np.empty(np.broadcast_shapes(length.shape, radius.shape) + (3,))
    semi[..., 0] = 0.5 * length + radius
    semi[..., 1:] = radius[..., None]
    return Ellipsoids(0.5 * (start + end), rotations, semi)


def spheres(centres: np.ndarray, radius: np.ndarray | float) -> Ellipsoids:
    """Spheres (the seed's 50 mm hand and end effector)."""
    centres = np.asarray(centres, dtype=float)
    radius = np.broadcast_to(np.asarray(radius, dtype=float), centres.shape[:-1])
    rotations = np.broadcast_to(np.eye(3), centres.shape + (3,)).copy()
    return Ellipsoids(centres, rotations, np.repeat(radius[..., None], 3, axis=-1))


def concatenate(*sets: Ellipsoids) -> Ellipsoids:
    """One set from several, along the ellipsoid axis."""
    return Ellipsoids(*(np.concatenate([getattr(s, f) for s in sets], axis=axis)
                        for f, axis in (("centres", -2), ("rotations", -3),
                                        ("semi_axes", -2))))


# The UR5e's links between DH frame origins (seed Eqs. 1-3 place an ellipsoid at each
# link's centre): shoulder column, upper arm, forearm, the three wrist links; the same
# segments as the capsules' (robot_geometry, the one definition of the robot's geometry).
ROBOT_SEGMENTS = LINK_SEGMENTS


def robot_ellipsoids(q: np.ndarray, link_radii, tool_radius: float,
                     tool_offset: float = 0.0) -> Ellipsoids:
    """The robot's ellipsoids at joint positions q (..., 6): one per link segment between
    DH frame origins (radii ``link_radii``: 6 values, or none for the tool only) and a
    sphere of ``tool_radius`` ``tool_offset`` along tool0's z axis from the flange (the
    seed's end-effector ellipsoid)."""
    frames = dh_frames(q)
    origins = frames[..., :3, 3]
    tool = origins[..., 6, :] + tool_offset * frames[..., 6, :3, 2]
    n = len(link_radii)
    lead = tool.shape[:-1]
    centres = np.empty(lead + (n + 1, 3))
    rotations = np.empty(lead + (n + 1, 3, 3))
    semi = np.empty(lead + (n + 1, 3))
    if n:
        links = segment_ellipsoids(origins[..., [a for a, _ in ROBOT_SEGMENTS], :],
                                   origins[..., [b for _, b in ROBOT_SEGMENTS], :],
                                   np.asarray(link_radii, dtype=float))
        centres[..., :n, :] = links.centres
        rotations[..., :n, :, :] = links.rotations
        semi[..., :n, :] = links.semi_axes
    centres[..., n, :] = tool
    rotations[..., n, :, :] = np.eye(3)
    semi[..., n, :] = tool_radius
    return Ellipsoids(centres, rotations, semi)


SHOULDER_WIDTH = 0.40  # m
ARM_SEGMENT = 0.30  # m, upper arm and forearm
TORSO_BEHIND_HANDS = 0.45  # m
TORSO_ABOVE_HANDS = 0.35  # m


def human_ellipsoids(hands: np.ndarray, sizes) -> Ellipsoids:
    """An operator's upper body from its two tracked hands (..., 2, 3), metres.

    The seed models hands, forearms, upper arms, head and torso from a Kinect skeleton;
    our tracker sees gloves, so we build the skeleton (our interpretation): the operator
    faces the robot base (the origin), the torso centre stands ``TORSO_BEHIND_HANDS``
    behind the hands' midpoint and ``TORSO_ABOVE_HANDS`` above it, shoulders 0.2 m
    above the torso centre and ``SHOULDER_WIDTH`` apart, elbows where an arm of two
    ``ARM_SEGMENT`` lengths bends below the shoulder-hand line, the head 0.55 m above
    the torso centre. ``sizes`` has the radii of ``EllipsoidConfig``.

    Returns 8 ellipsoids: 2 hands, 2 forearms, 2 upper arms, head and torso.
    """
    hands = np.asarray(hands, dtype=float)
    middle = 0.5 * (hands[..., 0, :] + hands[..., 1, :])
    # forward: horizontal, from the hands' midpoint towards the base (e_x above it).
    fx, fy = -middle[..., 0], -middle[..., 1]
    norm = np.sqrt(fx * fx + fy * fy)
    level = norm > 1e-9
    fx = np.where(level, fx / np.where(level, norm, 1.0), 1.0)
    fy = np.where(level, fy / np.where(level, norm, 1.0), 0.0)
    lead = middle.shape[:-1]
    frame = np.zeros(lead + (3, 3))  # columns: forward, left = up x forward, up
    frame[..., 0, 0], frame[..., 1, 0] = fx, fy
    frame[..., 0, 1], frame[..., 1, 1] = -fy, fx
    frame[..., 2, 2] = 1.0
    forward, left = frame[..., 0], frame[..., 1]
    torso = middle - TORSO_BEHIND_HANDS * forward
    torso[..., 2] += TORSO_ABOVE_HANDS
    # Each hand hangs from the shoulder on its own side (arms never cross).
    lateral = np.einsum("...ki,...i->...k", hands - middle[..., None, :], left)
    first_left = (lateral[..., 0] >= lateral[..., 1])[..., None]
    side = np.where(first_left, [0.5, -0.5], [-0.5, 0.5])[..., None] * SHOULDER_WIDTH
    shoulders = torso[..., None, :] + side * left[..., None, :]
    shoulders[..., 2] += 0.2
    span = hands - shoulders
    half = np.minimum(0.5 * np.sqrt(np.einsum("...i,...i->...", span, span)), ARM_SEGMENT)
    elbows = shoulders + 0.5 * span
    elbows[..., 2] -= np.sqrt(np.maximum(ARM_SEGMENT**2 - half**2, 0.0))
    # 2 hands, 2 forearms, 2 upper arms, head, torso; the limbs in one call.
    limbs = segment_ellipsoids(np.concatenate((elbows, shoulders), axis=-2),
                               np.concatenate((hands, elbows), axis=-2),
                               np.array([sizes.forearm_radius] * 2 + [sizes.upper_arm_radius] * 2))
    centres = np.empty(lead + (8, 3))
    rotations = np.empty(lead + (8, 3, 3))
    semi = np.empty(lead + (8, 3))
    centres[..., :2, :] = hands
    centres[..., 2:6, :] = limbs.centres
    centres[..., 6, :] = torso
    centres[..., 6, 2] += 0.55
    centres[..., 7, :] = torso
    rotations[..., [0, 1, 6], :, :] = np.eye(3)
    rotations[..., 2:6, :, :] = limbs.rotations
    rotations[..., 7, :, :] = frame
    semi[..., :2, :] = sizes.hand_radius
    semi[..., 2:6, :] = limbs.semi_axes
    semi[..., 6, :] = sizes.head_radius
    semi[..., 7, :] = sizes.torso_semi_axes
    return Ellipsoids(centres, rotations, semi)
