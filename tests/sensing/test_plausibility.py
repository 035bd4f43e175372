"""The plausibility bounds: real people's recordings pass, misread or frozen-then-jumping
bodies do not, and the figures named are the ones a second reader computes."""

import glob
import math
from pathlib import Path

import numpy as np
import pytest

from safety_systems.files.input_error import InputError
from safety_systems.sensing.motive_csv import read_motive_csv
from safety_systems.sensing.plausibility import (
    MAX_ACCELERATION,
    MAX_SPEED,
    first_implausible,
    held_before_jumps,
)
from safety_systems.sensing.recording_files import read_recording
from safety_systems.sensing.recording_mapping import load_recorded_operator
from tests.sensing.motive_holds import HOLDS, held_export, positions

DATA = Path(__file__).parents[1] / "data"
MAPPING = """\
capture_to_cell: {{up_axis: y}}
{extra}operators:
- name: juggler
  bodies:
  - {{recorded: stick_right, name: right, point: hand_right}}
  - {{recorded: stick_left, name: left, point: hand_left}}
"""


@pytest.mark.parametrize("path", sorted(glob.glob(str(DATA / "motive_csv" / "*.csv")))
                         + sorted(glob.glob(str(DATA / "c3d*" / "sample02_*.c3d")))
                         + [str(DATA / "c3d" / "ezc3d_markers_analogs_vicon100Hz_boxlift.c3d")])
def test_real_recordings_of_people_are_plausible(path):
    rec = read_recording(path)
    assert first_implausible(rec.times, rec.positions) is None


def test_a_stop_dead_from_9_m_s_is_an_implausible_acceleration_and_from_6_is_not():
    t = np.arange(240) / 120.0
    for speed, implausible in ((9.0, True), (6.0, False)):
        p = np.zeros((240, 1, 3))
        p[:, 0, 0] = speed * np.minimum(t, 1.0)  # at `speed`, then still from t = 1 s
        bad = first_implausible(t, p)
        assert (bad is not None) == implausible
        if implausible:  # (0.5 * 9 * 0.05 ... : the second difference 9 * 0.05 m)
            h = 6 / 120.0
            assert bad.what == "acceleration" and 120 <= bad.frame <= 132
            assert bad.figure == pytest.approx((speed * h - 0.02) / h**2, rel=0.2)
            assert bad.figure > MAX_ACCELERATION


def test_a_jump_that_stays_is_implausible_and_held_samples_before_it_are_found():
    t = np.arange(100) / 100.0
    p = np.zeros((100, 2, 3))
    p[:, 0, 0] = 0.5 * t  # walking
    p[:, 1, 0] = np.where(t < 0.5, 0.0, 0.8)  # re-identified 0.8 m away: 80 m/s
    p[30:50, 1] = p[30, 1]  # (already still)
    bad = first_implausible(t, p)
    assert (bad.body, bad.frame, bad.what) == (1, 50, "speed")
    assert bad.figure == pytest.approx((0.8 - 0.01) / 0.01)
    held = held_before_jumps(t, p)
    assert np.flatnonzero(held[:, 1]).tolist() == list(range(1, 50))  # held from frame 0
    assert not held[:, 0].any()
    assert MAX_SPEED == 10.0


def test_a_motive_export_frozen_then_jumping_is_refused_or_repaired_as_stated(tmp_path):
    rec_path = held_export(tmp_path / "frozen.csv")
    raw = positions(rec_path)  # the second reader: the csv module alone
    a, b = HOLDS[0]
    jump = math.dist(raw[b], raw[b - 1]) * 120.0
    assert jump > 40.0  # m/s, the cells as written
    (tmp_path / "map.yaml").write_text(MAPPING.format(extra=""))
    with pytest.raises(InputError) as e:
        load_recorded_operator(rec_path, tmp_path / "map.yaml")
    line = str(e.value)
    assert "\n" not in line and line.startswith(str(rec_path))
    assert (f"Motive CSV (Format Version 1.22): 'stick_right' at frame {b} of the file "
            f"(counted from 0; t = {b / 120.0:.4g} s from its first): speed") in line
    assert f"speed: got '{(jump / 120.0 - 0.01) * 120.0:.2f} m/s'" in line
    assert "max_speed, 10 m/s" in line
    # the stated repair: the held samples read as untracked, said with a warning
    (tmp_path / "map.yaml").write_text(MAPPING.format(extra="implausible: untracked\n"))
    with pytest.warns(UserWarning, match=rf"stick_right: {3 * 59} sample\(s\) from frame "
                                         rf"{a + 1} .* read as untracked: held still"):
        bodies = load_recorded_operator(rec_path, tmp_path / "map.yaml")
    hidden = np.isnan(bodies.raw[:, 0, 0])
    assert np.flatnonzero(hidden).tolist() == [f for x, y in HOLDS for f in range(x + 1, y)]
    assert bodies.gaps[0][0] == pytest.approx((a / 120.0, b / 120.0))
    # the untouched export reads as before
    untouched = read_motive_csv(held_export(tmp_path / "none.csv", holds=()))
    assert first_implausible(untouched.times, untouched.positions) is None
