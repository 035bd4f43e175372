"""What real motion capture writes: real Motive exports (tests/data/motive_csv, with their
licences and sources) and the layouts real files have that this project's own writer
does not (Motive 3 skeleton exports, rates the time column rounds, skipped frame
numbers, truncated exports, C3D drop-outs stored at the origin, repeated C3D labels)."""

import csv
import io
from pathlib import Path

import ezc3d
import numpy as np
import pytest

from safety_systems.files.input_error import InputError
from safety_systems.sensing.c3d_file import read_c3d
from safety_systems.sensing.motive_csv import motive_csv_text, read_motive_csv
from safety_systems.sensing.recording import MAX_BODIES
from safety_systems.sensing.recording_mapping import load_recorded_operator

MOTIVE = Path(__file__).parent / "data" / "motive_csv"
Z_HOP = MOTIVE / "2020-07-11_basic_physics__z_hop_1.csv"
CIRCULAR = MOTIVE / "2020-07-11_basic_physics__circular_accel_left_stick_motion.csv"
V1_21 = MOTIVE / "cmuphyscomp_hmv-s16_sample_optitrack_take_v1.21.csv"


@pytest.mark.parametrize("path, frames, body, position, rotation", [
    # (the files' first data rows, as exported)
    (Z_HOP, 726, "stick_right", (-0.150353, 0.436091, 0.738103),
     (0.579157, 0.607438, 0.367702, 0.400488)),
    (CIRCULAR, 137, "stick_right", (0.209618, 0.016767, 0.908816),
     (-0.256928, 0.083916, 0.826310, 0.494124)),
    (V1_21, 250, "Rigid Body 1", (0.060002, 0.019150, 0.076611),
     (0.000035, 0.000016, -0.000030, -1.0)),
])
def test_real_motive_exports_with_empty_row_labels_are_read(path, frames, body, position,
                                                            rotation):
    rec = read_motive_csv(path)
    k = rec.body(body)
    assert rec.times.size == frames and rec.rate_hz == pytest.approx(120.0)
    np.testing.assert_allclose(rec.positions[0, k], position, atol=1e-6)
    q = np.array(rotation) / np.linalg.norm(rotation)
    assert abs(np.dot(rec.rotations[0, k], q)) == pytest.approx(1.0, abs=1e-6)
    # times from the frame numbers at the header's 120 Hz (the export starts at frame 21120)
    np.testing.assert_allclose(np.diff(rec.times), 1.0 / 120.0, rtol=0, atol=1e-12)
    if path == Z_HOP:
        assert rec.times[-1] == pytest.approx((21845 - 21120) / 120.0, abs=1e-12)
        assert set(rec.names) == {"stick_right", "stick_left", "diabolo_red"}


def test_the_real_1_21_export_keeps_its_markers_and_skips_its_quality_columns():
    rec = read_motive_csv(V1_21)
    assert "Rigid Body 1" in rec.names and any(n.startswith("Unlabeled:") for n in rec.names)
    assert not any(n.startswith("Rigid Body 1_") for n in rec.names)  # expected markers
    markers = [i for i, n in enumerate(rec.names) if n != "Rigid Body 1"]
    assert np.isnan(rec.rotations[:, markers]).all()


