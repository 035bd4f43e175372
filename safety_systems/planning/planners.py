"""Potential-field planners of seed 001: the IAPF (Section 2.3) and the plain
gradient-descent APF it is compared with (the seed's GDA baseline, Section 3).

Both follow F_total (Eq. 4a) from the start in steps of at most ``planner.step``.

- :func:`plan_gda`: plain APF with the GDA's gains (``planner.gda_k_att``,
  ``gda_k_rep``; the same Eq. 2e attraction and zeta as the IAPF), d_factor off (Eq.
  3a's flag False, so F(2) = 0), a fixed step along F_total / |F_total|, no escape. It
  bounces in and out of the zone where repulsion acts and stops when it stagnates
  (trapped in a local minimum) or at ``planner.max_iterations``.
- :func:`plan_iapf`: the IAPF: d_factor and F(2) as configured; it follows the flow
  line of F_total (the path of steepest descent of U_combined, Eq. 1b) with Heun's
  method, each step as long as ``planner.step`` allows while the force turns by at
  most 10 degrees over it (so the path is smooth where the repulsion bends it rather
  than chattering on it), U_combined falls, and the new point keeps
  ``planner.clearance`` from every obstacle, plus step^2 / (8 clearance), the most a
  straight step between two such points can dip towards a convex obstacle (so no point
  of the path breaks the bound); and an escape from local minima.

The seed's "gradient-based recalibration ... to prevent the robot from becoming stuck
in local minima" (Section 2.3.2, item 2) is not specified. Our reading: where the
descent stalls (no step down, or less than ``STALL_FRACTION`` of the possible progress
over ``STALL_WINDOW`` steps) the attraction and repulsion cancel; we recalibrate the
direction by projecting the goal direction onto the tangent plane of the nearest
obstacle (dropping the part the repulsion cancels) or, when that projection vanishes
(a symmetric trap), a random tangent from ``numpy.random.default_rng(planner.seed)``.
The tool then follows the obstacle's boundary at the distance where it stalled, its
heading kept in the tangent plane, until U_combined is below its value at the minimum;
the descent resumes from there and, being monotone in U, cannot fall back into that
minimum. An attempt that does not get there in ``planner.escape_steps`` steps is
discarded and another tangent drawn, up to ``planner.escape_attempts`` in all.
"""

import dataclasses
import time

import numpy as np

from safety_systems.planning.potential_field import (
    Field,
    field_from_scene,
    total_force,
    total_potential,
)
from safety_systems.planning.task_space import TaskScene, clearance, signed_distances

STALL_WINDOW = 20  # steps
STALL_FRACTION = 0.1  # of STALL_WINDOW full steps
MIN_STEP_FRACTION = 1.0 / 1024.0  # of planner.step: the shortest step tried
COS_MAX_TURN = float(np.cos(np.radians(10.0)))  # largest turn of the force within a step


@dataclasses.dataclass(frozen=True)
class PlannedPath:
    """A planner's answer: ``points`` (K, 3) m from start to where it stopped (the goal
    when ``reached_goal``), ``planning_time`` s, and what it did (``iterations``,
    ``escapes`` made, free-form ``note``)."""

    planner: str
    points: np.ndarray
    planning_time: float
    reached_goal: bool
    iterations: int = 0
    escapes: int = 0
    note: str = ""


def guard_distance(clearance: float, step: float) -> float:
    """The distance (m) at which the end points of a straight step of ``step`` m must
    stay from every convex obstacle for the whole step to keep ``clearance``: the
    inflated obstacle curves no tighter than ``clearance``, so a chord dips at most
    step^2 / (8 clearance) below its ends."""
    return clearance + step**2 / (8.0 * clearance)


def _stalled(path: list[np.ndarray], step: float) -> bool:
    if len(path) <= STALL_WINDOW:
        return False
    return np.linalg.norm(path[-1] - path[-1 - STALL_WINDOW]) < (
        STALL_FRACTION * STALL_WINDOW * step)


def plan_gda(scene: TaskScene) -> PlannedPath:
    """Plain APF by gradient descent (the seed's GDA baseline): fixed steps along
    F_total without d_factor, no escape; stops at the goal, when stalled, or after
    ``planner.max_iterations`` steps."""
    began = time.perf_counter()
    p = scene.planner
    field = field_from_scene(scene, baseline=True)
    goal = field.goal
    q = np.asarray(scene.start, dtype=float)
    path = [q]
    reached, note = False, "iteration limit"
    for _ in range(p.max_iterations):
        to_goal = float(np.linalg.norm(goal - q))
        if to_goal <= p.step:
            path.append(goal.copy())
            reached, note = True, ""
            break
        force = total_force(q, field)[0]
        norm = float(np.linalg.norm(force))
        if norm == 0.0 or _stalled(path, p.step):
            note = "trapped in a local minimum"
            break
        q = q + min(p.step, to_goal) * force / norm
        path.append(q)
    return PlannedPath("GDA", np.array(path), time.perf_counter() - began, reached,
                       iterations=len(path) - 1, note=note)


