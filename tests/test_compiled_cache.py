"""numba's disk cache is keyed on a function's own file; builds that inline compiled code
from other files are dropped when those files change (safety_systems.compiled_cache)."""

from safety_systems.compiled_cache import drop_stale_builds


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
