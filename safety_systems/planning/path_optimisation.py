"""Path optimisation of seed 001 (Section 2.4, Eq. 5): minimise omega1 L(p) + omega2 B(p)
subject to the clearance bound and the workspace bounds L(t) <= p(t) <= U(t), the ends
fixed, starting from the IAPF path.

How we read Section 2.4:

- The path p(t) is a clamped cubic B-spline (``planner.opt_points`` control points, the
  first and last the start and goal, so the ends stay fixed) sampled at about
  ``planner.metric_spacing`` m; L and B (Eq. 5b) are those of the sampled polyline
  (``safety_systems.planning.path_metrics``), so the optimised path is measured exactly as every
  other path is. A spline, rather than moving the points of the polyline, keeps the
  curvature honest: a coarse polyline can hide a sharp corner between long segments.
- The seed optimises "using a gradient descent algorithm"; we use SciPy's SLSQP with
  exact gradients, a gradient method that handles the constraints.
- "O_top(t) >= zeta": the bound is ``planner.clearance`` from every obstacle's surface
  at every sample, not the field's threshold zeta: zeta is where repulsion starts, so
  the IAPF path runs just inside it by construction and would start infeasible, and
  RRT* is held to the same ``planner.clearance``, which makes the comparison fair. Set
  ``clearance`` just below ``zeta`` for the literal reading. Between samples the
  polyline can dip towards a convex obstacle by at most h^2 / (8 clearance) for
  samples h apart (the inflated obstacle's boundary curves no tighter than the
  clearance), so the samples are held that much further out, and the result is checked
  densely and re-optimised with a larger margin if it still falls short.
- The workspace bounds are those of ``task_space.workspace_bounds``, applied to the
  control points (the spline stays in their convex hull).
"""

import dataclasses
import time

import numpy as np
from scipy.interpolate import BSpline
from scipy.optimize import minimize

from safety_systems.planning.path_metrics import (
    bending_energy_and_gradient,
    length_gradient,
    min_clearance,
    path_length,
    resample,
    segment_lengths,
)
from safety_systems.planning.planners import PlannedPath
from safety_systems.planning.task_space import (
    ObstacleSet,
    TaskScene,
    obstacle_set,
    signed_distances,
    workspace_bounds,
)

DEGREE = 3
FTOL = 1e-8  # SLSQP: stop when the objective (m) changes by less
MAX_ROUNDS = 3  # optimisations with a growing margin until the dense check passes
NEAR = 0.1  # m: a sample is held clear of the obstacles within this of the bound at the
#             start of a round (the others are too far to matter; the dense check after
#             the round catches any that do)


@dataclasses.dataclass(frozen=True)
class OptimisedPath:
    """The optimised path (K, 3) m, whether SLSQP converged and the dense check passed,
    SLSQP's message, its iterations over every round, and the margin (m) used."""

    points: np.ndarray
    success: bool
    message: str
    iterations: int
    margin: float
    seconds: float


def spline_basis(samples: int, controls: int) -> np.ndarray:
    """(samples, controls) clamped uniform cubic B-spline basis at equally spaced
    parameters in [0, 1]."""
    inner = np.linspace(0.0, 1.0, controls - DEGREE + 1)
    knots = np.concatenate([[0.0] * DEGREE, inner, [1.0] * DEGREE])
    u = np.linspace(0.0, 1.0, samples)
    return BSpline.design_matrix(u, knots, DEGREE).toarray()


