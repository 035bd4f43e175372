"""Sweeps and falsification over a scenario space (robustness >= 0 safe; we minimise it).

Points live in the unit cube over the space's free parameters
(``verification.spaces.space.to_point`` maps them to values).

- Sweeps: ``grid``, ``sobol``, ``halton``, ``uniform`` and ``corners`` (every vertex).
- Falsification (:func:`falsify`), cheapest routes first: one Sobol point simulated
  at once (where violations are common that is all it takes); then Sobol points in the
  corner of the box where the proofs' margins are least (found by a coordinate search
  of some hundred pointwise margins, ``verification.search.ranking.margin_corner``); then the
  rest of the Sobol set ordered by those margins (``ranking.bound_scores``,
  microseconds a candidate) and its best simulated in doubling batches; then the
  reduced model of the loop (``ranking.danger_scores``, about a simulation's cost a
  candidate) and the best it ranks; then CMA-ES (the ``cma``
  package) minimises each property's closed-loop robustness from the best point found,
  each population simulated as one batch. Every evaluation of any model is counted
  (``verification.search.counts``: the runner's tally) and priced in simulation-
  equivalents (``counts.COST``): the budget bounds them all, and sizes each phase (how
  many candidates each ranking scores, and whether the reduced model runs at all).
  Every verdict rests on closed-loop simulations.

The rankings model scripted approaches: a space built around a recording
(``verification.spaces.recorded``) is searched without them (see :func:`falsify`), and
its corners are swept in their plain order.
"""

import dataclasses
import itertools
import math
import warnings

import cma
import numpy as np
from scipy.stats import qmc

from safety_systems.config.resolved_cell import ResolvedCell
from verification.search.counts import COST
from verification.search.ranking import bound_scores, danger_scores, margin_corner
from verification.search.runner import Runner
from verification.spaces.box import ScenarioSpace
from verification.spaces.space import corners, free_parameters, make_scenario, to_point

SWEEPS = ("grid", "sobol", "halton", "uniform", "corners")
# The reduced model's score column (``ranking.SCORES``) for each column of the runner's
# figures: contact for the contact figures, separation for the separation ones.
# (permitted contact, column 4, by contact's: its proof's margin is Theorem 1's)
SCORE_OF = {0: 0, 1: 0, 2: 1, 3: 1, 4: 0}
# The focus phase's box: the parameters that move a property's margin within this
# fraction of their range from the margin's least corner (``ranking.margin_corner``).
FOCUS_WIDTH = 1.0 / 16.0
# The budget's shares (simulation-equivalents): the proofs' margins may score candidates
# for up to MARGIN_SHARE of it, the reduced model for up to DANGER_SHARE; the reduced
# model runs only if that buys MIN_DANGER candidates (at 3.5 simulations a score, a
# budget of 224 and more).
MARGIN_SHARE = 1.0 / 16.0
DANGER_SHARE = 1.0 / 4.0
MIN_DANGER = 16
RANKINGS = ("margins", "dangers")  # the tally's kinds that rank candidates


def sweep_points(method: str, n: int, d: int, *, seed: int = 0) -> np.ndarray:
    """(m, d) points of the unit cube; m = n except for ``grid`` (the largest full grid
    of at most n points, at least 2 per axis) and ``corners`` (all 2^d)."""
    if d == 0:
        return np.zeros((1, 0))
    if method == "sobol":
        return qmc.Sobol(d, scramble=True, seed=seed).random(n)
    if method == "halton":
        return qmc.Halton(d, scramble=True, seed=seed).random(n)
    if method == "uniform":
        return np.random.default_rng(seed).uniform(size=(n, d))
    if method == "corners":
        return np.array(list(itertools.product((0.0, 1.0), repeat=d)))
    if method == "grid":
        per_axis = max(2, int(math.floor(n ** (1.0 / d) + 1e-9)))
        axis = np.linspace(0.0, 1.0, per_axis)
        return np.array(list(itertools.product(axis, repeat=d)))
    raise ValueError(f"method: got {method!r}; allowed: {' | '.join(SWEEPS)}")


