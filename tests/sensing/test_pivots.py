"""A rigid body's pivot (issue 46): a mapping moves each reported position to the body point
it marks (its pivot offset, turned with the body's orientation) or says it is there
(at_point); without either the point may be as far off as the body's kind allows, which
the live runtime refuses under a certificate that assumed less."""

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from safety_systems.files.input_error import InputError
from safety_systems.sensing.pivots import PIVOT_BOUNDS, body_points, pivot_bound
from safety_systems.sensing.recording_files import read_recording
from safety_systems.sensing.recording_mapping import (
    load_mapping,
    recorded_bodies,
    unknown_pivots,
)

DATA = Path(__file__).parents[1] / "data"
DIABOLO = DATA / "motive_csv" / "2020-07-11_basic_physics__z_hop_1.csv"
C3D = DATA / "c3d" / "ezc3d_markers_analogs_vicon100Hz_boxlift.c3d"

MAPPING = """\
capture_to_cell: {{up_axis: y}}
operators:
- name: juggler
  bodies:
  - {{recorded: stick_right, name: right, point: hand_right{right}}}
  - {{recorded: stick_left, name: left, point: hand_left{left}}}
"""


def test_the_body_point_is_the_pivot_offset_turned_with_the_body():
    q = Rotation.from_euler("z", 90.0, degrees=True).as_quat()
    p = body_points(np.array([[1.0, 2.0, 3.0]]), q[None], [0.1, 0.0, 0.0])
    np.testing.assert_allclose(p, [[1.0, 2.1, 3.0]], atol=1e-12)
    # no orientation known: no point (an untracked sample), never the position as is
    assert np.isnan(body_points(np.array([[1.0, 2.0, 3.0]]), np.full((1, 4), np.nan),
                                [0.1, 0.0, 0.0])).all()


def test_a_bodys_point_is_off_by_its_kinds_bound_unless_the_mapping_says():
    assert pivot_bound("head", [], False) == PIVOT_BOUNDS["head"] == 0.15
    assert pivot_bound("head", [0.0, -0.12, 0.0], False) == 0.0
    assert pivot_bound("hand_right", [], True) == 0.0


def _map(folder, right="", left=""):
    folder.mkdir(exist_ok=True)
    (folder / "map.yaml").write_text(MAPPING.format(right=right, left=left))
    return load_mapping(folder / "map.yaml")


def test_a_real_motive_exports_bodies_are_moved_to_their_points(tmp_path):
    """The diabolo export's sticks (real rigid bodies, with their quaternions): a pivot
    of 0.2 m along a stick's own x axis moves every sample by that vector turned with
    the stick, in the capture frame, before the capture frame's turn into the cell."""
    plain = _map(tmp_path / "plain")
    moved_map = _map(tmp_path / "moved", right=", pivot: [0.2, 0.0, 0.0]",
                     left=", at_point: true")
    rec = read_recording(str(DIABOLO), ["stick_right", "stick_left"])
    before = recorded_bodies(rec, plain, plain.operators[0])
    after = recorded_bodies(rec, moved_map, moved_map.operators[0])
    k = rec.body("stick_right")
    turn = Rotation.from_euler("x", 90.0, degrees=True)  # up_axis: y
    seen = np.isfinite(before.raw[:, 0, 0]) & np.all(np.isfinite(rec.rotations[:, k]), axis=1)
    assert seen.sum() > 100
    expected = before.raw[seen, 0] + turn.apply(Rotation.from_quat(
        rec.rotations[seen, k]).apply([0.2, 0.0, 0.0]))
    np.testing.assert_allclose(after.raw[seen, 0], expected, atol=1e-9)
    np.testing.assert_array_equal(after.raw[:, 1], before.raw[:, 1])  # at_point: as is
    assert [f for f, _ in unknown_pivots(plain)] == ["operators[0].bodies[0]",
                                                     "operators[0].bodies[1]"]
    assert unknown_pivots(moved_map) == []


def test_a_pivot_on_a_marker_without_orientation_is_refused(tmp_path):
    (tmp_path / "map.yaml").write_text(
        "capture_to_cell: {up_axis: z}\noperators:\n- name: worker\n  bodies:\n"
        "  - {recorded: 'Daphnee:WRIST', name: hand, point: hand_right, pivot: [0.0, 0.0, 0.05]}\n")
    mapping = load_mapping(tmp_path / "map.yaml")
    rec = read_recording(str(C3D), ["Daphnee:WRIST"])
    with pytest.raises(InputError, match=r"bodies\[0\]\.pivot.*no orientation"):
        recorded_bodies(rec, mapping, mapping.operators[0])


@pytest.mark.parametrize("body", [
    "pivot: [0.1, 0.0]", "pivot: [0.0, 0.1, 0.0], at_point: true", "pivot: [0.9, 0.0, 0.0]"])
def test_bad_pivots_are_one_line(tmp_path, body):
    (tmp_path / "map.yaml").write_text(MAPPING.format(right=", " + body, left=""))
    with pytest.raises(InputError, match=r"bodies\[0\]\.pivot") as e:
        load_mapping(tmp_path / "map.yaml")
    assert len(str(e.value).splitlines()) == 1
