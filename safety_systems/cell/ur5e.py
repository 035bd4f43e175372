"""UR5e model: published DH data, the URDF, ``AddUr5e`` and fast tool0 kinematics.

Frames: ``base_link`` is the standard-DH base frame {0} (z up; at q = 0 the arm points
along -x), ``tool0`` is DH frame {6} at the flange. The URDF is generated from the
constants below by ``models/generate_urdf.py``; ``models/ur5e/README.md`` lists
the sources.
"""

import math
from pathlib import Path

import numba
import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex

from safety_systems.cell.ur_kinematics import (
    tool0_from_trig,
    trig_one,
    trig_reusing,
)

UR5E_URDF = Path(__file__).resolve().parent.parent.parent / "models" / "ur5e" / "ur5e.urdf"

# Universal Robots, "DH parameters for calculations of kinematics and dynamics", UR5e
# row (standard DH; metres, radians, kilograms; centres of mass in DH frame i).
DH_D = (0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996)
DH_A = (0.0, -0.425, -0.3922, 0.0, 0.0, 0.0)
DH_ALPHA = (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)
LINK_MASSES = (3.761, 8.058, 2.846, 1.37, 1.3, 0.365)
LINK_COMS = (
    (0.0, -0.02561, 0.00193),
    (0.2125, 0.0, 0.11336),
    (0.15, 0.0, 0.0265),
    (0.0, -0.0018, 0.01634),
    (0.0, 0.0018, 0.01634),
    (0.0, 0.0, -0.001159),
)
TOTAL_MASS = sum(LINK_MASSES)  # the URDF's base_link is massless (welded to the world)

JOINT_NAMES = (
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
)
# UR5e datasheet: +-360 deg on every joint (elbow limited to +-180 deg in practice by
# self-collision), 180 deg/s on every joint, sizes 3/3/3/1/1/1 torque ratings.
JOINT_POSITION_UPPER = np.array([2 * math.pi, 2 * math.pi, math.pi] + [2 * math.pi] * 3)
JOINT_POSITION_LOWER = -JOINT_POSITION_UPPER
JOINT_VELOCITY_LIMIT = math.pi  # radians per second
JOINT_EFFORT_LIMITS = np.array([150.0, 150.0, 150.0, 28.0, 28.0, 28.0])  # newton metres
NUM_JOINTS = 6
UR5E_DH = (DH_D[0], DH_A[1], DH_A[2], DH_D[3], DH_D[4], DH_D[5])  # ur_kinematics' dh


def AddUr5e(plant: MultibodyPlant, *, model_name: str = "ur5e") -> ModelInstanceIndex:
    """Parses the UR5e URDF into ``plant`` and welds ``base_link`` to the world origin."""
    parser = Parser(plant, model_name)
    (instance,) = parser.AddModels(str(UR5E_URDF))
    plant.WeldFrames(
        plant.world_frame(), plant.GetFrameByName("base_link", instance), RigidTransform()
    )
    return instance


def dh_frames(q: np.ndarray) -> np.ndarray:
    """Poses of DH frames {0} ... {6} in the base frame, shape ``(..., 7, 4, 4)``.

    T_i = Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i), chained; frame {6} is tool0. ``q`` has
    shape ``(..., 6)``.
    """
    q = np.asarray(q, dtype=float)
    ct, st = np.cos(q), np.sin(q)  # (..., 6)
    ca, sa = np.cos(DH_ALPHA), np.sin(DH_ALPHA)
    links = np.zeros(q.shape + (4, 4))  # T_1 ... T_6
    links[..., 0, 0], links[..., 0, 1], links[..., 0, 2] = ct, -st * ca, st * sa
    links[..., 1, 0], links[..., 1, 1], links[..., 1, 2] = st, ct * ca, -ct * sa
    links[..., 0, 3], links[..., 1, 3] = DH_A * ct, DH_A * st
    links[..., 2, 1], links[..., 2, 2], links[..., 2, 3] = sa, ca, DH_D
    links[..., 3, 3] = 1.0
    frames = np.empty(q.shape[:-1] + (7, 4, 4))
    frames[..., 0, :, :] = np.eye(4)
    frames[..., 1, :, :] = links[..., 0, :, :]
    for i in range(1, NUM_JOINTS):
        np.matmul(frames[..., i, :, :], links[..., i, :, :], out=frames[..., i + 1, :, :])
    return frames


