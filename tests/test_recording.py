"""Recorded motion: Motive CSV and C3D read, mapped onto the cell and replayed through the
diagram with true positions equal to the file's; bad files are one line."""

import dataclasses
import json
from pathlib import Path

import ezc3d
import numpy as np
import pytest

from safety_systems.cli import main
from safety_systems.files.input_error import InputError
from safety_systems.sensing.motive_csv import motive_csv_text, read_motive_csv
from safety_systems.sensing.c3d_file import read_c3d
from safety_systems.sensing.recording_mapping import load_mapping, rotation_matrix, to_cell
from safety_systems.config.scenario import load_scenario, operator_points
from safety_systems.diagrams.simulation import simulate
from safety_systems.diagrams.workcell import MakeWorkcell
from verification.search.evaluate_batch import evaluate_batch, evaluate_many
from verification.search.evaluate_drake import evaluate_drake

RECORDINGS = Path(__file__).parents[1] / "models" / "recordings"
RATE = 100.0  # Hz: a sample every 5 control ticks

MAPPING = """\
capture_to_cell:
  up_axis: {up}
  rpy_deg: [0.0, 0.0, 30.0]
  translation: [0.4, -0.2, 0.1]
operators:
- name: tester
  bodies:
  - {{recorded: {a}, name: right_glove, streaming_id: {ida}}}
  - {{recorded: {b}, name: helmet, point: head}}
"""

SCENARIO = """\
name: replay
duration: 2.0
robot: {{cycles: 1}}
controller: {{sensor: {{noise_std: 0.0}}}}
operators:
- {{recording: {recording}, mapping: map.yaml, start: {start}}}
"""


