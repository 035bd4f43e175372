"""The `slow` mark (pyproject.toml registers it): the tests tests/slow_tests.txt lists,
measured, and those using a fixture that takes minutes to build (SLOW_FIXTURES).
``pytest -m "not slow"`` is the README's fast selection; CI runs every test."""

import os
from pathlib import Path

import pytest
from hypothesis import settings

# Property tests draw the same examples on every run ("fixed", the default: a test run, and
# CI's, passes or fails for the code, not the draw), or fresh ones with
# HYPOTHESIS_PROFILE=explore (more of them, at random: run it after changing the maths; a
# failure it finds prints the example to add as an @example).
settings.register_profile("fixed", derandomize=True, print_blob=True)
settings.register_profile("explore", derandomize=False, max_examples=2000, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "fixed"))

LIST = Path(__file__).with_name("slow_tests.txt")
# Session or module fixtures whose building alone takes more than a minute: a small tune
# run and its export (tests/verification/conftest.py), and a whole verify, tune and export
# per robot (tests/verification/test_any_robot.py).
SLOW_FIXTURES = ("tuned", "robot_run")


def listed() -> set[str]:
    """The test functions tests/slow_tests.txt lists (``path::name``)."""
    return {line.split("#")[0].strip() for line in LIST.read_text().splitlines()
            if line.split("#")[0].strip()}


def pytest_collection_modifyitems(config, items) -> None:
    slow = listed()
    root = Path(config.rootpath)
    for item in items:
        function = (f"{Path(item.path).relative_to(root).as_posix()}::"
                    f"{item.originalname if hasattr(item, 'originalname') else item.name}")
        if function in slow or any(f in getattr(item, "fixturenames", ())
                                   for f in SLOW_FIXTURES):
            item.add_marker(pytest.mark.slow)