@dataclasses.dataclass
class SearchLog:
    """Every closed-loop evaluation of a search, in order, and when the first violation
    of each watched column was found."""

    points: list = dataclasses.field(default_factory=list)  # unit points
    figures: list = dataclasses.field(default_factory=list)  # FIELDS of runner
    watch: tuple = (0,)  # the columns whose first violation ``first`` records
    # column -> {"simulation": its number, and the runner's tally's snapshot when the
    # batch that held it was done: evaluations by kind, CPU and wall seconds}
    first: dict = dataclasses.field(default_factory=dict)

    @property
    def robustness(self) -> np.ndarray:
        """"Stopped before contact" of every simulation."""
        return self.column(0)

    def column(self, j: int) -> np.ndarray:
        """Figure ``j`` (a column of the runner's ``FIELDS``) of every simulation."""
        return np.array([f[j] for f in self.figures])

    def first_violation(self, j: int = 0) -> int | None:
        """Number of simulations up to and including the first violation of the property
        in column ``j`` (None if none)."""
        bad = np.flatnonzero(self.column(j) < 0.0)
        return int(bad[0]) + 1 if bad.size else None


def evaluate_points(space: ScenarioSpace, cell: ResolvedCell, runner: Runner,
                    points: np.ndarray, log: SearchLog, objective: int = 0) -> np.ndarray:
    """Simulates the scenarios of ``points`` (under ``cell``'s configuration, the space's
    resolved cell: ``spaces.space.space_cell``) as one batch; appends to ``log`` (and
    records the first violation of each column it watches); returns the figure in
    column ``objective`` (0: "stopped before contact")."""
    scenarios = [make_scenario(space, cell.config, to_point(space, u)) for u in points]
    figures = runner.evaluate(scenarios, cell)
    before = len(log.points)
    log.points.extend(np.asarray(points, dtype=float).tolist())
    log.figures.extend(figures.tolist())
    for j in log.watch:
        bad = np.flatnonzero(figures[:, j] < 0.0) if len(figures) else []
        if j not in log.first and len(bad):
            log.first[j] = {"simulation": before + int(bad[0]) + 1, **runner.tally.snapshot()}
    return figures[:, objective] if len(figures) else np.zeros(0)


