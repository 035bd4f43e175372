"""``safety-systems check``: exported parameters pass only as exported, with a proved (or
passed) verdict; anything else is one line and a non-zero exit."""

import json
import shutil
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from verification.deploy.certificate import (
    SCHEMA_VERSION,
    certificate_text,
    check,
    own_digest_holds,
    read_certificate,
    safety_checksum,
)
from verification.verdicts import EXIT_REQUIREMENT

MODELS = Path(__file__).parents[3] / "models"
ISO = MODELS / "configs" / "iso.yaml"
CHARACTERS = st.characters(min_codepoint=32, max_codepoint=126) | st.sampled_from(
    ["\n", "\t", "é", "\x00"])


def _copy(exported: Path, tmp_path: Path) -> Path:
    folder = tmp_path / "copy"
    shutil.copytree(exported / "export", folder)
    return folder


def test_the_export_checks(exported, cli):
    code, out, err = cli(["check", exported / "export" / "params.yaml"])
    assert code == 0 and "certified proved" in out and err == ""
    cert, text = read_certificate(exported / "export" / "certificate.json")
    assert own_digest_holds(text)
    # What the certificate holds (the list).
    assert cert["verdict"] == "proved" and "z3" in cert["method"]
    assert {x["basis"] for x in cert["premises"]} == {"checked", "trusted"}
    assert cert["braking_data"]["origin"] == "placeholder"
    assert cert["assumptions"]["space"]["parameters"]["peak_speed"]["max"] == 2.0
    assert cert["assumptions"]["assumptions"] and cert["assumptions"]["box"]
    assert cert["simulations"] == 6 and cert["evaluations"]["drake"] >= 1
    report = json.loads((exported / "verified" / "report.json").read_text())
    assert cert["evaluations"] == report["evaluations"]  # one vocabulary
    assert set(cert["min_robustness"]) == {"contact", "separation"}
    # Both properties' verdicts (contact and separation), each with its proof's premises.
    assert {n: p["verdict"] for n, p in cert["properties"].items()} == {
        "contact": "proved", "separation": "proved"}
    assert all(p["proved"] and p["premises"] for p in cert["properties"].values())
    # The whole cell: capsules, the operators' body model, hidden bodies, frame gating, the
    # robot's
    # speed in S, as figures beside the premises that speak of them.
    cell = cert["cell"]
    assert cell["monitor"]["robot_geometry"] == "capsules"
    assert len(cell["monitor"]["radii"]) == len(cell["contact"]["radii"]) == 7
    assert all(m >= r for m, r in zip(cell["monitor"]["radii"], cell["contact"]["radii"]))
    assert cell["monitor"]["robot_speed"] == "directed"
    bodies = cell["bodies"]
    assert bodies["tracked"] == ["hand_right", "hand_left", "head"]
    assert bodies["dimensions"]["forearm"] == 0.41 and bodies["dimensions"]["hand_radius"] == 0.12
    assert bodies["tracking_allowance"] == 0.01
    assert cell["hidden_bodies"]["rule"] == "hazard"
    assert cell["hidden_bodies"]["occlusion_speed"] == 2.0
    assert cell["frames"]["gate"] is True and cell["frames"]["gate_width"] > 0.0
    statements = " ".join(x["statement"] for x in cert["premises"])
    for words in ("monitor's robot contains", "hidden bodies stay hazards",
                  "pass the gate", "capsules contain the real arm",
                  "body is within the monitor's model", "tracking allowance covers"):
        assert words in statements, words
    assert cert["parameters"]["controller.safety.robot_speed"] == '"directed"'
    assert {"safety-systems", "drake", "numpy"} <= set(cert["versions"])
    assert len(cert["checksum"]) == 64 and cert["checksum_short"] == cert["checksum"][:8].upper()


