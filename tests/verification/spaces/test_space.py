"""Scenario spaces: strict loading, the unit cube's mapping and the scenarios of points."""

import dataclasses as dc
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from safety_systems.cell import human_body
from safety_systems.cell.joint_path import joint_path_state
from safety_systems.cell.operator_paths import make_operator_path, operator_position_velocity
from safety_systems.config.scenario import (
    ScenarioError,
    dump_scenario,
    load_controller_config,
    scenario_from_text,
    validate_scenario,
)
from safety_systems.cell.ur5e import dh_frames, tool0_position
from safety_systems.config.configuration import joint_path
from verification.spaces.box import LIMITS, MIN_GAP, NAMES, WHOLE, Range
from verification.spaces.space import (
    POSTURES,
    TRACKED,
    posture_offsets,
    assumptions,
    corners,
    free_parameters,
    load_space,
    lower_upper,
    make_scenario,
    target_point,
    to_point,
    validate_space,
)

ROOT = Path(__file__).resolve().parents[3]
SPACE = load_space(ROOT / "models/spaces/default.yaml")
FLANGE = load_space(ROOT / "models/spaces/flange.yaml")
CONFIG = load_controller_config(ROOT / "models/configs/iso.yaml")
# The default space with up to four operators, so that n > 2 is exercised too.
WIDE = dc.replace(SPACE, parameters=dc.replace(SPACE.parameters, operators=Range(1.0, 4.0)))
FIXED = settings(derandomize=True, deadline=None, max_examples=40)


def test_default_space_loads_and_validates():
    validate_space(SPACE)
    assert SPACE.name == "default"
    assert set(NAMES) == set(LIMITS)
    lo, hi = lower_upper(SPACE)
    assert np.all(lo <= hi)
    assert SPACE.parameters.peak_speed.max <= 2.0  # ISO 13855 hand speed
    assert "peak_speed" in free_parameters(SPACE)
    assert "braking_time_scale" not in free_parameters(SPACE)  # fixed at 1


@pytest.mark.parametrize("text, field", [
    ("bogus: 1", "bogus"),
    ("parameters:\n  bogus: {min: 0.0, max: 1.0}", "parameters.bogus"),
    ("parameters:\n  peak_speed: {min: 0.5, max: 2.0, mean: 1.0}", "parameters.peak_speed.mean"),
    ("parameters:\n  peak_speed: {min: fast, max: 2.0}", "parameters.peak_speed.min"),
    ("parameters:\n  peak_speed: {min: 1.5, max: 1.0}", "parameters.peak_speed"),
    ("parameters:\n  peak_speed: {min: 0.5, max: 4.5}", "parameters.peak_speed"),
    ("parameters:\n  elevation_deg: {min: -90.0, max: 0.0}", "parameters.elevation_deg"),
    ("parameters:\n  noise_std: {min: -0.001, max: 0.001}", "parameters.noise_std"),
    ("parameters:\n  overshoot: {min: 0.0, max: .inf}", "parameters.overshoot"),
    ("parameters:\n  operators: {min: 1.5, max: 2.0}", "parameters.operators"),
    ("parameters:\n  operators: {min: 1.0, max: 2.5}", "parameters.operators"),
    ("settle_time: 0.0", "settle_time"),
    ("noise_bound_sigmas: -1.0", "noise_bound_sigmas"),
])
def test_bad_space_files_name_the_field(tmp_path, text, field):
    path = tmp_path / "space.yaml"
    path.write_text(f"name: bad\n{text}\n")
    with pytest.raises(ScenarioError) as error:
        load_space(path)
    assert error.value.field == field
    assert field in str(error.value)


@FIXED
@given(name=st.sampled_from(NAMES), below=st.booleans(), by=st.floats(1e-3, 100.0))
def test_ranges_outside_the_limits_are_rejected(name, below, by):
    lo, hi = LIMITS[name]
    if name == "target_link":  # (the robot's capsules: the UR5e's seven)
        hi = 6.0
    bad = Range(lo - by, hi) if below else Range(lo, hi + by)
    space = dc.replace(SPACE, parameters=dc.replace(SPACE.parameters, **{name: bad}))
    with pytest.raises(ScenarioError, match=f"parameters.{name}"):
        validate_space(space)
    validate_space(dc.replace(SPACE, parameters=dc.replace(SPACE.parameters,
                                                           **{name: Range(lo, hi)})))