def _motive3_text(bones: int, markers_per_bone: int, frames: int, rate: float = 120.0,
                  total: int | None = None, time_digits: int = 6, skip=()) -> str:
    """A Motive 3 skeleton export (Format Version 1.25, labelled rows with a Parent row,
    Bone and Bone Marker columns, two rigid bodies): bone j at (j, 0.01 t, 1) m at frame
    t, the rigid bodies at (-1, 0, 0) and (-2, 0, 0)."""
    cols = []  # (type, name, id, parent, group, axis, value(t))
    for j in range(bones):
        name = f"Skeleton:Bone{j}"
        for a, v in zip("XYZW", (0.0, 0.0, 0.0, 1.0)):
            cols.append(("Bone", name, str(j + 1), "Skeleton:Hip", "Rotation", a,
                         lambda t, v=v: v))
        for a, f in zip("XYZ", (lambda t, j=j: float(j), lambda t: 0.01 * t,
                                lambda t: 1.0)):
            cols.append(("Bone", name, str(j + 1), "Skeleton:Hip", "Position", a, f))
        for m in range(markers_per_bone):
            for a in "XYZ":
                cols.append(("Bone Marker", f"{name}:M{m}", "", name, "Position", a,
                             lambda t: 0.5))
    for r in range(2):
        for a, v in zip("XYZW", (0.0, 0.0, 0.0, 1.0)):
            cols.append(("Rigid Body", f"Tool{r}", str(100 + r), "", "Rotation", a,
                         lambda t, v=v: v))
        for a, v in zip("XYZ", (-1.0 - r, 0.0, 0.0)):
            cols.append(("Rigid Body", f"Tool{r}", str(100 + r), "", "Position", a,
                         lambda t, v=v: v))
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(["Format Version", "1.25", "Take Name", "skeleton", "Capture Frame Rate",
                f"{rate:.6f}", "Export Frame Rate", f"{rate:.6f}", "Total Frames in Take",
                str(frames), "Total Exported Frames", str(total or frames), "Rotation Type",
                "Quaternion", "Length Units", "Meters", "Coordinate Space", "Global"])
    w.writerow([])
    for label, k in (("Type", 0), ("Name", 1), ("ID", 2), ("Parent", 3)):
        w.writerow(["", label] + [c[k] for c in cols])
    w.writerow(["", ""] + [c[4] for c in cols])
    w.writerow(["Frame", "Time (Seconds)"] + [c[5] for c in cols])
    for t in range(frames):
        if t in skip:
            continue
        w.writerow([str(t), f"{t / rate:.{time_digits}f}"] + [f"{c[6](t):.6f}" for c in cols])
    return out.getvalue()


def test_a_motive_3_skeleton_export_of_many_bodies_is_read_for_the_mapped_ones(tmp_path):
    path = tmp_path / "skeleton.csv"
    path.write_text(_motive3_text(bones=80, markers_per_bone=1, frames=30))  # 162 bodies
    with pytest.raises(InputError) as e:  # all of them: more than a recording holds
        read_motive_csv(path)
    assert "<bodies>" in str(e.value) and "\n" not in str(e.value)
    rec = read_motive_csv(path, ["Skeleton:Bone3", "Skeleton:Bone79", "Tool1"])
    assert sorted(rec.names) == ["Skeleton:Bone3", "Skeleton:Bone79", "Tool1"]
    k = rec.body("Skeleton:Bone79")
    np.testing.assert_allclose(rec.positions[:, k, 0], 79.0)
    np.testing.assert_allclose(rec.positions[:, k, 1], 0.01 * np.arange(30), atol=1e-9)
    np.testing.assert_allclose(rec.rotations[:, k], [[0.0, 0.0, 0.0, 1.0]] * 30, atol=1e-9)
    assert rec.ids[k] == 80 and rec.ids[rec.body("Tool1")] == 101
    assert 82 > MAX_BODIES  # (the bones and rigid bodies alone)
    # through a mapping: only its bodies are read
    (tmp_path / "map.yaml").write_text(
        "capture_to_cell: {up_axis: z}\noperators:\n- name: a\n  bodies:\n"
        "  - {recorded: 'Skeleton:Bone3', name: hand, point: hand_right}\n"
        "  - {recorded: 'Skeleton:Bone5', name: head, point: head}\n")
    bodies = load_recorded_operator(path, tmp_path / "map.yaml")
    np.testing.assert_allclose(bodies.raw[0, :, 0], [3.0, 5.0])


def test_the_rate_comes_from_the_header_and_the_frame_numbers(tmp_path):
    # 360 Hz with the time column rounded to the millisecond: 1/360 s reads as 0.003 s
    path = tmp_path / "fast.csv"
    path.write_text(_motive3_text(bones=2, markers_per_bone=0, frames=361, rate=360.0,
                                  time_digits=3))
    rec = read_motive_csv(path)
    assert rec.rate_hz == pytest.approx(360.0, rel=1e-12)
    np.testing.assert_allclose(rec.times, np.arange(361) / 360.0, rtol=0, atol=1e-12)
    # a time column that disagrees with the frames by more than half a frame is refused
    text = path.read_text().replace("\n5,0.014,", "\n5,0.020,")
    path.write_text(text)
    with pytest.raises(InputError) as e:
        read_motive_csv(path)
    assert "column Time" in str(e.value) and "frame 5" in str(e.value)


