import base64
import hashlib
import importlib
import importlib.metadata
import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from safety_systems.cli import build_parser, main
from safety_systems.sensing.stops import STOP_REASONS

INSPECTION = Path(__file__).parents[1] / "models" / "scenarios" / "inspection_seed.yaml"


def test_simulate_writes_every_output(tmp_path, capsys, caplog):
    out = tmp_path / "run"
    argv = ["simulate", str(INSPECTION), "--out", str(out), "--duration", "1.5", "--html",
            "--quiet"]
    assert main(argv) == 0
    # Quiet: not even Drake's line about a Meshcat server nobody connects to; but one
    # line saying that the stopping data is the placeholder.
    err = capsys.readouterr().err + caplog.text
    assert "listening" not in err
    assert err.count("built-in placeholder") == 1 and len(err.strip().splitlines()) == 1
    summary = json.loads((out / "summary.json").read_text())
    for key in ("task_time", "min_separation_while_moving", "contact_while_moving",
                "stopped_time"):
        assert key in summary
    assert summary["duration"] == pytest.approx(1.5)
    assert summary["braking_data"] == "placeholder"
    assert "built-in placeholder" in summary["braking_data_warning"]
    origin = summary["provenance"]
    assert origin["inputs"] == {str(INSPECTION): hashlib.sha256(INSPECTION.read_bytes())
                                .hexdigest()}
    assert origin["command_line"] == shlex.join(["safety-systems", *argv])
    assert origin["seeds"] == {"sensor": 0, "alteration": 0}
    assert origin["drake_version"] == importlib.metadata.version("drake")
    assert origin["safety_systems_version"] == importlib.metadata.version("safety-systems")
    lines = (out / "trace.csv").read_text().splitlines()
    assert len(lines) == 1 + 751  # header + one row per 2 ms tick in [0, 1.5]
    assert lines[0].startswith("time,k,path_rate,robot_speed,stop_reason,S_max")
    reasons = {line.split(",")[4] for line in lines[1:]}
    assert "none" in reasons and reasons <= set(STOP_REASONS)  # by name, not by code
    html = (out / "replay.html").read_text()
    # Meshcat embeds its commands as base64 msgpack: the operator's true segments (the
    # whole body now, not the tracked gloves: the right hand's ball, the trunk's capsule),
    # the capsule of S about its nearest envelope, an animation and the robot.
    commands = b"".join(base64.b64decode(blob) for blob in
                        re.findall(r"base64,([A-Za-z0-9+/=]+)", html))
    for needle in (b"operators/technician/hand_right/a", b"operators/technician/upper_trunk/axis",
                   b"operators/technician/forearm_left/axis", b"protective/technician/axis",
                   b"animation", b"shoulder_link"):
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
    (INSPECTION.read_text().replace("max_speed: 1.8", "max_speed: 4.4"),
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


def test_version(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    assert capsys.readouterr().out.strip() == (
        f"safety-systems {importlib.metadata.version('safety-systems')} "
        f"(Drake {importlib.metadata.version('drake')})")


def _options(parser):
    for action in parser._actions:
        if action.choices and isinstance(action.choices, dict):  # the subcommands
            for sub in action.choices.values():
                yield from _options(sub)
        elif action.option_strings and action.dest not in ("help", "version"):
            yield action


def test_every_option_states_its_default():
    options = list(_options(build_parser()))
    assert len(options) >= 20
    for action in options:
        assert "default" in (action.help or ""), action.option_strings
        if action.default not in (None, False):
            assert str(action.default) in action.help % vars(action), action.option_strings


MODELS = INSPECTION.parents[1]


@pytest.mark.parametrize("argv, work", [
    (["simulate", str(INSPECTION)], "safety_systems.diagrams.simulation.simulate"),
    (["verify", str(MODELS / "configs" / "iso.yaml"), "--space",
      str(MODELS / "spaces" / "default.yaml")], "verification.verify.verify"),
    (["compare", str(INSPECTION), "--controllers", "none"],
     "safety_systems.outputs.compare.compare"),
    (["plan", str(MODELS / "scenes" / "paper.yaml")],
     "safety_systems.outputs.plan_report.write_plan"),
])
def test_an_unwritable_out_is_refused_before_any_work(tmp_path, capsys, monkeypatch, argv,
                                                      work):
    module, name = work.rsplit(".", 1)

    def no_work(*args, **kwargs):
        raise AssertionError(f"{work} ran before --out was checked")

    monkeypatch.setattr(importlib.import_module(module), name, no_work)
    (tmp_path / "file").write_text("x")
    out = tmp_path / "file" / "out"
    assert main([*argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("safety-systems: --out: ") and str(out) in err[-1]
    assert "can be created and written" in err[-1]


@pytest.mark.parametrize("controllers", ["", " , ,"])
def test_compare_refuses_an_empty_controller_list(tmp_path, capsys, controllers):
    code = main(["compare", str(INSPECTION), "--controllers", controllers, "--out",
                 str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "--controllers" in err[0] and "one or more" in err[0]
    assert not (tmp_path / "out").exists()


def test_unreachable_scheduler_fails_with_one_line(tmp_path, capsys, monkeypatch):
    import socket

    from verification.search import runner

    monkeypatch.setattr(runner, "SCHEDULER_TIMEOUT", 1.0)
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    for address in (f"tcp://127.0.0.1:{port}", "nowhere", "http://127.0.0.1:1"):
        code = main(["verify", str(MODELS / "configs" / "iso.yaml"), "--space",
                     str(MODELS / "spaces" / "default.yaml"), "--out", str(tmp_path / "out"),
                     "--scheduler", address])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1, err
        assert err[0].startswith("safety-systems: --scheduler: ") and address in err[0]
        assert not (tmp_path / "out").exists()


def test_check_reads_every_kind_of_file(tmp_path, capsys):
    for kind, folder in (("scenario", "scenarios"), ("config", "configs"),
                         ("space", "spaces")):
        files = sorted(str(p) for p in (MODELS / folder).glob("*.yaml"))
        assert main(["check", kind, *files]) == 0
        assert capsys.readouterr().out.count(": ok") == len(files)
    assert main(["check", "scene", str(MODELS / "scenes" / "paper.yaml")]) == 0
    assert main(["check", "task-path", str(MODELS / "scenes" / "paper_task_path.yaml")]) == 0
    bad = tmp_path / "bad.yaml"
    bad.write_text("points: [[0, 0, 0], [1, 2]]\npoints: []\n")
    assert main(["check", "task-path", str(bad)]) == 2
    assert capsys.readouterr().err.strip() == (
        f"safety-systems: {bad}: points: got \"a second 'points' on line 2\"; allowed: "
        "each key once in a mapping (the first is on line 1)")


def test_simulate_says_the_separation_margin_on_the_console(tmp_path, capsys):
    # The inspection run keeps the separation invariant: the margin is on the line, and
    # the words for a broken invariant are not.
    out = tmp_path / "run"
    assert main(["simulate", str(INSPECTION), "--out", str(out), "--duration", "12"]) == 0
    line = capsys.readouterr().out.strip().splitlines()[-1]
    summary = json.loads((out / "summary.json").read_text())
    margin = summary["min_separation_margin"]
    assert margin > 0.0 and f"min_separation_margin={margin:+.3f} m" in line
    assert "separation invariant broken" not in line


def test_the_console_line_says_when_the_separation_invariant_is_broken():
    from safety_systems.cli import simulate_line

    summary = {"task_time": None, "min_separation_while_moving": 0.9,
               "contact_while_moving": False, "min_separation_margin": -0.136,
               "min_separation_margin_time": 12.34, "stopped_time": 3.766}
    line = simulate_line(summary)
    assert "min_separation_margin=-0.136 m at 12.34 s (the separation invariant broken" in line
    assert "task_time=unfinished" in line and "stopped_time=3.77 s" in line
    assert "min_separation_margin=n/a," in simulate_line({**summary,
                                                         "min_separation_margin": None})
