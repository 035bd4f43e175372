"""Ctrl-C ends a long command within a second or two, in any phase, with exit 130.

Python raises ``KeyboardInterrupt`` where the main thread next runs Python code, which is
not always enough: raised inside a Drake system's callback it may come back out of
pydrake as another exception (a ``TypeError`` naming the arguments of the call it broke),
code may catch that, and worker processes that get the terminal's SIGINT too die with
tracebacks of their own. So, while :class:`Interruptible` is entered:

- the first SIGINT marks the command interrupted and raises ``KeyboardInterrupt``; any
  exception that then ends the command counts as the interruption (:func:`interrupted`);
- if the command has not ended ``GRACE`` seconds later, its worker processes
  (:func:`on_deadline` registers how to stop them) are ended and the process exits 130
  at once; a second SIGINT does that straight away;
- worker processes ignore SIGINT (:func:`ignore_in_worker`, their pool's initializer):
  the command that started them ends them.
"""

import os
import signal
import sys
import threading

EXIT_INTERRUPTED = 130
GRACE = 1.5  # s from the first SIGINT to the exit, whatever the command is doing

_state = {"interrupted": False, "timer": None}
_stoppers: dict[int, object] = {}  # id -> a callable that ends some worker processes


def interrupted() -> bool:
    """Whether a SIGINT came while an :class:`Interruptible` was entered."""
    return _state["interrupted"]


def on_deadline(key: object, stop) -> None:
    """``stop()`` ends worker processes before a forced exit (see the module docstring);
    :func:`forget` removes it."""
    _stoppers[id(key)] = stop


def forget(key: object) -> None:
    _stoppers.pop(id(key), None)


def ignore_in_worker(*_) -> None:
    """A worker process's initializer: SIGINT is left to the command that started it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def stop_workers() -> None:
    """Before an exit that skips the interpreter's shutdown: ends every worker process
    registered with :func:`on_deadline` (the workers ignore SIGINT, and one left running
    holds the command's stderr open until its task is done) and the fork server."""
    for stop in list(_stoppers.values()):
        try:
            stop()
        except Exception:  # noqa: BLE001 - exiting anyway
            pass
    _stop_fork_server()


def _stop_fork_server() -> None:
    """Ends this process's multiprocessing fork server, if it started one: it ignores
    Ctrl-C (``verification.search.runner``), and one still importing its preload when
    the command exits would hold the command's stderr open for as long as that takes.
    Only before an exit: a later pool in this process would find it gone mid-start."""
    from multiprocessing import forkserver

    pid = getattr(getattr(forkserver, "_forkserver", None), "_forkserver_pid", None)
    if pid is not None:
        try:
            os.kill(pid, signal.SIGTERM)
        except OSError:  # (ended already)
            pass


def _exit_now(line: str) -> None:
    stop_workers()
    print(f"safety-systems: {line}", file=sys.stderr, flush=True)
    os._exit(EXIT_INTERRUPTED)


def _handler(signum, frame) -> None:
    if _state["interrupted"]:
        _exit_now("interrupted (twice: exiting at once)")
    _state["interrupted"] = True
    timer = threading.Timer(GRACE, _exit_now, args=(
        f"interrupted (ended {GRACE:g} s after Ctrl-C, in the middle of its work)",))
    timer.daemon = True
    timer.start()
    _state["timer"] = timer
    raise KeyboardInterrupt


class Interruptible:
    """A context in which Ctrl-C ends the command as the module docstring says (in the
    main thread only; elsewhere it does nothing)."""

    def __enter__(self):
        self._previous = None
        _state["interrupted"] = False
        if threading.current_thread() is threading.main_thread():
            self._previous = signal.signal(signal.SIGINT, _handler)
        return self

    def __exit__(self, *exc) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)
        # Interrupted, the deadline stays: it bounds the exit too (the interpreter's
        # shutdown joins threads and pools; the timer's thread is a daemon).
        timer = _state["timer"]
        if timer is not None and not _state["interrupted"]:
            timer.cancel()
            _state["timer"] = None
