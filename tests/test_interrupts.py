"""Ctrl-C ends ``verify`` and ``tune`` in every phase, Drake runs included, with exit 130
(``safety_systems.interrupts``): each command started as a terminal would run it (its own
process group, which the SIGINT goes to as a terminal sends it), interrupted once it names
the phase. The time from the signal to the exit is printed (the goal is 2 s); the test
waits at most ``WAIT`` s for it, a bound a loaded machine keeps."""

import os
import queue
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "models"
WAIT = 10.0  # s the test waits for the exit after the SIGINT
START = 900.0  # s it waits for a phase to start (a first run compiles for minutes)
# (the phase, and how long after its line the SIGINT goes: a short phase is interrupted
# on its line, else the signal may come after it)
VERIFY_PHASES = [(1, 0.0), (2, 0.5), (3, 0.5), (4, 0.0)]
TUNE_PHASES = [(1, 0.5), (2, 0.0), (3, 0.0), (4, 0.5), (5, 0.2)]
TUNE_BLOCK = """\
tune:
- {name: safety.robot_uncertainty, min: 0.4, max: 0.7}
- {name: safety.reaction_time, min: 0.1, max: 0.2}
"""


def interrupt_at(argv: list[str], phase: str, delay: float) -> tuple[int, float, list[str]]:
    """Runs ``safety-systems ARGV``, sends SIGINT to its process group ``delay`` s after
    a stderr line holds ``phase``; (exit code, s from the signal to the exit, stderr)."""
    process = subprocess.Popen([sys.executable, "-m", "safety_systems.cli", *argv],
                               cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                               text=True, start_new_session=True)
    lines: queue.Queue = queue.Queue()
    threading.Thread(target=lambda: [lines.put(x) for x in process.stderr] + [lines.put(None)],
                     daemon=True).start()
    seen, deadline = [], time.monotonic() + START
    try:
        while True:
            line = lines.get(timeout=max(0.0, deadline - time.monotonic()))
            if line is None:
                pytest.fail(f"ended (exit {process.wait()}) before {phase!r}: {seen[-3:]}")
            seen.append(line)
            if phase in line:
                break
        time.sleep(delay)
        os.killpg(process.pid, signal.SIGINT)
        sent = time.monotonic()
        code = process.wait(timeout=WAIT)
        took = time.monotonic() - sent
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    while (line := lines.get(timeout=WAIT)) is not None:
        seen.append(line)
    return code, took, seen


def _check(code: int, took: float, err: list[str], command: str, phase: int) -> None:
    landed = [line for line in err if f"{command}: phase " in line][-1]
    said = [line.strip() for line in err if "safety-systems: interrupted" in line]
    print(f"{command}, SIGINT in phase {phase}: exit {code} {took:.2f} s after it "
          f"(its last phase line: {landed.strip()[-90:]!r}; {said[-1:]})")
    text = "".join(err)
    assert code == 130, text[-2000:]
    assert "safety-systems: interrupted" in text and "Traceback" not in text, text[-2000:]


@pytest.mark.slow
@pytest.mark.parametrize("phase, delay", VERIFY_PHASES)
def test_ctrl_c_ends_verify_in_every_phase(phase, delay, tmp_path):
    argv = ["verify", str(MODELS / "configs" / "iso.yaml"), "--space",
            str(MODELS / "spaces" / "default.yaml"), "--out", str(tmp_path / "out"),
            "--workers", "2"]
    code, took, err = interrupt_at(argv, f"verify: phase {phase} of 4", delay)
    _check(code, took, err, "verify", phase)
    if phase == 2:  # the finished simulations are kept: the same command resumes
        assert "the same command resumes it" in "".join(err)


@pytest.mark.slow
@pytest.mark.parametrize("phase, delay", TUNE_PHASES)
def test_ctrl_c_ends_tune_in_every_phase_drake_runs_included(phase, delay, tmp_path):
    """Phases 1, 4 and 5 run the Drake diagram in worker processes (--workers 2), and
    phase 1's verifications replay scenarios in it in the command's own process."""
    (tmp_path / "tune.yaml").write_text(TUNE_BLOCK)
    task = yaml.safe_load((MODELS / "scenarios" / "inspection_seed.yaml").read_text())
    task["duration"], task["robot"]["cycles"] = 25.0, 3
    (tmp_path / "task.yaml").write_text(yaml.safe_dump(task, sort_keys=False))
    argv = ["tune", str(MODELS / "configs" / "iso.yaml"), "--tune", str(tmp_path / "tune.yaml"),
            "--space", str(ROOT / "tests" / "verification" / "small_space.yaml"), "--tasks",
            str(tmp_path / "task.yaml"), "--out", str(tmp_path / "out"), "--budget", "8",
            "--candidates", "1", "--screen", "2", "--workers", "2"]
    code, took, err = interrupt_at(argv, f"tune: phase {phase} of 5", delay)
    _check(code, took, err, "tune", phase)
