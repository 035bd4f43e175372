"""Speed alteration along the path (seed 004): ERGA and the baselines it was compared with.

Every sampling period the controller picks an end-effector speed V along the
pre-programmed path (m/s, signed: negative backs away along the path), from the
operators' ellipsoids predicted one step ahead (Eqs. 9-10) and the robot's ellipsoids
at the pose each speed leads to:

- ``erga``: the elite real-coded GA minimising Eqs. 11-12
  (``safety_systems.speed_alteration.erga``);
- ``hwang``: Hwang et al.'s objective, Eq. 13 (collision-trend index from the ellipsoids
  read as Gaussians, with the penalty index), choosing among the pre-programmed speed
  and the two limits;
- ``bimodal``: Morato et al.'s stop/go: full speed while every ellipsoid pair is more
  than a clearance apart, else stop;
- ``none``: the pre-programmed speed (no alteration).

The danger index of a candidate speed is read off a grid of path positions spanning
every speed the controller may pick (``GRID`` points, the worse neighbour between
them; Hwang's three candidates are evaluated as they are), so one decision costs one
batch of forward kinematics plus the search.
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
    the upper-body model
    (:func:`safety_systems.speed_alteration.ellipsoids.human_ellipsoids`); every other
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


def hwang_candidates(v_pre: float, limit: float) -> np.ndarray:
    """The speeds Hwang's choice is made among (m/s, sorted): -limit, the pre-programmed
    speed (capped at the limit) and +limit; :func:`hwang_speed` says why."""
    return np.unique(np.clip([-limit, v_pre, limit], -limit, limit))


def hwang_speed(*, speeds: np.ndarray, danger: np.ndarray, danger_now: np.ndarray,
                v_pre: float, v_prev: float) -> float:
    """Hwang et al.'s choice of speed (seed 004, Eq. 13, with the penalty index).

    ``speeds``: the candidates (:func:`hwang_candidates`); ``danger`` (len(speeds),
    pairs): the DI of each robot-operator pair at the pose each candidate reaches one
    period ahead, with the operators predicted (Eqs. 7, 9-10); ``danger_now`` (pairs,):
    at the current pose; ``v_prev``: the speed selected last period. Eq. 13 is

        f(V) = sum_ij P_ij(k) + sum_ij (P_ij(k) - P_ij(k-1)) + |V - V_pre| / V_pre,

    P_ij the collision-trend index of a pair (:func:`collision_trend`). Seed 004 gives
    Eq. 13 and one sentence on each term; it cites Hwang, Ju and Chen 2003 for the rest,
    which we could not consult. How each part is read:

    - P_ij(k) at the pose V leads to (at the current pose no term would depend on V and
      Eq. 13 would always return V_pre); P_ij(k-1) at the current pose.
    - The penalty index (named in seed 004's Section I, not printed): a candidate whose
      predicted pose collides by the seed's measure (DI >= 1, Eq. 12's DI-bar) ranks
      after every one that does not, whatever Eq. 13 gives; among colliding candidates,
      the least colliding (sum of DI^2). So no weight has to be chosen, and the predicted
      DI stays below 1 (as in Fig. 11(a)) wherever a candidate allows it.
    - The candidates: V_pre and the two limits, nothing between. The seed reports that
      Hwang's selected velocity "is the maximum speed", switching abruptly to -250 and
      then to +250 mm/s at two successive samples (Fig. 11(b)), and names no other
      speed for it. Over a continuous range Eq. 13 cannot do that with the seed's
      simulated pair (the hand and tool spheres): P_ij is in [0, 1], so between two
      candidates the P terms of one pair differ by at most 2, while a limit's last term
      is at least (V_max - V_pre) / V_pre = 4 (seed: 250 and 50 mm/s). A limit then wins
      only over speeds within 2 V_pre of it: the choice is V_pre while collision-free,
      else the collision-free speed nearest it (steps of about V_pre; this function did
      that before). Weighting the P terms does not help: they are smooth in V, so the
      minimum stays between the limits (on our rebuilds of the seed's two simulations,
      weights of 20 and 50 gave -115 mm/s at most, or a robot that never left its
      start). The reported limits thus need a choice among V_pre and the limits: the
      robot keeps its pre-programmed speed, or alters it to the fastest retreat
      (-V_max) or advance (+V_max), abruptly (Eq. 13 has no smoothing term).
    - The trend term, sum_ij (P_ij(k) - P_ij(k-1)). P_ij(k-1) is the past, the same for
      every candidate, so as a cost the term only doubles the first one. Seed 004 gives
      it a role of its own: it "is used to force the robot to move at the selected speed
      to reduce the sum of the collision-trend index". We read it so: while the robot is
      at an altered speed (``v_prev`` is not V_pre) and some collision-free candidate
      reduces the sum (its trend term < 0), the choice is among those. The alteration
      ends when V_pre reduces the sum too (it is then the cheapest), or when no
      candidate does (Eq. 13 alone then: a robot that retreated from an operator who
      now stands still moves on, and alters again only if its predicted pose collides).

    So the method runs at V_pre until its predicted pose collides, then jumps to a
    limit (the advance, cheaper by Eq. 13's last term, if its pose is collision-free,
    else the retreat), holds it while it reduces the collision-trend sum and V_pre
    would not, and jumps back: steps of V_max +- V_pre or 2 V_max between decisions.

    A note, not used here: the seed divides by V_preprog, which is -50 mm/s in its
    negative simulation; read literally, that makes the last term negative there and
    pushes the choice away from V_pre to the limits, which may be why the seed's Hwang
    is at the limits in the negative simulation (jerk SD 39x ERGA's) and not in the
    positive one (2x). Eq. 8 defines V_pre as a length over a time, and so do we (our
    speeds are signed along the path), so our two files are mirror images.
    """
    trend = collision_trend(danger)
    rise = (trend - collision_trend(danger_now)).sum(axis=1)
    cost = trend.sum(axis=1) + rise + np.abs(speeds - v_pre) / abs(v_pre)
    penalty = danger_penalty(danger, 1.0)
    low, high = speeds[0], speeds[-1]
    altered = np.clip(v_prev, low, high) != np.clip(v_pre, low, high)
    # While altered, speeds that do not reduce the collision-trend sum rank after those
    # that do (all alike when none does); the penalty index ranks before both.
    keeps_rising = (rise >= 0.0) if altered else np.zeros(len(speeds), dtype=bool)
    return float(speeds[np.lexsort((cost, keeps_rising, penalty))[0]])


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
