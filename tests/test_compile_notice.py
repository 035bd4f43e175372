"""A run that compiles the per-tick maths says so when the compile starts (with the first
run's time where the kept builds foretold it); a run refused on a bad file says one line."""

import numba
import pytest

from safety_systems import compile_notice
from safety_systems.cli import main


def _tree(tmp_path, built: tuple[str, ...] = ()):
    """A copy of the layout of the modules the notice looks at: every one without a build,
    but those in ``built`` (a numba index file beside them)."""
    for name in compile_notice.LOOP + compile_notice.SEARCH:
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("")
        if name in built:
            (path.parent / "__pycache__").mkdir(exist_ok=True)
            (path.parent / "__pycache__" / f"{path.stem}.f-12.py311.nbi").write_bytes(b"")
    return tmp_path


def test_a_module_without_a_kept_build_is_missing(tmp_path):
    root = _tree(tmp_path, built=compile_notice.LOOP)
    assert compile_notice.missing_builds(compile_notice.LOOP, root) == []
    assert compile_notice.missing_builds(compile_notice.SEARCH, root) == [
        root / name for name in compile_notice.SEARCH]
    assert compile_notice.first_run_line("simulate", root) is None
    line = compile_notice.first_run_line("verify", root)
    assert line.startswith("compiling the per-tick maths (first run only, about 2.5 min")
    assert compile_notice.first_run_line("check", _tree(tmp_path / "cold")) is None


def test_a_run_refused_on_a_bad_file_says_one_line_even_on_a_cold_cache(
        tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(compile_notice, "ROOT", _tree(tmp_path / "cold"))
    code = main(["simulate", str(tmp_path / "missing.yaml"), "--out", str(tmp_path / "o")])
    assert code == 2  # nothing compiled before the file was refused: its line alone
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and "missing.yaml" in err[0] and "compiling" not in err[0], err


@pytest.mark.parametrize("foreseen", [False, True])
def test_the_first_compile_says_so_once(foreseen, tmp_path):
    from numba.core import event

    first = compile_notice.first_run_line("simulate", _tree(tmp_path)) if foreseen else None
    lines = []
    listener = compile_notice.watch_compiles(first, lines.append)
    try:
        twice = numba.njit(lambda x: 2 * x)  # not cached: it compiles here, per type
        twice(1)
        twice(1.0)
    finally:
        event.unregister("numba:compile", listener)
    assert lines == [first if foreseen else compile_notice.COMPILING]
    assert foreseen == lines[0].startswith("compiling the per-tick maths (first run only")