@pytest.mark.parametrize("space, capsules", [
    ("models/spaces/default.yaml", 7), ("models/spaces/robots/default_ur10e.yaml", 7),
    ("models/spaces/robots/default_panda.yaml", 9)])
def test_target_link_indexes_the_space_robot_s_capsules(space, capsules):
    """Approaches aim at any of the space's robot's capsules (its links', then the
    tool's): the last index is accepted, the one after it refused naming them."""
    space = load_space(ROOT / space)
    last = dc.replace(space, parameters=dc.replace(
        space.parameters, target_link=Range(0.0, capsules - 1.0)))
    validate_space(last)
    over = dc.replace(space, parameters=dc.replace(
        space.parameters, target_link=Range(0.0, float(capsules))))
    with pytest.raises(ScenarioError, match=f"0 <= target_link <= {capsules - 1} .*tool"):
        validate_space(over)


@FIXED
@given(unit=st.lists(st.floats(-0.5, 1.5), min_size=25, max_size=25))
def test_to_point_maps_the_unit_cube_onto_the_ranges(unit):
    free = free_parameters(WIDE)
    unit = np.array(unit[:len(free)])
    values = to_point(WIDE, unit)
    assert set(values) == set(NAMES)
    for name in NAMES:
        r = getattr(WIDE.parameters, name)
        if name not in free:
            assert values[name] == r.min  # fixed parameters keep their value
            continue
        u = min(max(unit[free.index(name)], 0.0), 1.0)
        expected = r.min + u * (r.max - r.min)
        if name in WHOLE:
            assert values[name] == round(expected) and abs(values[name] - expected) <= 0.5
        else:
            assert values[name] == pytest.approx(expected, rel=1e-12, abs=1e-12)
        assert r.min <= values[name] <= r.max
    lo, hi = lower_upper(WIDE)
    assert to_point(WIDE, np.zeros(len(free))) == dict(zip(NAMES, lo.tolist()))
    assert to_point(WIDE, np.ones(len(free))) == dict(zip(NAMES, hi.tolist()))


def _target(space, v, path):
    """The point of the robot the hand goes for, from Drake-independent DH frames: on the
    link's segment between its joints' origins, or from the flange along the tool."""
    frames = dh_frames(joint_path_state(path, v["target_phase"] * path.cycle_time)[0])
    link = int(v["target_link"])
    if link == 6:  # the tool: from the flange along tool0's z axis
        start, axis = frames[6, :3, 3], frames[6, :3, 2] * space.robot.tool_length
        return start + v["target_along"] * axis
    a, b = frames[link, :3, 3], frames[link + 1, :3, 3]
    return a + v["target_along"] * (b - a)


