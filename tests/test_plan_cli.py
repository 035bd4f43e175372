"""``safety-systems plan``: its files, a sweep, and bad input (exit 2, one line)."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

from safety_systems.cli import main
from safety_systems.planning.path_metrics import min_clearance
from safety_systems.config.scenario import TaskPoints, load_typed
from safety_systems.planning.task_space import load_scene, obstacle_set

PAPER = Path(__file__).parents[1] / "models" / "scenes" / "paper.yaml"
FAST = "\n  rrt_time: 5.0\n  rrt_max_iterations: 300\n"  # appended to the planner: mapping


def _fast_scene(tmp_path, text=None) -> Path:
    path = tmp_path / "scene.yaml"
    path.write_text((text or PAPER.read_text()).rstrip() + FAST)
    return path


def test_plan_writes_every_file(tmp_path):
    out = tmp_path / "plan"
    assert main(["plan", str(_fast_scene(tmp_path)), "--out", str(out), "--quiet"]) == 0
    paths = json.loads((out / "paths.json").read_text())
    assert set(paths) == {"IAPF", "IAPF+opt", "GDA", "RRT*"}
    report = json.loads((out / "plan.json").read_text())
    rows = {r["planner"]: r for r in report["rows"]}
    for name in ("IAPF", "IAPF+opt", "RRT*"):
        assert rows[name]["reached_goal"] and rows[name]["min_clearance"] >= 0.02
        for key in ("time_to_goal", "length", "bending_energy", "planning_time"):
            assert rows[name][key] > 0.0
    assert "| IAPF+opt | yes |" in (out / "plan.md").read_text()
    assert (out / "plan.png").stat().st_size > 20_000
    task = load_typed(TaskPoints, out / "task_path.yaml")
    points = np.array(task.points)
    np.testing.assert_allclose(points, np.array(paths["IAPF+opt"]["points"]))
    scene = load_scene(PAPER)
    np.testing.assert_allclose(points[[0, -1]], [scene.start, scene.goal])
    assert min_clearance(points, obstacle_set(scene.obstacles)) >= scene.planner.clearance


def test_plan_sweep_writes_one_row_per_setting(tmp_path):
    out = tmp_path / "sweep"
    assert main(["plan", str(_fast_scene(tmp_path)), "--out", str(out), "--sweep", "zeta",
                 "--quiet"]) == 0
    sweep = json.loads((out / "plan.json").read_text())["sweep"]
    assert sweep["name"] == "zeta"
    assert [s["setting"] for s in sweep["settings"]] == ["zeta 4 cm", "zeta 5 cm", "zeta 6 cm"]
    clearances = [next(r for r in s["rows"] if r["planner"] == "IAPF")["min_clearance"]
                  for s in sweep["settings"]]
    assert clearances == sorted(clearances)  # a larger threshold keeps the IAPF further out
    table = (out / "plan.md").read_text().split("## Sweep: zeta")[1]
    assert sum(line.startswith("| zeta ") for line in table.splitlines()) == 3


@pytest.mark.parametrize("text, args, needle", [
    ("start: [0.1, 0.7, 0.15]\ngoal: [0.7, 0.3, 0.05]\nplanner: {zeta: 0.01}\n", [],
     "planner.clearance"),
    ("start: [0.1, 0.7, 0.15]\ngoal: [0.95, 0.3, 0.05]\n", [], "goal"),
    ("start: [0.1, 0.7, 0.15]\ngoal: [0.7, 0.3, 0.05]\nobstacles: {walls: []}\n", [],
     "obstacles.walls"),
    (None, ["--sweep", "colour"], "--sweep"),
    ("start: [0.1, 0.7, 0.15]\ngoal: [0.7, 0.3, 0.05]\n", ["--sweep", "height"], "--sweep"),
])
def test_bad_input_exits_2_with_one_line(tmp_path, capsys, text, args, needle):
    scene = tmp_path / "bad.yaml"
    scene.write_text(text if text is not None else PAPER.read_text())
    out = tmp_path / "out"
    assert main(["plan", str(scene), "--out", str(out), *args]) == 2
    err = capsys.readouterr().err.strip()
    # A file's error names the file first; an option's names the option.
    assert re.match(rf"safety-systems: ({re.escape(str(scene))}: )?{re.escape(needle)}",
                    err) and "\n" not in err
    assert not (out / "task_path.yaml").exists()


def test_missing_scene_exits_2(tmp_path, capsys):
    assert main(["plan", str(tmp_path / "none.yaml"), "--out", str(tmp_path / "o")]) == 2
    assert "path" in capsys.readouterr().err
