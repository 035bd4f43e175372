"""The status line the log writer prints from what the loop publishes."""

from safety_systems.cell.human_body import SEGMENT_NAMES
from safety_systems.runtime.run_status import status_line
from safety_systems.runtime.run_tally import FRAMES, LOG_DROPPED_TICKS, RunTally

COLUMNS = ["time", "k", "stop_reason", "a:d_measured", "a:nearest_measured", "a:S",
           "b:d_measured", "b:nearest_measured", "b:S"]


def test_the_status_line_names_the_closest_segment_the_stop_and_lost_records():
    tally = RunTally(1, len(COLUMNS))
    tally.row[:] = [12.34, 0.5, 1.0, 1.5, 3.0, 1.2, 0.9, 7.0, 0.8]
    tally.set(FRAMES, 42)
    tally.publish()
    line = status_line(tally, COLUMNS)
    assert "12.3 s" in line and "k=0.50" in line and "stop: separation" in line
    assert f"closest b/{SEGMENT_NAMES[7]} 0.90 m (S 0.80 m)" in line
    assert "frames 42" in line and "LOG" not in line
    tally.set(LOG_DROPPED_TICKS, 3)
    tally.publish()
    assert "LOG: 3 records lost" in status_line(tally, COLUMNS)
    tally.row[:] = float("nan")  # nothing published yet: no closest segment, no stop
    line = status_line(tally, COLUMNS)
    assert "closest" not in line and "stop: -" in line


def test_the_first_frame_is_said_once_with_the_summarys_wait(capsys):
    import threading

    import numpy as np

    from safety_systems.runtime.run_status import show_status

    tally = RunTally(1, len(COLUMNS))
    for i, reason in enumerate([2, 2, 2, 1, 1]):  # held for the first frame until 0.006 s
        tally.tick(0.002 * i, reason, 0.0, np.zeros(4), np.zeros(1, bool))
    tally.publish()
    done = threading.Event()
    thread = threading.Thread(target=show_status, args=(tally, COLUMNS, done))
    thread.start()
    said = ""
    while said.count("\r") < 4:  # the line, then three status lines
        thread.join(timeout=0.05)
        said += capsys.readouterr().err
    done.set()
    thread.join()
    assert said.count("run: first frame after 0.01 s; running") == 1
    assert tally.summary(["x"], 0.002, "running")["first_frame_wait"] == 0.006
