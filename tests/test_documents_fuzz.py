"""Fuzzing every loader from the shipped examples: a mutated file either loads or fails
with exit code 2 and one line on stderr (``safety-systems check``, run in this process)
and never anything else: no traceback, no other exit code, no file written."""

import contextlib
import io
import math
import shutil
import tempfile
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from safety_systems.cli import main
from safety_systems.sensing.recording_mapping import load_mapping

MODELS = Path(__file__).parents[1] / "models"
SOURCES = {
    "scenario": sorted((MODELS / "scenarios").glob("*.yaml")),
    "config": sorted((MODELS / "configs").glob("*.yaml")),
    "space": sorted((MODELS / "spaces").glob("*.yaml")),
    "scene": [MODELS / "scenes" / "paper.yaml"],
    "task-path": [MODELS / "scenes" / "paper_task_path.yaml"],
    "mapping": [MODELS / "recordings" / "approach_mapping.yaml"],
}
EXAMPLES = 120  # per kind of file
# A whole operator as no shipped scenario writes it (a body model, legacy and named points,
# a posture): its points, posture and dimensions are fuzzed too. Written into the fuzz's
# folder as whole_operator.yaml, a scenario source like the shipped ones.
WHOLE_OPERATOR = """\
name: whole_operator
duration: 5.0
controller:
  body: {upper_arm: 0.42, trunk_lean_deg: 30.0, tracking_allowance: 0.02}
operators:
- name: fitter
  bodies:
  - {name: head, offset: [0.3, 0.0, 0.5]}
  - {name: hand}
  - {name: band, point: elbow_left, offset: [0.1, 0.25, 0.1]}
  posture:
  - {point: chest, offset: [0.3, 0.0, 0.1]}
  - {point: hand_left, offset: [0.0, 0.3, 0.0]}
  waypoints:
  - {time: 0.0, position: [2.5, 0.0, 1.0]}
  - {time: 3.0, position: [1.5, 0.5, 1.0]}
"""

ODD_NUMBERS = [0, -0.0, -1, 1e-320, 1e3, 1e6, 1e12, 1e300, 1e308, -1e308, 2**63, 10**30,
               math.inf, -math.inf, math.nan]
PATHS = ["", ".", "/", "\x00", "a\x00b", "/dev/null", "../scenes", "x" * 300,
         "../scenes/paper_task_path.yaml", "../scenes/paper.yaml", "../docs/paper.yaml"]
values = st.one_of(
    st.none(), st.booleans(), st.sampled_from(ODD_NUMBERS),
    st.integers(-10**6, 10**6), st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=12), st.sampled_from(["1e400", ".nan", "0x10", "", "~", "yes", "true",
                                           "../scenes/paper_task_path.yaml", "/", "\x00"]),
    st.lists(st.floats(-10.0, 10.0), max_size=7),
    st.dictionaries(st.sampled_from(["min", "max", "name", "x", "points"]),
                    st.integers(-3, 3), max_size=2))


def _paths(node, path=()):
    """Every path to a node of the plain YAML data (not the root)."""
    children = (node.items() if isinstance(node, dict)
                else enumerate(node) if isinstance(node, list) else ())
    for key, child in children:
        yield path + (key,)
        yield from _paths(child, path + (key,))


def _parent(data, path):
    for key in path[:-1]:
        data = data[key]
    return data


def _mutate_tree(data, draw):
    paths = list(_paths(data))
    if not paths:
        return
    kind = draw(st.sampled_from(["replace", "delete", "wrap", "scale", "repeat", "text"]))
    strings = [p for p in paths if isinstance(_parent(data, p)[p[-1]], str)]
    path = draw(st.sampled_from(strings if kind == "text" and strings else paths))
    parent, key = _parent(data, path), path[-1]
    value = parent[key]
    if kind == "replace":
        parent[key] = draw(values)
    elif kind == "text":  # names, modes, types, file names
        parent[key] = draw(st.one_of(st.text(max_size=12), st.sampled_from(PATHS)))
    elif kind == "delete":
        del parent[key]
    elif kind == "wrap":  # a list where a mapping belongs, or the reverse
        parent[key] = (dict(enumerate(value)) if isinstance(value, list)
                       else [value] if isinstance(value, dict) else {"value": value})
    elif kind == "scale" and isinstance(value, (int, float)) and not isinstance(value, bool):
        parent[key] = value * draw(st.sampled_from(ODD_NUMBERS))
    elif kind == "repeat" and isinstance(parent, list):
        parent.insert(key, value)


