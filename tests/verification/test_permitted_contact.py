"""Contact where ISO/TS 15066 allows it (safety.mode: ssm_pfl), in the Drake diagram: a
head approach never touches while the robot moves, a hand pressed by a robot that keeps
moving is a counterexample and a brief contact it comes off is not (the hand drawn back, or
the robot moving off a hand held still), a hand on the robot's
own table and a forearm between two links keep pure SSM with no surface declared; and the
proofs' power and force limiting premises (issues 36, 46)."""

import dataclasses

import numpy as np
import pytest

from safety_systems.cell.human_body import POINTS, SEGMENT_NAMES
from safety_systems.cell.operator_paths import make_operator_path
from safety_systems.config.configuration import pfl_terms
from safety_systems.config.scenario import Box, Waypoint, load_controller_config
from safety_systems.diagrams.simulation import simulate_workcell
from safety_systems.diagrams.workcell import MakeWorkcell
from safety_systems.sensing.stops import STOP_REASONS
from verification.search.evaluate_batch import evaluate_many
from safety_systems.outputs.metrics import robot_contact_state, robot_speed, true_pairs
from safety_systems.ssm.true_measures import moving
from verification.proof.theorems import prove_permitted_contact
from verification.search.evaluate_drake import evaluate_drake
from verification.spaces.box import Range
from verification.spaces.space import (
    free_parameters,
    load_space,
    make_scenario,
    space_cell,
    to_point,
)

REACH = load_space("tests/verification/data/pfl_reach.yaml")
DEFAULT = load_space("models/spaces/default.yaml")
HEAD, NECK, HAND, FOREARM = (SEGMENT_NAMES.index(n) for n in ("head", "neck", "hand_right",
                                                               "forearm_right"))


def _config(name, **safety):
    config = load_controller_config(f"models/configs/{name}.yaml")
    return dataclasses.replace(config, safety=dataclasses.replace(config.safety, **safety))


# A hand held in a long tool's path (tests/verification/data/pfl_reach.yaml), the operator
# tracked in full (tight segments), the robot on a small pedestal: nothing can clamp the
# hand, so the caps are power and force limiting's own.
SUIT = dataclasses.replace(REACH, tracked=list(POINTS), robot=dataclasses.replace(
    REACH.robot, tool_length=0.3, mounting_size=[0.3, 0.3]))
# The seed's estimated speeds on the whole robot, with power and force limiting, and a
# robot force limit (50 N with its tolerance) low enough for its contact detection to hold
# a lasting contact within the quasi-static compressions at the caps it allows (mm/s).
SEED_PFL = _config("seed_estimated", mode="ssm_pfl", robot_geometry="capsules",
                   clamp_margin=0.0, tool_length=0.3, contact_stop_force=50.0)


def _contacts(run):
    """(segment, relative speed) of every pair in contact while the robot moves."""
    clearance, _, v_r = true_pairs(run)
    speed = robot_speed(robot_contact_state(run)[1])
    touch = (np.nan_to_num(clearance, nan=np.inf) < 0.0) & moving(speed)[:, None, None]
    _, segment, _ = np.nonzero(touch)
    return segment % len(SEGMENT_NAMES), v_r[touch]


def test_a_hand_pressed_by_a_robot_that_keeps_moving_is_a_counterexample(monkeypatch):
    """Issue 46: caps from the impact speeds alone (the rule before it, put back here) let
    the robot run into a hand held still in its path at the hand's 1.2 m/s limit and press
    on until its force limit (175 N, held 0.25 s) stops it: 0.17 m into the hand, within
    the speed limit at every tick. The property calls it a counterexample (a compression,
    m), in both evaluators, which agree; the robot's contact stop held it afterwards."""
    import safety_systems.config.configuration as configuration

    monkeypatch.setattr(configuration, "pressing_speeds",
                        lambda x, *args: np.full(len(x), np.inf))
    config = dataclasses.replace(SEED_PFL, safety=dataclasses.replace(
        SEED_PFL.safety, contact_stop_force=175.0))
    scenario = make_scenario(SUIT, config, to_point(SUIT, np.array([0.0])), name="pressed")
    batch = evaluate_many([scenario])
    drake, run = evaluate_drake(scenario)
    assert drake.permitted_contact == pytest.approx(batch.permitted_contact[0], abs=1e-9)
    segment, v = _contacts(run)
    limits = pfl_terms(scenario.robot, scenario.controller).limits
    assert np.any(segment == HAND) and np.all(v <= limits[segment])  # every impact legal
    assert drake.permitted_contact < -0.1  # yet the robot pressed 0.1 m past the limits
    x_qs = pfl_terms(scenario.robot, scenario.controller).compressions[HAND, 1]
    full = simulate_workcell(MakeWorkcell(scenario))
    assert full["contact_stop.contact_stop"].max() == 1.0  # its detection stopped it
    stop = full["override.stop_reason"][:, 0] == STOP_REASONS.index("contact")
    assert stop.any() and np.all(full["override.path_speed_commanded"][stop, 0] == 0.0)
    assert x_qs < 0.002