def _check_scenario(space, values):
    v = values
    scenario = make_scenario(space, CONFIG, v, name="probe")
    path = joint_path(space.robot)
    target = _target(space, v, path)
    onset = space.settle_time + v["onset_phase"] * path.cycle_time
    n = int(v["operators"])
    heads = int(v["heads"]) == 1
    assert [o.name for o in scenario.operators] == [f"operator_{j}" for j in range(n)]
    assert scenario.contact_geometry == space.contact_geometry
    azimuths, directions = [], []
    for o in scenario.operators:
        w = [np.array(p.position) for p in o.waypoints]
        assert o.waypoints[0].time == 0.0 and o.waypoints[1].time == pytest.approx(onset)
        assert o.max_speed == v["peak_speed"] and o.max_acceleration == v["acceleration"]
        assert [(b.name, b.point) for b in o.bodies] == list(TRACKED[:2 + heads])
        u = (w[0] - target) / v["start_distance"]
        assert np.linalg.norm(w[0] - target) == pytest.approx(v["start_distance"], abs=1e-9)
        assert math.degrees(math.asin(u[2])) == pytest.approx(v["elevation_deg"], abs=1e-6)
        # The whole body in its posture, relative to the lead point, facing the target
        # (back along the approach's horizontal direction): every point given once, the
        # tracked ones by the bodies, the others by the posture.
        k = int(v["posture"])
        az = math.atan2(u[1], u[0])
        points = {b.point: np.array(b.offset) for b in o.bodies} | {
            q.point: np.array(q.offset) for q in o.posture}
        assert sorted(points) == sorted(human_body.POINTS) and len(o.bodies) + len(
            o.posture) == human_body.NUM_POINTS
        expected = posture_offsets(k, az)
        for name, x in points.items():
            np.testing.assert_allclose(x, expected[name], atol=1e-12)
        lead = np.mean([points[q] for q in POSTURES[k][1]], axis=0)
        np.testing.assert_allclose(lead, 0.0, atol=1e-12)  # the lead point is the reference
        # the posture faces the target: its hands are nearer the target than its pelvis
        facing = -np.array([math.cos(az), math.sin(az), 0.0])
        assert np.mean([points["hand_left"], points["hand_right"]], axis=0) @ facing \
            > points["pelvis"] @ facing
        azimuths.append(math.degrees(math.atan2(u[1], u[0])))
        directions.append(u)
        if v["retreat_distance"] > 0.0:  # away along the approach line, then back in
            assert len(w) == 3
            np.testing.assert_allclose(w[1], w[0] + v["retreat_distance"] * u, atol=1e-9)
        else:
            assert len(w) == 2
        # The final point lies ``overshoot`` past the target, on the line from the start.
        np.testing.assert_allclose(w[-1], target - v["overshoot"] * u, atol=1e-9)
        assert np.linalg.norm(w[-1] - w[0]) == pytest.approx(
            v["start_distance"] + v["overshoot"], abs=1e-9)
        # The hand has arrived, at rest, before the tail of the run.
        op_path = make_operator_path([p.time for p in o.waypoints], w, o.max_speed,
                                     o.max_acceleration)
        p_end, v_end = operator_position_velocity(op_path, scenario.duration - space.tail_time)
        np.testing.assert_allclose(p_end, w[-1], atol=1e-9)
        np.testing.assert_allclose(v_end, 0.0, atol=1e-9)
    turns = np.mod(np.array(azimuths) - azimuths[0], 360.0)
    turns = np.where(turns > 360.0 - 1e-6, 0.0, turns)
    np.testing.assert_allclose(turns, 360.0 / n * np.arange(n), atol=1e-6)
    assert (azimuths[0] - v["azimuth_deg"] + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=1e-6)
    s = scenario.sensor
    assert (s.noise_std, s.latency) == (v["noise_std"], v["latency"])
    if v["dropout"] > MIN_GAP:
        assert len(s.dropouts) == 1
        assert (s.dropouts[0].start, s.dropouts[0].end) == pytest.approx(
            (onset, onset + v["dropout"]))
    else:
        assert s.dropouts == []
    hidden = [n for n, _ in TRACKED][:int(v["occluded_bodies"])]
    bodies = [f"{o.name}/{b.name}" for o in scenario.operators for b in o.bodies]
    if v["occlusion"] > MIN_GAP:
        assert [o.body for o in s.occlusions] == [b for b in bodies
                                                   if b.split("/")[1] in hidden]
        for o in s.occlusions:
            assert (o.start, o.end) == pytest.approx((onset, onset + v["occlusion"]))
    else:
        assert s.occlusions == []
    frames = int(v["outlier_frames"])
    if frames:  # every body, ``frames`` captures after the gaps and the delay
        period = 1.0 / s.rate_hz
        assert [f.body for f in s.faults] == bodies and {f.kind for f in s.faults} == {"outlier"}
        after = onset + max(v["occlusion"], v["dropout"]) + v["outlier_delay"]
        for f in s.faults:
            captures = [k for k in range(int(f.end / period) + 2)
                        if f.start <= k * period + 1e-9 < f.end]
            assert len(captures) == frames and after - 1e-9 <= captures[0] * period
            assert captures[0] * period < after + period
            u = directions[int(f.body.split("/")[0].split("_")[1])]
            np.testing.assert_allclose(f.offset, v["outlier_offset"] * u, atol=1e-12)
    else:
        assert s.faults == []
    assert scenario.robot.braking_time_scale == v["braking_time_scale"]
    assert scenario.robot.cycles * path.cycle_time >= scenario.duration  # keeps working
    assert scenario.contact_distance == space.contact_distance
    assert scenario.controller == CONFIG
    validate_scenario(scenario)
    assert scenario_from_text(dump_scenario(scenario)) == scenario
    return scenario, target


