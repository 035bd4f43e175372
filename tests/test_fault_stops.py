"""Every fault of the sensing chain stops the robot within one control period, for its
own reason, and the robot resumes afterwards (the Drake diagram, end to end)."""

import csv
import json

import numpy as np
import pytest

from safety_systems.sensing import stops
from safety_systems.outputs.run_files import write_outputs
from safety_systems.config.scenario import scenario_from_text
from safety_systems.diagrams.simulation import simulate

# An operator whose gloves stand 4.0 m from the robot: far enough that separation never
# stops or slows it. (It stood at 3.5 m when the monitor saw two glove balls; the monitor
# now bounds the whole operator from the gloves: at 3.5 m the lower trunk's envelope came
# within 1.18 m of the robot and the override slowed it to 0.90; at 4.0 m, 1.68 m.)
SCENARIO = """
name: faults
duration: 8.5
robot: {cycles: 3}
controller:
  sensor:
    rate_hz: 20.0
    noise_std: 0.0002
    faults:
    - {kind: non_finite, body: op/right, start: 1.0, end: 1.2}
    - {kind: unknown_id, body: op/left, start: 2.0, end: 2.2}
    - {kind: time_duplicate, start: 3.0, end: 3.05}
    - {kind: time_backwards, start: 4.0, end: 4.1}
    - {kind: outlier, body: op/right, start: 5.0, end: 5.2, offset: [0.0, 1.0, 0.0]}
    - {kind: swap, body: op/right, other: op/left, start: 6.0, end: 6.1}
    dropouts:
    - {start: 7.0, end: 7.2}
operators:
- name: op
  bodies:
  - {name: right, point: hand_right, offset: [0.0, -0.2, 0.0]}
  - {name: left, point: hand_left, offset: [0.0, 0.2, 0.0]}
  waypoints:
  - {time: 0.0, position: [4.0, 0.0, 0.3]}
"""
DT = 0.002
TOL = 1e-9  # s of rounding in tick times
PROCESSING = 0.001  # the tracker's default processing time
TIMEOUT = 1.5 * 0.05 + PROCESSING  # the default frame timeout, no latency
# cause: (when the first bad frame is processed or the timeout expires, when the first
# clean frame after it is processed)
FAULTS = {
    stops.STOP_NON_FINITE: (1.0 + PROCESSING, 1.2 + PROCESSING),
    stops.STOP_UNKNOWN_ID: (2.0 + PROCESSING, 2.2 + PROCESSING),
    stops.STOP_BAD_TIME: ((3.0 + PROCESSING, 3.05 + PROCESSING),
                          (4.0 + PROCESSING, 4.1 + PROCESSING)),
    stops.STOP_GATE: ((5.0 + PROCESSING, 5.2 + PROCESSING), (6.0 + PROCESSING, 6.1 + PROCESSING)),
    stops.STOP_STALE_FRAME: (6.95 + TIMEOUT, 7.2 + PROCESSING),
}


@pytest.fixture(scope="module")
def run_and_outputs(tmp_path_factory):
    run = simulate(scenario_from_text(SCENARIO))
    out = tmp_path_factory.mktemp("faults")
    return run, write_outputs(run, out), out


def _episodes(reason, code):
    on = reason == code
    edges = np.diff(np.r_[0, on.astype(int), 0])
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)))


@pytest.mark.parametrize("code", list(FAULTS))
def test_each_fault_stops_within_one_control_period_and_clears(run_and_outputs, code):
    run, _, _ = run_and_outputs
    t, reason = run.time, run["override.stop_reason"][:, 0]
    k, rate = run["override.path_speed_commanded"][:, 0], run["follower.path_state"][:, 1]
    windows = FAULTS[code]
    windows = windows if isinstance(windows[0], tuple) else (windows,)
    episodes = [(a, b) for a, b in _episodes(reason, code) if t[a] > 0.0]  # not the start
    assert len(episodes) == len(windows), f"{stops.STOP_REASONS[code]}: {episodes}"
    for (begin, clear), (a, b) in zip(windows, episodes):
        # The stop begins at the first control tick after the fault is known ...
        assert begin <= t[a] <= begin + DT + TOL, (stops.STOP_REASONS[code], t[a], begin)
        assert np.all(k[a:b] == 0.0)
        # ... and clears at the first tick after the next clean frame is processed.
        assert clear <= t[b] <= clear + DT + TOL, (stops.STOP_REASONS[code], t[b], clear)
        # The robot moves again afterwards.
        later = (t > t[b]) & (t < t[b] + 1.0)
        assert rate[later].max() > 0.5


def test_robot_runs_at_full_speed_between_faults(run_and_outputs):
    run, _, _ = run_and_outputs
    reason = run["override.stop_reason"][:, 0]
    assert set(np.unique(reason)) == {0.0} | set(FAULTS)  # never a separation stop
    assert run["override.path_speed_commanded"][reason == 0, 0].min() == 1.0


def test_summary_and_trace_count_stops_rejections_and_hidden_time(run_and_outputs):
    run, summary, out = run_and_outputs
    assert summary == json.loads((out / "summary.json").read_text())
    stops_ = summary["protective_stops"]
    assert {name: stops_[name]["count"] for name in stops_} == {
        "separation": 0, "stale_frame": 1, "lost_track": 0, "bad_time": 2, "non_finite": 1,
        "unknown_id": 1, "gate": 2, "contact": 0}
    # Stale: the dropout; the hold before the first frame is processed (t < 0.001 s) is
    # the start, not a stop, and said apart.
    assert stops_["stale_frame"]["time"] == pytest.approx(7.201 - (6.95 + TIMEOUT), abs=DT)
    assert 0.0 < summary["first_frame_wait"] <= DT + 1e-9
    # 4 frames of each body fault; time: the duplicate frame at 3.0 s carries 2.95 s (the
    # newest good frame's), and at 4.0 and 4.05 s frames carry 3.9 and 3.95 s; the gate:
    # 4 outlier frames, then 2 swapped frames of both gloves.
    assert summary["rejected_frames"] == {"non_finite": 4, "time": 3, "unknown_id": 4,
                                          "gate": 8}
    hidden_time = summary["hidden_time"]
    # Hidden while rejected: the right glove 0.2 + 0.2 + 0.1 s, the left 0.2 + 0.1 s.
    assert hidden_time["op/right"] == pytest.approx(0.5, abs=0.01)
    assert hidden_time["op/left"] == pytest.approx(0.3, abs=0.01)
    with open(out / "trace.csv") as f:
        rows = list(csv.DictReader(f))
    assert rows[-1]["rejected_gate"] == "8" and rows[0]["rejected_gate"] == "0"
    hidden_ticks = sum(r["op/left:hidden"] == "1" for r in rows)
    assert hidden_ticks * DT == pytest.approx(hidden_time["op/left"], abs=DT)
    assert (out / "plot.png").stat().st_size > 10_000


def test_the_wait_for_the_first_frame_is_not_a_stop_but_a_stream_that_never_comes_is():
    from safety_systems.outputs.metrics import first_frame_wait, stops_by_cause

    stale, none = stops.STOP_REASONS.index("stale_frame"), 0
    t = np.arange(6) * 0.5
    waited = np.array([stale, stale, none, stale, none, none], dtype=float)
    assert first_frame_wait(waited, t) == 1.0
    assert stops_by_cause(waited, t)["stale_frame"] == {"count": 1, "time": 0.5}
    never = np.full(6, float(stale))  # no frame ever came: a fault, counted whole
    assert first_frame_wait(never, t) == 0.0
    assert stops_by_cause(never, t)["stale_frame"] == {"count": 1, "time": 2.5}
