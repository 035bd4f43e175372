"""Every evaluation of a model of the loop that a verification makes, and what it cost.

Three kinds, counted apart and in total (``KINDS``):

- ``simulations``: closed-loop simulations of the search (the batched evaluator, or the
  Drake diagram for the scenarios it does not model: ``evaluate_batch.evaluate_many``),
  counted as they are evaluated (a figure read back from a resumed run's cache is not);
- ``rankings``: scorings of a candidate by the falsifier's reduced model
  (``verification.search.ranking``), which orders candidates before they are simulated;
- ``drake``: runs of the Drake diagram that replay a search's scenario (confirmations
  and cross-checks; ``verification.verify``).

CPU seconds are this process's (``time.process_time``) plus the CPU time of the work
done in worker processes (measured there and sent back with the results); wall seconds
are ``time.perf_counter``'s. Both run from the tally's creation.
"""

import dataclasses
import time

KINDS = ("simulations", "rankings", "drake")


@dataclasses.dataclass
class Tally:
    """Running counts of evaluations by kind, and the clocks since the start."""

    simulations: int = 0
    rankings: int = 0
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

    def cpu_seconds(self) -> float:
        return time.process_time() - self._cpu0 + self.worker_cpu

    def wall_seconds(self) -> float:
        return time.perf_counter() - self._wall0

    def evaluations(self) -> dict:
        """The counts by kind and their total."""
        return {**{k: getattr(self, k) for k in KINDS}, "total": self.total}

    def snapshot(self) -> dict:
        """The counts so far and the CPU and wall seconds since the start."""
        return {"evaluations": self.evaluations(), "cpu_seconds": self.cpu_seconds(),
                "wall_seconds": self.wall_seconds()}
