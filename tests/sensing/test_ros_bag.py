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


def _header(ns: int, frame: str = "", ts=TS):
    Header, Time = ts.types["std_msgs/msg/Header"], ts.types["builtin_interfaces/msg/Time"]
    seq = {"seq": 0} if "seq" in Header.__dataclass_fields__ else {}  # ROS 1's header
    return Header(**seq, stamp=Time(sec=int(ns // 1_000_000_000),
                                    nanosec=int(ns % 1_000_000_000)), frame_id=frame)


def _bag_messages(ts, *, tf: bool = True, helmet_frame: str = "mocap",
                  drop_joint: str = "") -> list[tuple]:
    """(arrival stamp ns, topic, message, type) of the bag's messages in typestore ``ts``:
    the robot's JointState (without ``drop_joint``), the glove's PoseStamped and the
    helmet's TF child frame (``tf``) or PoseStamped in ``helmet_frame``."""
    JointState = ts.types["sensor_msgs/msg/JointState"]
    PoseStamped, Pose = ts.types["geometry_msgs/msg/PoseStamped"], ts.types["geometry_msgs/msg/Pose"]
    Point, Quaternion = ts.types["geometry_msgs/msg/Point"], ts.types["geometry_msgs/msg/Quaternion"]
    TFMessage = ts.types["tf2_msgs/msg/TFMessage"]
    TransformStamped = ts.types["geometry_msgs/msg/TransformStamped"]
    Transform, Vector3 = ts.types["geometry_msgs/msg/Transform"], ts.types["geometry_msgs/msg/Vector3"]
    names = list(robot_model("ur5e").joint_names)
    messages = []
    for ns, q in zip(*_robot()):
        # The bag's joint order differs from the model's, and a gripper joint comes too.
        order = [j for j in [5, 0, 3, 1, 4, 2] if names[j] != drop_joint]
        msg = JointState(header=_header(T0 + ns, ts=ts), name=[names[j] for j in order]
                         + ["gripper"], position=np.r_[q[order], 0.01],
                         velocity=np.zeros(0), effort=np.zeros(0))
        messages.append((T0 + ns, "/joint_states", msg, JointState.__msgtype__))
    ns_op, p = _operator()
    unit = Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
    for ns, (glove, helmet) in zip(ns_op, p):
        if np.isfinite(glove).all():
            pose = Pose(position=Point(x=glove[0], y=glove[1], z=glove[2]), orientation=unit)
            messages.append((T0 + ns, "/mocap/glove", PoseStamped(
                header=_header(T0 + ns, "mocap", ts), pose=pose), PoseStamped.__msgtype__))
        if tf:
            x = TransformStamped(header=_header(T0 + ns, helmet_frame, ts),
                                 child_frame_id="helmet", transform=Transform(
                                     translation=Vector3(x=helmet[0], y=helmet[1], z=helmet[2]),
                                     rotation=unit))
            messages.append((T0 + ns, "/tf", TFMessage(transforms=[x]), TFMessage.__msgtype__))
        else:
            pose = Pose(position=Point(x=helmet[0], y=helmet[1], z=helmet[2]), orientation=unit)
            messages.append((T0 + ns, "/mocap/helmet", PoseStamped(
                header=_header(T0 + ns, helmet_frame, ts), pose=pose),
                PoseStamped.__msgtype__))
    return messages


def _write(writer, messages: list[tuple], ts, serialize) -> None:
    """``messages`` into an open bag ``writer``, each arriving later than its stamp."""
    connections = {}
    for _, topic, _, msgtype in messages:
        if topic not in connections:
            connections[topic] = writer.add_connection(topic, msgtype, typestore=ts)
    for k, (ns, topic, msg, msgtype) in enumerate(sorted(messages, key=lambda m: m[0])):
        # Arrival: later than the stamp by 37 ms and a jitter of up to 4 ms (less than
        # a spacing, so the order stays), which the reader must not take for time.
        late = ARRIVAL + (k % 5) * 1_000_000
        writer.write(connections[topic], int(ns + late), serialize(msg, msgtype))


def _write_bag(path: Path, storage: StoragePlugin, *, tf: bool = True, **kwargs) -> None:
    """A rosbag2 bag of :func:`_bag_messages` in ``storage``."""
    with Writer(path, version=9, storage_plugin=storage) as writer:
        _write(writer, _bag_messages(TS, tf=tf, **kwargs), TS, TS.serialize_cdr)


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


def test_a_ros1_bag_is_read_as_a_recording_and_as_joint_states(tmp_path, capsys):
    """The same messages in a ROS 1 .bag (rosbags' rosbag1 writer, ROS 1's message
    types): the robot's joints and the operator's bodies at their header stamps."""
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.typesys import get_types_from_msg

    from safety_systems.cell.robot_log import read_joint_log

    ts1 = get_typestore(Stores.ROS1_NOETIC)  # without tf2_msgs: its one-line definition
    ts1.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms",
                                    "tf2_msgs/msg/TFMessage"))
    with Writer1(tmp_path / "cell.bag") as writer:
        _write(writer, _bag_messages(ts1), ts1, ts1.serialize_ros1)
    rec = read_recording(tmp_path / "cell.bag", ["/mocap/glove", "helmet"])
    np.testing.assert_array_equal(rec.positions, _operator()[1])
    assert rec.times[1] == 0.01
    names = tuple(robot_model("ur5e").joint_names)
    log = read_joint_log(tmp_path / "cell.bag", names, "/joint_states")
    ns, q = _robot()
    np.testing.assert_array_equal(log.q, q)
    np.testing.assert_array_equal(log.times, ns / 1e9)
    assert log.row_name == "message" and log.rows[0] == 1
    assert main(["check", "robot-log", str(tmp_path / "cell.bag")]) == 0
    assert main(["check", "recording", str(tmp_path / "cell.bag")]) == 0  # its PoseStamped