# The tool held near one point (a 1 cm line): the hand goes for it and finds it there.
CREEP = dataclasses.replace(SUIT, robot=dataclasses.replace(SUIT.robot, path=dataclasses.replace(
    SUIT.robot.path, task_path=dataclasses.replace(
        SUIT.robot.path.task_path, points=[[0.6, -0.005, 0.2], [0.6, 0.005, 0.2]],
        speed=0.02))))


def _touching(run):
    clearance = np.nan_to_num(true_pairs(run)[0], nan=np.inf).min(axis=-1)
    return (clearance < 0.0).any(axis=1)


def _reachable(op, times, positions) -> bool:
    """Whether the operator can walk ``positions`` departing at ``times``."""
    try:
        make_operator_path(times, positions, op.max_speed, op.max_acceleration)
    except ValueError:
        return False
    return True


def test_a_contact_ends_in_the_window_or_stops_within_the_quasi_static_limit():
    """The caps that keep a lasting contact within the limits (the robot creeps at mm/s
    near the hand): a hand held on the tool for seconds is pressed less than the
    quasi-static compression (permitted); a hand drawn back 0.2 s after the touch leaves
    a brief contact within the transient compression (permitted). Each is the contact's own figure (m), not the
    no-contact fallback, and both evaluators agree."""
    scenario = make_scenario(CREEP, SEED_PFL, to_point(CREEP, np.array([0.0])), name="held")
    x_tr, x_qs, _ = pfl_terms(scenario.robot, scenario.controller).compressions[HAND]
    drake, run = evaluate_drake(scenario)
    assert drake.permitted_contact == pytest.approx(evaluate_many([scenario]).permitted_contact[0],
                                                    abs=1e-9)
    touching = _touching(run)
    assert touching[-1] and run.time[touching][0] < run.time[-1] - 1.0  # held for seconds
    assert 0.0 <= drake.permitted_contact <= x_qs  # pressed less than x_qs, for seconds
    # The hand stopped 2 cm into the tool (its ball meets the tool's capsule 0.17 m from
    # the axis), and drawn back as soon as it is there.
    (op,) = scenario.operators
    start, target = (np.array(w.position) for w in op.waypoints[:2])
    reach = np.linalg.norm(target - start)
    short = start + (target - start) * (reach - 0.15) / reach
    times = np.arange(op.waypoints[1].time + 0.1, op.waypoints[1].time + 3.0, 0.01)
    leave = next(t for t in times if _reachable(op, [op.waypoints[0].time,
                                                     op.waypoints[1].time, t],
                                                 [start, short, start]))
    back = dataclasses.replace(op, waypoints=[op.waypoints[0], Waypoint(
        op.waypoints[1].time, short.tolist()), Waypoint(float(leave), start.tolist())])
    brief = dataclasses.replace(scenario, name="brief", operators=[back])
    drake, run = evaluate_drake(brief)
    assert drake.permitted_contact == pytest.approx(evaluate_many([brief]).permitted_contact[0],
                                                    abs=1e-9)
    touching = _touching(run)
    span = run.time[touching]
    assert span.size and span[-1] - span[0] < 0.5 and not touching[-1]  # over in the window
    assert 0.0 <= drake.permitted_contact <= x_tr


