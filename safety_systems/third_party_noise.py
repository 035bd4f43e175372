"""Third-party warnings that mean nothing to a user, kept out of the console.

numba's warnings while it compiles (its pedantic checks: "variable ... is not in scope
... Please report ... at github.com/numba/numba"; its performance hints) and what
pydrake's logger prints say nothing about a run's result. A command that writes an
output folder keeps them in ``third_party.log`` there (:func:`keep_in`, in the command's
process and in its worker processes); the warnings of this project and of its file
readers (a truncated export used, capture glitches) still reach the console, one line
each.
"""

import contextlib
import logging
import os
import re
import warnings
from pathlib import Path

LOG_NAME = "third_party.log"
LOGGERS = ("drake",)  # pydrake's messages go to Python's logging under this name

_state: dict = {"path": None, "pending": []}
_COLOURS = re.compile(r"\x1b\[[0-9;]*m")  # numba colours its messages


def is_noise(category: type, filename: str) -> bool:
    """Whether a warning of ``category`` raised in ``filename`` is third-party noise:
    numba's own warnings, and anything pydrake warns of."""
    module = getattr(category, "__module__", "") or ""
    return (module == "numba" or module.startswith("numba.")
            or f"{os.sep}pydrake{os.sep}" in str(filename))


def log_path() -> Path | None:
    """The log this process keeps third-party noise in (None: none kept)."""
    return _state["path"]


def note(line: str) -> None:
    """Appends ``line`` (its terminal colours dropped) to the log; held until the log's
    folder exists."""
    if _state["path"] is None:
        return
    _state["pending"].append(_COLOURS.sub("", line).rstrip("\n") + "\n")
    _flush()


def _flush() -> None:
    path = _state["path"]
    if path is not None and _state["pending"] and path.parent.is_dir():
        with open(path, "a") as f:
            f.writelines(_state["pending"])
        _state["pending"].clear()


class _ToLog(logging.Handler):
    def emit(self, record: logging.LogRecord) -> None:
        note(f"{record.name}: {record.levelname}: {record.getMessage()}")


@contextlib.contextmanager
def kept_in(path: Path | None, show=None):
    """Within it, this process keeps third-party noise in ``path`` (its folder may be
    made later; None: the noise is dropped) and shows every other warning through
    ``show`` (``warnings.showwarning``'s signature; default: the one in force). On
    leaving, the warnings' display and pydrake's logger are as they were."""
    saved = (warnings.showwarning, [(logging.getLogger(n), list(logging.getLogger(n).handlers),
                                     logging.getLogger(n).propagate) for n in LOGGERS])
    keep_in(path, show)
    try:
        yield
    finally:
        _flush()  # what came before the folder was made
        warnings.showwarning = saved[0]
        for logger, handlers, propagate in saved[1]:
            logger.handlers, logger.propagate = handlers, propagate
        _state["path"], _state["pending"] = None, []


def keep_in(path: Path | None, show=None) -> None:
    """:func:`kept_in` for the rest of this process (a worker process's initializer)."""
    _state["path"] = None if path is None else Path(path)
    _state["pending"] = []
    show = warnings.showwarning if show is None else show

    def showwarning(message, category, filename, lineno, file=None, line=None):
        if is_noise(category, filename):
            note(f"{category.__name__}: {filename}:{lineno}: "
                 + " ".join(str(message).split()))
        else:
            show(message, category, filename, lineno, file, line)

    warnings.showwarning = showwarning
    for name in LOGGERS:
        logger = logging.getLogger(name)
        logger.handlers = [_ToLog()]
        logger.propagate = False
