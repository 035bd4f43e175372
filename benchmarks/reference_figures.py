"""Reference figures: a fingerprint of what the product computes, to compare two trees.

A change that should not change behaviour (a refactoring, a move of files) is checked by
running this script before and after and comparing the two manifests:

    python benchmarks/reference_figures.py OUT_BEFORE
    ... change ...
    python benchmarks/reference_figures.py OUT_AFTER
    python benchmarks/reference_figures.py --compare OUT_BEFORE OUT_AFTER

Everything runs through the ``safety-systems`` command line, so the script does not
depend on where modules live. The reference set:

- ``simulate``: every scenario in ``models/scenarios/`` in the kinematic and in the
  dynamic robot mode (Drake traces, byte for byte, and summaries);
- ``compare``: ``erga_positive`` and ``erga_negative`` under the four controllers;
- ``plan``: ``models/scenes/paper.yaml`` with its obstacle sweep (RRT*'s rows left out:
  it plans for a wall-clock budget, so its paths differ from run to run);
- ``verify``: Sobol sweeps of 168 closed-loop scenarios in all (``SWEEPS``: ``iso.yaml``,
  the seed's ``seed_estimated.yaml`` and ``iso_previous.yaml`` on the default space, the
  seed's on the e-waste cell's spline path) with both properties: every scenario's
  figures, the proofs' margins, the Drake confirmations; and the seed's configuration
  searched for its first counterexample.

The manifest holds a SHA-256 per output file after dropping what legitimately differs
between runs (provenance, versions, paths, CPU and wall times) and the figures themselves
(``summary.json``, the comparison rows, ``report.json``'s verdicts and robustness), so a
difference names the file and the field. Input files' digests are left out too (a comment
edited in a configuration changes them); what the inputs mean shows in the figures. Plots
and HTML replays are not compared (their bytes carry timestamps); their inputs are.
"""

import argparse
import hashlib
import json
import math
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MODELS = ROOT / "models"
CLI = [sys.executable, "-m", "safety_systems.cli"]
# (name, configuration, space, Sobol points): 168 closed-loop scenarios in all, three
# configurations over the default space and the seed's on the e-waste cell's spline path.
SWEEPS = (("iso_default", "iso.yaml", "default.yaml", 64),
          ("seed_default", "seed_estimated.yaml", "default.yaml", 64),
          ("previous_default", "iso_previous.yaml", "default.yaml", 32),
          ("seed_ewaste", "seed_estimated.yaml", "ewaste.yaml", 8))
# Keys whose values differ between two runs of the same code: never compared.
VOLATILE = {"provenance", "origin", "versions", "cpu_seconds", "wall_seconds", "seconds",
            "elapsed", "command", "inputs", "created", "date", "time_to_verdict", "timing",
            "wall", "cpu", "rate", "real_time_factor", "host", "python", "out", "path",
            "replay", "scenario_file", "file", "files", "planning_time",
            # digests of input files: a comment edited in a configuration changes them;
            # what the inputs mean is compared through the figures they produce
            "config_sha256", "space_sha256", "sha256",
            # the evaluation cache's key hashes the scenario's text, field names included
            "key"}
# Planners run for a wall-clock budget (RRT*'s 1 s): their rows cannot repeat bit for bit.
TIME_BUDGETED = {"RRT*"}
COMPARED = (".json", ".jsonl", ".csv", ".md", ".yaml")
# plan.md sets planning times and RRT*'s figures in the same rows as the others; its
# figures are compared through plan.json.
NOT_COMPARED = {"plan.md"}


def _clean(value):
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in sorted(value.items())
                if k not in VOLATILE and k not in TIME_BUDGETED}
    if isinstance(value, list):
        return [_clean(v) for v in value
                if not (isinstance(v, dict) and v.get("planner") in TIME_BUDGETED)]
    if isinstance(value, float) and not math.isfinite(value):
        return repr(value)
    return value


def _digest(path: Path, out: Path) -> tuple[str, object]:
    """(SHA-256 of the file's comparable content, its figures or None)."""
    text = path.read_text(errors="replace").replace(str(out), "OUT").replace(str(ROOT), "ROOT")
    if path.suffix == ".json":
        data = _clean(json.loads(text))
        canon = json.dumps(data, sort_keys=True)
        return hashlib.sha256(canon.encode()).hexdigest(), data
    if path.suffix == ".jsonl":
        rows = sorted(json.dumps(_clean(json.loads(line)), sort_keys=True)
                      for line in text.splitlines() if line.strip())
        return hashlib.sha256("\n".join(rows).encode()).hexdigest(), None
    if path.suffix == ".md":  # reports carry times and versions in prose: keep figures only
        lines = [ln for ln in text.splitlines()
                 if not any(w in ln.lower() for w in ("second", " s ", "version", "cpu",
                                                      "wall", "command", "date", "python",
                                                      "sha256"))
                 and not any(f"| {p} |" in ln for p in TIME_BUDGETED)]
        text = "\n".join(lines)
    return hashlib.sha256(text.encode()).hexdigest(), None


