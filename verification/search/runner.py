"""Where scenarios are evaluated: in this process, on local cores, or on a Dask cluster.

Drake objects never cross process boundaries: workers receive scenario dataclasses, with
their configuration's resolved cell where the caller has one (``config.resolved_cell``:
arrays and dataclasses, some 15 KB pickled), and build what they need. Every evaluation
goes through an :class:`EvaluationCache` kept in a JSON-lines file, so an interrupted
run, started again with the same output folder, does not repeat finished work: a run
killed at any point leaves at worst its last line cut short, which the next run drops
(and evaluates again).
"""

import dataclasses
import functools
import gc
import hashlib
import json
import multiprocessing
import os
import signal
import threading
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from tqdm import tqdm

from safety_systems import interrupts, third_party_noise
from safety_systems.config.resolved_cell import ResolvedCell
from safety_systems.files.input_error import InputError
from safety_systems.config.scenario import Scenario
from verification.search.counts import Tally
from verification.search.evaluate_batch import evaluate_many

FIELDS = ("robustness", "min_separation_while_moving", "separation",
          "separation_violation_time", "permitted_contact")
# Changes whenever FIELDS or what they measure change, so that a resumed run never
# reads figures of another kind from an older evaluations.jsonl.
FIGURES_VERSION = ("3: contact, min separation, separation invariant (SSM's part), its "
                   "violation time, permitted contact")
SCHEDULER_TIMEOUT = 5.0  # s to reach a Dask scheduler before giving up


def _evaluate_chunk(scenarios: list[Scenario], cell: ResolvedCell | None = None
                    ) -> np.ndarray:
    """(len(FIELDS), B) figures of a chunk under their configuration's resolved ``cell``
    (None: ``evaluate_many`` resolves it; runs in a worker)."""
    r = evaluate_many(scenarios, cell=cell)
    return np.stack([getattr(r, f) for f in FIELDS])


def _apply(job: tuple) -> object:
    """fn(*args) of a job (fn, args) (runs in a worker)."""
    fn, args = job
    return fn(*args)


def _timed(job: tuple) -> tuple:
    """(fn(item), the CPU seconds it took) of a job (fn, item), in a worker process."""
    fn, item = job
    start = time.process_time()
    result = fn(item)
    return result, time.process_time() - start


def scenario_key(scenario: Scenario) -> str:
    """A stable key of a scenario's content (its dataclasses' ``repr``, without its name:
    every float written in full, as ``repr`` does; a YAML dump would say the same at some
    hundred times the cost) and of the figures kept for it (``FIGURES_VERSION``)."""
    text = FIGURES_VERSION + "\n" + repr(dataclasses.replace(scenario, name=""))
    return hashlib.sha256(text.encode()).hexdigest()[:24]


class EvaluationCache:
    """Figures by scenario key, appended to ``path`` (JSON lines) as they arrive.

    Opening drops what an interrupted run may have left at the end of the file: a
    line cut short (the file is cut back to its last complete line, so the next line
    appended starts on a line of its own); any line that is not a complete row is
    skipped."""

    def __init__(self, path: Path | None):
        self.path = path
        self.values: dict[str, list[float]] = {}
        if path is None or not path.exists():
            return
        data = path.read_bytes()
        end = data.rfind(b"\n") + 1
        if end < len(data):
            with open(path, "r+b") as f:
                f.truncate(end)
        for line in data[:end].decode("utf-8", errors="replace").splitlines():
            try:
                row = json.loads(line)
                key, figures = row["key"], [float(x) for x in row["figures"]]
            except (ValueError, TypeError, KeyError):
                continue
            if isinstance(key, str) and len(figures) == len(FIELDS):
                self.values[key] = figures

    def add(self, key: str, figures: np.ndarray) -> None:
        self.values[key] = [float(x) for x in figures]
        if self.path is not None:
            with open(self.path, "a") as f:
                f.write(json.dumps({"key": key, "figures": self.values[key]}) + "\n")


