"""Elite real-coded genetic algorithm choosing the robot's speed (seed 004, Section III).

Chan and Tsai 2020 choose, every sampling period, the end-effector speed V_select along
the pre-programmed path that minimises (Eq. 11)

    f = P (V - V_pre)^2 / V_pre^2 + D (V - V_prev)^2 / V_pre^2

subject to DI < 1 for every robot-operator ellipsoid pair at the predicted next pose and
|V| <= 250 mm/s (ISO 10218-1), with the DI constraint as the penalty of Eq. 12:
F = f + R * sum of DI^2 over the pairs with DI >= 1 (we read the seed's DI_ij-bar
squared as summed over the pairs), and the speed bound as the search interval.

The ERGA (Fig. 1): an initial population uniform over [-V_max, V_max]; each generation
keeps the two best (elites), fills the rest with children of parents chosen by binary
tournament (the seed does not say how parents are chosen; ties go to the individual
ranked first by a stable sort), crossed with probability
0.8 by uniform arithmetic crossover (child = a p1 + (1 - a) p2, a ~ U(0, 1)) and
mutated with probability 0.1 by redrawing uniformly ("random" mutation). Randomness
comes from an explicit numpy Generator, every number of a run drawn up front. :func:`erga`
takes any fitness vectorised over the population; the controller's fitness (Eq. 11 as a
polynomial plus Eq. 12's penalty per grid cell) runs the same generations compiled with
numba (:func:`erga_piecewise_quadratic`; a test holds the two equal bit for bit).
"""

import dataclasses
from collections.abc import Callable

import numba
import numpy as np


@dataclasses.dataclass(frozen=True)
class ErgaParameters:
    """Seed values by default (Section IV-A)."""

    population: int = 50
    generations: int = 100
    crossover: float = 0.8
    mutation: float = 0.1
    elites: int = 2

    def __post_init__(self) -> None:
        if not (isinstance(self.population, int) and self.population >= 2):
            raise ValueError(f"population: got {self.population!r}; allowed: an integer >= 2")
        if not (isinstance(self.generations, int) and self.generations >= 1):
            raise ValueError(f"generations: got {self.generations!r}; allowed: an integer >= 1")
        for name in ("crossover", "mutation"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name}: got {value!r}; allowed: a probability in [0, 1]")
        if not (isinstance(self.elites, int) and 0 <= self.elites < self.population):
            raise ValueError(f"elites: got {self.elites!r}; allowed: 0 <= elites < population")


def danger_penalty(danger: np.ndarray, R: float) -> np.ndarray:
    """Eq. 12's penalty: R times the sum of DI^2 over the pairs with DI >= 1."""
    return R * np.sum(np.where(danger >= 1.0, danger, 0.0) ** 2, axis=-1)


def speed_terms(v: np.ndarray, *, v_preprogrammed: float, v_previous: float, P: float,
                D: float) -> np.ndarray:
    """Eq. 11's f: P (V - V_pre)^2 / V_pre^2 + D (V - V_prev)^2 / V_pre^2."""
    c2, c1, c0 = speed_terms_polynomial(v_preprogrammed=v_preprogrammed,
                                        v_previous=v_previous, P=P, D=D)
    v = np.asarray(v, dtype=float)
    return (c2 * v + c1) * v + c0


def speed_terms_polynomial(*, v_preprogrammed: float, v_previous: float, P: float,
                           D: float) -> tuple[float, float, float]:
    """Eq. 11's f as c2 V^2 + c1 V + c0 (expanded once, so a population costs four array
    operations)."""
    scale = 1.0 / (v_preprogrammed * v_preprogrammed)
    return ((P + D) * scale, -2.0 * (P * v_preprogrammed + D * v_previous) * scale,
            (P * v_preprogrammed**2 + D * v_previous**2) * scale)


def speed_objective(v: np.ndarray, *, v_preprogrammed: float, v_previous: float,
                    danger: np.ndarray, P: float = 1.0, D: float = 1.0,
                    R: float = 10.0) -> np.ndarray:
    """F of Eqs. 11-12 for candidate speeds ``v`` (...,); ``danger`` (..., pairs) holds
    each pair's DI at the pose each candidate leads to (m/s throughout)."""
    return (speed_terms(v, v_preprogrammed=v_preprogrammed, v_previous=v_previous, P=P, D=D)
            + danger_penalty(danger, R))


def _plan(bound: float, rng: np.random.Generator, params: ErgaParameters):
    """Every random number of a run, drawn at once: the initial population, and per
    generation the parents' pool indices (``winners`` (g, m, 2): tournament winners by
    rank, a mutated child's first parent being its fresh value) and the mixes (g, m)."""
    if not bound > 0.0:
        raise ValueError(f"bound: got {bound!r}; allowed: a speed > 0")
    n, g, e = params.population, params.generations, params.elites
    m = n - e  # children per generation
    pop = rng.uniform(-bound, bound, n)
    picks = rng.integers(0, n, (g, 2, m, 2))
    mix, cross, mutate, fresh = rng.uniform(0.0, 1.0, (4, g, m))
    cross, mutate = cross < params.crossover, mutate < params.mutation
    fresh = -bound + 2.0 * bound * fresh
    # A binary tournament between the individuals ranked a and b (0 = fittest) is won
    # by rank min(a, b); drawing ranks uniformly is drawing individuals uniformly.
    winners = np.minimum(picks[:, 0], picks[:, 1])  # (g, m, 2)
    # No crossover is the mix a = 1 (the child is its first parent). A mutated child is
    # crossed with a = 1 from its fresh value, which sits in the pool after the ranked
    # population (pool[n + k m + i] for child i of generation k).
    mix = np.where(cross & ~mutate, mix, 1.0)
    winners[..., 0] = np.where(mutate, n + np.arange(g * m).reshape(g, m), winners[..., 0])
    pool = np.concatenate((np.empty(n), fresh.ravel()))
    return pop, winners, mix, pool