def _mutate_text(text: bytes, draw) -> bytes:
    kind = draw(st.sampled_from(["line", "bytes", "cut", "tab"]))
    lines = text.splitlines(keepends=True) or [b""]
    i = draw(st.integers(0, len(lines) - 1))
    if kind == "line":  # duplicate keys, or items
        lines.insert(i, lines[i])
    elif kind == "bytes":
        at = draw(st.integers(0, len(lines[i])))
        junk = draw(st.one_of(st.binary(min_size=1, max_size=6),
                              st.text(":-[]{}#&*!|>'\"%@ ,.0123456789eEx", min_size=1,
                                      max_size=6).map(str.encode)))
        lines[i] = lines[i][:at] + junk + lines[i][at:]
    elif kind == "cut":
        return text[:draw(st.integers(0, len(text)))]
    else:
        lines[i] = b"\t" + lines[i].lstrip(b" ")
    return b"".join(lines)


def _check(kind: str, path: Path) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(["check", kind, str(path)])
    return code, err.getvalue()


@pytest.mark.parametrize("kind", list(SOURCES))
def test_mutated_files_load_or_fail_with_one_line(kind):
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder)
        (root / "scenes").mkdir()
        (root / "docs").mkdir()
        # Files that examples name relative to themselves (../scenes/...,
        # ../recordings/...).
        shutil.copy(MODELS / "scenes" / "paper_task_path.yaml", root / "scenes")
        shutil.copytree(MODELS / "recordings", root / "recordings")
        shutil.copy(MODELS / "recordings" / "approach.csv", root / "docs")  # the mapping's
        (root / "whole_operator.yaml").write_text(WHOLE_OPERATOR)
        sources = SOURCES[kind] + ([root / "whole_operator.yaml"] if kind == "scenario"
                                   else [])

        @settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
                  suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
        @given(data=st.data())
        def fuzz(data):
            source = data.draw(st.sampled_from(sources), label="source")
            tree = yaml.safe_load(source.read_text())
            for _ in range(data.draw(st.integers(1, 4), label="tree mutations")):
                _mutate_tree(tree, data.draw)
            text = (yaml.safe_dump(tree, sort_keys=False, allow_unicode=True).encode()
                    if data.draw(st.booleans(), label="dump") else source.read_bytes())
            if data.draw(st.integers(0, 9), label="text mutations") >= 7:  # 3 in 10
                text = _mutate_text(text, data.draw)
            path = root / "docs" / source.name
            path.write_bytes(text)
            before = sorted(root.rglob("*"))
            code, err = _check(kind, path)
            assert sorted(root.rglob("*")) == before  # nothing written
            if code == 0:
                assert err == ""
            else:
                assert code == 2, err
                lines = err.splitlines()
                assert len(lines) == 1 and lines[0].startswith("safety-systems: "), err
                assert "allowed: " in lines[0], err

        fuzz()


def test_the_fuzzer_reaches_both_outcomes():
    # The unmutated examples load; a mutated one fails (the fuzz test is not vacuous).
    with tempfile.TemporaryDirectory() as folder:
        (Path(folder) / "src").mkdir()
        whole = Path(folder) / "src" / "whole_operator.yaml"
        whole.write_text(WHOLE_OPERATOR)
        for kind, sources in (SOURCES | {"scenario": SOURCES["scenario"] + [whole]}).items():
            for source in sources:
                if "file: " in source.read_text():
                    continue  # names a file relative to its own folder
                copy = Path(folder) / source.name
                copy.write_bytes(source.read_bytes())
                named = load_mapping(source).recording if kind == "mapping" else ""
                if named:  # the recording it names, relative to itself
                    shutil.copy(source.parent / named, folder)
                assert _check(kind, copy) == (0, "")
                key = next(line for line in source.read_text().splitlines()
                           if line[:1].isalpha())  # a top-level key, once more
                copy.write_text(source.read_text() + key + "\n")
                code, err = _check(kind, copy)
                assert code == 2 and len(err.splitlines()) == 1
