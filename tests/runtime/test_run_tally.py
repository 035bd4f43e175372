"""The live run's summary kept as the run goes: the same stops, waits and counts as the
whole trace gives, percentiles within their stated bound, and a block that does not grow."""

import math

import numpy as np
import pytest

from safety_systems.outputs.metrics import first_frame_wait, stops_by_cause
from safety_systems.runtime.run_tally import (
    BIN_RATIO,
    FRAMES,
    RunTally,
    bin_of,
    bin_value,
    percentile,
    run_summary,
)
from safety_systems.sensing.stops import STOP_REASONS, STOP_STALE_FRAME


@pytest.mark.parametrize("seed", range(40))
def test_stops_and_the_first_frame_wait_are_those_of_the_whole_trace(seed):
    """Random stop reasons at random tick times (a wait for the first frame of any
    length, a run that never gets one): the tally counted tick by tick gives
    ``stops_by_cause`` and ``first_frame_wait`` of the whole trace, exactly."""
    rng = np.random.default_rng(seed)
    ticks = int(rng.integers(1, 80))
    reasons = rng.choice([0, 1, 1, 2, 2, 3, 8, 9, 10, 11], size=ticks)
    reasons[:int(rng.integers(0, ticks + 1))] = STOP_STALE_FRAME
    times = np.cumsum(rng.uniform(0.0015, 0.004, ticks))
    tally = RunTally(2, 3)
    for t, reason in zip(times, reasons):
        tally.tick(float(t), int(reason), 1e-4, np.zeros(4), np.array([True, False]))
    tally.publish()
    summary = tally.summary(["a", "b"], 0.002, "duration")
    whole = stops_by_cause(reasons, times)
    for cause, stop in whole.items():
        assert summary["protective_stops"][cause]["count"] == stop["count"], cause
        assert summary["protective_stops"][cause]["time"] == pytest.approx(stop["time"],
                                                                           abs=1e-12)
    assert summary["first_frame_wait"] == pytest.approx(first_frame_wait(reasons, times),
                                                         abs=1e-12)
    assert summary["ticks"] == ticks and summary["duration"] == times[-1]
    assert summary["hidden_time"] == {"a": pytest.approx(ticks * 0.002), "b": 0.0}
    assert set(summary["protective_stops"]) == set(STOP_REASONS[1:])


def test_percentiles_are_within_half_a_bin_of_the_value_of_their_rank():
    rng = np.random.default_rng(7)
    values = np.concatenate([rng.lognormal(-8.0, 1.5, 20_000), [0.0, 3e-8, 250.0]])
    tally = RunTally(1, 1)
    for x in values:
        tally.tick(0.0, 0, float(x), np.zeros(4), np.zeros(1, bool))
        tally.frame_to_k(float(x))
    tally.publish()
    bound = math.sqrt(BIN_RATIO) - 1.0  # half a bin (geometric): 0.5%
    for q in (1, 50, 90, 99, 99.9):
        exact = np.percentile(values, q, method="inverted_cdf")
        assert percentile(tally.late, q) == pytest.approx(exact, rel=bound)
        assert percentile(tally.latency, q) == pytest.approx(exact, rel=bound)
    timing = tally.summary(["x"], 0.002, "duration")["timing"]
    assert timing["tick_late_max"] == 250.0 and timing["frame_to_k_max"] == 250.0
    assert percentile(np.zeros(10, dtype=int), 50) is None
    assert bin_of(0.0) == bin_of(math.nan) == 0 and bin_value(0) == 0.0
    assert bin_value(bin_of(1e-3)) == pytest.approx(1e-3, rel=bound)


def test_the_block_is_fixed_and_another_process_reads_what_was_published():
    """The numbers live in one block of a fixed size (nothing grows with the run); a
    reader of the same memory sees the counters once they are published."""
    size = RunTally.nbytes(3, 10)
    memory = bytearray(size)
    tally = RunTally(3, 10, memory)
    reader = RunTally(3, 10, memory, fresh=False)
    for i in range(5000):
        tally.tick(0.002 * i, 1, 1e-4, np.array([0.0, 1.0, 0.0, 2.0]), np.zeros(3, bool))
    tally.set(FRAMES, 1200)
    assert reader.summary(["a", "b", "c"], 0.002, "running")["ticks"] == 0
    tally.publish()
    seen = reader.summary(["a", "b", "c"], 0.002, "running")
    assert seen["ticks"] == 5000 and seen["frames"] == 1200
    assert seen["rejected_frames"] == {"non_finite": 0, "time": 1, "unknown_id": 0, "gate": 2}
    assert seen["protective_stops"]["separation"] == {"count": 1,
                                                      "time": pytest.approx(0.002 * 4999)}
    assert len(memory) == size == tally.block.nbytes


def test_run_summary_puts_the_fixed_fields_around_the_tally():
    tally = RunTally(1, 1)
    fixed = dict(fields={"params": "p.yaml", "certified": True}, names=["op/head"],
                 period=0.002, log={"segment_length": 600.0}, clock_start=12.5,
                 provenance={"inputs": {}})
    summary = run_summary(fixed, tally, "interrupted while connecting")
    assert list(summary)[:3] == ["params", "certified", "end"]
    assert summary["end"] == "interrupted while connecting" and summary["ticks"] == 0
    assert summary["log"]["segment_length"] == 600.0 and summary["log"]["segments"] == 0
    assert list(summary)[-2:] == ["clock_start", "provenance"]


def test_a_separation_stops_seconds_go_to_the_segment_that_held_the_robot():
    """Each tick's seconds (to the next) count to the stop it was in and, for a
    separation stop, to the segment nearest in the monitor's measure at that tick; the
    summary's ``held`` has ``outputs.held.held_by``'s fields."""
    from safety_systems.cell.human_body import SEGMENT_NAMES
    from safety_systems.sensing.stops import STOP_SEPARATION

    lower, head = SEGMENT_NAMES.index("lower_trunk"), SEGMENT_NAMES.index("head")
    ticks = [(0.0, 0, lower), (0.5, STOP_SEPARATION, lower), (1.5, STOP_SEPARATION, head),
             (1.75, STOP_SEPARATION, math.nan), (2.0, 0, head), (3.0, STOP_SEPARATION, head)]
    tally = RunTally(1, 3)
    for t, reason, segment in ticks:
        tally.tick(t, reason, 1e-4, np.zeros(4), np.array([False]), segment)
    summary = tally.summary(["a"], 0.002, "duration")
    held = summary["held"]
    assert held["separation"]["by_segment"] == {"lower_trunk": 1.0, "head": 0.25,
                                                "none": 0.25}
    assert list(held["separation"]["by_segment"]) == ["lower_trunk", "head", "none"]
    assert held["separation"]["time"] == 1.5 == \
        summary["protective_stops"]["separation"]["time"]
    assert held["causes"] == {"separation": 1.5}
    assert held["separation"]["true_clearance_median"] is None
