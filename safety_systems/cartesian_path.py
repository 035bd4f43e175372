"""Joint paths from Cartesian tool paths, by Drake's inverse kinematics."""

import numpy as np
from pydrake.math import RollPitchYaw, RotationMatrix
from pydrake.multibody.inverse_kinematics import InverseKinematics
from pydrake.multibody.plant import MultibodyPlant
from pydrake.solvers import Solve

from safety_systems.joint_path import SplinePath, make_spline_path
from safety_systems.ur5e import AddUr5e

ORIENTATION_TOLERANCE = 1e-6  # rad


def line_path(start: np.ndarray, goal: np.ndarray, *, speed: float, rpy: np.ndarray,
              seed: np.ndarray, samples: int = 25) -> SplinePath:
    """A tool0 straight line from ``start`` to ``goal`` (m, base frame) at ``speed``
    (m/s, nominal), with the tool held at roll-pitch-yaw ``rpy`` (rad), as a joint
    spline: inverse kinematics at ``samples`` evenly spaced points, each seeded with the
    previous solution (the first with ``seed``) and pulled towards it, so the arm stays
    on one branch.

    Raises:
        ValueError: a point the arm cannot reach with that orientation.
    """
    start, goal = np.asarray(start, dtype=float), np.asarray(goal, dtype=float)
    length = float(np.linalg.norm(goal - start))
    if not (length > 0.0 and speed > 0.0):
        raise ValueError(f"line: length {length} m and speed {speed} m/s must be > 0")
    plant = MultibodyPlant(0.0)
    AddUr5e(plant)
    plant.Finalize()
    context = plant.CreateDefaultContext()
    tool, world = plant.GetFrameByName("tool0"), plant.world_frame()
    R_WT = RotationMatrix(RollPitchYaw(np.asarray(rpy, dtype=float)))
    q_prev, qs = np.asarray(seed, dtype=float), []
    for f in np.linspace(0.0, 1.0, samples):
        p = start + f * (goal - start)
        ik = InverseKinematics(plant, context)
        ik.AddPositionConstraint(tool, np.zeros(3), world, p, p)
        ik.AddOrientationConstraint(world, R_WT, tool, RotationMatrix(), ORIENTATION_TOLERANCE)
        ik.prog().AddQuadraticErrorCost(np.eye(6), q_prev, ik.q())
        ik.prog().SetInitialGuess(ik.q(), q_prev)
        result = Solve(ik.prog())
        if not result.is_success():
            raise ValueError(f"line: no inverse kinematics for the tool at {p.tolist()} m")
        q_prev = result.GetSolution(ik.q())
        qs.append(q_prev)
    return make_spline_path(np.linspace(0.0, length / speed, samples), np.array(qs))