def test_the_checksum_covers_parameters_braking_path_and_assumptions(exported):
    result = check(exported / "export" / "params.yaml")
    params = result.params
    cert, _ = read_certificate(exported / "export" / "certificate.json")
    a = cert["assumptions"]
    base = safety_checksum(params, a)
    assert base == cert["checksum"]
    import dataclasses

    c = params.controller
    changed = [
        dataclasses.replace(params, controller=dataclasses.replace(
            c, safety=dataclasses.replace(c.safety, d_min=c.safety.d_min + 1e-9))),
        dataclasses.replace(params, controller=dataclasses.replace(
            c, safety=dataclasses.replace(c.safety, robot_speed="fastest_point"))),
        dataclasses.replace(params, controller=dataclasses.replace(
            c, braking=dataclasses.replace(c.braking, speed_fraction=[1.0],
                                           stopping_time=[0.53], stopping_distance=[0.6]))),
        dataclasses.replace(params, robot=dataclasses.replace(
            params.robot, path=dataclasses.replace(
                params.robot.path, segment_durations=[1.0] + params.robot.path
                .segment_durations[1:]))),
    ]
    assert all(safety_checksum(p, a) != base for p in changed)
    other = json.loads(json.dumps(a))
    other["assumptions"][0] += " "
    assert safety_checksum(params, other) != base


