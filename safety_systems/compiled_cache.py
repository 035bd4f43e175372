"""Keeping numba's disk cache honest across files.

numba keys the disk cache of a compiled function (``cache=True``) on the function's own
file: when a compiled function inlines compiled functions from other files, a change to
those files would leave a stale build in the cache. A module whose compiled functions
inline code from other modules calls :func:`drop_stale_builds` at import, before its
functions are first called.
"""

import contextlib
from collections.abc import Iterable
from pathlib import Path
from types import ModuleType


def drop_stale_builds(module_file: str | Path, depends: Iterable[ModuleType | Path],
                      cache: Path | None = None) -> None:
    """Drops the cached builds of ``module_file``'s compiled functions (in ``cache``,
    by default its ``__pycache__``) when a file in ``depends`` (modules or paths)
    changed since the last look (a stamp of their sizes and modification times is kept
    beside the builds; no stamp counts as changed)."""
    module_file = Path(module_file)
    cache = module_file.parent / "__pycache__" if cache is None else cache
    paths = [Path(d.__file__) if isinstance(d, ModuleType) else Path(d) for d in depends]
    stamp = " ".join(f"{p.stat().st_mtime_ns}:{p.stat().st_size}" for p in paths)
    mark = cache / f"{module_file.stem}.depends"
    with contextlib.suppress(OSError):  # no mark yet: as good as changed
        if mark.read_text() == stamp:
            return
    with contextlib.suppress(OSError):  # a read-only install: numba caches elsewhere
        for build in cache.glob(f"{module_file.stem}.*.nb[ic]"):
            build.unlink(missing_ok=True)
        cache.mkdir(exist_ok=True)
        mark.write_text(stamp)
