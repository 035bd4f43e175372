"""``check mapping`` opens the recording a mapping names and refuses, with simulate's own
line and exit code, whatever simulate refuses of it (it calls simulate's function)."""

from pathlib import Path

import pytest

from safety_systems.cli import main
from tests.sensing.c3d_patches import DEC_INT, KYOWA, patched
from tests.sensing.motive_holds import held_export

MAPPING = """\
capture_to_cell: {{up_axis: {up}}}
recording: {recording}
{extra}operators:
- name: worker
  bodies:
  - {{recorded: '{a}', name: right, point: hand_right}}
  - {{recorded: '{b}', name: left, point: hand_left}}
"""
SCENARIO = """\
name: replay
duration: 1.0
robot: {{cycles: 1}}
operators:
- {{recording: {recording}, mapping: map.yaml}}
"""


def _both(folder: Path, capsys) -> tuple[tuple[int, str], tuple[int, str]]:
    """(exit code, stderr) of `check mapping map.yaml` and of `simulate s.yaml`."""
    out = []
    for argv in (["check", "mapping", str(folder / "map.yaml")],
                 ["simulate", str(folder / "s.yaml"), "--out", str(folder / "out")]):
        code = main(argv)
        out.append((code, capsys.readouterr().err.strip()))
    return out[0], out[1]


@pytest.mark.parametrize("kind", ["frozen_motive", "kyowa_c3d", "evart_like_c3d"])
def test_check_mapping_refuses_what_simulate_refuses_with_the_same_line(tmp_path, capsys,
                                                                        kind):
    if kind == "frozen_motive":
        held_export(tmp_path / "rec.csv")
        name, up, a, b = "rec.csv", "y", "stick_right", "stick_left"
    else:
        name, up = "rec.c3d", "z"
        if kind == "kyowa_c3d":
            (tmp_path / name).write_bytes(KYOWA.read_bytes())
            a, b = "1", "2"
        else:
            patched(DEC_INT, tmp_path / name, analog_rate=190.0)
            a, b = "LFT1", "RFT3"
    (tmp_path / "map.yaml").write_text(MAPPING.format(up=up, recording=name, extra="", a=a,
                                                      b=b))
    (tmp_path / "s.yaml").write_text(SCENARIO.format(recording=name))
    check, simulate = _both(tmp_path, capsys)
    assert check[0] == simulate[0] == 2
    assert check[1] == simulate[1] and len(check[1].splitlines()) == 1
    assert str(tmp_path / name) in check[1]
    assert ("Motive CSV (Format Version 1.22)" if kind == "frozen_motive"
            else "C3D (DEC processor, 16-bit integers)") in check[1]


def test_check_mapping_reads_a_good_recording_and_says_what_it_read(tmp_path, capsys):
    held_export(tmp_path / "rec.csv")
    (tmp_path / "map.yaml").write_text(MAPPING.format(
        up="y", recording="rec.csv", extra="implausible: untracked\n", a="stick_right",
        b="stick_left"))
    assert main(["check", "mapping", str(tmp_path / "map.yaml")]) == 0
    out, err = capsys.readouterr()
    assert "ok (its recording read as simulate reads it: 1 operator(s), 2 bodies, 726 " \
           "frames" in out
    assert "warning" in err and "held still" in err and len(err.strip().splitlines()) == 1
    # a mapping that names no recording is checked alone, and says so
    (tmp_path / "alone.yaml").write_text(MAPPING.format(
        up="y", recording="''", extra="", a="stick_right", b="stick_left"))
    assert main(["check", "mapping", str(tmp_path / "alone.yaml")]) == 0
    assert "names no recording" in capsys.readouterr().out
    # a missing recording, and a scenario that plays another recording than the mapping's
    (tmp_path / "map.yaml").write_text(MAPPING.format(
        up="y", recording="gone.csv", extra="", a="stick_right", b="stick_left"))
    assert main(["check", "mapping", str(tmp_path / "map.yaml")]) == 2
    assert "recording: got 'gone.csv'" in capsys.readouterr().err
    (tmp_path / "s.yaml").write_text(SCENARIO.format(recording="rec.csv"))
    assert main(["simulate", str(tmp_path / "s.yaml"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "map.yaml: recording: got 'gone.csv'" in err and "rec.csv" in err


def test_check_recording_applies_the_glitch_and_plausibility_rules_to_every_body(tmp_path,
                                                                                 capsys):
    """check recording FILE reads every body under a mapping's rules at their defaults:
    the frozen-then-jumping export is refused with the line a mapping of that body gives;
    the untouched export passes and says what was checked."""
    from tests.sensing.motive_holds import Z_HOP

    held_export(tmp_path / "rec.csv")
    (tmp_path / "map.yaml").write_text(MAPPING.format(up="y", recording="rec.csv", extra="",
                                                      a="stick_right", b="stick_left"))
    assert main(["check", "recording", str(tmp_path / "rec.csv")]) == 2
    line = capsys.readouterr().err.strip()
    assert main(["check", "mapping", str(tmp_path / "map.yaml")]) == 2
    assert capsys.readouterr().err.strip() == line
    assert "'stick_right' at frame" in line and "speed: got '" in line
    assert main(["check", "recording", str(Z_HOP)]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"{Z_HOP}: ok (") and "frames, every body within the default " \
        "plausibility bounds, 10 m/s and 150 m/s^2" in out
