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