def _samples(T: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(times, positions (T, 2, 3) in a Y-up capture frame, m) of two bodies walking."""
    rng = np.random.default_rng(seed)
    t = np.arange(T) / RATE
    start = np.array([[2.0, 0.3, 0.5], [2.2, 1.5, 0.4]])  # x, y (up), z
    p = start + np.outer(t, [-0.4, 0.0, 0.1])[:, None] + rng.normal(scale=0.002, size=(T, 2, 3))
    return t, p


def _write_motive(folder: Path, units: str, rotation: str, gap=(60, 70)) -> tuple:
    t, p = _samples(251)
    p[gap[0]:gap[1], 0] = np.nan  # the glove untracked for 0.1 s
    q = np.tile([0.0, 0.0, 0.0, 1.0], (len(t), 2, 1))
    (folder / "rec.csv").write_text(motive_csv_text(t, ["Glove", "Helmet"], [7, 9], p, q,
                                                    rate_hz=RATE, units=units,
                                                    rotation_type=rotation))
    (folder / "map.yaml").write_text(MAPPING.format(up="y", a="Glove", b="Helmet", ida=7))
    return t, p


def _write_c3d(folder: Path) -> tuple:
    t, p = _samples(251, seed=1)
    p[100:104, 1] = np.nan
    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = [RATE]
    c["parameters"]["POINT"]["LABELS"]["value"] = ("glove", "helmet")
    c["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    points = np.ones((4, 2, len(t)))
    points[:3] = np.transpose(p * 1000.0, (2, 1, 0))
    c["data"]["points"] = points
    c.write(str(folder / "rec.c3d"))
    (folder / "map.yaml").write_text(MAPPING.format(up="z", a="glove", b="helmet", ida=0))
    return t, p


@pytest.mark.parametrize("units, rotation", [("Meters", "Quaternion"),
                                             ("Millimeters", "XYZ"), ("Centimeters", "ZYX")])
def test_motive_csv_is_read_in_its_units_and_rotation_type(tmp_path, units, rotation):
    t, p = _write_motive(tmp_path, units, rotation)
    rec = read_motive_csv(tmp_path / "rec.csv")
    assert rec.names == ("Glove", "Helmet") and rec.ids == (7, 9)
    assert rec.rate_hz == pytest.approx(RATE)
    np.testing.assert_allclose(rec.times, t, atol=1e-6)
    np.testing.assert_allclose(rec.positions, p, atol=1e-6, equal_nan=True)
    assert np.isnan(rec.positions[60:70, 0]).all() and np.isfinite(rec.positions[:60]).all()
    np.testing.assert_allclose(np.abs(rec.rotations[:, 1, 3]), 1.0, atol=1e-6)


def test_c3d_is_read_with_its_units_and_invalid_points(tmp_path):
    _, p = _write_c3d(tmp_path)
    rec = read_c3d(tmp_path / "rec.c3d")
    assert rec.names == ("glove", "helmet") and rec.ids == (0, 0)
    np.testing.assert_allclose(rec.positions, p, atol=1e-6, equal_nan=True)
    assert np.isnan(rec.rotations).all()


def test_motive_y_up_is_turned_to_the_cells_z_up(tmp_path):
    (tmp_path / "map.yaml").write_text(MAPPING.format(up="y", a="A", b="B", ida=0))
    c = load_mapping(tmp_path / "map.yaml").capture_to_cell
    c.rpy_deg, c.translation = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
    np.testing.assert_allclose(to_cell(c, [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
                               [[0.0, 0.0, 1.0], [0.0, -1.0, 0.0]], atol=1e-15)
    assert np.linalg.det(rotation_matrix(c)) == pytest.approx(1.0)


def _truth_at_samples(tmp_path, recording: str, start: float, t, p):
    """The replayed scenario's true positions at the control ticks that fall on samples,
    and the file's positions there after the mapping's transform."""
    (tmp_path / "s.yaml").write_text(SCENARIO.format(recording=recording, start=start))
    scenario = load_scenario(tmp_path / "s.yaml")
    # The bodies and the points they mark come from the mapping (right_glove by its
    # legacy name, the helmet by its point).
    assert [b.name for b in scenario.operators[0].bodies] == ["right_glove", "helmet"]
    assert operator_points(scenario.operators[0]) == ["hand_right", "head"]
    run = simulate(scenario)
    c = load_mapping(tmp_path / "map.yaml").capture_to_cell
    tau = start + run.time
    on_sample = np.isclose(tau * RATE, np.round(tau * RATE), atol=1e-6) & (tau <= t[-1])
    index = np.round(tau[on_sample] * RATE).astype(int)
    expected = to_cell(c, p[index])
    return run, on_sample, expected


@pytest.mark.parametrize("kind", ["csv", "c3d"])
def test_a_recording_replays_in_the_diagram_with_the_files_positions(tmp_path, kind):
    t, p = (_write_motive(tmp_path, "Millimeters", "Quaternion") if kind == "csv"
            else _write_c3d(tmp_path))
    run, on_sample, expected = _truth_at_samples(tmp_path, f"rec.{kind}", 0.3, t, p)
    truth = run.bodies("operators.positions_true")[on_sample]
    present = run["operators.present"][on_sample] > 0.5
    tracked = np.all(np.isfinite(expected), axis=2)
    assert present.all() and tracked.sum() > 300
    # Within float precision: the file's numbers as read, through the one transform.
    file_values = to_cell(load_mapping(tmp_path / "map.yaml").capture_to_cell,
                          (read_motive_csv if kind == "csv" else read_c3d)(
                              tmp_path / f"rec.{kind}").positions)
    index = np.round((0.3 + run.time[on_sample]) * RATE).astype(int)
    np.testing.assert_allclose(truth[tracked], file_values[index][tracked], rtol=0,
                               atol=1e-12)
    # Where the file has no sample the sensor does not see the body: the tracker hides it.
    status = run["tracker.track_status"]
    gap = ((60, 70) if kind == "csv" else (100, 104))
    body = 0 if kind == "csv" else 1
    inside = (run.time + 0.3 > gap[0] / RATE + 0.1) & (run.time + 0.3 < gap[1] / RATE - 0.01)
    if inside.any():
        assert np.all(status[inside, body] != 1)  # never "tracking" in the gap


def test_the_shipped_recording_replays_and_runs_in_drake_in_evaluate_many():
    scenario = load_scenario(RECORDINGS / "approach.yaml")
    short = dataclasses.replace(scenario, duration=3.0)
    with pytest.raises(ValueError, match="recorded operators in the Drake diagram"):
        evaluate_batch([short])
    many = evaluate_many([short])
    drake, _ = evaluate_drake(short)
    assert many.robustness[0] == pytest.approx(drake.stopped_before_contact)
    assert many.separation[0] == pytest.approx(drake.separation)
    names = MakeWorkcell(short).body_names
    assert names == ["technician/right_glove", "technician/left_glove", "technician/head"]


@pytest.mark.parametrize("text, field", [
    ("Format Version,1.23,Rotation Type,Euler,Length Units,Meters\n", "Rotation Type"),
    ("Format Version,1.23,Rotation Type,Quaternion,Length Units,Inches\n", "Length Units"),
    ("Frame,Time\n0,0\n", "line 1"),
    ("Format Version,1.23,Rotation Type,Quaternion,Length Units,Meters\n\n,Name,A\n",
     "header row"),
    # an export of another format version: its version and the versions read, named
    ("Format Version,1.1,Take Name,t,Rotation Type,Quaternion,Length Units,Meters\n",
     "Motive CSV: Format Version: got '1.1'; allowed: 1.2, 1.21, 1.22, 1.23, 1.24, 1.25"),
    ("info,version,1.1\ninfo,framecount,2\nframe,0,0.0\n",
     "Format Version 1.2, 1.21, 1.22, 1.23, 1.24, 1.25 (it begins with 'Format Version'); "
     "this file says version 1.1"),
])
def test_a_bad_motive_file_is_one_line(tmp_path, text, field):
    (tmp_path / "bad.csv").write_text(text)
    with pytest.raises(InputError) as e:
        read_motive_csv(tmp_path / "bad.csv")
    assert field in str(e.value) and str(tmp_path / "bad.csv") in str(e.value)
    assert "\n" not in str(e.value)


def test_a_bad_number_or_mapping_gives_exit_2_and_one_line(tmp_path, capsys):
    _write_motive(tmp_path, "Meters", "Quaternion")
    text = (tmp_path / "rec.csv").read_text().splitlines()
    cells = text[20].split(",")
    cells[7] = "abc"
    text[20] = ",".join(cells)
    (tmp_path / "rec.csv").write_text("\n".join(text) + "\n")
    (tmp_path / "s.yaml").write_text(SCENARIO.format(recording="rec.csv", start=0.0))
    assert main(["simulate", str(tmp_path / "s.yaml"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    # the recording's own line (as `check mapping` gives it), naming its file and format
    assert len(err.splitlines()) == 1 and "abc" in err and "rec.csv: Motive CSV" in err
    _write_motive(tmp_path, "Meters", "Quaternion")
    (tmp_path / "map.yaml").write_text(MAPPING.format(up="x", a="Glove", b="Helmet", ida=7))
    assert main(["simulate", str(tmp_path / "s.yaml"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "up_axis" in err and "y | z" in err
    (tmp_path / "map.yaml").write_text(MAPPING.format(up="y", a="Glove", b="Helmet", ida=8))
    assert main(["simulate", str(tmp_path / "s.yaml"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert "streaming_id" in err and "(7)" in err
    # A body whose name is not a legacy one must name its point; two cannot mark one; a
    # mapping in the former format (a radius per body) is refused at the radius.
    for mapping, field in (
            (MAPPING.replace("name: helmet, point: head", "name: helmet"), ".bodies[1].point"),
            (MAPPING.replace("point: head", "point: hand_right"), ".bodies[1].point"),
            (MAPPING.replace("point: head", "radius: 0.12"), ".bodies[1].radius")):
        (tmp_path / "map.yaml").write_text(mapping.format(up="y", a="Glove", b="Helmet",
                                                          ida=7))
        assert main(["simulate", str(tmp_path / "s.yaml"), "--out", str(tmp_path / "o")]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and f"operators[0]{field}" in err, err
        assert "allowed" in err


def test_a_replay_names_each_body_whose_pivot_the_mapping_leaves_unknown(tmp_path, capsys):
    """A rigid body reported at its markers' centroid is taken for the point it marks; the
    replay says so in one line per body, naming it and the pivot offset a proof's tracking
    allowance must then cover (sensing.pivots.PIVOT_BOUNDS), and summary.json keeps the
    lines (issue 46). A mapping that places its bodies gets none."""
    _write_motive(tmp_path, "Meters", "Quaternion")
    (tmp_path / "s.yaml").write_text(SCENARIO.format(recording="rec.csv", start=0.0))
    assert main(["simulate", str(tmp_path / "s.yaml"), "--out", str(tmp_path / "o"),
                 "--quiet"]) == 0
    warned = [line.removeprefix("safety-systems: warning: ")
              for line in capsys.readouterr().err.splitlines() if ".pivot" in line]
    assert len(warned) == 2
    assert "bodies[0].pivot: tester's Glove (marking the hand_right)" in warned[0]
    assert "bodies[1].pivot: tester's Helmet (marking the head)" in warned[1]
    assert "may be 0.08 m off" in warned[0] and "may be 0.15 m off" in warned[1]
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["unknown_pivots"] == warned
    placed = (MAPPING.format(up="y", a="Glove", b="Helmet", ida=7)
              .replace("point: head}", "point: head, at_point: true}")
              .replace("streaming_id: 7}", "streaming_id: 7, pivot: [0.0, -0.05, 0.0]}"))
    (tmp_path / "map.yaml").write_text(placed)
    assert main(["simulate", str(tmp_path / "s.yaml"), "--out", str(tmp_path / "o2"),
                 "--quiet"]) == 0
    assert ".pivot" not in capsys.readouterr().err
    assert "unknown_pivots" not in json.loads((tmp_path / "o2" / "summary.json").read_text())


def test_scripted_and_recorded_operators_do_not_mix(tmp_path, capsys):
    _write_motive(tmp_path, "Meters", "Quaternion")
    (tmp_path / "s.yaml").write_text(SCENARIO.format(recording="rec.csv", start=0.0) + """\
- name: other
  bodies: [{name: a, point: hand_left}, {name: b, point: hand_right}]
  waypoints: [{time: 0.0, position: [2.0, 0.0, 0.0]}]
""")
    assert main(["simulate", str(tmp_path / "s.yaml"), "--out", str(tmp_path / "o")]) == 2
    assert "all scripted or all recorded" in capsys.readouterr().err


@pytest.mark.parametrize("field, value", [("start", 1.0), ("time_scale", 1.2),
                                          ("yaw_deg", 30.0), ("shift", [0.1, 0.0, 0.0])])
def test_a_scripted_operator_refuses_the_recorded_operators_fields(tmp_path, capsys, field,
                                                                   value):
    (tmp_path / "s.yaml").write_text(f"""\
operators:
- name: walker
  bodies: [{{name: a, point: hand_left}}, {{name: b, point: hand_right}}]
  waypoints: [{{time: 0.0, position: [2.0, 0.0, 0.0]}}]
  {field}: {value}
""")
    assert main(["simulate", str(tmp_path / "s.yaml"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"operators[0].{field}" in err
    assert "for a scripted operator" in err