def erga(fitness: Callable[[np.ndarray], np.ndarray], *, bound: float,
         rng: np.random.Generator, params: ErgaParameters = ErgaParameters()
         ) -> tuple[float, np.ndarray]:
    """Minimises ``fitness`` (vectorised over a population) over [-bound, bound].

    Returns the best speed and the best fitness after each generation (for plots like
    the seed's Fig. 11(d)). :func:`erga_piecewise_quadratic` runs the same generations
    compiled, for the fitness the controller uses.
    """
    pop, winners, mix, pool = _plan(bound, rng, params)
    n, g, e = params.population, params.generations, params.elites
    m = n - e
    ranked, step = pool[:n], np.empty(m)
    fit = fitness(pop)
    history = np.empty(g)
    for k in range(g):
        order = fit.argsort(kind="stable")
        if k:
            history[k - 1] = fit[order[0]]
        ranked[:] = pop[order]
        parents = pool[winners[k]]
        p1, p2 = parents[:, 0], parents[:, 1]
        # Elites first, then the children p2 + a (p1 - p2) with a in [0, 1]: between
        # their parents (to rounding; the decision is clipped to the bound).
        pop = np.empty(n)
        pop[:e] = ranked[:e]
        np.multiply(mix[k], np.subtract(p1, p2, out=step), out=step)
        np.add(p2, step, out=pop[e:])
        fit = fitness(pop)
    history[-1] = fit.min()
    return min(max(float(pop[fit.argmin()]), -bound), bound), history


def piecewise_quadratic(v: np.ndarray, c2: float, c1: float, breaks: np.ndarray,
                        by_cell: np.ndarray) -> np.ndarray:
    """(c2 v + c1) v + by_cell[i], i the number of ``breaks`` (ascending) <= v: Eq. 11 as
    a polynomial plus a per-cell constant (Eq. 12's penalty and c0) -- the fitness of
    :func:`erga_piecewise_quadratic`, in numpy."""
    v = np.asarray(v, dtype=float)
    return (c2 * v + c1) * v + by_cell[breaks.searchsorted(v, side="right")]


@numba.njit(cache=True)
def _fill_fitness(pop, c2, c1, breaks, by_cell, out):  # piecewise_quadratic, compiled
    for i in range(pop.size):
        v = pop[i]
        out[i] = (c2 * v + c1) * v + by_cell[np.searchsorted(breaks, v, side="right")]


@numba.njit(cache=True)
def _evolve(pop, winners, mix, pool, elites, c2, c1, breaks, by_cell):
    """The generations of :func:`erga` (same operations, same order), compiled, with
    :func:`piecewise_quadratic` as the fitness."""
    n = pop.size
    g, m = mix.shape
    pop = pop.copy()
    fit = np.empty(n)
    _fill_fitness(pop, c2, c1, breaks, by_cell, fit)
    history = np.empty(g)
    for k in range(g):
        order = np.argsort(fit, kind="mergesort")  # stable
        if k:
            history[k - 1] = fit[order[0]]
        for i in range(n):
            pool[i] = pop[order[i]]
        pop[:elites] = pool[:elites]
        for i in range(m):
            p1 = pool[winners[k, i, 0]]
            p2 = pool[winners[k, i, 1]]
            pop[elites + i] = p2 + mix[k, i] * (p1 - p2)
        _fill_fitness(pop, c2, c1, breaks, by_cell, fit)
    best = np.argmin(fit)
    history[g - 1] = fit[best]
    return pop[best], history


def erga_piecewise_quadratic(*, c2: float, c1: float, breaks: np.ndarray,
                             by_cell: np.ndarray, bound: float, rng: np.random.Generator,
                             params: ErgaParameters = ErgaParameters()
                             ) -> tuple[float, np.ndarray]:
    """:func:`erga` of :func:`piecewise_quadratic` (``breaks`` ascending, ``by_cell`` one
    longer), compiled: the same random numbers and operations, so the same result as
    ``erga(lambda v: piecewise_quadratic(v, c2, c1, breaks, by_cell), ...)`` (tested)."""
    pop, winners, mix, pool = _plan(bound, rng, params)
    best, history = _evolve(pop, winners, mix, pool, params.elites, float(c2), float(c1),
                            np.ascontiguousarray(breaks, dtype=float),
                            np.ascontiguousarray(by_cell, dtype=float))
    return min(max(float(best), -bound), bound), history
