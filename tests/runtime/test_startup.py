"""What run says while it starts."""

import pytest

from safety_systems.runtime.startup import Phases, process_age


def test_each_step_is_said_with_its_seconds_and_kept(capsys):
    phases = Phases(quiet=False)
    with phases.step("connecting", "connecting"):
        pass
    phases.say("ready")
    err = capsys.readouterr().err
    assert err.startswith("run: connecting... ") and err.endswith(" s\nrun: ready\n")
    assert phases.took["connecting"] >= 0.0 and phases.now == "connecting"
    age = process_age()
    assert age is None or (age > 0.0 and phases.took["imports"] > 0.0)


def test_a_failed_step_ends_its_line_and_quiet_says_nothing(capsys):
    phases = Phases(quiet=False)
    with pytest.raises(KeyboardInterrupt):
        with phases.step("safety_loop", "loading"):
            raise KeyboardInterrupt
    assert capsys.readouterr().err == "run: loading...\n"
    assert "safety_loop" not in phases.took and phases.now == "loading"
    quiet = Phases(quiet=True)
    with quiet.step("connecting", "connecting"):
        pass
    quiet.say("ready")
    assert capsys.readouterr().err == "" and "connecting" in quiet.took
