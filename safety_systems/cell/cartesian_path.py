"""Joint paths from Cartesian tool paths, by Drake's inverse kinematics."""

import functools

import numpy as np
from pydrake.math import RollPitchYaw, RotationMatrix
from pydrake.multibody.inverse_kinematics import InverseKinematics
from pydrake.multibody.plant import MultibodyPlant
from pydrake.solvers import Solve

from safety_systems.cell.joint_path import SplinePath, make_spline_path
from safety_systems.cell.ur5e import AddUr5e

ORIENTATION_TOLERANCE = 1e-6  # rad


def polyline_path(points: np.ndarray, *, speed: float, rpy: np.ndarray, seed: np.ndarray,
                  spacing: float = 0.01, min_samples: int = 25, cycles: int = 1,
                  there_and_back: bool = False) -> SplinePath:
    """A tool0 path through ``points`` (K, 3) (m, base frame) at ``speed`` (m/s,
    nominal mean speed), the tool held at roll-pitch-yaw ``rpy`` (rad), as a joint
    spline: inverse kinematics at points spaced along the polyline (about ``spacing``
    apart, at least ``min_samples``), each seeded with the previous solution (the first
    with ``seed``) and pulled towards it, so the arm stays on one branch.

    One way (``there_and_back`` False) the tool runs at a uniform speed; there and back
    (``cycles`` times) it runs rest to rest along the polyline with a minimum-jerk
    timing (peak 1.875 times the mean speed), out and back again.

    Raises:
        ValueError: a point the arm cannot reach with that orientation.
    """
    points = np.asarray(points, dtype=float)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) < 2:
        raise ValueError(f"points has shape {points.shape}: need (K >= 2, 3) metres")
    times, qs = _ik_samples(tuple(map(tuple, points.tolist())), float(speed),
                            tuple(np.asarray(rpy, dtype=float).tolist()),
                            tuple(np.asarray(seed, dtype=float).tolist()),
                            float(spacing), int(min_samples), bool(there_and_back))
    return make_spline_path(times, qs, rest_to_rest=there_and_back, cycles=cycles,
                            there_and_back=there_and_back)


@functools.lru_cache(maxsize=32)
def _ik_samples(points: tuple, speed: float, rpy: tuple, seed: tuple, spacing: float,
                min_samples: int, there_and_back: bool) -> tuple[np.ndarray, np.ndarray]:
    """Sample times and joint positions of ``polyline_path`` (cached: a scenario space
    builds many scenarios on one path, and each would otherwise solve the same
    inverse kinematics again)."""
    points = np.array(points, dtype=float)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    length = float(arc[-1])
    if not (length > 0.0 and speed > 0.0):
        raise ValueError(f"path: length {length} m and speed {speed} m/s must be > 0")
    samples = max(min_samples, int(np.ceil(length / spacing)) + 1)
    duration = length / speed
    times = np.linspace(0.0, duration, samples)
    if there_and_back:
        tau = times / duration
        along = length * tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)
    else:
        along = speed * times
    targets = np.stack([np.interp(along, arc, points[:, k]) for k in range(3)], axis=1)
    plant = MultibodyPlant(0.0)
    AddUr5e(plant)
    plant.Finalize()
    context = plant.CreateDefaultContext()
    tool, world = plant.GetFrameByName("tool0"), plant.world_frame()
    R_WT = RotationMatrix(RollPitchYaw(np.array(rpy)))
    def solve(p, q_near):
        ik = InverseKinematics(plant, context)
        ik.AddPositionConstraint(tool, np.zeros(3), world, p, p)
        ik.AddOrientationConstraint(world, R_WT, tool, RotationMatrix(), ORIENTATION_TOLERANCE)
        ik.prog().AddQuadraticErrorCost(np.eye(6), q_near, ik.q())
        ik.prog().SetInitialGuess(ik.q(), q_near)
        result = Solve(ik.prog())
        return result.GetSolution(ik.q()) if result.is_success() else None

    # The first point: the given seed, else elbow-up seeds facing the point (at q1 = 0
    # the UR arm reaches along -x).
    facing = np.degrees(np.arctan2(targets[0, 1], targets[0, 0])) - 180.0
    tries = [np.array(seed)] + [
        np.radians([facing, lift, elbow, -90.0 - lift - elbow, -90.0, 0.0])
        for lift in (-60.0, -90.0, -45.0) for elbow in (100.0, 80.0, 120.0)]
    q_prev = next((q for q in (solve(targets[0], t) for t in tries) if q is not None), None)
    if q_prev is None:
        raise ValueError(f"path: no inverse kinematics for the tool at {targets[0].tolist()} m")
    qs = []
    for p in targets:
        q_prev = solve(p, q_prev)
        if q_prev is None:
            raise ValueError(f"path: no inverse kinematics for the tool at {p.tolist()} m")
        qs.append(q_prev)
    times, qs = np.array(times), np.array(qs)
    times.flags.writeable = False
    qs.flags.writeable = False
    return times, qs


def line_path(start: np.ndarray, goal: np.ndarray, *, speed: float, rpy: np.ndarray,
              seed: np.ndarray, samples: int = 25) -> SplinePath:
    """A straight tool0 line from ``start`` to ``goal``: ``polyline_path`` of two points."""
    return polyline_path(np.array([start, goal], dtype=float), speed=speed, rpy=rpy, seed=seed,
                         min_samples=samples)
