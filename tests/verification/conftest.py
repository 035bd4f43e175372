"""Shared fixtures: iso.yaml verified on the default space (a small budget) and
exported."""

import contextlib
import io
from pathlib import Path

import pytest

from safety_systems.cli import main

MODELS = Path(__file__).parents[2] / "models"
ISO = MODELS / "configs" / "iso.yaml"
SPACE = MODELS / "spaces" / "default.yaml"


def run_cli(argv: list[str]) -> tuple[int, str, str]:
    """``safety-systems ARGV`` in this process: (exit code, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in argv])
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(scope="session")
def cli():
    """``run_cli``: a command in this process, (exit code, stdout, stderr)."""
    return run_cli


@pytest.fixture(scope="session")
def exported(tmp_path_factory) -> Path:
    """A folder holding iso.yaml's verification (verified/) and its export (export/)."""
    root = tmp_path_factory.mktemp("exported")
    verified, export = root / "verified", root / "export"
    code, _, err = run_cli(["verify", ISO, "--space", SPACE, "--out", verified, "--budget",
                            "6", "--workers", "1", "--quiet"])
    assert code == 0, err
    code, _, err = run_cli(["export", ISO, "--report", verified / "report.json", "--out",
                            export, "--quiet"])
    assert code == 0, err
    return root

