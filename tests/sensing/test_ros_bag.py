"""ROS 2 bags (issue 51): one bag, written here with rosbags' writer in rosbag2's SQLite 3
and MCAP storage, holds the robot's JointState and the operator's bodies (a PoseStamped
topic and a TF child frame); it replays as a scenario (the robot's path from its joints,
the operator from its poses, every time a header stamp, not the arrival in the bag), and
its figures equal those of the same motion given as an RTDE CSV and a Motive CSV."""

from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from safety_systems.cell.joint_path import joint_path_state
from safety_systems.cell.robot_log import read_rtde_csv
from safety_systems.cell.robot_model import robot_model
from safety_systems.cli import main
from safety_systems.config.configuration import joint_path
from safety_systems.config.scenario import load_scenario
from safety_systems.files.input_error import InputError
from safety_systems.sensing.motive_csv import motive_csv_text
from safety_systems.sensing.recording_files import read_recording
from verification.search.evaluate_batch import evaluate_many

REAL = Path(__file__).parents[1] / "data" / "ur_rtde" / "ur3e_rad_moves.csv"
TS = get_typestore(Stores.ROS2_HUMBLE)
T0 = 1_732_700_000_000_000_000  # ns: the bag's first header stamp
RATE = 100  # Hz, the motion capture's
ARRIVAL = 37_000_000  # ns: every message arrives in the bag at least this after its stamp
MAPPING = """\
capture_to_cell: {{up_axis: z, rpy_deg: [0.0, 0.0, 0.0], translation: [0.0, 0.0, 0.0]}}
operators:
- name: tester
  bodies:
  - {{recorded: {glove}, name: right_glove}}
  - {{recorded: {helmet}, name: helmet, point: head}}
"""
SCENARIO = """\
name: bag
duration: 4.0
robot:
  cycles: 1
  path:
    log: {{file: {log}, topic: {topic}}}
controller: {{sensor: {{noise_std: 0.0}}}}
operators:
- {{recording: {recording}, mapping: map.yaml}}
"""


def _robot() -> tuple[np.ndarray, np.ndarray]:
    """(stamps ns from T0, q (T, 6)): the real log's first 4.5 s."""
    log = read_rtde_csv(REAL)
    keep = log.times - log.times[0] <= 4.5
    ns = np.round((log.times[keep] - log.times[0]) * 1e9).astype(np.int64)
    return ns, log.q[keep]


