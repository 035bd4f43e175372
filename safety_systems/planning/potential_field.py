"""The improved artificial potential field of seed 001 (Eqs. 1b, 2a-2f, 3a-3g, 4a).

Plain functions, vectorised over points q (P, 3) in metres (the tool's position: the
seed's configuration q is the end effector's position, Section 2.3.1). Forces are the
negative gradients of the potentials, so a test can check each against a finite
difference of its potential.

How we read the seed where it is ambiguous:

- Eq. 2e's constant term is printed K_att / (2 (d*_goal)^2). With it the quadratic and
  conic pieces do not meet at d = d*_goal; we use 1/2 K_att (d*_goal)^2 (the textbook
  form), so U_att and its gradient are both continuous there.
- Eq. 2c prints the gradient of K_att d as K_att / d * (q, q_goal); we read (q, q_goal)
  as the difference q - q_goal. Beyond d*_goal the gradient of Eq. 2e is d*_goal times
  Eq. 2c's (the conic piece has slope d*_goal K_att).
- Eq. 3a's d_factor = |q_start - q_goal|^n: with the fixed start, d_factor would be a
  constant and Eq. 3f's force "from differentiating the potential w.r.t. the
  manipulator position" would vanish. We read q_start as the current position q, as in
  the potential of Ge and Cui (2000) that Eqs. 3a-3f follow: d_factor = |q - q_goal|^n,
  the Euclidean norm of the vector difference. flag False: d_factor = 1 (plain APF).
- Eq. 3c omits the d_factor that Eq. 3b multiplies in; we keep it, so F(1) = -d_factor
  times Eq. 3c's gradient (Eq. 3d), the part that pushes away from the obstacle.
- Eq. 3f prints a scalar, -(n_i / 2) K_rep (1/rho - 1/zeta)^2 d'_factor. We read n_i
  as the unit vector from q towards the goal (Ge and Cui's n_RG) and d'_factor as
  Eq. 3e's n |q - q_goal|^(n - 1), so F(2) = 1/2 K_rep (1/rho - 1/zeta)^2 *
  n |q - q_goal|^(n-1) * n_RG, exactly the rest of -grad U_rep,i: F(1) + F(2) =
  -grad U_rep,i (Eq. 3g). F(2) pulls towards the goal and keeps the goal reachable
  when it lies near an obstacle.
- rho_i is the distance from the obstacle's surface (``task_space.signed_distances``)
  and zeta_i one threshold for every obstacle (``PlannerSettings.zeta``).
- Units: the seed's coordinates are centimetres (``models/scenes/paper.yaml``), and so,
  we read, are the lengths in its gains: Eqs. 2-3 are evaluated with every length (d,
  rho, zeta, d*_goal, the d_factor) in ``field_unit`` (default 0.01 m). In metres the
  same K_att = 0.03 and K_rep = 0.1 would make the repulsion a wall a micrometre inside
  zeta (it grows as 1/rho^3 against an attraction of K_att d*_goal); in centimetres the
  field balances a few millimetres inside zeta and the gains shape the path, as the
  seed's Tables V-VII vary them. Positions, gradients and forces in this module's
  interface are per metre: grad_q U = (1 / field_unit) grad U in the seed's units.
"""

import dataclasses
import functools

import numpy as np

from safety_systems.planning.task_space import (
    ObstacleSet,
    TaskScene,
    obstacle_set,
    signed_distances,
)

RHO_FLOOR = 1e-6  # m: rho is clamped here so the potential stays finite inside obstacles


@dataclasses.dataclass(frozen=True)
class Field:
    """Everything Eqs. 2-4 need: goal (3,) m, gains, thresholds (m), obstacles, and the
    length unit (m) the gains are for."""

    goal: np.ndarray
    k_att: float
    d_goal: float
    k_rep: float
    zeta: float
    n: float
    flag: bool
    obstacles: ObstacleSet
    unit: float = 1.0

    @functools.cached_property
    def in_unit(self) -> "Field":
        """This field with every length divided by ``unit`` (obstacles excepted)."""
        u = self.unit
        return dataclasses.replace(self, goal=self.goal / u, d_goal=self.d_goal / u,
                                   zeta=self.zeta / u, unit=1.0)


def field_from_scene(scene: TaskScene, *, baseline: bool = False) -> Field:
    """The IAPF field of a scene, or with ``baseline`` the GDA's: its own gains and no
    d_factor (Eq. 3a's flag False)."""
    p = scene.planner
    return Field(goal=np.asarray(scene.goal, dtype=float),
                 k_att=p.gda_k_att if baseline else p.k_att, d_goal=p.d_goal,
                 k_rep=p.gda_k_rep if baseline else p.k_rep, zeta=p.zeta, n=p.d_factor_n,
                 flag=False if baseline else p.d_factor,
                 obstacles=obstacle_set(scene.obstacles), unit=p.field_unit)


