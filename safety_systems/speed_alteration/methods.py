"""Speed alteration along the path (seed 004): ERGA and the baselines it was compared with.

Every sampling period the controller picks an end-effector speed V along the
pre-programmed path (m/s, signed: negative backs away along the path), from the
operators' ellipsoids predicted one step ahead (Eqs. 9-10) and the robot's ellipsoids
at the pose each speed leads to:

- ``erga``: the elite real-coded GA minimising Eqs. 11-12 (``safety_systems.speed_alteration.erga``);
- ``hwang``: Hwang et al.'s objective, Eq. 13 (collision-trend index from the ellipsoids
  read as Gaussians, with the penalty index), minimised over a grid of speeds;
- ``bimodal``: Morato et al.'s stop/go: full speed while every ellipsoid pair is more
  than a clearance apart, else stop;
- ``none``: the pre-programmed speed (no alteration).

The danger index of a candidate speed is read off a grid of path positions spanning
every speed the controller may pick (``GRID`` points, the worse neighbour between
them), so one decision costs one batch of forward kinematics plus the search.
"""

import numpy as np
from scipy.integrate import trapezoid

from safety_systems.speed_alteration.ellipsoids import (
    Ellipsoids,
    concatenate,
    danger_index,
    human_ellipsoids,
    robot_ellipsoids,
    spheres,
    support,
)
from safety_systems.speed_alteration.erga import (
    ErgaParameters,
    danger_penalty,
    erga_piecewise_quadratic,
    speed_terms_polynomial,
)
from safety_systems.cell.joint_path import joint_path_state
from safety_systems.cell.ur5e import tool0_position_and_velocity

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
    the upper-body model (:func:`safety_systems.speed_alteration.ellipsoids.human_ellipsoids`); every other
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


def collision_trend(danger: np.ndarray) -> np.ndarray:
    """Hwang et al.'s collision-trend index P_ij of each pair from its danger index.

    Seed 004 (Sections I and IV-B) describes P_ij as "defined by projecting the ellipsoids
    onto a Gaussian distribution" and cites Hwang, Ju and Chen 2003 for it; the formula
    is printed in neither the seed nor anything we could consult, so this is our reading.
    Hwang's transformation (Section II-B) turns a pair into the point (0, 0, 0) and one
    ellipsoid whose quadratic form F_ij is 1 on its surface; F_ij = 1 / DI_ij (Eq. 7).
    Projecting that ellipsoid onto a Gaussian takes it as the Gaussian's one-sigma
    surface (the usual correspondence between an ellipsoid and a covariance: F is then
    the squared Mahalanobis distance of the point), and P_ij is the Gaussian at the point
    scaled to 1 at its centre: P_ij = exp(-F_ij / 2) = exp(-1 / (2 DI_ij)). So P_ij is 1
    for coincident centres, exp(-1/2) = 0.61 when the pair touches (DI = 1), and falls
    to 0 as the pair separates (absent bodies, DI = 0, give 0). The only choice is
    which contour the ellipsoid is, and one sigma is the convention; no constant is
    tuned.
    """
    danger = np.asarray(danger, dtype=float)
    with np.errstate(divide="ignore"):
        return np.exp(-0.5 / danger)


def hwang_speed(*, grid_speeds: np.ndarray, danger: np.ndarray, danger_now: np.ndarray,
                v_pre: float) -> float:
    """Hwang et al.'s choice of speed (seed 004, Eq. 13, with the penalty index).

    Among ``grid_speeds``, the speed that minimises, first, the penalty index, then

        Eq. 13:  sum_ij P_ij(k) + sum_ij (P_ij(k) - P_ij(k-1)) + |V - V_pre| / |V_pre|,

    with P_ij the collision-trend index (:func:`collision_trend`) of each pair at the pose
    the speed leads to (``danger`` (G, pairs), k) and at the current pose (``danger_now``
    (pairs,), k - 1). How each term is read:

    - P_ij(k): at the predicted next pose, so that the choice of V can change it (at the
      current pose it would not depend on V and Eq. 13 would always return V_pre).
    - P_ij(k) - P_ij(k-1): the trend, negative for a speed that takes the pair apart
      (the seed: it forces the robot "to reduce the sum of the collision-trend index").
    - |V - V_pre| / V_pre: the departure from the pre-programmed speed (Eq. 8).
    - The penalty index: seed 004 names it beside the collision-trend index (Section I)
      without printing it, and reports that Hwang's method keeps DI < 1 (Fig. 11(a)),
      which a bounded P_ij cannot do on its own. We read it as the penalty of a speed
      whose predicted pose collides, the seed's own measure of collision: the sum over
      pairs with DI_ij >= 1 of DI_ij^2 (Eq. 12's DI-bar with unit weight,
      ``erga.danger_penalty``), ranked before Eq. 13 (as if weighted above anything Eq.
      13 can add up to, so no weight has to be chosen): a colliding speed is taken only
      when every speed collides, and then the least colliding one.

    Consequence, not a tuning: Eq. 13's last term changes by 1 / V_pre per unit of speed,
    while the two P_ij(k) terms of a pair change by at most 2 x 0.61 dt / rho per unit of
    speed (0.61 / rho is the steepest slope of exp(-d^2 / (2 rho^2)), at contact, d = rho,
    rho the pair's contact distance; a unit of speed moves the robot dt). For seed 004's
    hand and tool spheres (rho = 0.1 m, dt = 0.1 s, V_pre = 0.05 m/s) that is 1.2 against
    20: with one such pair the collision-trend terms cannot move the choice, and the
    method runs at V_pre while that is collision-free, else at the collision-free speed
    nearest V_pre, switching at once (no smoothing term). Speeds at the limits (the
    seed's -250/+250 mm/s, Fig. 11(b)) need the collision-trend sum to outweigh the speed
    term: some 16 pairs near contact at once (seed 004 models every link and the upper
    body, Fig. 2; its DI and our scenarios keep the hand and tool spheres), or V_pre above
    rho / (1.2 dt) = 0.83 m/s, beyond the 0.25 m/s cap.
    """
    trend = collision_trend(danger)
    cost = (trend.sum(axis=1) + (trend - collision_trend(danger_now)).sum(axis=1)
            + np.abs(grid_speeds - v_pre) / abs(v_pre))
    penalty = danger_penalty(danger, 1.0)
    return float(grid_speeds[np.lexsort((cost, penalty))[0]])


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