def test_frames_missing_from_the_numbering_are_frames_without_tracking(tmp_path):
    path = tmp_path / "gaps.csv"
    path.write_text(_motive3_text(bones=2, markers_per_bone=0, frames=50, total=46,
                                  skip={10, 11, 12, 30}))
    rec = read_motive_csv(path)
    assert rec.times.size == 50
    np.testing.assert_allclose(rec.times, np.arange(50) / 120.0, rtol=0, atol=1e-12)
    hidden = np.isnan(rec.positions[:, 0, 0])
    assert np.flatnonzero(hidden).tolist() == [10, 11, 12, 30]


def test_a_truncated_export_is_one_line_or_used_with_a_warning(tmp_path):
    path = tmp_path / "cut.csv"
    path.write_text(_motive3_text(bones=2, markers_per_bone=0, frames=32, total=17263))
    with pytest.raises(InputError) as e:
        read_motive_csv(path)
    line = str(e.value)
    assert "Total Exported Frames" in line and "17263" in line and "32 frames" in line
    assert str(path) in line and "\n" not in line
    with pytest.warns(UserWarning, match="truncated export"):
        rec = read_motive_csv(path, truncated="use")
    assert rec.times.size == 32


def test_this_projects_own_export_still_reads_as_written(tmp_path):
    t = np.arange(20) / 100.0
    p = np.zeros((20, 1, 3)) + [1.0, 2.0, 3.0]
    q = np.tile([0.0, 0.0, 0.0, 1.0], (20, 1, 1))
    (tmp_path / "own.csv").write_text(motive_csv_text(t, ["A"], [3], p, q, rate_hz=100.0))
    rec = read_motive_csv(tmp_path / "own.csv")
    np.testing.assert_allclose(rec.times, t, atol=1e-12)


