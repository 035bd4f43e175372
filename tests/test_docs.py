"""The README is a front door and the documentation site builds, warnings as errors; its
reference, generated from the code (docs/hooks/reference.py), names every field of every
file kind and every option of every command."""

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs" / "hooks"))

import reference  # noqa: E402

MOST_README_LINES = 150


def test_the_readme_is_a_front_door_whose_links_all_lead_somewhere():
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= MOST_README_LINES
    links = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", text)
    local = [link for link in links if not link.startswith("http")]
    assert len(local) > 20 and all((ROOT / link).exists() for link in local), local
    for page in ("docs/tutorial.md", "docs/how-to/recordings.md", "docs/how-to/live-run.md",
                 "docs/how-to/robot-logs.md", "docs/reference/commands.md", "docs/speed.md"):
        assert f"]({page})" in text, page


def test_ci_runs_the_readmes_test_command_and_the_slow_tests_and_times_both():
    readme = (ROOT / "README.md").read_text()
    (tests,) = [line for line in readme.splitlines() if "pytest" in line]
    selection = tests.split(".venv/bin/python -m pytest", 1)[1].strip()
    assert selection == '-n auto -m "not slow"'
    ci = (ROOT / ".ci" / "run").read_text()
    # CI runs the README's line itself: the first line of the README that .ci/run's grep
    # finds is that command, and .ci/run runs what it found
    (found,) = [line for line in readme.splitlines() if "-m pytest" in line][:1]
    assert found == tests
    assert "readme_tests=$(grep -m1 -- '-m pytest' README.md)" in ci
    assert 'bash -c "$readme_tests"' in ci and "-m pytest -n auto -m slow" in ci
    assert "'.[test,docs]'" in ci and ci.count("took") >= 2


@pytest.mark.parametrize("kind", sorted(reference.schemas()))
def test_the_reference_names_every_field_of_every_file_kind(kind):
    text = reference.file_reference(kind)
    sections = {part.split("`", 2)[1]: part for part in text.split("### ")[1:]}
    fields = reference.file_fields(kind)
    assert fields
    for path in fields:
        parent, _, name = path.rpartition(".")
        assert f"| `{name}` |" in sections[parent or "the file"], path


def test_a_fields_allowed_values_come_from_the_files_own_checks():
    text = reference.file_reference("config")
    assert r"| `human_speed` | text | `estimated` | estimated \| iso \| estimated_with_floor |" \
        in text
    assert "| `reaction_time` | a number | `0.1` | 0 <= reaction_time <= 5 s |" in text
    assert reference.text_choices("config", ["safety", "stopping"]) == "full_speed | by_speed"
    assert reference.text_choices("scenario", ["name"]) == ""  # any text


def test_the_reference_names_every_option_of_every_command():
    text = reference.command_reference()
    sections = {part.split("`", 2)[1]: part for part in text.split("\n## ")}
    options = reference.command_options()
    assert {"verify --budget", "tune --candidates", "run --mocap", "check --require"} \
        <= set(options)
    for entry in options:
        command, option = entry.split(" ", 1) if " " in entry else ("", entry)
        title = f"safety-systems {command}".strip()
        assert f"`{option}" in sections[title], entry
    assert "(default: 200)" in sections["safety-systems verify"]


def test_every_reference_page_names_a_known_reference_and_every_one_is_on_a_page():
    used = set()
    for page in (ROOT / "docs").rglob("*.md"):
        used |= set(reference.MARK.findall(page.read_text()))
    assert used == set(reference.schemas()) | {"commands"}


NO_MKDOCS = ("MkDocs is not installed here (the docs extra: pip install -e '.[docs]'; CI "
             "installs it)")


@pytest.mark.skipif(importlib.util.find_spec("mkdocs") is None
                    or importlib.util.find_spec("material") is None, reason=NO_MKDOCS)
def test_the_site_builds_with_warnings_as_errors(tmp_path):
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir",
                           str(tmp_path / "site")], cwd=ROOT, capture_output=True, text=True,
                          env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    assert done.returncode == 0, done.stderr[-3000:]
    page = (tmp_path / "site" / "reference" / "configuration" / "index.html").read_text()
    assert "iso_human_speed" in page and "reference: config" not in page
