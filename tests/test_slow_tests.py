"""tests/slow_tests.txt names test functions that exist (a renamed test would silently
leave the fast selection otherwise)."""

import ast
from pathlib import Path

from conftest import LIST, listed

ROOT = Path(__file__).resolve().parents[1]


def test_every_listed_slow_test_exists():
    names = listed()
    assert len(names) > 40
    for entry in names:
        path, function = entry.split("::")
        tree = ast.parse((ROOT / path).read_text())
        defined = {n.name for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)}
        assert function in defined, f"{LIST.name}: {entry} names no test"