def fit_controls(points: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """Control points (M, 3) whose spline fits ``points`` resampled at equal arc length,
    the first and last control points at the path's ends."""
    target = resample(points, count=basis.shape[0])
    ends = np.outer(basis[:, 0], target[0]) + np.outer(basis[:, -1], target[-1])
    inner, *_ = np.linalg.lstsq(basis[:, 1:-1], target - ends, rcond=None)
    return np.vstack([target[0], inner, target[-1]])


def _clearance_constraint(x, curve, inner_basis, obstacles, bound):
    """SLSQP's inequality (rho - bound >= 0) with its Jacobian over the (sample, obstacle)
    pairs within NEAR of the bound on the curve of ``x`` (none: an empty list)."""
    n = inner_basis.shape[1]
    rho, _ = signed_distances(curve(x), obstacles)
    rows, cols = np.nonzero(rho < bound + NEAR)
    if len(rows) == 0:
        return []

    def gaps(x: np.ndarray) -> np.ndarray:
        rho, _ = signed_distances(curve(x), obstacles)
        return rho[rows, cols] - bound

    def gaps_jacobian(x: np.ndarray) -> np.ndarray:
        _, grad = signed_distances(curve(x), obstacles)  # (S, N, 3)
        jac = inner_basis[rows, :, None] * grad[rows, cols][:, None, :]  # (R, n, 3)
        return jac.reshape(len(rows), 3 * n)

    return [{"type": "ineq", "fun": gaps, "jac": gaps_jacobian}]


def optimise_path(points: np.ndarray, obstacles: ObstacleSet, *, clearance: float,
                  omega1: float, omega2: float, controls: int, spacing: float,
                  bounds: tuple[np.ndarray, np.ndarray]) -> OptimisedPath:
    """Eq. 5a from ``points`` (K, 3) m; see the module docstring."""
    began = time.perf_counter()
    points = np.asarray(points, dtype=float)
    samples = max(4 * controls, int(np.ceil(path_length(points) / spacing)) + 1)
    basis = spline_basis(samples, controls)
    inner_basis = basis[:, 1:-1]
    c0 = fit_controls(points, basis)
    first, last = c0[0], c0[-1]
    n = controls - 2

    def curve(x: np.ndarray) -> np.ndarray:
        return basis @ np.vstack([first, x.reshape(n, 3), last])

    def objective(x: np.ndarray) -> tuple[float, np.ndarray]:
        s = curve(x)
        bend, d_bend = bending_energy_and_gradient(s)
        value = omega1 * path_length(s) + omega2 * bend
        grad = omega1 * length_gradient(s) + omega2 * d_bend
        return value, (inner_basis.T @ grad).ravel()

    low, high = bounds
    box = [(low[k], high[k]) for _ in range(n) for k in range(3)]
    x = np.clip(c0[1:-1], low, high).ravel()
    margin = float(np.max(segment_lengths(curve(x)))) ** 2 / (8.0 * clearance)
    iterations, result = 0, None
    for _ in range(MAX_ROUNDS):
        constraints = _clearance_constraint(x, curve, inner_basis, obstacles,
                                            clearance + margin)
        result = minimize(objective, x, jac=True, method="SLSQP", bounds=box,
                          constraints=constraints, options={"maxiter": 300, "ftol": FTOL})
        iterations += int(result.nit)
        x = result.x
        shortfall = clearance - min_clearance(curve(x), obstacles)
        if shortfall <= 0.0:
            break
        margin += shortfall + 1e-4
    path = curve(x)
    ok = bool(result.success) and min_clearance(path, obstacles) >= clearance
    return OptimisedPath(path, ok, str(result.message), iterations, margin,
                         time.perf_counter() - began)


def plan_optimised(scene: TaskScene, iapf: PlannedPath) -> PlannedPath:
    """The IAPF path optimised by Eq. 5 ("IAPF+opt"); its planning time is the IAPF's
    plus the optimisation's. Where the optimisation fails (SLSQP does not converge or
    the result breaks the clearance bound) the IAPF path is kept and ``note`` says so;
    an IAPF path that did not reach the goal is not optimised."""
    if not iapf.reached_goal:
        return dataclasses.replace(iapf, planner="IAPF+opt", note="IAPF did not reach the goal")
    p = scene.planner
    result = optimise_path(iapf.points, obstacle_set(scene.obstacles), clearance=p.clearance,
                           omega1=p.omega1, omega2=p.omega2, controls=p.opt_points,
                           spacing=p.metric_spacing, bounds=workspace_bounds(scene))
    seconds = iapf.planning_time + result.seconds
    if not result.success:
        return dataclasses.replace(
            iapf, planner="IAPF+opt", planning_time=seconds,
            note=f"optimisation failed ({result.message}); the IAPF path is kept")
    return PlannedPath("IAPF+opt", result.points, seconds, True, iterations=result.iterations,
                       escapes=iapf.escapes)
