"""Keeping numba's disk cache honest across files, and the conventions of compiled code.

numba keys the disk cache of a compiled function (``cache=True``) on the function's own
file: when a compiled function inlines compiled functions from other files, a change to
those files would leave a stale build in the cache. :func:`drop_all_stale_builds` runs
when ``safety_systems`` or ``verification`` is first imported, before any compiled
function is called: for every module with compiled code, the builds are dropped when a
module with compiled code that it imports, directly or through others, changed. Domain
modules hold no housekeeping of their own.

Conventions of the compiled code (numba), stated here once:

- a function marked ``inline="always"`` is inlined into its callers, so a compiled loop
  pays no call and no array reference counting per element;
- such a function has one exit (one ``return`` at its end): a return per branch made
  the callers' loops several times slower (numba then keeps the arrays' reference
  counting in them);
- the public Python function beside a compiled kernel converts its arguments to
  contiguous float arrays and its results to Python numbers.
"""

import ast
import contextlib
from collections.abc import Iterable
from pathlib import Path
from types import ModuleType

_COMPILED = "numba.njit("


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


def _project_imports(path: Path, root: Path) -> set[Path]:
    """The project files ``path`` imports (``root`` holds the packages)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        names = []
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        for name in names:
            base = root.joinpath(*name.split("."))
            for candidate in (base.with_suffix(".py"), base / "__init__.py"):
                if candidate.is_file():
                    found.add(candidate)
    return found


def compiled_dependencies(root: Path, packages: Iterable[str]) -> dict[Path, list[Path]]:
    """For every module of ``packages`` (folders under ``root``) with compiled code, the
    project modules it imports, directly or through other modules: compiled functions
    inline theirs, and numba freezes their module-level constants into the build."""
    files = [f for pkg in packages for f in sorted((root / pkg).rglob("*.py"))]
    imports: dict[Path, set[Path]] = {}

    def closure(f: Path, seen: set[Path]) -> set[Path]:
        if f not in imports:
            imports[f] = _project_imports(f, root)
        for g in imports[f] - seen:
            seen.add(g)
            closure(g, seen)
        return seen

    return {f: deps for f in files if _COMPILED in f.read_text()
            for deps in [sorted(closure(f, set()) - {f})] if deps}


def drop_all_stale_builds(root: Path, packages: Iterable[str]) -> None:
    """:func:`drop_stale_builds` for every module of ``packages`` with compiled code,
    against the modules it imports (see :func:`compiled_dependencies`).

    It runs at every start of the packages, so the import graph is parsed only when a
    file it was made of changed: a mark in the first package's ``__pycache__`` keeps those
    files' sizes and modification times (a file not in it has no build that could be
    stale, or changed the imports of one that is)."""
    root = Path(root)
    packages = tuple(packages)
    mark = root / packages[0] / "__pycache__" / f"{'+'.join(packages)}.compiled"
    with contextlib.suppress(OSError):  # no mark, or a file of it gone
        files = mark.read_text().split("\n")[1:]
        if mark.read_text() == _graph_mark(files):
            return
    with contextlib.suppress(OSError):  # an installed copy without its sources: nothing to do
        graph = compiled_dependencies(root, packages)
        for module, deps in graph.items():
            drop_stale_builds(module, deps)
        files = sorted({str(f) for module, deps in graph.items() for f in (module, *deps)})
        mark.parent.mkdir(exist_ok=True)
        mark.write_text(_graph_mark(files))


def _graph_mark(files: list[str]) -> str:
    """A stamp of ``files``' sizes and modification times, then the files, one a line."""
    stamp = " ".join(f"{s.st_mtime_ns}:{s.st_size}" for s in (Path(f).stat() for f in files))
    return "\n".join([stamp, *files])
