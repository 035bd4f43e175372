"""numba's disk cache is keyed on a function's own file; builds that inline compiled code
from other files are dropped when those files change (safety_systems.compiled_cache)."""

from pathlib import Path

from safety_systems.compiled_cache import (
    compiled_dependencies,
    drop_all_stale_builds,
    drop_stale_builds,
)


def test_builds_dropped_when_what_they_inline_changes(tmp_path):
    cache, module, dep = tmp_path / "__pycache__", tmp_path / "caller.py", tmp_path / "dep.py"
    module.write_text("")
    dep.write_text("a")
    drop_stale_builds(module, (dep,))  # first look: no folder yet, it is made
    builds = [cache / "caller._advance-208.py311.nbi", cache / "caller._advance-208.py311.1.nbc"]
    other = cache / "other.f-10.py311.nbi"  # another module's build
    for path in (*builds, other):
        path.write_text("build")
    drop_stale_builds(module, (dep,))  # nothing changed: kept
    assert all(b.exists() for b in builds)
    dep.write_text("changed")
    drop_stale_builds(module, (dep,))
    assert not any(b.exists() for b in builds) and other.exists()
    builds[0].write_text("build")  # a build beside no mark (made before the mark existed)
    (cache / "caller.depends").unlink()
    drop_stale_builds(module, (dep,))
    assert not builds[0].exists()


def test_every_compiled_module_stamps_what_it_imports(tmp_path):
    """A compiled module's builds depend on every project module it imports, directly or
    through others (numba inlines their functions and freezes their constants); modules
    without compiled code keep no stamp."""
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "sub" / "codes.py").write_text("STOP = 3\n")
    (pkg / "rules.py").write_text("from pkg.sub import codes\nimport numba\n"
                                  "@numba.njit(cache=True)\ndef f():\n    return codes.STOP\n")
    (pkg / "loop.py").write_text("import numba\nfrom pkg.rules import f\n"
                                 "@numba.njit(cache=True)\ndef g():\n    return f()\n")
    (pkg / "plain.py").write_text("from pkg import loop\n")
    deps = compiled_dependencies(tmp_path, ("pkg",))
    names = {k.name: sorted(str(p.relative_to(pkg)) for p in v) for k, v in deps.items()}
    assert names == {"rules.py": ["sub/__init__.py", "sub/codes.py"],
                     "loop.py": ["rules.py", "sub/__init__.py", "sub/codes.py"]}
    build = pkg / "__pycache__" / "loop.g-3.py311.nbi"
    drop_all_stale_builds(tmp_path, ("pkg",))  # first look: marks written
    build.write_text("build")
    drop_all_stale_builds(tmp_path, ("pkg",))
    assert build.exists()
    (pkg / "sub" / "codes.py").write_text("STOP = 40\n")  # a constant two imports away
    drop_all_stale_builds(tmp_path, ("pkg",))
    assert not build.exists()


def test_the_project_keeps_no_housekeeping_in_its_modules():
    """drop_stale_builds runs from the packages' __init__ only (compiled_cache's rule)."""
    root = Path(__file__).resolve().parent.parent
    callers = [p for pkg in ("safety_systems", "verification") for p in (root / pkg).rglob("*.py")
               if "drop_stale_builds(" in p.read_text() and p.name != "compiled_cache.py"]
    assert callers == []
