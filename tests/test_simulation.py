"""End to end on the inspection scenario (seed Section 7.1), what ``simulate`` writes of
it (per operator and body slot), and the two plant modes."""

import csv
import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from safety_systems.cell.human_body import SEGMENT_NAMES
from safety_systems.config.configuration import truth_recipe
from safety_systems.config.resolved_cell import resolve_scenario
from safety_systems.outputs.metrics import hidden, tool_state, true_separations
from safety_systems.outputs.run_files import trace_table, write_outputs, write_trace
from safety_systems.config.scenario import load_scenario
from safety_systems.diagrams.simulation import simulate
from safety_systems.sensing.stops import STOP_SEPARATION
from safety_systems.sensing.tracks import TRACK_HIDDEN, TRACK_TRACKING
from safety_systems.ssm.formulas import level_at_or_above, separation_distances

SCENARIOS = Path(__file__).parents[1] / "models" / "scenarios"


@pytest.fixture(scope="module")
def inspection(tmp_path_factory):
    scenario = load_scenario(SCENARIOS / "inspection_seed.yaml")
    run = simulate(scenario)
    out = tmp_path_factory.mktemp("inspection")
    summary = write_outputs(run, out)
    return scenario, run, out, summary


def _k(run):
    return run["override.path_speed_commanded"][:, 0]


def test_full_speed_while_the_operator_is_far(inspection):
    _, run, _, _ = inspection
    far = (run.time > 1.0) & (run.time < 8.0)  # standing 3.7 m away (STEP 1)
    assert np.all(np.nanmin(true_separations(run)[far], axis=1) > 3.5)
    # The monitor sees the gloves only: the trunk's envelope reaches 1.5 m nearer.
    assert np.all(np.nanmin(run["monitor.distances"][far], axis=1) > 2.0)
    assert np.all(_k(run)[far] == 1.0)
    assert np.all(run["follower.path_state"][far, 1] == 1.0)


def test_stop_inside_d_min(inspection):
    scenario, run, _, _ = inspection
    d_min = scenario.controller.safety.d_min
    d = run["monitor.distances"]
    inside = np.min(np.where(np.isnan(d), np.inf, d), axis=1) < d_min
    assert inside.sum() > 500  # the operator leans in for more than a second (STEP 4)
    assert np.all(_k(run)[inside] == 0.0)
    # The true distance was inside d_min too, and the robot came to rest there.
    _, speed = tool_state(run)
    t_inside = run.time[inside]
    settled = inside & (run.time > t_inside[0] + 0.6)
    assert np.all(speed[settled] < 1e-9)


def test_robot_resumes_after_the_operator_leaves(inspection):
    _, run, _, summary = inspection
    stopped = np.flatnonzero(_k(run) == 0.0)
    last_stop = run.time[stopped[-1]]
    # Held while the envelope of the trunk (bounded from the gloves) is within S: until
    # the technician has backed well away (STEP 5, at 32 s 5 m out).
    assert 30.0 < last_stop < 36.0
    after = run.time > 41.0  # the operator has left the cell (STEP 6; leave_time 40 s)
    assert np.all(run["tracker.track_status"][after] == 0)
    assert np.all(run["envelopes.segment_status"][after] == 0)
    unfinished = run["follower.path_state"][:, 2] < 0.5
    assert np.all(_k(run)[after] == 1.0)
    assert np.all(run["follower.path_state"][after & unfinished, 1] == 1.0)
    assert run["follower.path_state"][-1, 0] > run["follower.path_state"][after, 0][0]
    assert summary["task_time"] is None or summary["task_time"] > 41.0


