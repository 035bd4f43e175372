"""``explain`` on a params.yaml that ``export`` wrote (iso.yaml verified on the default
space): certified, its figures those of the configuration it was exported from."""

import json
from pathlib import Path

import pytest

ISO = Path(__file__).parents[3] / "models" / "configs" / "iso.yaml"


def test_explain_reads_an_exported_params_yaml(exported, cli, tmp_path):
    params = exported / "export" / "params.yaml"
    code, out, err = cli(["explain", params, "--json", tmp_path / "params.json"])
    assert code == 0, err
    assert "NOT CERTIFIED" not in err
    assert out.startswith("robot ur5e; S full speed; stopping data: placeholder")
    code, _, err = cli(["explain", ISO, "--json", tmp_path / "iso.json"])
    assert code == 0, err
    mine, theirs = (json.loads((tmp_path / f"{n}.json").read_text()) for n in ("params", "iso"))
    assert [r["segment"] for r in mine["segments"]] == [r["segment"] for r in theirs["segments"]]
    # params.yaml writes the default cycle out as its waypoints: the same path, V_R to
    # the bound's resolution
    assert mine["speed_bound"] == pytest.approx(theirs["speed_bound"], rel=1e-3)
    for a, b in zip(mine["segments"], theirs["segments"]):
        assert a["S"] == pytest.approx(b["S"], abs=1e-3) and a["dominant"] == b["dominant"]


def test_report_html_shows_explains_tables(exported, cli, tmp_path):
    page = (exported / "export" / "report.html").read_text()
    assert "<h3>What it makes the robot do</h3>" in page
    code, _, err = cli(["explain", exported / "export" / "params.yaml", "--space",
                        Path(__file__).parents[3] / "models" / "spaces" / "default.yaml",
                        "--json", tmp_path / "e.json"])
    assert code == 0, err
    data = json.loads((tmp_path / "e.json").read_text())
    hand = [r for r in data["segments"] if r["segment"].endswith("/hand_right")]
    row = (f"<tr><td>{hand[0]['segment']}</td><td>{hand[0]['envelope']:.3f}</td>"
           f"<td>{hand[0]['envelope_from']}</td>"
           + "".join(f"<td>{r['S']:.3f} human</td>" for r in hand) + "</tr>")
    assert row in page  # the page's figures are explain's on the space verified
