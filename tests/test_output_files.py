"""Output folders checked before work; results written whole or not at all."""

import json
import os

import pytest

from safety_systems.files.input_error import InputError
from safety_systems.files.output_files import atomic_path, prepare_out, write_json, write_text


def test_prepare_out_creates_the_folder_and_its_parents(tmp_path):
    out = prepare_out(tmp_path / "a" / "b")
    assert out.is_dir() and list(out.iterdir()) == []


def test_prepare_out_refuses_a_folder_under_a_file(tmp_path):
    (tmp_path / "file").write_text("x")
    for target in (tmp_path / "file", tmp_path / "file" / "out"):
        with pytest.raises(InputError) as e:
            prepare_out(target)
        assert e.value.field == "--out" and str(target) in str(e.value)
        assert "\n" not in str(e.value)


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_prepare_out_refuses_a_read_only_folder(tmp_path):
    tmp_path.joinpath("ro").mkdir(mode=0o555)
    with pytest.raises(InputError, match="can be created and written"):
        prepare_out(tmp_path / "ro")


def test_an_interrupted_write_leaves_the_old_file(tmp_path):
    path = tmp_path / "summary.json"
    write_json(path, {"run": 1})
    with pytest.raises(RuntimeError):
        with atomic_path(path) as temporary:
            temporary.write_text('{"run": 2, "half')
            raise RuntimeError("killed")
    assert json.loads(path.read_text()) == {"run": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["summary.json"]
    write_text(path, "new\n")
    assert path.read_text() == "new\n"
    assert [p.name for p in tmp_path.iterdir()] == ["summary.json"]


def test_prepare_out_removes_what_a_killed_writer_left(tmp_path):
    # A process that has ended (a pid far beyond any running one) and one that runs.
    dead = tmp_path / ".report.json.999999999.0123abcd.part"
    alive = tmp_path / f".report.json.{os.getpid()}.0123abcd.part"
    other = tmp_path / ".notes.part"
    for p in (dead, alive, other):
        p.write_text("half")
    prepare_out(tmp_path)
    assert not dead.exists() and alive.exists() and other.exists()
