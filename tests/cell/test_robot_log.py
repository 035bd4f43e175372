"""A robot's own log as its path: a real UR RTDE log is read in either writer's layout,
checked and run as a spline through its samples at its own pace; a log with a gap, a
repeated or decreasing stamp, a joint beyond its limit, in degrees or too fast is refused
in one line naming the file, the row, the field and the value."""

import math
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from safety_systems.cell.joint_path import joint_path_state
from safety_systems.cell.robot_log import check_joint_log, read_rtde_csv
from safety_systems.cell.robot_model import robot_model
from safety_systems.cli import main
from safety_systems.config.configuration import joint_path
from safety_systems.config.scenario import load_scenario
from safety_systems.files.input_error import InputError

REAL = Path(__file__).parents[1] / "data" / "ur_rtde" / "ur3e_rad_moves.csv"
UR5E = robot_model("ur5e")
SCENARIO = """\
name: log
duration: 3.0
robot:
  cycles: {cycles}
  path:
    log: {{file: {file}, repeat: {repeat}}}
operators:
- name: op
  bodies: [{{name: hand}}]
  waypoints: [{{time: 0.0, position: [3.0, 0.0, 1.0]}}]
"""


def _lines() -> list[str]:
    return REAL.read_text().splitlines()


def _cell(lines: list[str], row: int, column: str) -> str:
    """The text of ``column`` in the file's line ``row`` (1: the header)."""
    return lines[row - 1].split(",")[lines[0].split(",").index(column)]


def _scenario(folder: Path, lines: list[str] | None = None, *, repeat: bool = False,
              cycles: int = 1, name: str = "log.csv") -> Path:
    if lines is None:
        shutil.copy(REAL, folder / name)
    else:
        (folder / name).write_text("\n".join(lines) + "\n")
    path = folder / "scenario.yaml"
    path.write_text(SCENARIO.format(file=name, repeat=str(repeat).lower(), cycles=cycles))
    return path


def test_the_real_log_is_read_and_passes_its_checks():
    log = read_rtde_csv(REAL)
    assert log.q.shape == (225, 6) and log.fields[0] == "actual_q_0"
    assert np.median(np.diff(log.times)) == pytest.approx(0.04, abs=1e-6)  # 25 Hz
    assert log.rows[0] == 2 and log.rows[-1] == 226  # the file's line numbers
    check_joint_log(log, lower=UR5E.position_lower, upper=UR5E.position_upper,
                    speed_limit=UR5E.velocity_limit, robot="ur5e", max_gap=0.05)


def test_the_path_runs_through_every_sample_at_the_logs_pace(tmp_path):
    scenario = load_scenario(_scenario(tmp_path))
    path = joint_path(scenario.robot)
    log = read_rtde_csv(REAL)
    s = log.times - log.times[0]
    assert path.cycle_time == pytest.approx(s[-1]) and path.cycles == 1
    q, dq, _ = joint_path_state(path, s)
    assert np.abs(q - log.q).max() < 1e-9
    # At path rate 1 the joints move as logged: the spline's rate between two samples
    # is their mean speed somewhere between them (the mean value theorem).
    mean = np.diff(log.q, axis=0) / np.diff(s)[:, None]
    mid = joint_path_state(path, 0.5 * (s[1:] + s[:-1]))[1]
    assert np.median(np.abs(mid - mean)) < 0.01 * np.abs(mean).max()
    # The path stays at its last sample after it (one pass).
    assert np.abs(joint_path_state(path, s[-1] + 5.0)[0] - log.q[-1]).max() < 1e-9


def test_record_py_space_layout_gives_the_same_log(tmp_path):
    rows = [x.split(",") for x in _lines()]
    header = rows[0]
    keep = ["timestamp"] + [f"actual_q_{j}" for j in range(6)] + ["joint_temperatures_0"]
    cols = [header.index(k) for k in keep]
    (tmp_path / "s.csv").write_text("\n".join(" ".join(r[c] for c in cols) for r in rows)
                                    + "\n")
    a, b = read_rtde_csv(REAL), read_rtde_csv(tmp_path / "s.csv")
    assert np.array_equal(a.times, b.times) and np.array_equal(a.q, b.q)


