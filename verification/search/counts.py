"""Every evaluation of a model of the loop that a verification makes, and what it cost.

Four kinds, counted apart and in total (``KINDS``):

- ``simulations``: closed-loop simulations of the search (the batched evaluator, or the
  Drake diagram for the scenarios it does not model: ``evaluate_batch.evaluate_many``),
  the scenario built included, counted as they are evaluated (a figure read back from a
  resumed run's cache is not);
- ``margins``: candidates scored by the proofs' margins (``ranking.bound_scores``, and
  the coordinate search for their least corner, ``ranking.margin_corner``);
- ``dangers``: candidates scored by the reduced model of the loop
  (``ranking.danger_scores``), which orders them before they are simulated;
- ``drake``: runs of the Drake diagram that replay a search's scenario (confirmations
  and cross-checks; ``verification.verify``).

One currency, the simulation-equivalent (``COST``: each kind's measured CPU cost per
evaluation over a closed-loop simulation's, the batched evaluator's on the default space;
``benchmarks/bench_verify.py --parts costs`` measures them again): a search's ``--budget``
bounds what its kinds cost together (``search_cost``: simulations, margins, dangers); the
Drake replays that check its verdict are counted and priced beside it, outside the budget
(a verdict always has its replays).

CPU seconds are this process's (``time.process_time``) plus the CPU time of the work
done in worker processes (measured there and sent back with the results); wall seconds
are ``time.perf_counter``'s. Both run from the tally's creation.
"""

import dataclasses
import time

KINDS = ("simulations", "margins", "dangers", "drake")
SEARCH_KINDS = ("simulations", "margins", "dangers")  # what a search's budget bounds
# Simulation-equivalents per evaluation (see the module docstring), as bench_verify
# --parts costs measured them on this project's machine (two shared cores, 2026-11-26;
# a simulation 2.3 ms of CPU, its scenario built included): a margin scoring 7 us, a
# reduced-model score 7.4 ms, a whole 10 s scenario in the Drake diagram 0.5-0.6 s. The
# ratios, not the times, are what a budget uses; they moved by less than 30% between
# configurations.
COST = {"simulations": 1.0, "margins": 0.004, "dangers": 3.5, "drake": 250.0}


@dataclasses.dataclass
class Tally:
    """Running counts of evaluations by kind, and the clocks since the start."""

    simulations: int = 0
    margins: int = 0
    dangers: int = 0
    drake: int = 0
    worker_cpu: float = 0.0  # s of CPU spent in other processes
    _cpu0: float = dataclasses.field(default_factory=time.process_time)
    _wall0: float = dataclasses.field(default_factory=time.perf_counter)

    def add(self, kind: str, n: int = 1) -> None:
        if kind not in KINDS:
            raise ValueError(f"kind: got {kind!r}; allowed: {' | '.join(KINDS)}")
        setattr(self, kind, getattr(self, kind) + int(n))

    @property
    def total(self) -> int:
        return sum(getattr(self, k) for k in KINDS)

    def search_cost(self) -> float:
        """What the search's evaluations cost, in simulation-equivalents (``COST``)."""
        return self.cost(SEARCH_KINDS)

    def cost(self, kinds=KINDS) -> float:
        """What the evaluations of ``kinds`` cost (default: all, Drake replays included),
        in simulation-equivalents (``COST``)."""
        return sum(COST[k] * getattr(self, k) for k in kinds)

    def cpu_seconds(self) -> float:
        return time.process_time() - self._cpu0 + self.worker_cpu

    def wall_seconds(self) -> float:
        return time.perf_counter() - self._wall0

    def evaluations(self) -> dict:
        """The counts by kind, their total, and their cost in simulation-equivalents (the
        search's, which its budget bounds, and with the Drake replays)."""
        return {**{k: getattr(self, k) for k in KINDS}, "total": self.total,
                "search_cost": round(self.search_cost(), 3), "cost": round(self.cost(), 3)}

    def snapshot(self) -> dict:
        """The counts so far and the CPU and wall seconds since the start."""
        return {"evaluations": self.evaluations(), "cpu_seconds": self.cpu_seconds(),
                "wall_seconds": self.wall_seconds()}
