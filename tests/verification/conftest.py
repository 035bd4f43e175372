"""Shared fixtures: iso.yaml verified on the default space (a small budget) and
exported; a small tune run from iso.yaml and its chosen configuration exported."""

import contextlib
import io
import json
import shutil
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


def _shared(tmp_path_factory, worker_id: str, name: str, build) -> Path:
    """``build(folder)`` once per test run: under pytest-xdist the workers share the
    run's temporary root, and the first to come builds while the others wait on a lock
    (the results are only read afterwards)."""
    if worker_id == "master":
        folder = tmp_path_factory.mktemp(name)
        build(folder)
        return folder
    import fcntl

    root = tmp_path_factory.getbasetemp().parent  # this run's, shared by its workers
    folder = root / name
    with open(root / f"{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (folder / "done").exists():
            shutil.rmtree(folder, ignore_errors=True)
            folder.mkdir()
            build(folder)
            (folder / "done").touch()
    return folder


@pytest.fixture(scope="session")
def exported(tmp_path_factory, worker_id) -> Path:
    """A folder holding iso.yaml's verification (verified/) and its export (export/)."""
    return _shared(tmp_path_factory, worker_id, "exported", _export_iso)


def _export_iso(root: Path) -> None:
    verified, export = root / "verified", root / "export"
    code, _, err = run_cli(["verify", ISO, "--space", SPACE, "--out", verified, "--budget",
                            "6", "--workers", "1", "--quiet"])
    assert code == 0, err
    code, _, err = run_cli(["export", ISO, "--report", verified / "report.json", "--out",
                            export, "--quiet"])
    assert code == 0, err


TUNE_BLOCK = """\
tune:
- {name: safety.intrusion_distance, min: 0.0, max: 0.12}
- {name: safety.robot_uncertainty, min: 0.4, max: 0.7}
- {name: safety.reaction_time, min: 0.1, max: 0.2}
- {name: safety.robot_speed, choices: [directed, fastest_point]}
"""
# The tuned fixture's tune file prices one lever too (tests/verification/tune/test_tune.py).
LEVERS_BLOCK = """\
levers:
- {sensor_set: gloves+helmet+belt+elbows, rate_hz: 120.0, latency: 0.02, cost: 3.0}
"""
SMALL_SPACE = Path(__file__).parent / "small_space.yaml"


@pytest.fixture(scope="session")
def tuned(tmp_path_factory, worker_id) -> Path:
    """A small tune run from iso.yaml (DIR/tune/) over a small space, its one task the
    inspection scenario cut to 3 cycles, and the chosen configuration exported with the
    counterexamples kept on the way (DIR/export/)."""
    return _shared(tmp_path_factory, worker_id, "tuned", _tune_iso)


def _tune_iso(root: Path) -> None:
    import yaml

    (root / "tune.yaml").write_text(TUNE_BLOCK + LEVERS_BLOCK)
    task = yaml.safe_load((MODELS / "scenarios" / "inspection_seed.yaml").read_text())
    task["duration"], task["robot"]["cycles"] = 25.0, 3
    (root / "task.yaml").write_text(yaml.safe_dump(task, sort_keys=False))
    code, out, err = run_cli(["tune", ISO, "--tune", root / "tune.yaml", "--space", SMALL_SPACE,
                            "--tasks", root / "task.yaml", "--out", root / "tune", "--budget",
                            "24", "--candidates", "3", "--screen", "4", "--workers", "1"])
    assert code == 0, err
    (root / "tune_stderr.txt").write_text(err)  # its progress and console, for test_tune
    (root / "tune_stdout.txt").write_text(out)
    result = json.loads((root / "tune" / "tune.json").read_text())
    chosen = result["chosen"]
    code, _, err = run_cli(["export", chosen["config"], "--report", chosen["report"], "--tune",
                            root / "tune" / "tune.json", "--out", root / "export", "--quiet"])
    assert code == 0, err
