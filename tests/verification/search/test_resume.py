"""``verify`` killed at any point and run again with the same folder ends with the report
an uninterrupted run writes."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from verification.search.runner import FIELDS, EvaluationCache

MODELS = Path(__file__).parents[3] / "models"
# The previous configuration on approaches to the elbow by operators in suits: a run that
# falsifies, so that every stage (evaluating, confirming, reporting) happens.
ARGS = [str(MODELS / "configs" / "iso_previous.yaml"), "--space",
        str(MODELS / "spaces" / "elbow_approach.yaml"), "--budget", "48", "--method", "sobol",
        "--workers", "1", "--quiet"]


def _verify(out: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "safety_systems.cli", "verify", *ARGS,
                             "--out", str(out)], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)


def _lines(out: Path) -> int:
    try:
        return (out / "evaluations.jsonl").read_bytes().count(b"\n")
    except FileNotFoundError:
        return 0


def _kill_when(out: Path, ready) -> bool:
    """Starts verify, SIGKILLs it as soon as ``ready(out)`` holds; True if it was still
    running then (False: it finished first)."""
    process = _verify(out)
    try:
        while process.poll() is None and not ready(out):
            time.sleep(0.005)
        if process.poll() is not None:
            return False
        process.send_signal(signal.SIGKILL)
        process.wait()
        return True
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()


def _comparable(out: Path) -> dict:
    """The report but what depends on how the run went rather than what it found: its
    provenance, and the evaluations and seconds it spent (a resumed run reads finished
    simulations from its cache)."""
    report = json.loads((out / "report.json").read_text())
    provenance = report.pop("provenance")
    for key in ("evaluations", "cpu_seconds", "wall_seconds"):
        report.pop(key)
    for p in report["properties"].values():
        p.pop("first_counterexample")
    text = json.dumps(report).replace(str(out), "OUT")
    return {"report": json.loads(text), "inputs": provenance["inputs"]}


def test_verify_survives_being_killed_at_any_point(tmp_path):
    reference = tmp_path / "reference"
    assert _verify(reference).wait() == 1  # falsified
    expected = _comparable(reference)
    assert expected["report"]["properties"]["separation"]["counterexamples"]

    out = tmp_path / "resumed"
    start = time.monotonic()
    kills = [
        _kill_when(out, lambda o: time.monotonic() - start > 0.3),  # while starting up
        _kill_when(out, lambda o: _lines(o) >= 1),  # while evaluating
        _kill_when(out, lambda o: (o / "counterexamples").exists()),  # while confirming
        _kill_when(out, lambda o: (o / "report.json").exists()),  # while reporting
    ]
    assert sum(kills) >= 2, kills  # at least two of them landed mid-run
    # A kill in the middle of a line: the file cut short inside its last line.
    data = (out / "evaluations.jsonl").read_bytes()
    if data:
        (out / "evaluations.jsonl").write_bytes(data[:-7])
    process = _verify(out)
    assert process.wait() == 1
    assert _comparable(out) == expected
    lines = (out / "evaluations.jsonl").read_text().splitlines()
    keys = [json.loads(line)["key"] for line in lines]
    assert len(keys) == len(set(keys))  # nothing evaluated twice, nothing cut short
    assert not list(out.glob(".*.part"))  # no temporary file left behind
    markdown = (out / "report.md").read_text()
    assert markdown.startswith(f"# Verification: {expected['report']['verdict'].upper()}")


def test_cache_drops_a_line_cut_short_and_appends_on_a_new_line(tmp_path):
    path = tmp_path / "evaluations.jsonl"
    figures = [0.5, 1.0] + [0.0] * (len(FIELDS) - 2)
    row = {"key": "a", "figures": figures}
    path.write_text(json.dumps(row) + "\n" + '{"key": "b", "figures": [0.1, 0.')
    cache = EvaluationCache(path)
    assert cache.values == {"a": figures}
    cache.add("c", np.arange(len(FIELDS), dtype=float))
    again = EvaluationCache(path)
    assert set(again.values) == {"a", "c"}
    assert path.read_text().count("\n") == 2


def test_cache_skips_rows_that_are_not_figures(tmp_path):
    path = tmp_path / "evaluations.jsonl"
    full = list(range(1, len(FIELDS) + 1))
    short = full[:-1]  # a row of an older version's figures (one field fewer)
    path.write_text("\n".join([json.dumps({"key": "a", "figures": full}), "[]", '{"key": 3}',
                               '{"key": "b", "figures": [1, 2]}',
                               json.dumps({"key": "c", "figures": ["x"] + full[1:]}),
                               json.dumps({"key": "d", "figures": short}),
                               "garbage"]) + "\n")
    assert EvaluationCache(path).values == {"a": [float(x) for x in full]}
    os.remove(path)
    assert EvaluationCache(path).values == {}