def _c3d(path: Path, labels: tuple, points: np.ndarray, residuals=None) -> None:
    """A C3D of ``points`` (T, n, 3) in mm at 100 Hz."""
    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = [100.0]
    c["parameters"]["POINT"]["LABELS"]["value"] = labels
    c["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    data = np.ones((4, len(labels), points.shape[0]))
    data[:3] = np.transpose(points, (2, 1, 0))
    c["data"]["points"] = data
    c.write(str(path))


def test_a_c3d_drop_out_at_the_origin_is_a_gap(tmp_path):
    T = 40
    p = np.zeros((T, 2, 3)) + [[1000.0, 200.0, 900.0], [1200.0, 0.0, 1500.0]]
    p[:, 0, 0] += 5.0 * np.arange(T)
    p[10:14, 0] = 0.0  # an ART-style drop-out: the point stored at the origin
    p[:, 1, 1] = 0.0  # a real position with a zero coordinate is not one
    _c3d(tmp_path / "drop.c3d", ("hand", "head"), p)
    rec = read_c3d(tmp_path / "drop.c3d")
    assert np.flatnonzero(np.isnan(rec.positions[:, 0, 0])).tolist() == [10, 11, 12, 13]
    assert np.isfinite(rec.positions[:, 1]).all()
    speeds = np.linalg.norm(np.diff(rec.positions[:, 0], axis=0), axis=1) * 100.0
    assert np.nanmax(speeds) == pytest.approx(0.5)  # not 112 m/s to the origin and back


def test_c3d_labels_repeated_matter_only_if_mapped(tmp_path):
    p = np.zeros((20, 3, 3)) + [[100.0, 0.0, 1000.0], [200.0, 0.0, 500.0], [300.0, 0, 500]]
    _c3d(tmp_path / "dup.c3d", ("WRIST", "RKNE", "RKNE"), p)
    rec = read_c3d(tmp_path / "dup.c3d", ["WRIST"])
    assert rec.names == ("WRIST",)
    np.testing.assert_allclose(rec.positions[0, 0], [0.1, 0.0, 1.0])
    for bodies in (None, ["WRIST", "RKNE"]):
        with pytest.raises(InputError) as e:
            read_c3d(tmp_path / "dup.c3d", bodies)
        assert "RKNE" in str(e.value) and "\n" not in str(e.value)


_BVH = """HIERARCHY
ROOT Hips
{
  OFFSET 0.0 0.0 0.0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT RightShoulder
  {
    OFFSET -20.0 50.0 0.0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT RightHand
    {
      OFFSET -60.0 0.0 0.0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET -10.0 0.0 0.0
      }
    }
  }
}
MOTION
Frames: FRAMES
Frame Time: 0.01
ROWS"""


def _bvh(path: Path, frames: int = 50, flips=()) -> np.ndarray:
    """A BVH of a root walking along x at 1 m/s (in cm) and an arm swinging about the
    shoulder's z axis by 90 deg * t (s); returns the hand's positions (frames, 3) in m.
    At the frames ``flips`` the arm is turned by 180 deg more (a joint flipped for a
    frame, as real BVH files have); the returned positions are the unflipped ones."""
    rows, hand = [], []
    for f in range(frames):
        t = 0.01 * f
        angle = 90.0 * t
        rows.append(f"{100.0 * t} 90.0 0.0 0.0 0.0 0.0 {angle + 180.0} 0.0 0.0 0.0 0.0 0.0"
                    if f in flips else None)
        rows[-1] = rows[-1] or(f"{100.0 * t} 90.0 0.0 0.0 0.0 0.0 {angle} 0.0 0.0 0.0 0.0 0.0")
        a = np.radians(angle)  # the arm (-60, 0, 0) turned about z
        hand.append([1.0 * t - 0.2 - 0.6 * np.cos(a), 0.9 + 0.5 - 0.6 * np.sin(a), 0.0])
    path.write_text(_BVH.replace("FRAMES", str(frames)).replace("ROWS", "\n".join(rows)))
    return np.array(hand)


def test_a_bvh_file_is_read_in_the_units_the_mapping_gives(tmp_path):
    from safety_systems.sensing.recording_files import read_recording

    hand = _bvh(tmp_path / "walk.bvh")
    rec = read_recording(tmp_path / "walk.bvh", units="cm")
    assert rec.names == ("Hips", "RightShoulder", "RightHand")
    assert rec.rate_hz == pytest.approx(100.0)
    np.testing.assert_allclose(rec.positions[:, 2], hand, atol=1e-5)
    np.testing.assert_allclose(rec.positions[:, 0, 0], 0.01 * np.arange(50), atol=1e-6)
    with pytest.raises(InputError) as e:  # a BVH file states no unit
        read_recording(tmp_path / "walk.bvh")
    assert "units" in str(e.value) and "\n" not in str(e.value)
    with pytest.raises(InputError) as e:  # a Motive export states its own
        read_recording(Z_HOP, units="cm")
    assert "units" in str(e.value) and "\n" not in str(e.value)
    (tmp_path / "map.yaml").write_text(
        "capture_to_cell: {up_axis: y}\nunits: cm\noperators:\n- name: a\n  bodies:\n"
        "  - {recorded: RightHand, name: hand, point: hand_right}\n"
        "  - {recorded: Hips, name: hips, point: pelvis}\n")
    bodies = load_recorded_operator(tmp_path / "walk.bvh", tmp_path / "map.yaml")
    assert bodies.raw.shape == (50, 2, 3)
    np.testing.assert_allclose(bodies.raw[:, 0, 2], hand[:, 1], atol=1e-5)  # y up -> z


def test_single_frame_flips_of_a_bvh_joint_are_capture_glitches(tmp_path):
    """The arm flipped by 180 deg for one frame (t = 0.3 s) and for two (0.6, 0.61 s):
    the hand jumps 1.2 m and back, about 120 m/s. Those samples are read as untracked with
    a warning, so the played truth (and the fastest-body premise) moves as the body did;
    with a flip_speed above the jump they are read as written."""
    hand = _bvh(tmp_path / "flip.bvh", frames=100, flips={30, 60, 61})
    mapping = ("capture_to_cell: {up_axis: y}\nunits: cm\nFLIPoperators:\n- name: a\n"
               "  bodies:\n  - {recorded: RightHand, name: hand, point: hand_right}\n"
               "  - {recorded: Hips, name: hips, point: pelvis}\n")
    (tmp_path / "map.yaml").write_text(mapping.replace("FLIP", ""))
    with pytest.warns(UserWarning, match=r"RightHand: 3 sample\(s\) from t = 0.3 s"):
        bodies = load_recorded_operator(tmp_path / "flip.bvh", tmp_path / "map.yaml")
    assert bodies.flips == (3, 0)
    assert np.flatnonzero(np.isnan(bodies.raw[:, 0, 0])).tolist() == [30, 60, 61]
    np.testing.assert_allclose(bodies.gaps[0], [(0.29, 0.31), (0.59, 0.62)])
    assert bodies.gaps[1] == ()
    np.testing.assert_allclose(bodies.points[:, 0, 2], hand[:, 1], atol=0.02)
    speed = np.linalg.norm(np.diff(bodies.points, axis=0), axis=2) / 0.01
    assert speed.max() < 2.0  # walk 1 m/s + swing 0.94 m/s, not 120 m/s
    # a flip_speed above the jump keeps the flips; then the plausibility bounds refuse
    # them (a hand at 120 m/s), naming the body, the frame and the figure ...
    (tmp_path / "map.yaml").write_text(mapping.replace("FLIP", "flip_speed: 1000\n"))
    with pytest.raises(InputError) as e:
        load_recorded_operator(tmp_path / "flip.bvh", tmp_path / "map.yaml")
    assert "BVH: 'RightHand' at frame 30 of the file (counted from 0; t = 0.3 s from its " \
           "first): speed" in str(e.value)
    assert "max_speed, 10 m/s" in str(e.value) and "\n" not in str(e.value)
    # ... unless the mapping raises them too: then they are read as written
    (tmp_path / "map.yaml").write_text(mapping.replace(
        "FLIP", "flip_speed: 1000\nmax_speed: 200\nmax_acceleration: 10000\n"))
    bodies = load_recorded_operator(tmp_path / "flip.bvh", tmp_path / "map.yaml")
    assert bodies.flips == (0, 0) and np.isfinite(bodies.raw).all()
    assert (np.linalg.norm(np.diff(bodies.points, axis=0), axis=2) / 0.01).max() > 100.0


def test_fast_real_motion_and_a_jump_that_stays_are_not_glitches():
    from safety_systems.sensing.recording import flips

    rng = np.random.default_rng(3)
    t = np.arange(240) / 120.0
    p = np.zeros((240, 3, 3))
    p[:, 0, 0] = 3.4 * t  # a hand at 3.4 m/s (a real jump's), 2 mm noise
    p[:, 0] += rng.normal(0.0, 0.002, (240, 3))
    p[:, 1, 1] = np.where(t < 1.0, 0.0, 1.5)  # re-identified 1.5 m away, and stays there
    p[:, 2, 2] = 1.0
    p[0, 2, 2] = 3.0  # a first sample has no track to leave: not a glitch by the rule
    p[100, 2] = np.nan  # a gap beside a glitch: neighbours are the tracked samples
    p[101, 2, 2] = 2.0
    p[200:203, 2, 0] = 1.0  # three samples out and back: one glitch of three
    p[220:224, 2, 0] = 1.0  # four: longer than a glitch, read as written
    out = flips(t, p, 10.0)
    assert not out[:, :2].any()
    assert np.flatnonzero(out[:, 2]).tolist() == [101, 200, 201, 202]


def test_the_real_vicon_c3d_is_read_in_its_units():
    rec = read_c3d(Path(__file__).parent / "data" / "c3d" /
                   "ezc3d_markers_analogs_vicon100Hz_boxlift.c3d")
    assert rec.times.size == 580 and rec.rate_hz == pytest.approx(100.0)
    assert len(rec.names) == 51 and rec.names[0] == "boite:gauche_ext"
    # as pyomeca's file-reading test states it, in mm: the first marker at the last frame
    np.testing.assert_allclose(rec.positions[-1, 0], (0.09925964, -0.25917093, 0.9039809),
                               atol=1e-8)
    # its drop-outs are gaps, not jumps: no marker moves faster than a hand can
    step = np.linalg.norm(np.diff(rec.positions, axis=0), axis=2) * 100.0
    assert np.nanmax(step) < 5.0
    rec = read_c3d(rec.file, ["Daphnee:WRIST", "Daphnee:CLAV_post"])
    assert sorted(rec.names) == ["Daphnee:CLAV_post", "Daphnee:WRIST"]  # (in file order)