def test_a_brief_impact_the_robot_itself_comes_off_is_permitted(monkeypatch):
    """A hand held still beside the tool's path (the reach's hand moved 0.168 m off it, so
    that the passing tool grazes it 2 mm deep), with the impact speeds' caps alone (as in
    the pressed hand's test): the robot runs on, meets the hand at each pass and moves off
    it within the window by its own motion. Each contact is an impact below the hand's
    limit and a compression within x_tr: permitted, in both evaluators alike. The same
    pass 20 mm deep (0.15 m off) is a counterexample: its compression is beyond x_tr."""
    from safety_systems.config import configuration

    monkeypatch.setattr(configuration, "pressing_speeds",
                        lambda x, *args: np.full(len(x), np.inf))
    config = dataclasses.replace(SEED_PFL, safety=dataclasses.replace(
        SEED_PFL.safety, contact_stop_force=175.0))
    base = make_scenario(SUIT, config, to_point(SUIT, np.array([0.0])), name="grazed")
    (op,) = base.operators
    held = op.waypoints[-1].time  # the hand holds still from here

    def beside(offset):
        moved = [Waypoint(w.time, (np.array(w.position) + [offset, 0.0, 0.0]).tolist())
                 for w in op.waypoints]
        return dataclasses.replace(base, operators=[dataclasses.replace(op, waypoints=moved)])

    scenario = beside(0.168)
    drake, run = evaluate_drake(scenario)
    assert drake.permitted_contact == pytest.approx(
        evaluate_many([scenario]).permitted_contact[0], abs=1e-9)
    touching = _touching(run)
    starts = np.flatnonzero(np.diff(touching.astype(int)) == 1) + 1
    ends = np.flatnonzero(np.diff(touching.astype(int)) == -1) + 1
    assert len(starts) >= 2 and len(ends) == len(starts) and not touching[-1]
    assert run.time[starts[0]] > held  # the hand was still: the robot came and went
    assert np.all(run.time[ends] - run.time[starts] < 0.5)  # each over within the window
    segment, v = _contacts(run)
    limits = pfl_terms(scenario.robot, scenario.controller).limits
    assert np.any(segment == HAND) and np.all(v <= limits[segment])  # impacts, below limits
    x_tr = pfl_terms(scenario.robot, scenario.controller).compressions[HAND, 0]
    assert 0.0 <= drake.permitted_contact <= x_tr  # the contact's own figure: permitted
    deeper, _ = evaluate_drake(beside(0.15))
    assert deeper.permitted_contact < 0.0


@pytest.mark.parametrize("start", [3.0, 3.5, 4.0])
def test_a_head_approach_never_touches_while_the_robot_moves(start):
    # The trunk leaning in, the head leading (posture 4), at the forearm and the tool
    # from beyond S, under ISO's speeds with power and force limiting and S by speed: the
    # robot may run on at the arms' caps, never into the head or the neck.
    config = _config("iso", mode="ssm_pfl", stopping="by_speed")
    point = dict(to_point(DEFAULT, np.full(len(free_parameters(DEFAULT)), 0.5)), posture=4.0,
                 start_distance=start, operators=1.0, occlusion=0.0, outlier_frames=0.0,
                 target_link=2.0 if start < 3.5 else 6.0, peak_speed=2.0)
    scenario = make_scenario(DEFAULT, config, point, name="head")
    drake, run = evaluate_drake(scenario)
    segment, _ = _contacts(run)
    assert not np.any(np.isin(segment, (HEAD, NECK)))
    assert drake.permitted_contact >= 0.0
    clearance, _, _ = true_pairs(run)
    speed = robot_speed(robot_contact_state(run)[1])
    head = np.nan_to_num(clearance[:, [HEAD, NECK]], nan=np.inf).min(axis=(1, 2))
    assert np.all(head[moving(speed)] > 0.0)
    assert np.isfinite(head[moving(speed)]).any()  # the robot moved while it was there


# A bench under the hand, declared: its top 2 cm below the hand's ball.
BENCH = Box([0.3, -0.6, -0.2], [0.9, 0.6, 0.06])


def _low(space, z=0.12, **robot):
    """``space`` with the tool's line at height z (m above the robot's mounting surface)."""
    path = space.robot.path
    line = dataclasses.replace(path.task_path, points=[[0.6, -0.3, z], [0.6, 0.3, z]])
    return dataclasses.replace(space, robot=dataclasses.replace(
        space.robot, path=dataclasses.replace(path, task_path=line), **robot))