def falsify(space: ScenarioSpace, cell: ResolvedCell, runner: Runner, *, budget: int,
            seed: int = 0, candidates: int = 8192, pool: int = 16384, opening: int = 1,
            quick: int | None = None, focus: int | None = None, explore: int = 10,
            round_size: int = 16, max_round: int = 256, stop_at_first: bool = False,
            objectives: tuple | list = (0,), confirm=None) -> SearchLog:
    """Searches the configuration resolved in ``cell`` (``spaces.space.space_cell``) for
    the smallest robustness of each property in ``objectives`` (columns
    of the runner's figures; every simulation measures them all) with evaluations that
    cost at most ``budget`` simulation-equivalents in all (``counts.COST``: a simulation
    one, a margin scoring 0.004, a reduced-model score 3.5), cheapest routes first:

    1. opening: the first ``opening`` points (at most an eighth of the budget) of a Sobol
       set of ``pool`` points are simulated as one batch, unranked, before anything else
       (where violations are common, this is all it takes);
    2. focus: up to ``focus`` of the ``quick`` simulations (default: half) go to Sobol
       points whose parameters that move a property's proof margin lie within
       ``FOCUS_WIDTH`` of the corner where that margin is least (``_focus``), the others
       anywhere in their ranges, in batches of ``round_size`` doubling: the margin
       needs a few dozen scorings to find that corner;
       then the corners (at most 10 free parameters) and the Sobol set, as many as
       ``MARGIN_SHARE`` of the budget pays for (at 4096, all 16,384; at 200, 3,125), are
       scored by the proofs' margins evaluated pointwise (``ranking.bound_scores``,
       microseconds each) and the rest of the ``quick`` simulations (default: an eighth
       of the budget in all) go to them in that order, each property still searched
       taking its turn down its own score column (``SCORE_OF``), in batches of
       ``round_size`` doubling up to ``max_round``: violations that come of speed and
       sensing are found here;
    3. thorough: the reduced model of the loop (``ranking.danger_scores``, 3.5
       simulations a candidate) ranks the corners and the first Sobol points, as many as
       ``DANGER_SHARE`` of the budget pays for (at most ``candidates``; none below
       ``MIN_DANGER``: then the Sobol points not simulated yet, in order), and
       ``explore`` simulations go to them in danger order (each property still searched
       in turn down its own score; four ranked for one plain Sobol point), in rounds of
       five: violations that come of the geometry of an approach, occlusions or faults
       are found here;
    4. property by property, each with an even share of what is left, CMA-ES from the
       best point so far for it, restarted from the next candidates whenever it stops.

    A recording space has no ranking and no focus (both model scripted approaches):
    phases 2 and 3 take the Sobol set in its own order (``quick`` defaults to half the
    budget, the search's exploration), and CMA-ES restarts from the Sobol points not yet
    simulated.

    ``stop_at_first`` ends a property's part at its first violation (and skips the
    phases it no longer needs); with ``confirm`` (a function (log, column, simulation
    index) -> bool, e.g. a Drake replay), a violation counts only once ``confirm``
    accepts it, and the whole search ends at the first it accepts."""
    d = len(free_parameters(space))
    log = SearchLog(watch=tuple(objectives))
    if d == 0:
        evaluate_points(space, cell, runner, np.zeros((1, 0)), log)
        return log
    search = _Search(space, cell, runner, log, budget, stop_at_first, confirm)
    # sweep_points("sobol", max(pool, candidates), d, seed=seed), drawn in two parts so
    # that the opening batch is simulated before the rest is drawn (the same points)
    engine = qmc.Sobol(d, scramble=True, seed=seed)
    opening = min(opening, max(1, budget // 8), max(pool, candidates))
    with warnings.catch_warnings():  # (the whole set is a power of 2, its parts need not)
        warnings.simplefilter("ignore", UserWarning)
        first = engine.random(opening)
        search.simulate(first)
        sobol = np.vstack([first, engine.random(max(pool, candidates) - opening)])
    ranked = space.recording is None  # (the rankings model scripted approaches only)
    with_corners = ranked and d <= 10
    rest = np.vstack([corners(space) if with_corners else np.zeros((0, d)), sobol[opening:]])
    quick = (budget // 8 if ranked else budget // 2) if quick is None else quick
    focus = 0 if not ranked else quick // 2 if focus is None else min(focus, quick)
    began = search.spent()
    if search.wanted(objectives) and focus > 0:
        _focus(search, objectives, focus, seed, round_size, max_round)
    quick_left = quick - (search.spent() - began)  # (the focus's margins count too)
    done: set = set()  # indices of ``rest`` simulated
    queues: dict[int, list] = {j: [] for j in objectives}
    if search.wanted(objectives) and quick_left > 0:
        if ranked:
            scored = min(len(rest), _affordable(budget * MARGIN_SHARE, "margins"))
            scores = bound_scores(space, cell, rest[:scored], tally=runner.tally)
            queues = {j: list(np.argsort(scores[:, SCORE_OF[j]], kind="stable"))
                      for j in objectives}
        else:
            queues = {j: list(range(len(rest))) for j in objectives}
    stop = search.spent() + quick_left
    size = round_size
    while search.wanted(objectives) and search.spent() < stop:
        wanted = [j for j in search.wanted(objectives) if queues[j]]
        room = min(size, _whole(stop - search.spent()))
        batch: list = []
        while wanted and len(batch) < room and any(queues[j] for j in wanted):
            for j in wanted:  # each property in turn, down its own ranking
                while queues[j] and queues[j][0] in done:
                    queues[j].pop(0)
                if queues[j] and len(batch) < room:
                    done.add(queues[j][0])
                    batch.append(queues[j].pop(0))
        if not batch:
            break
        search.simulate(rest[batch])
        size = min(2 * size, max_round)
    queue: list = []
    if search.wanted(objectives) and explore > 0:
        n_danger = min(candidates + (2 ** d if with_corners else 0),
                       _affordable(budget * DANGER_SHARE, "dangers"))
        if ranked and n_danger >= MIN_DANGER:
            scored = np.vstack([corners(space) if with_corners else np.zeros((0, d)),
                                sobol[:candidates]])[:n_danger]
            danger = danger_scores(space, cell, scored, runner=runner)
            orders = [np.argsort(danger[:, SCORE_OF[j]], kind="stable")
                      for j in search.wanted(objectives)]  # each property's, in turn
            queue = _interleave(scored[[i for row in zip(*orders) for i in row]],
                                sobol[:candidates], 4)
        else:  # no ranking: the Sobol points not simulated yet, in order
            queue = [rest[i] for i in range(len(rest)) if i not in done]
        seen = {tuple(np.round(p, 12)) for p in log.points}
        queue = [p for p in queue if tuple(np.round(p, 12)) not in seen]
    stop = search.spent() + min(explore, search.left())
    while search.wanted(objectives) and search.spent() < stop and queue:
        take = min(5, _whole(stop - search.spent()))
        if take < 1:
            break
        batch, queue = np.array(queue[:take]), queue[take:]
        search.simulate(batch)
    for n, objective in enumerate(objectives):
        share = search.spent() + search.left() / (len(objectives) - n)
        restarts = queue + [rest[i] for i in queues[objective] if i not in done]
        restart = 0
        while (search.spent() < share and not search.found(objective) and not search.over()
               and (restart == 0 or restarts)):
            start = (np.asarray(log.points[int(np.argmin(log.column(objective)))])
                     if restart == 0 else np.asarray(restarts.pop(0)))
            if not _cma(search, start, share, seed + restart, objective):
                break
            restart += 1
    # What CMA-ES could not use (fewer simulations left than a population): the next
    # candidates in line, so that the whole budget is spent.
    if search.wanted(objectives) and search.left() >= 1.0:
        seen = {tuple(np.round(p, 12)) for p in log.points}
        line = itertools.chain(queue, (rest[i] for i in range(len(rest)) if i not in done))
        fresh = (p for p in line if tuple(np.round(p, 12)) not in seen)
        left = list(itertools.islice(fresh, _whole(search.left())))
        if left:
            search.simulate(np.array(left))
    return log


def _affordable(cost: float, kind: str) -> int:
    """How many evaluations of ``kind`` ``cost`` simulation-equivalents pay for."""
    return max(0, int(math.floor(cost / COST[kind] + 1e-9)))


def _whole(cost: float) -> int:
    """How many simulations ``cost`` simulation-equivalents pay for."""
    return _affordable(cost, "simulations")


def _focus(search: "_Search", objectives, allowance: int, seed: int, round_size: int,
           max_round: int) -> None:
    """Phase 2a of :func:`falsify`: up to ``allowance`` simulations of Sobol points in
    the corner of the box where each property's proof margin is least. The corner and
    the parameters that move the margin come from ``ranking.margin_corner`` (a few
    dozen scorings, counted in the allowance); each point keeps its other parameters
    anywhere in their range and puts those within ``FOCUS_WIDTH`` of the corner. The properties take
    turns, point by point, in batches of ``round_size`` doubling; a property whose
    margin no parameter moves has nothing to focus on."""
    space, runner = search.space, search.runner
    d = len(free_parameters(space))
    columns = sorted({SCORE_OF[j] for j in search.wanted(objectives)})
    aims = margin_corner(space, search.cell, columns, tally=runner.tally)
    engine = qmc.Sobol(d, scramble=True, seed=seed + 1)
    units = engine.random_base2(max(0, math.ceil(math.log2(max(allowance, 1)))))
    stop, used, size = search.spent() + allowance, 0, round_size
    while search.spent() < stop and used < len(units):
        wanted = [j for j in search.wanted(objectives) if aims[SCORE_OF[j]][1].any()]
        if not wanted:
            return
        take = units[used:used + min(size, _whole(stop - search.spent()))]
        if not len(take):
            return
        used += len(take)
        batch = take.copy()
        for k in range(len(batch)):
            corner, moves = aims[SCORE_OF[wanted[k % len(wanted)]]]
            batch[k, moves] = np.abs(corner[moves] - FOCUS_WIDTH * take[k, moves])
        search.simulate(batch)
        size = min(2 * size, max_round)


def _interleave(ranked: np.ndarray, plain: np.ndarray, ratio: int) -> list:
    """``ratio`` ranked points for each plain one, without repeats."""
    out, seen = [], set()
    for i, p in enumerate(ranked):
        extra = [plain[i // ratio]] if i % ratio == ratio - 1 and i // ratio < len(plain) else []
        for q in [p] + extra:
            key = tuple(np.round(q, 12))
            if key not in seen:
                seen.add(key)
                out.append(q)
    return out


class _Search:
    """What a falsification has found so far, and the rule for when it may stop."""

    def __init__(self, space, cell, runner, log, budget, stop_at_first, confirm):
        self.space, self.cell, self.runner, self.log = space, cell, runner, log
        self.budget, self.stop_at_first, self.confirm = budget, stop_at_first, confirm
        self.confirmed: dict[int, int] = {}  # column -> simulation index confirmed
        self.rejected: set = set()  # (column, index) the confirmation did not accept
        # (the tally may hold earlier work: only this search's rankings count)
        self.began = runner.tally.cost(RANKINGS)

    def spent(self) -> float:
        """What this search's evaluations have cost so far, simulation-equivalents: its
        simulations (a figure read back from a resumed run's cache too, so that a resumed
        search takes the same course) and its rankings."""
        return len(self.log.points) + self.runner.tally.cost(RANKINGS) - self.began

    def left(self) -> float:
        return self.budget - self.spent()

    def simulate(self, points: np.ndarray, objective: int = 0) -> np.ndarray:
        """Simulates as many of ``points`` as the budget has left (see :func:`falsify`)."""
        points = np.asarray(points)[:_whole(self.left())]
        if not len(points):
            return np.zeros(0)
        before = len(self.log.points)
        values = evaluate_points(self.space, self.cell, self.runner, points, self.log,
                                 objective)
        if self.stop_at_first and self.confirm is not None:
            for j in self.log.watch:  # confirm the new violations, worst first
                rho = self.log.column(j)[before:]
                for i in np.argsort(rho, kind="stable"):
                    if rho[i] >= 0.0 or self.over():
                        break
                    if self.confirm(self.log, j, before + int(i)):
                        self.confirmed[j] = before + int(i)
                    else:
                        self.rejected.add((j, before + int(i)))
        return values

    def found(self, j: int) -> bool:
        """Whether property column j's part of the search is done."""
        if not self.stop_at_first:
            return False
        if self.confirm is not None:
            return j in self.confirmed
        return self.log.first_violation(j) is not None

    def wanted(self, objectives) -> list:
        """The properties whose search goes on (all of them unless ``stop_at_first``)."""
        return [] if self.over() else [j for j in objectives if not self.found(j)]

    def over(self) -> bool:
        """With a confirmation, the whole search ends at the first it accepts."""
        return self.stop_at_first and self.confirm is not None and bool(self.confirmed)


def _cma(search: _Search, start, until: float, seed, objective=0) -> bool:
    """One CMA-ES run from ``start`` on the figure in column ``objective`` while the
    search has spent less than ``until``; False when that leaves no room for it."""
    popsize = 6
    if until - search.spent() < popsize:
        return False
    options = {"bounds": [0.0, 1.0], "seed": seed + 1, "verbose": -9, "popsize": popsize,
               "tolfun": 1e-4, "tolx": 1e-4}
    es = cma.CMAEvolutionStrategy(np.clip(start, 0.0, 1.0).tolist(), 0.08, options)
    while not es.stop() and search.spent() + popsize <= until:
        xs = np.clip(np.array(es.ask()), 0.0, 1.0)
        values = search.simulate(xs, objective)
        es.tell(list(xs), [float(v) if math.isfinite(v) else 1e3 for v in values])
        if search.found(objective) or search.over():
            break
    return True


def sweep(space: ScenarioSpace, cell: ResolvedCell, runner: Runner, *, method: str,
          budget: int, seed: int = 0) -> SearchLog:
    """Evaluates a sweep of at most ``budget`` points of the configuration resolved in
    ``cell`` (``spaces.space.space_cell``; corners in danger order, but a recording
    space's in their plain order)."""
    d = len(free_parameters(space))
    points = sweep_points(method, budget, d, seed=seed)
    if method == "corners" and len(points) > 1 and space.recording is None:
        points = points[np.argsort(danger_scores(space, cell, points, runner=runner)[:, 0],
                                   kind="stable")]
    log = SearchLog()
    evaluate_points(space, cell, runner, points[:budget], log)
    return log