# Coordinates of 0 or not vanishingly small (see test_make_scenario_of_a_tiny_gap).
UNIT = st.one_of(st.just(0.0), st.floats(1e-9, 1.0))


@FIXED
@given(unit=st.lists(UNIT, min_size=25, max_size=25), space=st.sampled_from([WIDE, FLANGE]))
def test_make_scenario_of_any_point(unit, space):
    free = free_parameters(space)
    _check_scenario(space, to_point(space, np.array(unit[:len(free)])))


def test_the_flange_space_is_the_previous_envelope():
    # Its approaches aim at the flange itself (tool0, as before), two gloves, no outliers.
    free = free_parameters(FLANGE)
    assert len(free) == 14 and FLANGE.contact_geometry == "tool_point"
    values = to_point(FLANGE, np.full(len(free), 0.3))
    scenario = make_scenario(FLANGE, CONFIG, values)
    path = joint_path(FLANGE.robot)
    target = tool0_position(joint_path_state(path, values["target_phase"] * path.cycle_time)[0])
    np.testing.assert_array_equal(target_point(FLANGE, values, path), target)  # bit for bit
    w = [np.array(p.position) for p in scenario.operators[0].waypoints]
    np.testing.assert_allclose(w[-1], target - values["overshoot"] * (w[0] - target)
                               / values["start_distance"], atol=1e-12)
    assert scenario.sensor.faults == [] and len(scenario.operators[0].bodies) == 2