def _read_trace(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    words = {"stop_reason", "zone", "nearest_true", "nearest_measured"}  # as names
    cols = {h: np.array([r[i] if h.rsplit(":", 1)[-1] in words
                         else float(r[i]) if r[i] else np.nan
                         for r in body]) for i, h in enumerate(header)}
    return cols


def _least(d, names, operator):
    """(T,) least d over the columns of ``names`` ("operator/segment") of ``operator``,
    NaN where all are NaN, and the segment that has it ("" there)."""
    columns = [i for i, n in enumerate(names) if n.rsplit("/", 1)[0] == operator]
    part = np.where(np.isnan(d[:, columns]), np.inf, d[:, columns])
    j = np.argmin(part, axis=1)
    least = part[np.arange(len(d)), j]
    none = np.isinf(least)
    which = np.array([names[columns[x]].rsplit("/", 1)[1] for x in j])
    return (np.where(none, np.nan, least), np.where(none, "", which),
            np.array(columns)[j])


def test_summary_matches_trace(inspection):
    scenario, run, out, summary = inspection
    assert summary == json.loads((out / "summary.json").read_text())
    trace = _read_trace(out / "trace.csv")
    assert len(trace["time"]) == len(run.time)
    # One operator's columns, then its body slots' (the gloves)
    assert [h for h in trace if h.startswith("technician")] == [
        "technician:d_true", "technician:nearest_true", "technician:d_measured",
        "technician:nearest_measured", "technician:S", "technician/right_glove:hidden",
        "technician/left_glove:hidden"]
    d_true = np.column_stack([v for k, v in trace.items() if k.endswith(":d_true")])
    moving = trace["robot_speed"] > 1e-3
    closest = np.nanmin(np.where(np.isnan(d_true), np.inf, d_true), axis=1)
    min_sep = closest[moving].min()
    assert summary["min_separation_while_moving"] == pytest.approx(min_sep, rel=1e-5)
    assert summary["contact_while_moving"] == bool(min_sep < scenario.contact_distance)
    assert summary["min_separation"] == pytest.approx(np.nanmin(d_true), rel=1e-5)
    dt = np.diff(trace["time"], append=trace["time"][-1])
    finished_at = summary["task_time"]
    before_end = trace["time"] < (np.inf if finished_at is None else finished_at)
    assert summary["stopped_time"] == pytest.approx(
        dt[(trace["path_rate"] == 0.0) & before_end].sum(), abs=2e-3)
    if finished_at is not None:  # the task ends when the path rate drops to rest for good
        assert np.all(trace["path_rate"][trace["time"] >= finished_at] == 0.0)
        assert trace["path_rate"][trace["time"] < finished_at][-1] > 0.0
    for body in run.body_names:
        assert summary["hidden_time"][body] == pytest.approx(
            np.sum(dt[trace[f"{body}:hidden"] > 0.5]), abs=1e-9)
    assert (out / "plot.png").stat().st_size > 10_000


def test_trace_per_operator_is_its_nearest_segment(inspection):
    # The trace's operator columns against the run's segments, recomputed here: the least
    # true clearance and the least monitored d over the twelve segments, which segment
    # has each (by name), and S of the monitored one; to the 6 digits written.
    scenario, run, out, _ = inspection
    trace = _read_trace(out / "trace.csv")
    truth, monitored = truth_recipe(scenario), resolve_scenario(scenario).recipe
    least, name, _ = _least(true_separations(run), truth.names, "technician")
    present = run["operators.operators_present"][:, 0] > 0.5
    assert np.all(np.isnan(least) == ~present) and (~present).sum() > 1000  # gone at 40 s
    np.testing.assert_allclose(trace["technician:d_true"], least, rtol=1e-5, atol=1e-9)
    assert np.all(trace["technician:nearest_true"] == name)
    # Nearest in truth: a forearm (the hand held out towards the robot), never the trunk
    assert set(name[present]) <= {"forearm_left", "forearm_right", "hand_left", "hand_right"}
    least, name, column = _least(run["monitor.distances"], monitored.names, "technician")
    np.testing.assert_allclose(trace["technician:d_measured"], least, rtol=1e-5, atol=1e-9)
    assert np.all(trace["technician:nearest_measured"] == name)
    assert set(name) <= set(SEGMENT_NAMES) | {""} and "lower_trunk" in set(name)
    s = run["monitor.protective_distances"][np.arange(len(run.time)), column]
    np.testing.assert_allclose(trace["technician:S"], np.where(name == "", np.nan, s),
                               rtol=1e-5, atol=1e-9)
    # The override's S_max is the largest S of the segments; the nearest one's is in it.
    tracked = name != ""
    assert np.all(trace["technician:S"][tracked] <= trace["S_max"][tracked] + 1e-9)
    # Where the override stopped for separation, the nearest segment was within S (or
    # d_min) or another segment's S (S_max) was larger than that segment's d.
    k = trace["k"]
    held = trace["stop_reason"] == "separation"
    assert np.all(trace["technician:d_measured"][held & tracked]
                  < np.maximum(scenario.controller.safety.delta_s * trace["S_max"],
                               scenario.controller.safety.d_min)[held & tracked] + 1e-5)
    assert np.all(k[(trace["technician:d_measured"] > 2.0 * trace["S_max"] + 1e-3)
                    & (trace["technician:d_measured"] > 0.3) & tracked] == 1.0)
    for i, body in enumerate(run.body_names):
        np.testing.assert_array_equal(trace[f"{body}:hidden"], hidden(run)[:, i])


@pytest.mark.parametrize("name", ["co_kitting", "erga_positive", "ewaste_sorting"])
def test_trace_columns_per_operator_and_body(name, tmp_path):
    # Two operators (co_kitting: columns for each, its own segments); the seed-004
    # controllers (erga) and the zones: no monitor, the tool's distance to each body's
    # estimate per body slot, as they see it.
    scenario = load_scenario(SCENARIOS / f"{name}.yaml")
    run = simulate(scenario, duration=min(scenario.duration, 20.0))  # co_kitting: B at 16 s
    write_trace(run, tmp_path / "trace.csv")
    trace = _read_trace(tmp_path / "trace.csv")
    truth = truth_recipe(scenario)
    ssm = scenario.controller.type == "ssm_override"
    tool = tool_state(run)[0]
    first = 0
    expected = []
    for o in scenario.operators:
        expected += [f"{o.name}:d_true", f"{o.name}:nearest_true"]
        if ssm:
            expected += [f"{o.name}:d_measured", f"{o.name}:nearest_measured", f"{o.name}:S"]
        least, segment, _ = _least(true_separations(run), truth.names, o.name)
        np.testing.assert_allclose(trace[f"{o.name}:d_true"], least, rtol=1e-5, atol=1e-9)
        assert np.all(trace[f"{o.name}:nearest_true"] == segment)
        if ssm:
            least, segment, _ = _least(run["monitor.distances"],
                                       resolve_scenario(scenario).recipe.names, o.name)
            np.testing.assert_allclose(trace[f"{o.name}:d_measured"], least, rtol=1e-5,
                                       atol=1e-9)
            assert np.all(trace[f"{o.name}:nearest_measured"] == segment)
        for b in o.bodies:
            body = f"{o.name}/{b.name}"
            assert run.body_names[first] == body
            if not ssm:
                expected.append(f"{body}:d_measured")
                seen = separation_distances(
                    tool, run.bodies("tracker.positions_estimated")[:, first:first + 1])[:, 0]
                np.testing.assert_allclose(trace[f"{body}:d_measured"], seen, rtol=1e-5,
                                           atol=1e-9)
            expected.append(f"{body}:hidden")
            first += 1
    assert [h for h in trace if ":" in h] == expected
    for o in scenario.operators:  # each was in the cell
        assert np.any(np.isfinite(trace[f"{o.name}:d_true"]))


def test_trace_s_under_by_speed_is_the_level_the_override_used(inspection):
    # safety.stopping: by_speed: S of the nearest segment at the level the override held
    # the distances to (the larger of the rate's level and k's); checked against the
    # override's own S_max (the largest S of the monitored segments at that level).
    scenario = inspection[0]
    safety = dataclasses.replace(scenario.controller.safety, stopping="by_speed")
    scenario = dataclasses.replace(
        scenario, controller=dataclasses.replace(scenario.controller, safety=safety))
    run = simulate(scenario, duration=12.0)
    header, rows = trace_table(run)
    s = rows[:, header.index("technician:S")]
    t, m = run["monitor.distances"].shape
    levels = run["monitor.level_protective_distances"].reshape(t, -1, m)
    g = levels.shape[1] - 1
    rate = run["follower.path_state"][:, 1]
    level = np.maximum([level_at_or_above(r, g) for r in rate],
                       np.rint(run["override.path_speed_commanded"][:, 0] * g).astype(int))
    at_level = levels[np.arange(t), level]
    usable = np.isin(run["envelopes.segment_status"], (TRACK_TRACKING, TRACK_HIDDEN))
    top = np.where(usable, at_level, -np.inf).max(axis=1)
    reason = run["override.stop_reason"][:, 0]
    decided = (reason <= STOP_SEPARATION) & np.isfinite(top)
    assert decided.sum() > 0.9 * t
    np.testing.assert_allclose(top[decided], run["override.max_protective_distance"][decided, 0])
    _, _, column = _least(run["monitor.distances"], resolve_scenario(scenario).recipe.names,
                          "technician")
    tracked = np.isfinite(rows[:, header.index("technician:d_measured")])
    np.testing.assert_allclose(s[tracked], at_level[np.arange(t), column][tracked])
    # It slowed through the levels (not only full speed and stop), so levels below G count
    k = run["override.path_speed_commanded"][:, 0]
    assert np.any((k > 0.0) & (k < 1.0)) and np.any(level[decided] < g)


def test_dynamic_and_kinematic_modes_agree_on_the_tool_path():
    """The dynamic plant (inverse-dynamics tracking) follows the braked reference:
    over the approach and slow-down of the inspection task the tool positions of the
    two modes agree within 5 mm."""
    scenario = load_scenario(SCENARIOS / "inspection_seed.yaml")
    runs = {
        mode: simulate(dataclasses.replace(
            scenario, robot=dataclasses.replace(scenario.robot, mode=mode)), duration=12.0)
        for mode in ("kinematic", "dynamic")
    }
    p_kin, _ = tool_state(runs["kinematic"])
    p_dyn, _ = tool_state(runs["dynamic"])
    assert np.linalg.norm(p_kin - p_dyn, axis=1).max() < 0.005
    # The run exercised the override (it slowed down), so the agreement is closed loop.
    assert _k(runs["dynamic"]).min() < 0.9


def test_a_run_stops_on_purpose_only_when_the_whole_run_shows_it():
    # ``until`` sees the logs since its last look; once it holds the run goes on for the
    # margin, and stops there only if it holds for the whole run so far.
    from safety_systems.diagrams.simulation import simulate_workcell
    from safety_systems.diagrams.workcell import MakeWorkcell

    scenario = dataclasses.replace(load_scenario("models/scenarios/inspection_seed.yaml"),
                                   duration=3.0)
    whole = simulate(scenario)
    looks = []

    def late(run):  # a slice that starts after 1 s: true; the whole run (from 0): false
        looks.append(run.time.size)
        return run.time.size > 0 and run.time[0] > 1.0

    run = simulate_workcell(MakeWorkcell(scenario), until=late, check_every=0.5,
                            margin=0.25)
    assert run.time[-1] == whole.time[-1] and len(looks) >= 3
    # Slices of about 0.5 s (and the overlap) each, then the whole run at the cut.
    assert max(looks[:-1]) < 0.6 / 0.002 and looks[-1] > 1.0 / 0.002
    for key in whole.signals:  # the same run
        np.testing.assert_array_equal(run[key], whole[key])
    cut = simulate_workcell(MakeWorkcell(scenario), until=lambda r: r.time.size > 0,
                            check_every=0.5, margin=0.25)
    assert cut.time[-1] == pytest.approx(0.75, abs=0.003)
    for key in whole.signals:
        np.testing.assert_array_equal(cut[key], whole[key][:cut.time.size])