def dh_forward_kinematics(q: np.ndarray) -> np.ndarray:
    """Pose of DH frame {6} (tool0) in the base frame, ``(..., 6) -> (..., 4, 4)``.

    Reference implementation (slow); see ``tool0_position``.
    """
    return dh_frames(q)[..., 6, :, :]


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def _tool0_from_trig(trig, v):
    """:func:`tool0_one` from trig = (cos, sin) of q1, q2, q2 + q3, q2 + q3 + q4, q5
    (``ur_kinematics.tool0_from_trig`` with the UR5e's constants)."""
    return tool0_from_trig(trig, v, UR5E_DH)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def tool0_one(q, v):
    """Closed-form tool0 position and velocity (6 floats: p, then J(q) v) of one joint
    position q and velocity v (6,), compiled and callable from other compiled code.

    Joints 2-4 are parallel, so in the frame turned by q1 the tool lies at
    u = a2 c2 + a3 c23 + d5 s234 - d6 s5 c234 (horizontal), w = a2 s2 + a3 s23
    - d5 c234 - d6 s5 s234 (vertical), n = d4 + d6 c5 (along joint 2's axis); then
    p = (c1 u + s1 n, s1 u - c1 n, d1 + w). The velocity is its time derivative.
    """
    return _tool0_from_trig(trig_one(q), v)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def tool0_reusing_trig(q, v, memo):
    """:func:`tool0_one`, equal bit for bit, keeping the cosines and sines of its five
    angles in ``memo`` (15,) (NaN at first) to reuse them at the next call with the same
    angle: a robot at rest, or joints that do not move in a path segment, costs no
    trigonometry (most of :func:`tool0_one`'s cost)."""
    return _tool0_from_trig(trig_reusing(q, memo), v)


@numba.njit(cache=True)
def _tool0_rows(q, v, out):
    """:func:`tool0_one` of rows q, v (L, 6) into out[0], out[1] (L, 3)."""
    for row in range(q.shape[0]):
        (out[0, row, 0], out[0, row, 1], out[0, row, 2], out[1, row, 0], out[1, row, 1],
         out[1, row, 2]) = tool0_one(q[row], v[row])


def tool0_position_and_velocity(
    q: np.ndarray, v: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray | None]:
    """Closed-form tool0 origin position and translational velocity J(q) v in base frame.

    ``q`` and ``v`` have shape ``(..., 6)``; returns arrays of shape ``(..., 3)`` (the
    velocity is None when ``v`` is None). Compiled (numba), a few microseconds for one
    configuration, fit for a 500 Hz system.
    """
    q = np.asarray(q, dtype=float)
    if q.ndim == 1 and v is not None and np.ndim(v) == 1:  # one configuration (500 Hz)
        out = np.empty((2, 1, 3))
        _tool0_rows(q[None], np.asarray(v, dtype=float)[None], out)
        return out[0, 0], out[1, 0]
    if v is None:
        lead, v_rows = q.shape[:-1], None
    else:
        v = np.asarray(v, dtype=float)
        lead = q.shape[:-1] if v.shape == q.shape else np.broadcast_shapes(q.shape[:-1],
                                                                           v.shape[:-1])
        if v.shape != lead + (6,):
            v = np.broadcast_to(v, lead + (6,))
        v_rows = v.reshape(-1, 6)
    if q.shape != lead + (6,):
        q = np.broadcast_to(q, lead + (6,))
    q_rows = q.reshape(-1, 6)
    out = np.empty((2, q_rows.shape[0], 3))
    _tool0_rows(q_rows, q_rows if v_rows is None else v_rows, out)
    return out[0].reshape(lead + (3,)), (None if v is None else out[1].reshape(lead + (3,)))


def tool0_position(q: np.ndarray) -> np.ndarray:
    """Closed-form tool0 origin position in the base frame; ``(..., 6) -> (..., 3)``."""
    return tool0_position_and_velocity(q)[0]