def test_make_scenario_hand_picked_point():
    values = to_point(SPACE, np.zeros(len(free_parameters(SPACE))))
    values.update(azimuth_deg=0.0, elevation_deg=0.0, start_distance=1.5, onset_phase=0.5,
                  target_phase=0.25, retreat_distance=0.4, overshoot=0.2, operators=3.0,
                  dropout=0.1, occlusion=0.2, occluded_bodies=2.0, outlier_frames=3.0,
                  outlier_offset=1.2, outlier_delay=0.25, target_link=2.0, target_along=0.5,
                  braking_time_scale=1.7)
    scenario, target = _check_scenario(SPACE, values)
    w = [np.array(p.position) for p in scenario.operators[0].waypoints]
    np.testing.assert_allclose(w[0], target + [1.5, 0.0, 0.0], atol=1e-12)  # azimuth 0: +x
    np.testing.assert_allclose(w[1], target + [1.9, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(w[2], target + [-0.2, 0.0, 0.0], atol=1e-12)
    cycle = joint_path(SPACE.robot).cycle_time
    assert scenario.sensor.dropouts[0].start == pytest.approx(SPACE.settle_time + 0.5 * cycle)
    assert scenario.robot.braking_time_scale == 1.7


@pytest.mark.parametrize("gap", ["dropout", "occlusion"])
def test_make_scenario_of_a_tiny_gap(gap):
    # A gap below MIN_GAP (here below the float resolution at the onset, which once gave
    # an empty interval [onset, onset) that validation rejected) is no gap.
    values = to_point(SPACE, np.zeros(len(free_parameters(SPACE))))
    values.update(onset_phase=0.5, **{gap: 1e-17})
    scenario, _ = _check_scenario(SPACE, values)
    assert scenario.sensor.dropouts == [] and scenario.sensor.occlusions == []


def _fix(space, names):
    """``space`` with the named parameters fixed at their minimum."""
    p = space.parameters
    return dc.replace(space, parameters=dc.replace(
        p, **{n: Range(getattr(p, n).min, getattr(p, n).min) for n in names}))


@pytest.mark.parametrize("fixed", [(), ("peak_speed",), ("peak_speed", "noise_std", "latency")])
def test_corners_are_every_vertex(fixed):
    space = _fix(SPACE, fixed)
    d = len(free_parameters(space))
    assert d == len(free_parameters(SPACE)) - len(fixed)
    c = corners(space)
    assert c.shape == (2**d, d)
    assert set(np.unique(c)) == {0.0, 1.0}
    assert len({tuple(row) for row in c}) == 2**d


def test_corners_of_a_point_space():
    # FAILS (bug in verification/spaces/space.py): with no free parameter, corners() raises
    # "cannot reshape array of size 0" instead of returning the one vertex, shape (1, 0).
    assert corners(_fix(SPACE, NAMES)).shape == (1, 0)


def test_assumptions_state_the_limits():
    p = SPACE.parameters
    odd = dc.replace(SPACE, contact_distance=0.137, notes=["a note"], parameters=dc.replace(
        p, peak_speed=Range(0.5, 1.7), start_distance=Range(0.45, 2.25),
        acceleration=Range(1.0, 7.5), overshoot=Range(0.0, 0.35), occlusion=Range(0.0, 0.15),
        dropout=Range(0.0, 0.07), operators=Range(1.0, 3.0), latency=Range(0.0, 0.03),
        retreat_distance=Range(0.0, 0.6),
        braking_time_scale=Range(1.0, 1.3), elevation_deg=Range(-15.0, 25.0)))
    text = "\n".join(assumptions(odd, CONFIG))
    for piece in ("1.7 m/s", "0.45 to 2.25 m", "7.5 m/s^2", "0.35 m past", "up to 0.15 s",
                  "up to 0.07 s", "1 to 3 operator", "latency 0 to 0.03 s", "by 1 to 1.3",
                  "elevation -15 to 25 deg", "within 0.137 m", "0.6 m before reversing",
                  f"{CONFIG.sensor.rate_hz:g} Hz", f"{odd.noise_bound_sigmas:g} sigma"):
        assert piece in text, piece
    assert assumptions(odd, CONFIG)[-1] == "a note"
    no_retreat = dc.replace(odd, parameters=dc.replace(odd.parameters,
                                                       retreat_distance=Range(0.0, 0.0)))
    assert "without retreat" in "\n".join(assumptions(no_retreat, CONFIG))


def test_space_on_a_task_path_targets_points_of_that_path():
    """A space whose robot runs a planned task path (read from its file, relative to the
    space file): the hand goes for where the tool is on that path."""
    space = load_space(ROOT / "models/spaces/ewaste.yaml")
    points = np.array(space.robot.path.task_path.points)
    assert len(points) > 2
    values = to_point(space, np.zeros(len(free_parameters(space))))
    values.update(target_phase=0.25, overshoot=0.0)  # half-way along the way out
    scenario = make_scenario(space, CONFIG, values)
    target = np.array(scenario.operators[0].waypoints[-1].position)
    gap = np.linalg.norm(points - target, axis=1).min()
    assert gap < 0.01  # on the planned polyline (its IK samples are 1 cm apart)
    assert not np.allclose(target, points[0]) and not np.allclose(target, points[-1])


def test_space_task_path_file_errors_name_the_field(tmp_path):
    text = (ROOT / "models/spaces/ewaste.yaml").read_text().replace(
        "../scenes/paper_task_path.yaml", "missing.yaml")
    path = tmp_path / "space.yaml"
    path.write_text(text)
    with pytest.raises(ScenarioError, match=r"robot\.path\.task_path\.file"):
        load_space(path)


def test_every_posture_is_a_body_the_model_allows_and_the_default_space_has_them_all():
    # The truth the properties measure must be a person the monitor's model allows (the
    # proofs check it of a space: premises.body_model_holds); each posture leads with the
    # point it names and faces its approach.
    for k, (name, lead, _) in enumerate(POSTURES):
        points = np.array([posture_offsets(k)[q] for q in human_body.POINTS])
        assert human_body.posture_violations(points, human_body.dimensions()) == [], name
        np.testing.assert_allclose(np.mean([posture_offsets(k)[q] for q in lead], axis=0),
                                   0.0, atol=1e-12)
    p = load_space(ROOT / "models/spaces/default.yaml").parameters.posture
    assert (p.min, p.max) == (0.0, len(POSTURES) - 1.0)
    # a posture that breaks the model is seen: a forearm stretched past the table's
    stretched = posture_offsets(0)
    stretched["hand_right"] = stretched["elbow_right"] + [0.5, 0.0, 0.0]
    assert human_body.posture_violations(np.array([stretched[q] for q in human_body.POINTS]),
                                         human_body.dimensions())
