"""Real-time scheduling for the live loop (``safety-systems run --priority``).

On a shared machine the loop's worst ticks are the scheduler's, not its own work: in
ordinary time-sharing another busy process can hold the core for milliseconds after a
frame arrives or a tick falls due. Under the kernel's first-in-first-out real-time
policy (Linux ``SCHED_FIFO``) the loop's thread runs as soon as it is ready, ahead of
every ordinary process; it sleeps in ``select`` between frames and ticks, so it leaves
the core to others when idle (and the kernel's real-time throttling keeps a share for
them even if it did not). The policy is set for the loop's thread only, for the run
only, and is not inherited by processes it starts (the replay server). It needs the
privilege to use real-time priorities (root, or ``CAP_SYS_NICE``, or an rtprio limit);
without it the loop runs at normal priority and says so: the overrun watchdog
(``--max-overrun``) stops the robot whenever a tick is late, with or without it.

With a real-time priority the process' memory is also locked in RAM for the run
(:func:`lock_for_run`, Linux ``mlockall``: the pages it has and every page it maps
later), so that no tick waits for a page to come back from swap; where that is refused
(an ``RLIMIT_MEMLOCK`` too small for an unprivileged process), the run goes on and says
so (``memory_locked``). Locking takes a moment (every page is brought in), so ``run``
does it before it connects: once frames flow, the loop starts at once.
"""

import contextlib
import ctypes
import ctypes.util
import os

MAX_PRIORITY = 99
MCL_CURRENT, MCL_FUTURE = 1, 2  # <sys/mman.h> on Linux


def lock_memory() -> str | None:
    """Locks the process' pages in RAM, now and from now on; None, or why it could not."""
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c"), use_errno=True)
        if libc.mlockall(MCL_CURRENT | MCL_FUTURE) == 0:
            return None
        return os.strerror(ctypes.get_errno())
    except (OSError, AttributeError) as e:
        return str(e)


def lock_for_run(priority: int) -> dict:
    """The memory locked where a real-time ``priority`` (1-99) is asked for; what was
    done, for summary.json's ``scheduling``: ``{"memory_locked": True}``, or ``False``
    with ``memory_lock_refused``; nothing at priority 0."""
    if priority == 0:
        return {}
    refused = lock_memory()
    return {"memory_locked": True} if refused is None else {
        "memory_locked": False, "memory_lock_refused": refused}


def unlock_memory() -> None:
    try:
        ctypes.CDLL(ctypes.util.find_library("c")).munlockall()
    except (OSError, AttributeError):
        pass


@contextlib.contextmanager
def real_time(priority: int):
    """Runs the body under SCHED_FIFO at ``priority`` (1-99; 0: leave the scheduling as
    it is) and restores the thread's previous policy after it. Yields what was set:
    ``{"policy": "fifo", "priority": p}`` or ``{"policy": "normal", ...}`` with
    ``refused`` saying why a priority asked for was not given."""
    if priority == 0:
        yield {"policy": "normal", "priority": 0}
        return
    if not hasattr(os, "sched_setscheduler"):
        yield {"policy": "normal", "priority": 0,
               "refused": "this system has no real-time scheduling (Linux SCHED_FIFO)"}
        return
    before = (os.sched_getscheduler(0), os.sched_getparam(0))
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO | getattr(os, "SCHED_RESET_ON_FORK", 0),
                              os.sched_param(priority))
    except OSError as e:
        yield {"policy": "normal", "priority": 0,
               "refused": f"SCHED_FIFO priority {priority}: {e.strerror or e}"}
        return
    try:
        yield {"policy": "fifo", "priority": priority}
    finally:
        os.sched_setscheduler(0, before[0] & ~getattr(os, "SCHED_RESET_ON_FORK", 0),
                              before[1])