def _edit(row: int, column: str, value: str) -> list[str]:
    lines = _lines()
    header = lines[0].split(",")
    cells = lines[row - 1].split(",")
    cells[header.index(column)] = value
    lines[row - 1] = ",".join(cells)
    return lines


def _refusal(tmp_path, lines, capsys) -> str:
    path = _scenario(tmp_path, lines)
    with pytest.raises(InputError) as e:
        load_scenario(path)
    line = str(e.value)
    assert main(["check", "scenario", str(path)]) == 2  # the files' rules: exit 2 ...
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "log.csv" in err  # ... and one line naming the log
    return line


def test_a_gap_is_refused_in_one_line(tmp_path, capsys):
    lines = _lines()
    after, before = _cell(lines, 106, "timestamp"), _cell(lines, 100, "timestamp")
    del lines[100:105]  # 5 samples, 0.2 s, lost
    line = _refusal(tmp_path, lines, capsys)
    assert after == "1550308.69" and before == "1550308.45"
    assert "log.csv: row 101: timestamp: got 1550308.69; allowed: within max_gap 0.05 s of " \
        "the previous sample's (1550308.45 s); a gap of 0.24 s is samples lost" in line


def test_a_repeated_stamp_is_refused_in_one_line(tmp_path, capsys):
    previous = _cell(_lines(), 100, "timestamp")
    line = _refusal(tmp_path, _edit(101, "timestamp", previous), capsys)
    assert f"row 101: timestamp: got {float(previous)!r}" in line
    assert "a repeated or decreasing stamp" in line


def test_a_decreasing_stamp_is_refused_in_one_line(tmp_path, capsys):
    line = _refusal(tmp_path, _edit(200, "timestamp", "1550300.0"), capsys)
    assert "row 200: timestamp: got 1550300.0" in line and "later than the previous" in line


def test_a_joint_beyond_its_limit_is_refused_in_one_line(tmp_path, capsys):
    line = _refusal(tmp_path, _edit(150, "actual_q_5", "6.5"), capsys)
    assert "row 150: actual_q_5: got 6.5" in line and "ur5e's joint limits" in line
    assert "whole turn" not in line  # one sample out of line, not a turned wrist


def test_a_wrist_that_has_turned_whole_turns_is_refused_and_told_so(tmp_path, capsys,
                                                                    monkeypatch):
    """The real log as recorded upstream (wrist 3 two whole turns on, 12.57 to 12.63 rad:
    tests/data/ur_rtde/README.md) is refused, with the line robot-logs.md shows."""
    lines = _lines()
    header = lines[0].split(",")
    for k in range(1, len(lines)):
        cells = lines[k].split(",")
        for c in (header.index("actual_q_5"), header.index("target_q_5")):
            cells[c] = repr(float(cells[c]) + 4 * math.pi)
        lines[k] = ",".join(cells)
    assert _cell(lines, 2, "actual_q_5") == "12.6283422"  # the source's own text
    monkeypatch.chdir(tmp_path)
    Path("ur3e_as_recorded.csv").write_text("\n".join(lines) + "\n")
    assert main(["check", "robot-log", "ur3e_as_recorded.csv"]) == 2
    err = capsys.readouterr().err.strip()
    page = (Path(__file__).parents[2] / "docs" / "how-to" / "robot-logs.md").read_text()
    shown = re.search(r"^safety-systems: ur3e_as_recorded.csv: .*$", page, flags=re.MULTILINE)
    assert err == shown[0]
    assert "2 whole turns from 0.06197 rad" in err


def test_a_log_in_degrees_is_refused_in_one_line(tmp_path, capsys):
    lines = _lines()
    header = lines[0].split(",")
    cols = [header.index(f"actual_q_{j}") for j in range(6)]
    out = [lines[0]]
    for text in lines[1:]:
        cells = text.split(",")
        for c in cols:
            cells[c] = repr(math.degrees(float(cells[c])))
        out.append(",".join(cells))
    line = _refusal(tmp_path, out, capsys)
    assert "row 2: actual_q_0: got -122.06" in line and "a log in degrees" in line
    assert "whole turn" not in line