class Runner:
    """Evaluates lists of scenarios with the batched evaluator.

    Args:
        workers: local processes (None: all cores; 1: in this process).
        scheduler: address of a Dask scheduler (``tcp://host:port``); overrides workers.
        cache_path: JSON-lines file of finished evaluations (None: memory only).
        chunk: scenarios per task.
        progress: show one progress bar over all evaluations (``total`` expected).
        tally: counts the simulations evaluated (not those read from the cache) and
            the CPU time of the workers (``verification.search.counts``); a new one if None.
    """

    def __init__(self, *, workers: int | None = None, scheduler: str | None = None,
                 cache_path: Path | None = None, chunk: int = 64, progress: bool = False,
                 total: int | None = None, tally: Tally | None = None):
        self.tally = Tally() if tally is None else tally
        self.workers = workers if workers is not None else (os.cpu_count() or 1)
        self.scheduler = scheduler
        self.cache = EvaluationCache(cache_path)
        self.chunk = chunk
        self._bar = tqdm(total=total, unit="sim", disable=not progress, delay=1.0)
        self._pool = None
        self._client = None

    def __enter__(self):
        return self

    def __exit__(self, kind, *exc):
        self.close(stop=kind is not None)

    def close(self, stop: bool = False) -> None:
        """Ends the workers: after their work, or with ``stop`` (an error, Ctrl-C) at
        once, their work dropped."""
        self._bar.close()
        interrupts.forget(self)
        if self._pool is not None:
            if stop:
                _stop_workers(self._pool)
            self._pool.shutdown(wait=not stop, cancel_futures=stop)
            self._pool = None
        if self._client is not None:
            self._client.close()
            self._client = None

    def evaluate(self, scenarios: list[Scenario], cell: ResolvedCell | None = None
                 ) -> np.ndarray:
        """(len(scenarios), len(FIELDS)) figures (see ``FIELDS``) in input order; ``cell``:
        their configuration resolved (``config.resolved_cell``), shipped to the workers
        with each chunk (None: each chunk's evaluator resolves its own)."""
        keys = [scenario_key(s) for s in scenarios]
        todo, queued = [], set()
        for i, k in enumerate(keys):  # each new scenario once
            if k not in self.cache.values and k not in queued:
                queued.add(k)
                todo.append(i)
        # Split the work evenly over the workers, in chunks of at most ``chunk``.
        size = max(1, min(self.chunk, -(-len(todo) // max(1, self.workers))))
        chunks = [todo[i:i + size] for i in range(0, len(todo), size)]
        self.tally.add("simulations", len(todo))
        for rows, figures in zip(chunks, self._map([[scenarios[i] for i in c] for c in chunks],
                                                   cell)):
            for i, column in zip(rows, figures.T):
                if keys[i] not in self.cache.values:
                    self.cache.add(keys[i], column)
        self._bar.update(len(scenarios))
        return np.array([self.cache.values[k] for k in keys]).reshape(len(scenarios), -1)

    def map(self, fn, arguments: list[tuple]) -> list:
        """[fn(*a) for a in arguments], on the runner's workers; ``fn`` a module-level
        function, its arguments picklable (no Drake objects)."""
        return list(self._run(_apply, [(fn, a) for a in arguments]))

    def _map(self, chunks, cell: ResolvedCell | None = None):
        return self._run(_apply, [(_evaluate_chunk, (c, cell)) for c in chunks])

    def _run(self, fn, items):
        """fn of every item, in order; elsewhere than in this process, timed there (the
        CPU seconds go to the tally)."""
        if not items:
            return iter(())
        if self.scheduler is None and (self.workers <= 1 or len(items) == 1):
            return (fn(c) for c in items)  # (this process's CPU time counts them)
        if self.scheduler is not None:
            if self._client is None:
                from dask.distributed import Client

                self._client = Client(self.scheduler, timeout=2 * SCHEDULER_TIMEOUT)
            futures = self._client.map(_timed, [(fn, c) for c in items], pure=False)
            timed = (f.result() for f in futures)
        else:
            if self._pool is None:
                # on this thread, not the pool's feeder thread: a Drake diagram's
                # cycles freed there abort (evaluate_drake.collect_diagram_garbage)
                gc.collect()
                self._pool = ProcessPoolExecutor(
                    max_workers=self.workers, mp_context=_worker_context(),
                    initializer=_worker_start, initargs=(third_party_noise.log_path(),))
                interrupts.on_deadline(self, functools.partial(_stop_workers, self._pool))
            timed = self._pool.map(_timed, [(fn, c) for c in items])
        return self._collect(timed)

    def _collect(self, timed):
        for result, cpu in timed:
            self.tally.worker_cpu += cpu
            yield result


def _worker_start(noise_log: Path | None) -> None:
    """A local worker's start: Ctrl-C is left to the command that started it (which ends
    its workers), and third-party noise goes where the command keeps it."""
    interrupts.ignore_in_worker()
    third_party_noise.keep_in(noise_log)


def _stop_workers(pool: ProcessPoolExecutor) -> None:
    """Ends a pool's worker processes now (SIGTERM), whatever they are doing."""
    # (the pool's own processes: Python 3.14's terminate_workers does this)
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        if process.is_alive():
            process.terminate()


def _worker_context():
    """Local workers start from a fork server that imported this module once: forking
    this process instead (Linux's default) copies a process whose threads (Drake's,
    numba's, a test runner's) may hold locks, and a child can then abort or hang."""
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload([__name__])
    _start_fork_server_deaf_to_ctrl_c()
    return context


def _start_fork_server_deaf_to_ctrl_c() -> None:
    """Starts the fork server (once per process) with SIGINT ignored. The server is in
    the command's process group, so a terminal's Ctrl-C reaches it too: while it imports
    its preload, a KeyboardInterrupt inside pydrake's import leaves a half-imported
    module behind (the server swallows the ImportError), and every worker forked after
    dies with a traceback. Ignored at its start, SIGINT stays ignored in the server (its
    Python keeps an inherited SIG_IGN) and in every worker it forks (which restore the
    server's inherited disposition). A Ctrl-C that comes meanwhile is held (blocked on
    this thread) and reaches the command's own handler after."""
    from multiprocessing import forkserver

    if threading.current_thread() is not threading.main_thread():
        forkserver.ensure_running()
        return
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        forkserver.ensure_running()
    finally:
        signal.signal(signal.SIGINT, previous)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def check_scheduler(address: str, timeout: float | None = None) -> None:
    """Raises InputError (``--scheduler``) unless a Dask scheduler answers at
    ``address`` within ``timeout`` seconds (default ``SCHEDULER_TIMEOUT``)."""
    import asyncio

    from distributed.core import rpc

    timeout = SCHEDULER_TIMEOUT if timeout is None else timeout

    async def identity():
        async with rpc(address, timeout=timeout) as scheduler:
            return await scheduler.identity()

    allowed = "the address of a running Dask scheduler, e.g. tcp://10.0.0.5:8786"
    try:
        answer = asyncio.run(asyncio.wait_for(identity(), timeout))
    except asyncio.TimeoutError:
        raise InputError("--scheduler", address,
                         f"{allowed} (no answer within {timeout:g} s)") from None
    except MemoryError:  # what Dask makes of bytes that are not its protocol
        raise InputError("--scheduler", address,
                         f"{allowed} (something that is not Dask answered)") from None
    except Exception as e:  # noqa: BLE001 - anything here means: not a scheduler
        reason = " ".join(str(e).split()) or type(e).__name__
        raise InputError("--scheduler", address, f"{allowed} ({reason})") from None
    if not isinstance(answer, dict) or answer.get("type") != "Scheduler":
        raise InputError("--scheduler", address, f"{allowed} (something else answered)")
