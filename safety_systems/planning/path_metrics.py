"""Metrics of a task-space path (K, 3) in metres: length, bending energy (seed 001,
Eq. 5b), clearance checked densely along every segment, and the time to goal at a
maximum tool speed and acceleration.

Bending energy, discretised: B = sum over interior vertices of kappa_i^2 ds_i with
kappa_i = |t_i - t_(i-1)| / ds_i (t the unit tangents of the segments either side,
|t_i - t_(i-1)| = 2 sin(theta_i / 2) for a turn of theta_i) and ds_i the mean of the
two segment lengths, so B = sum |t_i - t_(i-1)|^2 / ds_i, in 1/m. For a smooth curve
this tends to the integral of kappa^2 ds; a sharp corner has no finite bending energy,
so its figure grows as the sampling gets finer. Paths are therefore compared after
resampling at one arc-length spacing (:func:`resample`, ``metric_spacing``).
"""

import itertools

import numpy as np

from safety_systems.planning.task_space import ObstacleSet, clearance


def segment_lengths(points: np.ndarray) -> np.ndarray:
    """(K-1,) lengths of the segments, m."""
    return np.linalg.norm(np.diff(np.asarray(points, dtype=float), axis=0), axis=1)


def path_length(points: np.ndarray) -> float:
    """L(p) of Eq. 5a: the polyline's length, m."""
    return float(segment_lengths(points).sum())


def resample(points: np.ndarray, spacing: float | None = None, *,
             count: int | None = None) -> np.ndarray:
    """Points at equal arc length along the polyline (ends kept): about ``spacing`` m
    apart, or exactly ``count`` points."""
    points = np.asarray(points, dtype=float)
    arc = np.concatenate([[0.0], np.cumsum(segment_lengths(points))])
    if count is None:
        count = max(2, int(np.ceil(arc[-1] / spacing)) + 1)
    s = np.linspace(0.0, arc[-1], count)
    keep = np.concatenate([[True], np.diff(arc) > 0.0])
    return np.stack([np.interp(s, arc[keep], points[keep, k]) for k in range(3)], axis=1)


def bending_energy(points: np.ndarray) -> float:
    """B(p) of Eq. 5b, discretised as in the module docstring, 1/m."""
    return float(bending_energy_and_gradient(points)[0])


def bending_energy_and_gradient(points: np.ndarray) -> tuple[float, np.ndarray]:
    """B(p) and dB/dp (K, 3) (zero-length segments are not allowed)."""
    p = np.asarray(points, dtype=float)
    e = np.diff(p, axis=0)
    ell = np.linalg.norm(e, axis=1)
    t = e / ell[:, None]
    a = t[1:] - t[:-1]  # (K-2, 3)
    ds = 0.5 * (ell[1:] + ell[:-1])
    a2 = (a * a).sum(axis=1)
    value = float((a2 / ds).sum())
    # dB/dt and dB/dell for every segment, then through t = e / ell and e = diff(p).
    d_t = np.zeros_like(t)
    d_t[1:] += 2.0 * a / ds[:, None]
    d_t[:-1] -= 2.0 * a / ds[:, None]
    d_ell = np.zeros_like(ell)
    half = -0.5 * a2 / ds**2
    d_ell[1:] += half
    d_ell[:-1] += half
    d_e = (d_t - (d_t * t).sum(axis=1)[:, None] * t) / ell[:, None] + d_ell[:, None] * t
    grad = np.zeros_like(p)
    grad[1:] += d_e
    grad[:-1] -= d_e
    return value, grad


def length_gradient(points: np.ndarray) -> np.ndarray:
    """dL/dp (K, 3)."""
    e = np.diff(np.asarray(points, dtype=float), axis=0)
    t = e / np.linalg.norm(e, axis=1)[:, None]
    grad = np.zeros((len(e) + 1, 3))
    grad[1:] += t
    grad[:-1] -= t
    return grad


def dense_points(points: np.ndarray, spacing: float = 0.0005) -> np.ndarray:
    """The polyline sampled along every segment at most ``spacing`` m apart (vertices
    included), for checks between the vertices."""
    p = np.asarray(points, dtype=float)
    out = [p[:1]]
    for a, b in itertools.pairwise(p):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / spacing)))
        out.append(a + np.linspace(0.0, 1.0, n + 1)[1:, None] * (b - a))
    return np.vstack(out)


def min_clearance(points: np.ndarray, obstacles: ObstacleSet,
                  spacing: float = 0.0005) -> float:
    """The smallest distance (m) from any point of the polyline (sampled every
    ``spacing`` m along each segment) to any obstacle's surface."""
    return float(clearance(dense_points(points, spacing), obstacles).min())


def speed_limits(points: np.ndarray, max_speed: float, max_acceleration: float
                 ) -> np.ndarray:
    """(K,) the highest tool speed at each vertex: ``max_speed``, and where the path
    turns, sqrt(a_max / kappa_i) so that the centripetal acceleration stays within the
    limit; zero at both ends (rest to rest)."""
    p = np.asarray(points, dtype=float)
    ell = segment_lengths(p)
    t = np.diff(p, axis=0) / ell[:, None]
    kappa = np.linalg.norm(t[1:] - t[:-1], axis=1) / (0.5 * (ell[1:] + ell[:-1]))
    v = np.full(len(p), float(max_speed))
    turning = kappa > 0.0
    v[1:-1][turning] = np.minimum(max_speed, np.sqrt(max_acceleration / kappa[turning]))
    v[0] = v[-1] = 0.0
    return v


def time_to_goal(points: np.ndarray, max_speed: float, max_acceleration: float) -> float:
    """Seconds to run the path rest to rest, as fast as a tool speed of ``max_speed``
    (m/s) and a tangential and centripetal acceleration each of ``max_acceleration``
    (m/s^2) allow: the vertex speeds of :func:`speed_limits`, lowered by a forward and a
    backward pass so that no segment needs more than the acceleration limit; within a
    segment the tool accelerates, cruises at ``max_speed`` if it can reach it, and
    brakes. Resample the path first (:func:`resample`) so curvature is measured at one
    scale."""
    p = np.asarray(points, dtype=float)
    keep = np.concatenate([[True], segment_lengths(p) > 0.0])
    p = p[keep]
    if len(p) < 2:
        return 0.0
    ell = segment_lengths(p)
    v = speed_limits(p, max_speed, max_acceleration)
    a = float(max_acceleration)
    for i in range(len(ell)):
        v[i + 1] = min(v[i + 1], np.sqrt(v[i] ** 2 + 2.0 * a * ell[i]))
    for i in range(len(ell) - 1, -1, -1):
        v[i] = min(v[i], np.sqrt(v[i + 1] ** 2 + 2.0 * a * ell[i]))
    v0, v1 = v[:-1], v[1:]
    peak = np.minimum(max_speed, np.sqrt((2.0 * a * ell + v0**2 + v1**2) / 2.0))
    up = (peak**2 - v0**2) / (2.0 * a)
    down = (peak**2 - v1**2) / (2.0 * a)
    cruise = np.maximum(ell - up - down, 0.0)
    return float(((peak - v0) / a + (peak - v1) / a + cruise / peak).sum())
