"""Speed alteration along the path (seed 004): ERGA and the baselines it was compared with.

Every sampling period the controller picks an end-effector speed V along the
pre-programmed path (m/s, signed: negative backs away along the path), from the
operators' ellipsoids predicted one step ahead (Eqs. 9-10) and the robot's ellipsoids
at the pose each speed leads to:

- ``erga``: the elite real-coded GA minimising Eqs. 11-12 (``safety_systems.erga``);
- ``hwang``: Hwang et al.'s objective, Eq. 13, minimised over a grid of speeds;
- ``bimodal``: Morato et al.'s stop/go: full speed while every ellipsoid pair is more
  than a clearance apart, else stop;
- ``none``: the pre-programmed speed (no alteration).

The danger index of a candidate speed is read off a grid of path positions spanning
every speed the controller may pick (``GRID`` points, the worse neighbour between
them), so one decision costs one batch of forward kinematics plus the search.
"""

import numpy as np
from scipy.integrate import trapezoid

from safety_systems.ellipsoids import (
    Ellipsoids,
    concatenate,
    danger_index,
    human_ellipsoids,
    robot_ellipsoids,
    spheres,
    support,
)
from safety_systems.erga import (
    ErgaParameters,
    danger_penalty,
    erga_piecewise_quadratic,
    speed_terms_polynomial,
)
from safety_systems.joint_path import joint_path_state
from safety_systems.ur5e import tool0_position_and_velocity

GRID = 101


def preprogrammed_speed(path) -> float:
    """Eq. 8 generalised to any path: the tool's path length over its nominal duration
    (for a straight line, distance / T exactly), m/s."""
    s = np.linspace(0.0, path.cycle_time, 2001)
    q, dq, _ = joint_path_state(path, s)
    speed = np.linalg.norm(tool0_position_and_velocity(q, dq)[1], axis=-1)
    return float(trapezoid(speed, s) / path.cycle_time)


def operator_ellipsoids(positions: np.ndarray, valid: np.ndarray, operator_of: np.ndarray,
                        is_hand: np.ndarray, sizes) -> Ellipsoids:
    """The operators' ellipsoids from the tracked bodies (N, 3) that are ``valid``.

    With ``sizes.human == "upper_body"``, an operator whose two hands are tracked gets
    the upper-body model (:func:`safety_systems.ellipsoids.human_ellipsoids`); every other
    tracked body is a sphere (hand radius for gloves, head radius for heads).
    """
    parts, used = [], np.zeros(len(valid), dtype=bool)
    if sizes.human == "upper_body":
        pairs = [hands for k in np.unique(operator_of)
                 if (hands := np.flatnonzero((operator_of == k) & is_hand & valid)).size == 2]
        if pairs:  # every skeleton at once: (operators, 2, 3) -> (operators * 8,)
            body = human_ellipsoids(positions[np.array(pairs)], sizes)
            parts.append(Ellipsoids(body.centres.reshape(-1, 3),
                                    body.rotations.reshape(-1, 3, 3),
                                    body.semi_axes.reshape(-1, 3)))
            used[np.concatenate(pairs)] = True
    rest = valid & ~used
    if rest.any():
        radius = np.where(is_hand[rest], sizes.hand_radius, sizes.head_radius)
        parts.append(spheres(positions[rest], radius))
    if len(parts) == 1:
        return parts[0]
    if not parts:
        return spheres(np.zeros((0, 3)), 0.0)
    return concatenate(*parts)


FAR = 1e6  # m: where absent bodies' ellipsoids are put, out of every pair's reach


def operator_ellipsoids_over_time(positions: np.ndarray, present: np.ndarray,
                                  operator_of: np.ndarray, is_hand: np.ndarray,
                                  sizes) -> Ellipsoids:
    """``operator_ellipsoids`` at every instant at once: positions (T, N, 3), present
    (T, N). Returns (T, M) ellipsoids with a fixed M; those of absent bodies (and the
    upper-body model of operators without both hands) are moved ``FAR`` away."""
    parts, skeleton_hands = [], np.zeros(positions.shape[:2], dtype=bool)
    if sizes.human == "upper_body":
        for k in np.unique(operator_of):
            hands = np.flatnonzero((operator_of == k) & is_hand)
            if hands.size == 2:
                both = present[:, hands].all(axis=1)
                body = human_ellipsoids(positions[:, hands], sizes)
                parts.append(body.moved(np.where(both, 0.0, FAR)[:, None, None]))
                skeleton_hands[:, hands] = both[:, None]
    alone = present & ~skeleton_hands
    radius = np.where(is_hand, sizes.hand_radius, sizes.head_radius)
    parts.append(spheres(np.where(alone[..., None], positions, FAR),
                         np.broadcast_to(radius, alone.shape)))
    return concatenate(*parts)


