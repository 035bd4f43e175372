import base64
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from safety_systems.cli import main

INSPECTION = Path(__file__).parents[1] / "models" / "scenarios" / "inspection.yaml"


def test_simulate_writes_every_output(tmp_path, capsys, caplog):
    out = tmp_path / "run"
    assert main(["simulate", str(INSPECTION), "--out", str(out), "--duration", "1.5",
                 "--html", "--quiet"]) == 0
    # Quiet: not even Drake's line about a Meshcat server nobody connects to.
    assert "listening" not in capsys.readouterr().err + caplog.text
    summary = json.loads((out / "summary.json").read_text())
    for key in ("task_time", "min_separation_while_moving", "contact_while_moving",
                "stopped_time"):
        assert key in summary
    assert summary["duration"] == pytest.approx(1.5)
    lines = (out / "trace.csv").read_text().splitlines()
    assert len(lines) == 1 + 751  # header + one row per 2 ms tick in [0, 1.5]
    assert lines[0].startswith("time,k,path_rate,robot_speed")
    html = (out / "replay.html").read_text()
    # Meshcat embeds its commands as base64 msgpack: the bodies, S spheres and an animation.
    commands = b"".join(base64.b64decode(blob) for blob in
                        re.findall(r"base64,([A-Za-z0-9+/=]+)", html))
    for needle in (b"technician/right_glove/body", b"technician/left_glove/S", b"animation",
                   b"shoulder_link"):
        assert needle in commands
    assert not re.search(r"""src=["']https?://""", html)  # self-contained: nothing fetched
    assert (out / "plot.png").stat().st_size > 10_000


def _bad(tmp_path, text):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    return subprocess.run(
        [sys.executable, "-m", "safety_systems.cli", "simulate", str(path), "--out",
         str(tmp_path / "out")], capture_output=True, text=True)


@pytest.mark.parametrize("text, field", [
    ("robot: {mode: warp}\n", "robot.mode"),
    ("duration: -3\n", "duration"),
    ("speeed: 3\n", "speeed"),
    (INSPECTION.read_text().replace("max_speed: 1.8", "max_speed: 2.4"),
     "operators[0].max_speed"),
    (INSPECTION.read_text().replace("{time: 20.0,", "{time: 8.5,"), "operators[0].waypoints"),
])
def test_bad_input_exits_2_with_one_line(tmp_path, text, field):
    result = _bad(tmp_path, text)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert field in lines[0] and "allowed" in lines[0]
    assert not (tmp_path / "out").exists()


def test_missing_file_exits_2(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "safety_systems.cli", "simulate", str(tmp_path / "none.yaml"),
         "--out", str(tmp_path / "out")], capture_output=True, text=True)
    assert result.returncode == 2
    assert "none.yaml" in result.stderr and len(result.stderr.strip().splitlines()) == 1