def _run(args: list[str], out: Path, allowed=(0, 1)) -> int:
    proc = subprocess.run(CLI + args + ["--quiet"], cwd=ROOT, capture_output=True, text=True)
    if proc.returncode not in allowed:
        sys.exit(f"{' '.join(args)} exited {proc.returncode}: {proc.stderr.strip()[-500:]}")
    return proc.returncode


def produce(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    codes = {}
    for scenario in sorted((MODELS / "scenarios").glob("*.yaml")):
        for mode in ("kinematic", "dynamic"):
            name = f"simulate/{scenario.stem}_{mode}"
            codes[name] = _run(["simulate", str(scenario), "--mode", mode,
                                "--out", str(out / name)], out)
    codes["compare"] = _run(["compare", str(MODELS / "scenarios" / "erga_positive.yaml"),
                             str(MODELS / "scenarios" / "erga_negative.yaml"),
                             "--out", str(out / "compare")], out)
    codes["plan"] = _run(["plan", str(MODELS / "scenes" / "paper.yaml"), "--sweep", "obstacles",
                          "--out", str(out / "plan")], out)
    default = str(MODELS / "spaces" / "default.yaml")
    for name, config, space, budget in SWEEPS:
        codes[f"verify/{name}"] = _run(
            ["verify", str(MODELS / "configs" / config), "--space", str(MODELS / "spaces" / space),
             "--method", "sobol", "--budget", str(budget), "--workers", "1",
             "--out", str(out / "verify" / name)], out, allowed=(0, 1, 3, 4))
    codes["verify/seed_first"] = _run(
        ["verify", str(MODELS / "configs" / "seed_estimated.yaml"), "--space", default,
         "--stop-at-first", "--workers", "1", "--out", str(out / "verify/seed_first")],
        out, allowed=(0, 1, 3, 4))
    manifest = {"exit_codes": codes, "files": {}, "figures": {}}
    for path in sorted(out.rglob("*")):
        if (path.is_file() and path.suffix in COMPARED and path.name != "manifest.json"
                and path.name not in NOT_COMPARED):
            rel = str(path.relative_to(out))
            digest, figures = _digest(path, out)
            manifest["files"][rel] = digest
            if figures is not None:
                manifest["figures"][rel] = figures
    (out / "manifest.json").write_text(json.dumps(manifest, indent=1, sort_keys=True))
    print(f"{len(manifest['files'])} files fingerprinted in {out / 'manifest.json'}")


def _diff(a, b, where: str, lines: list[str]) -> None:
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            _diff(a.get(k, "<missing>"), b.get(k, "<missing>"), f"{where}.{k}", lines)
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)):
            _diff(x, y, f"{where}[{i}]", lines)
    elif a != b:
        lines.append(f"{where}: {a!r} -> {b!r}")


def compare(before: Path, after: Path) -> int:
    a = json.loads((before / "manifest.json").read_text())
    b = json.loads((after / "manifest.json").read_text())
    lines: list[str] = []
    _diff(a["exit_codes"], b["exit_codes"], "exit_codes", lines)
    for rel in sorted(set(a["files"]) | set(b["files"])):
        if a["files"].get(rel) != b["files"].get(rel):
            if rel in a["figures"] and rel in b["figures"]:
                before_lines = len(lines)
                _diff(a["figures"][rel], b["figures"][rel], rel, lines)
                if len(lines) == before_lines:
                    lines.append(f"{rel}: content differs")
            else:
                how = ("missing" if rel not in b["files"] else "new" if rel not in a["files"]
                       else "differs")
                lines.append(f"{rel}: {how}")
    print(f"{len(a['files'])} files before, {len(b['files'])} after; "
          f"{len(lines)} differences")
    for line in lines[:200]:
        print(" ", line)
    return 1 if lines else 0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="output folder (or the first of two to compare)")
    parser.add_argument("--compare", type=Path, metavar="AFTER",
                        help="compare the manifest in OUT with the one in AFTER")
    args = parser.parse_args()
    if args.compare:
        sys.exit(compare(args.out, args.compare))
    produce(args.out.resolve())


if __name__ == "__main__":
    main()