def robot_at(path, s: np.ndarray, sizes) -> Ellipsoids:
    """The robot's ellipsoids at path positions s (G,)."""
    q = joint_path_state(path, s)[0]
    return robot_ellipsoids(q, sizes.link_radii, sizes.tool_radius, sizes.tool_offset)


def danger_grid(path, s: float, speeds: np.ndarray, dt: float, v_pre: float,
                humans: Ellipsoids, sizes) -> np.ndarray:
    """(len(speeds), pairs) DI of every robot-operator pair at the pose each speed
    reaches after dt from path position s (Eq. 7 at X(k+1))."""
    robot = robot_at(path, s + speeds / v_pre * dt, sizes)
    return danger_index(robot, humans).reshape(len(speeds), -1)


def grid_upper(grid_speeds: np.ndarray, rows: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``rows`` (G, pairs), given at ``grid_speeds``, at speeds v: the larger of the two
    grid values around each v (between grid points the danger index is taken at its
    worse end, so a speed the search accepts is never riskier than it looks)."""
    x = np.interp(v, grid_speeds, np.arange(len(grid_speeds)))
    return np.maximum(rows[np.floor(x).astype(int)], rows[np.ceil(x).astype(int)])


def erga_speed(*, grid_speeds: np.ndarray, danger: np.ndarray, v_pre: float, v_prev: float,
               limit: float, rng: np.random.Generator, params: ErgaParameters,
               P: float, D: float, R: float) -> tuple[float, np.ndarray]:
    """ERGA's choice (Eqs. 11-12) and its best fitness per generation. The Eq. 12
    penalty of each grid cell (pairs taken at their worse end, ``grid_upper``) is
    summed once; a candidate reads its cell's (on a grid point, the cell above it:
    never less than the point's own)."""
    penalty = np.empty(len(grid_speeds))
    penalty[:-1] = danger_penalty(np.maximum(danger[:-1], danger[1:]), R)
    penalty[-1] = danger_penalty(danger[-1], R)  # the top grid point
    c2, c1, c0 = speed_terms_polynomial(v_preprogrammed=v_pre, v_previous=v_prev, P=P, D=D)
    # by_cell[i] is the penalty of the cell below grid_speeds[i] plus c0, so that the
    # right-sided search of v gives v's cell (a grid point's is the cell above it).
    by_cell = np.concatenate((penalty[:1], penalty)) + c0

    # Eq. 11 (as c2 v^2 + c1 v + c0) + Eq. 12, run compiled.
    return erga_piecewise_quadratic(c2=c2, c1=c1, breaks=grid_speeds, by_cell=by_cell,
                                    bound=limit, rng=rng, params=params)


def hwang_speed(*, grid_speeds: np.ndarray, danger: np.ndarray, danger_now: np.ndarray,
                v_pre: float) -> float:
    """Eq. 13 over the grid: sum_ij P_ij(k) + sum_ij (P_ij(k) - P_ij(k-1)) +
    |V - V_pre| / V_pre, reading the collision-trend index P_ij as the danger index at
    the pose the speed leads to (k) and at the current pose (k - 1) (interpretation:
    the seed does not define P_ij)."""
    cost = (danger.sum(axis=1) + (danger - danger_now).sum(axis=1)
            + np.abs(grid_speeds - v_pre) / v_pre)
    return float(grid_speeds[np.argmin(cost)])


def clearance(a: Ellipsoids, b: Ellipsoids) -> float:
    """Smallest centre distance minus support radii over the pairs (m; < 0: overlap
    possible); +inf without pairs."""
    if a.centres.shape[-2] == 0 or b.centres.shape[-2] == 0:
        return float("inf")
    diff = b.centres[None, :, :] - a.centres[:, None, :]
    d = np.linalg.norm(diff, axis=-1)
    u = np.divide(diff, d[..., None], out=np.zeros_like(diff), where=d[..., None] > 0)
    u[d == 0.0] = [1.0, 0.0, 0.0]  # coincident centres: any direction measures the overlap
    h = (support(a.rotations[:, None], a.semi_axes[:, None], u)
         + support(b.rotations[None], b.semi_axes[None], u))
    return float(np.min(d - h))


def bimodal_speed(gap: float, *, v_pre: float, threshold: float) -> float:
    """Morato et al.'s bi-modal strategy: V_pre while the clearance exceeds ``threshold``,
    else 0."""
    return v_pre if gap > threshold else 0.0