def goal_distance(q: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """Eq. 2a: (P,) Euclidean distance d from each point to the goal, m."""
    return np.linalg.norm(np.atleast_2d(q) - goal, axis=-1)


def attractive_potential(q: np.ndarray, goal: np.ndarray, k_att: float,
                         d_goal: float) -> np.ndarray:
    """Eqs. 2d-2e: (P,) quadratic 1/2 K_att d^2 within d*_goal, conic
    d*_goal K_att d - 1/2 K_att d*_goal^2 beyond (the constant makes the pieces meet)."""
    d = goal_distance(q, goal)
    return np.where(d <= d_goal, 0.5 * k_att * d**2,
                    d_goal * k_att * d - 0.5 * k_att * d_goal**2)


def attractive_gradient(q: np.ndarray, goal: np.ndarray, k_att: float,
                        d_goal: float) -> np.ndarray:
    """(P, 3) grad U_att: K_att (q - q_goal) within d*_goal, d*_goal K_att (q - q_goal)/d
    beyond (Eq. 2c scaled by the conic slope). F_att = -grad U_att (Eq. 2f)."""
    v = np.atleast_2d(q) - goal
    d = np.linalg.norm(v, axis=-1)
    scale = np.where(d <= d_goal, k_att, d_goal * k_att / np.where(d > 0.0, d, 1.0))
    return scale[:, None] * v


def d_factor(q: np.ndarray, goal: np.ndarray, n: float, flag: bool) -> np.ndarray:
    """Eq. 3a, q_start read as the current q: (P,) |q - q_goal|^n, or 1 when not flag."""
    if not flag:
        return np.ones(len(np.atleast_2d(q)))
    return goal_distance(q, goal) ** n


def d_factor_gradient(q: np.ndarray, goal: np.ndarray, n: float, flag: bool) -> np.ndarray:
    """Eq. 3e as a vector: (P, 3) n |q - q_goal|^(n-1) (q - q_goal)/|q - q_goal|."""
    v = np.atleast_2d(q) - goal
    if not flag or n == 0.0:
        return np.zeros_like(v)
    d = np.linalg.norm(v, axis=-1)
    safe = np.where(d > 0.0, d, 1.0)
    return (n * safe ** (n - 2.0) * (d > 0.0))[:, None] * v


def repulsive_potential(rho: np.ndarray, zeta: float, k_rep: float,
                        factor: np.ndarray) -> np.ndarray:
    """Eq. 3b: (P, N) 1/2 K_rep (1/rho_i - 1/zeta)^2 d_factor where rho_i < zeta, else 0.
    ``factor`` (P,) is Eq. 3a's d_factor."""
    r = np.maximum(rho, RHO_FLOOR)
    return np.where(rho < zeta, 0.5 * k_rep * (1.0 / r - 1.0 / zeta) ** 2, 0.0) * factor[:, None]


def repulsive_forces(q: np.ndarray, rho: np.ndarray, grad_rho: np.ndarray,
                     field: Field) -> tuple[np.ndarray, np.ndarray]:
    """F(1)_rep,i and F(2)_rep,i (each (P, N, 3)) of Eqs. 3d and 3f, every length (q,
    rho and the field's) in one unit; ``field.unit`` is not applied here.

    F(1) = -d_factor grad of Eq. 3c = K_rep (1/rho - 1/zeta) / rho^2 d_factor grad rho
    (away from the obstacle); F(2) = -1/2 K_rep (1/rho - 1/zeta)^2 grad d_factor
    (towards the goal). Both vanish where rho_i >= zeta.
    """
    r = np.maximum(rho, RHO_FLOOR)
    active = rho < field.zeta
    excess = np.where(active, 1.0 / r - 1.0 / field.zeta, 0.0)  # (P, N)
    factor = d_factor(q, field.goal, field.n, field.flag)  # (P,)
    f1 = (field.k_rep * excess / r**2 * factor[:, None])[..., None] * grad_rho
    grad_factor = d_factor_gradient(q, field.goal, field.n, field.flag)  # (P, 3)
    f2 = -0.5 * field.k_rep * (excess**2)[..., None] * grad_factor[:, None, :]
    return f1, f2


def total_potential(q: np.ndarray, field: Field, rho: np.ndarray | None = None
                    ) -> np.ndarray:
    """Eq. 1b: (P,) U_att + sum_i U_rep,i at points q (P, 3) m, lengths in field.unit;
    ``rho`` (P, N): the points' signed distances, if already known."""
    q = np.atleast_2d(q)
    if rho is None:
        rho, _ = signed_distances(q, field.obstacles)
    f, u = field.in_unit, field.unit
    qs = q / u
    factor = d_factor(qs, f.goal, f.n, f.flag)
    return (attractive_potential(qs, f.goal, f.k_att, f.d_goal)
            + repulsive_potential(rho / u, f.zeta, f.k_rep, factor).sum(axis=1))


def total_force(q: np.ndarray, field: Field) -> np.ndarray:
    """Eq. 4a: (P, 3) F_total = F_att + F_rep, F_rep = sum_i (F(1)_i + F(2)_i) (Eq. 3g);
    -grad of :func:`total_potential` per metre."""
    q = np.atleast_2d(q)
    rho, grad_rho = signed_distances(q, field.obstacles)
    f, u = field.in_unit, field.unit
    f1, f2 = repulsive_forces(q / u, rho / u, grad_rho, f)
    return (-attractive_gradient(q / u, f.goal, f.k_att, f.d_goal)
            + f1.sum(axis=1) + f2.sum(axis=1)) / u