@pytest.mark.parametrize("storage,definitions", [
    (StoragePlugin.SQLITE3, True), (StoragePlugin.MCAP, True), (StoragePlugin.SQLITE3, False)],
    ids=["sqlite3", "mcap", "sqlite3_without_definitions"])
def test_mocap4r2_rigid_bodies_are_read_by_their_names(tmp_path, storage, definitions):
    """A rosbag2 bag of mocap4r2_msgs/msg/RigidBodies (its types registered from its .msg
    definitions): the glove and the helmet by rigid_body_name, at each frame's header
    stamp; from the definitions the bag carries, or, where it carries none (as ROS 2
    Humble's SQLite 3 bags), from the reader's own."""
    import sqlite3

    from safety_systems.sensing.ros_bag import typestore

    ts = typestore()
    RigidBodies, RigidBody = (ts.types[f"mocap4r2_msgs/msg/{x}"] for x in ("RigidBodies",
                                                                         "RigidBody"))
    Pose, Point = ts.types["geometry_msgs/msg/Pose"], ts.types["geometry_msgs/msg/Point"]
    unit = ts.types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
    messages = []
    ns_op, p = _operator()
    for k, (ns, frame) in enumerate(zip(ns_op, p)):
        seen = [RigidBody(rigid_body_name=name, markers=[], pose=Pose(
            position=Point(x=x[0], y=x[1], z=x[2]), orientation=unit))
            for name, x in zip(("glove", "helmet"), frame) if np.isfinite(x).all()]
        messages.append((T0 + ns, "/rigid_bodies", RigidBodies(
            header=_header(T0 + ns, "mocap", ts), frame_number=k, rigidbodies=seen),
            RigidBodies.__msgtype__))
    with Writer(tmp_path / "b", version=9, storage_plugin=storage) as writer:
        _write(writer, messages, ts, ts.serialize_cdr)
    if not definitions:
        (db,) = (tmp_path / "b").glob("*.db3")
        with sqlite3.connect(db) as c:
            assert c.execute("DELETE FROM message_definitions").rowcount == 1
    rec = read_recording(tmp_path / "b", ["glove", "helmet"])
    np.testing.assert_array_equal(rec.positions, p)
    np.testing.assert_array_equal(rec.times, (ns_op - ns_op[0]) / 1e9)


def test_bodies_in_different_frames_are_refused_in_one_line(tmp_path, capsys):
    _write_bag(tmp_path / "b", StoragePlugin.MCAP, tf=False, helmet_frame="world")
    with pytest.raises(InputError, match=r"header.frame_id: got \"/mocap/glove in 'mocap', "
                                         r"/mocap/helmet in 'world'\"; allowed: "
                                         r"one frame for every mapped body"):
        read_recording(tmp_path / "b", ["/mocap/glove", "/mocap/helmet"])
    assert main(["check", "recording", str(tmp_path / "b")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "header.frame_id" in err and str(tmp_path / "b") in err


def test_a_joint_state_without_one_of_the_models_joints_is_refused_in_one_line(tmp_path,
                                                                              capsys):
    _write_bag(tmp_path / "b", StoragePlugin.SQLITE3, drop_joint="elbow_joint")
    assert main(["check", "robot-log", str(tmp_path / "b")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and f"{tmp_path / 'b'}: message 1: name: got " in err
    assert "(missing elbow_joint)" in err