@pytest.mark.parametrize("name", ["params.yaml", "certificate.json"])
def test_a_one_character_edit_anywhere_is_rejected(exported, tmp_path, name, cli):
    folder = _copy(exported, tmp_path)
    original = (folder / name).read_bytes().decode("utf-8")

    @settings(max_examples=60, deadline=None, derandomize=True, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
    @given(data=st.data())
    def edit(data):
        at = data.draw(st.integers(0, len(original) - 1), label="position")
        kind = data.draw(st.sampled_from(["replace", "insert", "delete"]), label="edit")
        if kind == "delete":
            text = original[:at] + original[at + 1:]
        else:
            c = data.draw(CHARACTERS.filter(lambda x: kind == "insert" or x != original[at]),
                          label="character")
            text = original[:at] + c + original[at + (kind == "replace"):]
        (folder / name).write_bytes(text.encode("utf-8"))
        code, out, err = cli(["check", folder / "params.yaml"])
        (folder / name).write_bytes(original.encode("utf-8"))
        assert code != 0 and out == ""
        lines = err.splitlines()
        assert len(lines) == 1 and lines[0].startswith("safety-systems: "), err

    edit()
    assert cli(["check", folder / "params.yaml"])[0] == 0  # the originals still pass


def _rewrite(folder: Path, **changes) -> None:
    """A certificate with ``changes`` and valid digests (as another export would write)."""
    cert, _ = read_certificate(folder / "certificate.json")
    cert.update(changes)
    (folder / "certificate.json").write_text(certificate_text(cert))


def test_each_reason_is_named(exported, tmp_path, cli):
    folder = _copy(exported, tmp_path)
    params = folder / "params.yaml"
    text = params.read_text()
    line = next(x for x in text.splitlines() if "controller.safety.d_min:" in x)
    params.write_text(text.replace(line, line.replace("0.3", "0.25")))
    code, _, err = cli(["check", params])
    assert code == 1 and "controller.safety.d_min: got 0.25" in err and "certified 0.3" in err
    params.write_text(text)
    (folder / "certificate.json").rename(folder / "elsewhere.json")
    code, _, err = cli(["check", params])
    assert code == 1 and "missing" in err
    code, out, _ = cli(["check", params, "--certificate", folder / "elsewhere.json"])
    assert code == 0 and "certified proved" in out
    (folder / "elsewhere.json").rename(folder / "certificate.json")
    _rewrite(folder, verdict="falsified")
    code, _, err = cli(["check", params])
    assert code == 1 and "verdict: got falsified" in err
    _rewrite(folder, verdict="passed")
    code, out, _ = cli(["check", params])
    assert code == 0 and "weaker than proved" in out
    code, _, err = cli(["check", params, "--require", "proved"])
    assert code == EXIT_REQUIREMENT and "weaker than proved" in err
    _rewrite(folder, schema_version=SCHEMA_VERSION + 1)
    code, _, err = cli(["check", params])
    assert code == 2 and f"schema_version: got {SCHEMA_VERSION + 1}" in err \
        and "another" in err
    shutil.copy(exported / "export" / "certificate.json", folder)
    cert = json.loads((folder / "certificate.json").read_text())
    cert["extra"] = 1
    (folder / "certificate.json").write_text(certificate_text(cert))
    code, _, err = cli(["check", params])
    assert code == 2 and "unknown key" in err
    shutil.copy(exported / "export" / "certificate.json", folder)
    params.write_text(text.replace("controller.safety.d_min:", "controller.safety.dmin:"))
    code, _, err = cli(["check", params])
    assert code == 2 and "unknown key" in err and "dmin" in err
    params.write_text(text + "# a comment\n")
    code, _, err = cli(["check", params])
    assert code == 1 and "comments, layout or spelling" in err
    params.write_text(text)
    assert cli(["check", params])[0] == 0


def test_check_still_reads_files_of_a_kind(tmp_path, cli):
    assert cli(["check", "config", ISO])[:2] == (0, f"{ISO}: ok\n")
    code, _, err = cli(["check", ISO])  # not a params file, no kind named
    assert code == 2 and "name its kind first" in err
    code, _, err = cli(["check", "config"])
    assert code == 2 and "one or more files" in err


def test_simulate_and_verify_take_params_and_refuse_unchecked_ones(exported, tmp_path, cli):
    folder = _copy(exported, tmp_path)
    params = folder / "params.yaml"
    scenario = MODELS / "scenarios" / "inspection_seed.yaml"
    code, _, err = cli(["simulate", scenario, "--config", params, "--out", tmp_path / "a",
                            "--duration", "1", "--quiet"])
    assert code == 0 and "UNVERIFIED" not in err
    text = params.read_text()
    params.write_text(text.replace("controller.safety.d_min: 0.3", "controller.safety.d_min: "
                                                                    "0.2"))
    for command in (["simulate", scenario, "--config", params, "--out", tmp_path / "b",
                     "--duration", "1", "--quiet"],
                    ["verify", params, "--space", MODELS / "spaces" / "default.yaml", "--out",
                     tmp_path / "c", "--budget", "2", "--workers", "1", "--quiet"]):
        code, _, err = cli(command)
        assert code == 1 and len(err.splitlines()) == 1 and "--unverified" in err
        assert not (tmp_path / "b").exists() and not (tmp_path / "c").exists()
    code, _, err = cli(["simulate", scenario, "--config", params, "--out", tmp_path / "b",
                            "--duration", "1", "--quiet", "--unverified"])
    assert code == 0 and "UNVERIFIED" in err


ODD = [None, True, -1, 0, 2**63, 1e308, -1e308, float("inf"), float("nan"), "", "iso", "1e400",
       [], [1.0, "a"], [[1.0]], {"a": 1.0}, [None], 0.5, [0.1, 0.2, 0.3]]


def test_mutated_params_are_refused_in_one_line(exported, tmp_path, cli):
    import yaml

    folder = _copy(exported, tmp_path)
    original = (folder / "params.yaml").read_text()
    tree = yaml.safe_load(original)
    (node, body), = tree.items()
    keys = list(body["ros__parameters"])

    @settings(max_examples=60, deadline=None, derandomize=True, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
    @given(data=st.data())
    def mutate(data):
        params = dict(body["ros__parameters"])
        for _ in range(data.draw(st.integers(1, 3), label="mutations")):
            key = data.draw(st.sampled_from(keys), label="key")
            kind = data.draw(st.sampled_from(["value", "delete", "rename"]), label="kind")
            if kind == "value":
                params[key] = data.draw(st.sampled_from(ODD), label="value")
            elif kind == "delete":
                params.pop(key, None)
            else:
                params[key + data.draw(st.sampled_from(["_x", ".item0", ".x"]))] = \
                    params.pop(key, 0.0)
        text = yaml.safe_dump({node: {"ros__parameters": params}}, sort_keys=False)
        (folder / "params.yaml").write_text(text)
        code, out, err = cli(["check", folder / "params.yaml"])
        assert code in (1, 2) and out == "", (code, err)
        assert len(err.splitlines()) == 1 and err.startswith("safety-systems: "), err

    mutate()
    (folder / "params.yaml").write_text(original)
    assert cli(["check", folder / "params.yaml"])[0] == 0