def _direction(q: np.ndarray, field: Field) -> np.ndarray | None:
    force = total_force(q, field)[0]
    norm = float(np.linalg.norm(force))
    return force / norm if norm > 0.0 else None


def _flow_step(q: np.ndarray, u: float, field: Field, step: float, bound: float
               ) -> tuple[np.ndarray, float] | None:
    """One IAPF step along the flow line of F_total (Heun's method on the unit force
    direction): the longest step of at most ``step`` m, halving, over which the force's
    direction turns by at most MAX_TURN, that lowers U_combined and keeps the clearance
    ``bound``; None when no step of at least MIN_STEP_FRACTION of ``step`` does."""
    d1 = _direction(q, field)
    if d1 is None:
        return None
    h = step
    while h >= step * MIN_STEP_FRACTION:
        d2 = _direction(q + h * d1, field)
        if d2 is not None and float(d1 @ d2) >= COS_MAX_TURN:
            mean = d1 + d2
            candidate = q + h * mean / np.linalg.norm(mean)
            rho, _ = signed_distances(candidate[None], field.obstacles)
            u_new = float(total_potential(candidate, field, rho)[0])
            if u_new < u and rho.min(initial=np.inf) >= bound:
                return candidate, u_new
        h *= 0.5
    return None


def _escape(q_min: np.ndarray, u_min: float, field: Field, scene: TaskScene,
            rng: np.random.Generator, random_tangent: bool) -> list[np.ndarray] | None:
    """Follow the nearest obstacle's boundary from the local minimum ``q_min`` until
    U_combined < ``u_min``; the points walked, or None if ``escape_steps`` run out."""
    p = scene.planner
    rho, grad = signed_distances(q_min[None], field.obstacles)
    k = int(rho[0].argmin())
    normal = grad[0, k]
    hold = max(float(rho[0, k]), p.clearance + p.step)
    bound = guard_distance(p.clearance, p.step)
    heading = field.goal - q_min
    heading = heading - heading.dot(normal) * normal
    if random_tangent or np.linalg.norm(heading) < 1e-3 * np.linalg.norm(field.goal - q_min):
        heading = rng.standard_normal(3)
        heading = heading - heading.dot(normal) * normal
    heading /= np.linalg.norm(heading)
    q, walked = q_min, []
    for _ in range(p.escape_steps):
        rho, grad = signed_distances(q[None], field.obstacles)
        k = int(rho[0].argmin())
        normal = grad[0, k]
        tangent = heading - heading.dot(normal) * normal
        if np.linalg.norm(tangent) > 1e-9:
            heading = tangent / np.linalg.norm(tangent)
        correction = np.clip(hold - rho[0, k], -p.step, p.step)
        move = p.step * heading + correction * normal
        candidate = q + move * min(1.0, p.step / float(np.linalg.norm(move)))
        if clearance(candidate[None], field.obstacles)[0] < bound:
            return None
        q = candidate
        walked.append(q)
        if float(total_potential(q, field)[0]) < u_min:
            return walked
    return None


def plan_iapf(scene: TaskScene) -> PlannedPath:
    """The IAPF planner (module docstring): descent on U_combined with the clearance
    bound, and the local-minimum escape."""
    began = time.perf_counter()
    p = scene.planner
    field = field_from_scene(scene)
    rng = np.random.default_rng(p.seed)
    goal = field.goal
    q = np.asarray(scene.start, dtype=float)
    u = float(total_potential(q, field)[0])
    path = [q]
    escapes, attempts, last_escape = 0, 0, 0
    reached, note = False, "iteration limit"
    for _ in range(p.max_iterations):
        if np.linalg.norm(goal - q) <= p.step:
            path.append(goal.copy())
            reached, note = True, ""
            break
        result = _flow_step(q, u, field, min(p.step, float(np.linalg.norm(goal - q))),
                            guard_distance(p.clearance, p.step))
        if result is not None:
            q, u = result
            path.append(q)
        if result is None or (len(path) - last_escape > STALL_WINDOW
                              and _stalled(path, p.step)):
            walked = None
            while walked is None and attempts < p.escape_attempts:
                walked = _escape(q, u, field, scene, rng, random_tangent=attempts > escapes)
                attempts += 1
            if walked is None:
                note = "trapped in a local minimum; escapes failed"
                break
            escapes += 1
            path.extend(walked)
            q = walked[-1]
            u = float(total_potential(q, field)[0])
            last_escape = len(path)
    return PlannedPath("IAPF", np.array(path), time.perf_counter() - began, reached,
                       iterations=len(path) - 1, escapes=escapes, note=note)
