import contextlib
import fcntl
import io
from pathlib import Path

import pytest

from safety_systems.cli import main

MODELS = Path(__file__).parents[2] / "models"


def _cli(argv: list) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main([str(a) for a in argv])
    return code, err.getvalue()


@pytest.fixture(scope="session")
def exported_params(tmp_path_factory, worker_id) -> Path:
    """iso.yaml verified on the default space (a small budget) and exported: a
    params.yaml with its certificate.json, which ``check`` accepts (built once per test
    run; the xdist workers share it under a lock)."""
    # under xdist the workers' temporary roots share this run's folder; without it, the
    # run's own root (its parent is shared by every run)
    base = tmp_path_factory.getbasetemp()
    root = base if worker_id == "master" else base.parent
    folder = root / "runtime_export"
    with open(root / "runtime_export.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (folder / "done").exists():
            iso = MODELS / "configs" / "iso.yaml"
            code, err = _cli(["verify", iso, "--space", MODELS / "spaces" / "default.yaml",
                              "--out", folder / "verified", "--budget", "6", "--workers", "1",
                              "--quiet"])
            assert code == 0, err
            code, err = _cli(["export", iso, "--report", folder / "verified" / "report.json",
                              "--out", folder / "export", "--quiet"])
            assert code == 0, err
            (folder / "done").touch()
    assert _cli(["check", folder / "export" / "params.yaml"])[0] == 0
    return folder / "export" / "params.yaml"
