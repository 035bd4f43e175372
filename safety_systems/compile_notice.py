"""The line a run prints before numba compiles the per-tick maths.

numba compiles the loop's functions on their first call and keeps the builds beside the
sources (``safety_systems.compiled_cache``): on a fresh clone the first ``simulate`` or
``verify`` spends minutes compiling, and without a word a new user takes it for a hang.
:func:`first_run_line` looks at the cache before anything runs (a few directory
listings) and words the line; :func:`watch_compiles` says it when numba starts the run's
first compile, so a run refused on a bad file (before anything compiles) prints its one
line alone. A compile the look did not foresee (a robot with a number of joints not seen
before compiles its own variants) is said the same way, in general words.
"""

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
# The modules whose builds every run of the loop needs, and those of the batched
# evaluator (verify, tune): a module with no build kept at all is compiled on this run.
LOOP = ("safety_systems/ssm/formulas.py", "safety_systems/ssm/separation.py",
        "safety_systems/sensing/tracks.py", "safety_systems/cell/human_body.py",
        "safety_systems/cell/robot_geometry.py", "safety_systems/cell/braking.py")
SEARCH = ("verification/search/evaluate_batch.py",)
NEEDS = {"simulate": LOOP, "compare": LOOP, "run": LOOP, "verify": LOOP + SEARCH,
         "tune": LOOP + SEARCH}
# Minutes of CPU the first run of each command spent compiling on a fresh clone, on the
# two-core machine this was written on (wall time is longer on a loaded machine): the
# first run's CPU time less the second's (verify iso.yaml over the default space: 157 s
# against 8 s; simulate inspection.yaml: 32 s against 6 s).
MINUTES = {"simulate": 0.5, "compare": 0.5, "run": 0.5, "verify": 2.5, "tune": 2.5}


def missing_builds(files, root: Path | None = None) -> list[Path]:
    """The module files (paths relative to ``root``) with no compiled build kept beside
    them: numba compiles their functions on their first call. Empty where the sources'
    folders are not writable (numba then keeps its builds elsewhere: not known here)."""
    out, root = [], ROOT if root is None else root
    for name in files:
        path = root / name
        cache = path.parent / "__pycache__"
        if not os.access(cache if cache.exists() else path.parent, os.W_OK):
            return []
        if not any(cache.glob(f"{path.stem}.*.nbi")):
            out.append(path)
    return out


def first_run_line(command: str, root: Path | None = None) -> str | None:
    """The line ``command`` prints first when its run will compile (None when every
    build it needs is kept, or for a command that runs no loop)."""
    if command not in NEEDS or not missing_builds(NEEDS[command], root):
        return None
    minutes = MINUTES[command]
    about = f"{minutes * 60:.0f} s" if minutes < 1 else f"{minutes:g} min"
    return (f"compiling the per-tick maths (first run only, about {about} on a free core; "
            "later runs load it)")


COMPILING = ("compiling the per-tick maths this run needs (once: later runs load it; a "
             "robot with a number of joints not seen before takes minutes)")


def watch_compiles(first_line: str | None, say=None):
    """Says (on stderr, or through ``say``) when numba first starts a compile in this
    process: ``first_line`` (the first-run line, with its time) where the look foresaw
    the compile, else :data:`COMPILING`. Returns the listener
    (``numba.core.event.unregister`` removes it)."""
    from numba.core import event

    if say is None:
        def say(line: str) -> None:
            print(f"safety-systems: {line}", file=sys.stderr, flush=True)

    class FirstCompile(event.Listener):
        def __init__(self):
            self.said = False

        def on_start(self, event) -> None:
            if not self.said:
                self.said = True
                say(COMPILING if first_line is None else first_line)

        def on_end(self, event) -> None:
            pass

    listener = FirstCompile()
    event.register("numba:compile", listener)
    return listener