def _caps_and_closest(space, config, segment):
    """(the segment's caps in force over the run, its least true clearance, the run's
    robustness) of the space's one scenario."""
    scenario = make_scenario(space, config, to_point(space, np.array([0.0])), name="clamp")
    run = simulate_workcell(MakeWorkcell(scenario))
    clearance = np.nan_to_num(true_pairs(run)[0], nan=np.inf).min(axis=-1)[:, segment]
    return run["override.segment_caps"][:, segment], clearance.min(), evaluate_drake(scenario)[0]


def test_a_hand_on_the_robots_own_table_and_a_forearm_between_two_links_keep_pure_ssm():
    """Issue 46, with no surface declared: a hand held just above the table the robot
    stands on, under the tool, has no cap (on a small pedestal it keeps one); a forearm
    reached across the robot's elbow, between its upper arm and forearm, has none."""
    pedestal = _low(SUIT)
    table = _low(SUIT, mounting_size=[])
    caps, closest, _ = _caps_and_closest(pedestal, SEED_PFL, HAND)
    assert caps.max() > 0.0 and closest < 0.15
    caps, closest, result = _caps_and_closest(table, SEED_PFL, HAND)
    assert caps.max() == 0.0 and closest < 0.15  # as near, and pure SSM throughout
    assert result.permitted_contact >= 0.0
    fold = dataclasses.replace(_low(SUIT, z=0.2, tool_length=0.0), parameters=dataclasses.replace(
        SUIT.parameters, posture=Range(1.0, 1.0), target_link=Range(2.0, 2.0),
        target_along=Range(0.0, 0.0)))  # the forearm across the robot's elbow
    config = dataclasses.replace(SEED_PFL, safety=dataclasses.replace(SEED_PFL.safety,
                                                                      tool_length=0.0))
    caps, closest, result = _caps_and_closest(fold, config, FOREARM)
    assert caps.max() == 0.0 and closest < 0.0  # it reached in: pure SSM near both links
    assert result.permitted_contact >= 0.0
    # a declared bench keeps the hand at pure SSM on the pedestal too
    bench = dataclasses.replace(SEED_PFL, safety=dataclasses.replace(
        SEED_PFL.safety, fixed_surfaces=[BENCH]))
    assert _caps_and_closest(pedestal, bench, HAND)[0].max() == 0.0


def test_the_proof_states_and_checks_the_power_and_force_limiting_premises():
    # a robot force limit whose detection can hold a lasting contact: caps of a few mm/s
    config = _config("iso", mode="ssm_pfl", stopping="by_speed", contact_stop_force=50.0,
                     clamp_margin=2.0)
    proof = prove_permitted_contact(space_cell(config, DEFAULT), DEFAULT)
    assert proof.proved
    statements = [p.statement for p in proof.premises]
    assert any("c_i V_R <= v_i" in s for s in statements)
    assert any("a contact that lasts" in s and p.holds
               for s, p in zip(statements, proof.premises))
    for trusted in ("Annex A", "contact detection", "transient contact's window",
                    "mounting surface"):
        assert any(trusted in s and p.basis == "trusted"
                   for s, p in zip(statements, proof.premises)), trusted
    assert proof.property == "permitted_contact"
    pressed = np.array(proof.terms["pressed_most"])
    x_qs = np.array(proof.terms["quasi_static_compression"])
    caps = np.array(proof.terms["caps"])
    assert np.any(caps > 0.0) and np.all(pressed[caps > 0.0] <= x_qs[caps > 0.0])
    # too little clamping margin (the robot's own table and links clamp by default): the
    # premise fails, no proof
    tight = dataclasses.replace(config, safety=dataclasses.replace(config.safety,
                                                                   clamp_margin=0.3))
    tight_proof = prove_permitted_contact(space_cell(tight, DEFAULT), DEFAULT)
    assert not tight_proof.proved
    assert any("clamping" in p.statement and not p.holds for p in tight_proof.premises)
    # the robot's default force limit (150 N and its tolerance) holds no lasting contact
    # within the quasi-static limits: every cap is 0 (pure SSM), and that is proved as such
    default = dataclasses.replace(config, safety=dataclasses.replace(config.safety,
                                                                     contact_stop_force=175.0))
    assert not np.any(pfl_terms(DEFAULT.robot, default).caps > 0.0)