def _operator() -> tuple[np.ndarray, np.ndarray]:
    """(stamps ns from T0, positions (T, 2, 3) m, to the micrometre, z up): a glove and a
    helmet walking towards the robot and back, the glove unseen for 0.1 s."""
    k = np.arange(4 * RATE + 1)
    t = k / RATE
    start = np.array([[1.8, 0.4, 1.0], [1.9, 0.5, 1.7]])
    walk = np.outer(np.minimum(t, 4.0 - t), [-0.5, 0.0, 0.0])
    p = np.round(start + walk[:, None], 6)
    p[150:160, 0] = np.nan
    return k * (1_000_000_000 // RATE), p


def _header(ns: int, frame: str = ""):
    Header, Time = TS.types["std_msgs/msg/Header"], TS.types["builtin_interfaces/msg/Time"]
    return Header(stamp=Time(sec=int(ns // 1_000_000_000), nanosec=int(ns % 1_000_000_000)),
                  frame_id=frame)


def _write_bag(path: Path, storage: StoragePlugin, *, tf: bool = True) -> None:
    JointState = TS.types["sensor_msgs/msg/JointState"]
    PoseStamped, Pose = TS.types["geometry_msgs/msg/PoseStamped"], TS.types["geometry_msgs/msg/Pose"]
    Point, Quaternion = TS.types["geometry_msgs/msg/Point"], TS.types["geometry_msgs/msg/Quaternion"]
    TFMessage = TS.types["tf2_msgs/msg/TFMessage"]
    TransformStamped = TS.types["geometry_msgs/msg/TransformStamped"]
    Transform, Vector3 = TS.types["geometry_msgs/msg/Transform"], TS.types["geometry_msgs/msg/Vector3"]
    names = list(robot_model("ur5e").joint_names)
    messages = []
    for ns, q in zip(*_robot()):
        # The bag's joint order differs from the model's, and a gripper joint comes too.
        order = [5, 0, 3, 1, 4, 2]
        msg = JointState(header=_header(T0 + ns), name=[names[j] for j in order] + ["gripper"],
                         position=np.r_[q[order], 0.01], velocity=np.zeros(0),
                         effort=np.zeros(0))
        messages.append((T0 + ns, "/joint_states", msg, JointState.__msgtype__))
    ns_op, p = _operator()
    unit = Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
    for ns, (glove, helmet) in zip(ns_op, p):
        if np.isfinite(glove).all():
            pose = Pose(position=Point(x=glove[0], y=glove[1], z=glove[2]), orientation=unit)
            messages.append((T0 + ns, "/mocap/glove", PoseStamped(
                header=_header(T0 + ns, "mocap"), pose=pose), PoseStamped.__msgtype__))
        if tf:
            x = TransformStamped(header=_header(T0 + ns, "mocap"), child_frame_id="helmet",
                                 transform=Transform(translation=Vector3(
                                     x=helmet[0], y=helmet[1], z=helmet[2]), rotation=unit))
            messages.append((T0 + ns, "/tf", TFMessage(transforms=[x]), TFMessage.__msgtype__))
        else:
            pose = Pose(position=Point(x=helmet[0], y=helmet[1], z=helmet[2]), orientation=unit)
            messages.append((T0 + ns, "/mocap/helmet", PoseStamped(
                header=_header(T0 + ns, "mocap"), pose=pose), PoseStamped.__msgtype__))
    with Writer(path, version=9, storage_plugin=storage) as writer:
        connections = {}
        for _, topic, _, msgtype in messages:
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, msgtype, typestore=TS)
        for k, (ns, topic, msg, msgtype) in enumerate(sorted(messages, key=lambda m: m[0])):
            # Arrival: later than the stamp by 37 ms and a jitter of up to 4 ms (less than
            # a spacing, so the order stays), which the reader must not take for time.
            late = ARRIVAL + (k % 5) * 1_000_000
            writer.write(connections[topic], int(ns + late), TS.serialize_cdr(msg, msgtype))


def _csv_twin(folder: Path) -> None:
    """The same motion as an RTDE CSV (the robot) and a Motive CSV (the operator)."""
    ns, q = _robot()
    rows = ["timestamp " + " ".join(f"actual_q_{j}" for j in range(6))]
    rows += [" ".join([repr(float(n / 1e9))] + [repr(float(x)) for x in qq]) for n, qq in zip(ns, q)]
    (folder / "robot.csv").write_text("\n".join(rows) + "\n")
    ns_op, p = _operator()
    rot = np.tile([0.0, 0.0, 0.0, 1.0], (len(ns_op), 2, 1))
    (folder / "op.csv").write_text(motive_csv_text(ns_op / 1e9, ["Glove", "Helmet"], [0, 0], p,
                                                   rot, rate_hz=RATE, units="Meters",
                                                   rotation_type="Quaternion"))


def _scenario(folder: Path, log: str, topic: str, recording: str, glove: str,
              helmet: str) -> Path:
    (folder / "map.yaml").write_text(MAPPING.format(glove=glove, helmet=helmet))
    path = folder / "scenario.yaml"
    path.write_text(SCENARIO.format(log=log, topic=topic or "''", recording=recording))
    return path


@pytest.mark.parametrize("storage", [StoragePlugin.SQLITE3, StoragePlugin.MCAP],
                         ids=["sqlite3", "mcap"])
def test_a_bag_replays_as_a_scenario_with_the_figures_of_its_csv_twin(tmp_path, storage):
    _write_bag(tmp_path / "cell_bag", storage)
    bag = load_scenario(_scenario(tmp_path, "cell_bag", "/joint_states", "cell_bag",
                                  "/mocap/glove", "helmet"))
    twin_dir = tmp_path / "twin"
    twin_dir.mkdir()
    _csv_twin(twin_dir)
    twin = load_scenario(_scenario(twin_dir, "robot.csv", "", "op.csv", "Glove", "Helmet"))
    # The robot's path: the joints by name, at their header stamps.
    a, b = joint_path(bag.robot), joint_path(twin.robot)
    s = np.linspace(0.0, a.cycle_time, 50)
    assert a.cycle_time == b.cycle_time == pytest.approx(4.48)  # 112 spacings of 40 ms
    assert np.array_equal(joint_path_state(a, s)[0], joint_path_state(b, s)[0])
    # The operator: the poses at their header stamps, the glove's gap kept.
    rec = read_recording(tmp_path / "cell_bag", ["/mocap/glove", "helmet"])
    assert rec.times[1] == 0.01 and np.isnan(rec.positions[150:160, 0]).all()
    np.testing.assert_array_equal(rec.positions, _operator()[1])
    # The same figures, run in the Drake diagram (recorded operators run there).
    ours, theirs = evaluate_many([bag]), evaluate_many([twin])
    assert np.isfinite(ours.robustness).all()  # the robot moved with the operator near
    for field in ("robustness", "separation", "permitted_contact", "min_separation_while_moving"):
        assert getattr(ours, field)[0] == pytest.approx(getattr(theirs, field)[0], abs=1e-9)


def test_poses_may_come_as_pose_stamped_topics_only(tmp_path):
    _write_bag(tmp_path / "b", StoragePlugin.MCAP, tf=False)
    rec = read_recording(tmp_path / "b", ["/mocap/glove", "/mocap/helmet"])
    np.testing.assert_array_equal(rec.positions, _operator()[1])


def test_a_bags_bad_robot_log_or_missing_body_is_one_line(tmp_path, capsys):
    _write_bag(tmp_path / "b", StoragePlugin.SQLITE3)
    path = _scenario(tmp_path, "b", "/no_such_topic", "b", "/mocap/glove", "helmet")
    with pytest.raises(InputError, match=r"path.log.topic: got '/no_such_topic'; allowed: a "
                                         r"sensor_msgs/msg/JointState topic of the bag"):
        load_scenario(path)
    path = _scenario(tmp_path, "b", "/joint_states", "b", "/mocap/glove", "visor")
    assert main(["check", "scenario", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "visor" in err and "TFMessage child frame" in err


def test_check_reads_a_bags_joints_and_poses(tmp_path, capsys):
    _write_bag(tmp_path / "b", StoragePlugin.MCAP, tf=False)
    assert main(["check", "robot-log", str(tmp_path / "b")]) == 0
    assert main(["check", "recording", str(tmp_path / "b")]) == 0
    assert capsys.readouterr().out.count(": ok") == 2


def test_an_mcap_file_is_read_as_what_it_is_a_bags_or_a_run_logs(tmp_path):
    """Both a rosbag2 bag's storage file and a live run's log segment end in .mcap: the
    registry reads each by its Header (``run_log.is_run_log``), not by its name."""
    from safety_systems.sensing.run_log import is_run_log

    _write_bag(tmp_path / "b", StoragePlugin.MCAP, tf=False)
    (storage,) = (tmp_path / "b").glob("*.mcap")
    assert not is_run_log(storage)
    rec = read_recording(storage, ["/mocap/glove", "/mocap/helmet"])
    np.testing.assert_array_equal(rec.positions, _operator()[1])
    not_mcap = tmp_path / "x.mcap"
    not_mcap.write_bytes(b"not an mcap file at all")
    assert not is_run_log(not_mcap)
    with pytest.raises(InputError):
        read_recording(not_mcap)


def test_check_mapping_opens_the_bag_folder_it_names(tmp_path, capsys):
    """A mapping's ``recording`` may name a rosbag2 folder: ``check mapping`` reads it
    under every rule a simulation applies, and refuses a bad body in one line."""
    _write_bag(tmp_path / "cell_bag", StoragePlugin.SQLITE3)
    mapping = tmp_path / "map.yaml"
    mapping.write_text(MAPPING.format(glove="/mocap/glove", helmet="helmet")
                       + "recording: cell_bag\n")
    assert main(["check", "mapping", str(mapping)]) == 0
    assert capsys.readouterr().out.strip() == (
        f"{mapping}: ok (its recording read as simulate reads it: 1 operator(s), 2 bodies, "
        "401 frames, every body within the plausibility bounds)")
    mapping.write_text(MAPPING.format(glove="/mocap/glove", helmet="visor")
                       + "recording: cell_bag\n")
    assert main(["check", "mapping", str(mapping)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "visor" in err and "TFMessage child frame" in err
    mapping.write_text(MAPPING.format(glove="/mocap/glove", helmet="helmet")
                       + "recording: no_such_bag\n")
    assert main(["check", "mapping", str(mapping)]) == 2
    assert "recording: got 'no_such_bag'" in capsys.readouterr().err