def test_a_joint_faster_than_its_limit_is_refused_in_one_line(tmp_path, capsys):
    q = float(_cell(_lines(), 150, "actual_q_3"))
    line = _refusal(tmp_path, _edit(151, "actual_q_3", repr(q + 0.2)), capsys)  # 5 rad/s
    assert "row 151: actual_q_3" in line and "joint speed limit (180 deg/s" in line


def _sudden_start(speed_deg: float, samples: int) -> list[str]:
    """The real log with its base joint held still to row 102 and then turned at
    ``speed_deg`` deg/s for ``samples`` spacings (40 ms), held again after."""
    lines = _lines()
    header = lines[0].split(",")
    c = header.index("actual_q_0")
    t = [float(x.split(",")[0]) for x in lines[1:]]
    q0 = float(lines[1].split(",")[c])
    for k in range(1, len(lines)):
        cells = lines[k].split(",")
        turned = min(max(t[k - 1] - t[100], 0.0), samples * 0.04)
        cells[c] = repr(q0 + turned * math.radians(speed_deg))
        lines[k] = ",".join(cells)
    return lines


def test_a_path_faster_than_its_samples_and_the_limit_is_refused_in_one_line(tmp_path,
                                                                           capsys):
    """Samples at 177.6 deg/s keep within the UR5e's 180, but the spline through them,
    which the robot runs, overshoots at the sudden start to 208.1 deg/s: refused."""
    lines = _sudden_start(177.6, 3)
    (tmp_path / "fast.csv").write_text("\n".join(lines) + "\n")
    log = read_rtde_csv(tmp_path / "fast.csv")
    steps = np.abs(np.diff(log.q[:, 0])) / np.diff(log.times)
    assert math.degrees(steps.max()) == pytest.approx(177.6, abs=0.01)
    check_joint_log(log, lower=UR5E.position_lower, upper=UR5E.position_upper,
                    speed_limit=UR5E.velocity_limit, robot="ur5e", max_gap=0.05)
    line = _refusal(tmp_path, lines, capsys)
    assert f"log.csv: row 103: actual_q_0: got {float(log.q[101, 0])!r}; allowed: a path the " \
        "robot runs within the ur5e's joint speed limit (180 deg/s): the spline through " \
        "the samples peaks at 208.1 deg/s between the previous sample and this one" in line
    assert main(["check", "robot-log", str(tmp_path / "fast.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "row 103: actual_q_0" in err and "208.1 deg/s" in err
    # Slower, the same start keeps its spline within the limit (peak 152 deg/s).
    _scenario(tmp_path, _sudden_start(130.0, 3))
    assert main(["check", "scenario", str(tmp_path / "scenario.yaml")]) == 0


def test_a_log_without_joint_columns_or_with_a_bad_number_is_one_line(tmp_path, capsys):
    lines = _lines()
    lines[0] = lines[0].replace("actual_q_2", "actual_qd_2")
    assert "<header>: got 'actual_q_2'" in _refusal(tmp_path, lines, capsys)
    line = _refusal(tmp_path, _edit(10, "actual_q_1", "nan?"), capsys)
    assert "row 10: actual_q_1: got 'nan?'" in line


def test_a_log_repeats_only_when_it_ends_where_it_starts(tmp_path, capsys):
    path = _scenario(tmp_path, repeat=True, cycles=2)
    with pytest.raises(InputError, match="path.log.repeat: got True; allowed: a log that ends "
                                         "where it starts"):
        load_scenario(path)
    # The log out and back (the way back: the same samples in reverse, later stamps)
    # ends where it starts, and repeats as a periodic path.
    lines = _lines()
    t = [float(x.split(",")[0]) for x in lines[1:]]
    back = [",".join([repr(2 * t[-1] - t[k] + 0.04)] + lines[1 + k].split(",")[1:])
            for k in range(len(t) - 1, -1, -1)]
    scenario = load_scenario(_scenario(tmp_path, lines + back, repeat=True, cycles=2))
    path = joint_path(scenario.robot)
    assert path.cycles == 2
    s = np.linspace(0.0, path.cycle_time, 7)
    q0, dq0, _ = joint_path_state(path, s)
    q1, dq1, _ = joint_path_state(path, s + path.cycle_time)
    assert np.abs(q0[:-1] - q1[:-1]).max() < 1e-9 and np.abs(dq0[:-1] - dq1[:-1]).max() < 1e-9


def test_check_reads_a_robot_log_and_refuses_a_bad_one_in_one_line(tmp_path, capsys):
    assert main(["check", "robot-log", str(REAL)]) == 0
    assert capsys.readouterr().out.strip() == f"{REAL}: ok"
    lines = _lines()
    del lines[100:105]
    (tmp_path / "gap.csv").write_text("\n".join(lines) + "\n")
    assert main(["check", "robot-log", str(tmp_path / "gap.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "gap.csv: row 101: timestamp" in err


def test_the_refusal_the_how_to_page_shows_is_the_one_its_command_gives(tmp_path, capsys,
                                                                        monkeypatch):
    """docs/how-to/robot-logs.md cuts samples out of the real log with ``sed`` and shows
    the line ``check robot-log`` refuses it with: the same cut, the same line."""
    page = (Path(__file__).parents[2] / "docs" / "how-to" / "robot-logs.md").read_text()
    cut = re.search(r"^sed '(\d+),(\d+)d' tests/data/ur_rtde/ur3e_rad_moves.csv > "
                    r"(\S+)\n(safety-systems check robot-log \3)$", page, flags=re.MULTILINE)
    shown = re.search(r"^safety-systems: " + re.escape(cut[3]) + ": row .*$", page,
                      flags=re.MULTILINE)
    lines = _lines()
    del lines[int(cut[1]) - 1:int(cut[2])]  # sed's line numbers count from 1, inclusive
    monkeypatch.chdir(tmp_path)
    Path(cut[3]).write_text("\n".join(lines) + "\n")
    assert main(cut[4].split()[1:]) == 2
    assert capsys.readouterr().err.strip() == shown[0]


def test_a_stop_near_a_one_pass_logs_end_rests_there(tmp_path):
    """braking.tool_stopping_distance on a log run once: a stop that runs past the last
    sample rests there (as the robot does), it does not jump back to the first sample's
    pose (the real log ends 0.4 m of tool travel from where it starts)."""
    from safety_systems.cell.braking import tool_stopping_distance
    from safety_systems.cell.model_points import tool0_position
    from safety_systems.cell.placeholder_stops import placeholder_braking_table

    ur3e = robot_model("ur3e")
    path = joint_path(load_scenario(_scenario(tmp_path)).robot)
    tool = tool0_position(ur3e)
    jump = np.linalg.norm(tool(read_rtde_csv(REAL).q[-1]) - tool(read_rtde_csv(REAL).q[0]))
    got = tool_stopping_distance(path, placeholder_braking_table("ur3e"), tool_position=tool)
    assert jump > 0.3 and 0.0 < got < 0.1 * jump


def test_the_worked_cells_log_is_the_tests_real_log():
    """models/robot_logs/ holds the real log of tests/data/ur_rtde/ byte for byte, with its
    licence, for models/scenarios/robot_log_example.yaml."""
    models = Path(__file__).parents[2] / "models" / "robot_logs"
    for name in ("ur3e_rad_moves.csv", "ur3e_rad_moves.LICENSE"):
        assert (models / name).read_bytes() == (REAL.parent / name).read_bytes()
    scenario = load_scenario(Path(__file__).parents[2] / "models" / "scenarios"
                             / "robot_log_example.yaml")
    assert scenario.robot.model == "ur3e"
    assert Path(scenario.robot.path.log.file).resolve() == (models / REAL.name).resolve()
