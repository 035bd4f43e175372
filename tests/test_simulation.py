"""End to end on the inspection scenario (seed Section 7.1), and the two plant modes."""

import csv
import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from safety_systems.outputs.metrics import tool_state
from safety_systems.outputs.run_files import write_outputs
from safety_systems.config.scenario import load_scenario
from safety_systems.diagrams.simulation import simulate

SCENARIOS = Path(__file__).parents[1] / "models" / "scenarios"


@pytest.fixture(scope="module")
def inspection(tmp_path_factory):
    scenario = load_scenario(SCENARIOS / "inspection.yaml")
    run = simulate(scenario)
    out = tmp_path_factory.mktemp("inspection")
    summary = write_outputs(run, out)
    return scenario, run, out, summary


def _k(run):
    return run["override.path_speed_commanded"][:, 0]


def test_full_speed_while_the_operator_is_far(inspection):
    _, run, _, _ = inspection
    far = (run.time > 1.0) & (run.time < 8.0)  # standing 3.7 m away (STEP 1)
    assert np.all(np.nanmin(run["monitor.distances"][far], axis=1) > 3.0)
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
    assert 20.0 < last_stop < 30.0
    after = run.time > 41.0  # the operator has left the cell (STEP 6; leave_time 40 s)
    assert np.all(run["tracker.track_status"][after] == 0)
    unfinished = run["follower.path_state"][:, 2] < 0.5
    assert np.all(_k(run)[after] == 1.0)
    assert np.all(run["follower.path_state"][after & unfinished, 1] == 1.0)
    assert summary["task_time"] is not None and summary["task_time"] > 38.0


def _read_trace(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    words = {"stop_reason", "zone"}  # written as names
    cols = {h: np.array([r[i] if h in words else float(r[i]) if r[i] else np.nan
                         for r in body]) for i, h in enumerate(header)}
    return cols


def test_summary_matches_trace(inspection):
    scenario, run, out, summary = inspection
    assert summary == json.loads((out / "summary.json").read_text())
    trace = _read_trace(out / "trace.csv")
    assert len(trace["time"]) == len(run.time)
    d_true = np.column_stack([v for k, v in trace.items() if k.endswith(":d_true")])
    moving = trace["robot_speed"] > 1e-3
    closest = np.nanmin(np.where(np.isnan(d_true), np.inf, d_true), axis=1)
    min_sep = closest[moving].min()
    assert summary["min_separation_while_moving"] == pytest.approx(min_sep, rel=1e-5)
    assert summary["contact_while_moving"] == bool(min_sep < scenario.contact_distance)
    dt = np.diff(trace["time"], append=trace["time"][-1])
    finished_at = summary["task_time"]
    before_end = trace["time"] < finished_at
    assert summary["stopped_time"] == pytest.approx(
        dt[(trace["path_rate"] == 0.0) & before_end].sum(), abs=2e-3)
    # The task ends when the path rate last drops to rest for good.
    assert np.all(trace["path_rate"][trace["time"] >= finished_at] == 0.0)
    assert trace["path_rate"][trace["time"] < finished_at][-1] > 0.0
    assert (out / "plot.png").stat().st_size > 10_000


def test_dynamic_and_kinematic_modes_agree_on_the_tool_path():
    """The dynamic plant (inverse-dynamics tracking) follows the braked reference:
    over the approach and slow-down of the inspection task the tool positions of the
    two modes agree within 5 mm."""
    scenario = load_scenario(SCENARIOS / "inspection.yaml")
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

    scenario = dataclasses.replace(load_scenario("models/scenarios/inspection.yaml"),
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
