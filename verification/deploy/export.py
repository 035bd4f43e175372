"""``safety-systems export``: a verified configuration as deployment parameters with its
certificate and a report for the safety assessor.

From a configuration and the report.json of its verification (``verify`` or ``tune``)
it writes into OUTDIR:

- ``params.yaml``: the configuration and the robot it was verified for
  (``safety_systems.config.params_file``: the project's loader reads it; a ROS 2 parameter
  file);
- ``certificate.json`` (``verification.deploy.certificate``): the verdict and method, each
  property's verdict (contact and separation), every premise marked checked or trusted,
  the whole cell's settings those premises speak of (capsules, body spheres, hidden
  bodies, frame gating), the braking data's origin, the assumptions and the
  scenario space, the counts of simulations and model evaluations, the minimum
  robustness, the versions, the safety checksum and the digests of both files;
- ``report.html`` (``verification.deploy.assessor_report``): one self-contained page for the
  safety assessor.

The report must be of this very configuration file (its ``config_sha256``) and its space
file must be unchanged since (the SHA-256 the report's provenance records).
"""

import datetime
import hashlib
import json
import platform
from pathlib import Path

from safety_systems.config.configuration import contact_capsules
from safety_systems.config.resolved_cell import ResolvedCell
from safety_systems.files.documents import inputs_read, read_input, read_text
from safety_systems.files.input_error import InputError
from safety_systems.files.output_files import write_text
from safety_systems.config.params_file import (
    Params,
    deployed_controller,
    deployed_robot,
    flat_parameters,
    params_text,
)
from safety_systems.outputs.provenance import version
from safety_systems.config.scenario import ControllerConfig
from verification.deploy.certificate import (
    SCHEMA,
    SCHEMA_VERSION,
    braking_data,
    certificate_text,
    params_log,
    params_cell,
    plain,
    read_json,
    robot_identity,
    safety_checksum,
    short,
)
from safety_systems.cell.human_body import DIMENSION_NAMES
from verification.properties import MODE_PROPERTIES, mode_properties
from verification.spaces.box import ScenarioSpace
from verification.spaces.space import load_space, tracked_bodies

# The installed packages whose code computed the verdict (the certificate names their
# versions): the simulators, the proofs' solver, the search's optimizer, the readers.
# (filterpy, listed before, is a test dependency: the Kalman filter's reference.)
DEPENDENCIES = ("drake", "numpy", "scipy", "numba", "z3-solver", "cma", "ezc3d", "bvhio")
VERDICT_MEANING = {
    "proved": "proved over the whole continuous box of the scenario space "
              "(verification.proof), the search and the Drake replays agreeing",
    "passed": "no counterexample found by the search, and no proof: weaker than proved",
    "falsified": "a counterexample confirmed in the Drake diagram: NOT SAFE TO DEPLOY",
    "inconclusive": "the evidence contradicts itself (an evaluator or the proof is wrong): "
                    "NOT SAFE TO DEPLOY",
}
COUNTS_MEANING = ("simulations: the search's closed-loop simulations of the space's "
                  "scenarios; evaluations: every evaluation of a model of the loop, by kind, "
                  "as verify's report.json gives them (simulations; margins and dangers, "
                  "candidates scored by the proofs' margins and by the reduced model; drake, "
                  "runs of the full Drake diagram that confirm or cross-check the search's "
                  "figures; their total; search_cost, the search's in simulation-"
                  "equivalents, which its budget bounds; cost, with the Drake runs). The "
                  "proofs are not simulations.")


NUMBER = (int, float)
MAYBE_NUMBER = (int, float, type(None))
PREMISE = {"statement": str, "basis": str, "holds": bool}
PROOF = {"proved": bool, "method": str, "premises": [PREMISE],
         "margin_at_worst_corner": MAYBE_NUMBER}
COUNTEREXAMPLE = {"drake_robustness": NUMBER, "parameters": dict, "scenario": str}
PROPERTY = {"verdict": str, "min_robustness": MAYBE_NUMBER, "proof": PROOF,
            "counterexamples": [COUNTEREXAMPLE], "drake_replays": [{"simulation": int}]}
REPORT = {"verdict": str, "method": str, "robot_mode": str, "config_sha256": str,
          "space": str, "assumptions": [str], "box": dict, "free_parameters": [str],
          "simulations": int, "properties": {"*": PROPERTY}}


def _expect(value, shape, where: str, path) -> None:
    """Raises InputError unless ``value`` has ``shape``: a type (or tuple of types), a
    list of one shape, or a mapping of keys to shapes ("*": every value)."""
    if isinstance(shape, list):
        if not isinstance(value, list):
            raise InputError(where, value, "a list", file=path)
        for i, item in enumerate(value):
            _expect(item, shape[0], f"{where}[{i}]", path)
    elif isinstance(shape, dict):
        if not isinstance(value, dict):
            raise InputError(where, value, "a mapping", file=path)
        for key, inner in shape.items():
            items = value.items() if key == "*" else [(key, value.get(key, KeyError))]
            for name, item in items:
                if item is KeyError:
                    raise InputError(f"{where}.{name}".lstrip("."), "missing", "a report.json "
                                     "of safety-systems verify (every field it writes)",
                                     file=path)
                _expect(item, inner, f"{where}.{name}".lstrip("."), path)
    elif isinstance(value, bool) and shape is not bool and bool not in (
            shape if isinstance(shape, tuple) else (shape,)):
        raise InputError(where, value, f"{_name(shape)} (not true or false)", file=path)
    elif not isinstance(value, shape):
        raise InputError(where, value, _name(shape), file=path)


def _name(shape) -> str:
    kinds = shape if isinstance(shape, tuple) else (shape,)
    return " or ".join({"int": "an integer", "float": "a number", "str": "a string",
                        "bool": "true or false", "dict": "a mapping",
                        "NoneType": "null"}.get(k.__name__, k.__name__) for k in kinds)


def read_report(path: str | Path) -> dict:
    """A verification's report.json, the fields export uses checked; raises InputError."""
    report = read_json(path)
    _expect(report, REPORT, "", path)
    if report["verdict"] not in VERDICT_MEANING:
        raise InputError("verdict", report["verdict"], " | ".join(VERDICT_MEANING), file=path)
    mode = report.get("safety_mode", "ssm")
    if mode not in MODE_PROPERTIES:
        raise InputError("safety_mode", mode, " | ".join(MODE_PROPERTIES), file=path)
    if sorted(report["properties"]) != sorted(mode_properties(mode)):
        raise InputError("properties", sorted(report["properties"]), f"both properties "
                         f"of safety.mode {mode}, {sorted(mode_properties(mode))} (verify "
                         "--property both): a certificate carries the verdict of each",
                         file=path)
    return report


def _space(report: dict, report_path: Path) -> tuple[ScenarioSpace, str, str]:
    """The report's space, loaded, with its path and SHA-256 (checked against the
    report's provenance when it has one)."""
    path = report["space"]
    sha = hashlib.sha256(read_input(path)).hexdigest()
    space = load_space(path)
    inputs = (report.get("provenance") or {}).get("inputs") or {}
    recorded = inputs.get(str(Path(path)), inputs.get(str(path)))
    if recorded is not None and recorded != sha:
        raise InputError("space", path, "the space file as verified (its SHA-256 differs "
                         "from the one the report records)", file=report_path)
    return space, str(path), sha


def premises(report: dict) -> list[dict]:
    """Every premise of the report's proofs once, with the properties it serves."""
    out: dict[str, dict] = {}
    for name, p in report["properties"].items():
        for x in p["proof"]["premises"]:
            entry = out.setdefault(x["statement"], {"statement": x["statement"],
                                                    "basis": x["basis"], "holds": x["holds"],
                                                    "properties": []})
            entry["holds"] = entry["holds"] and x["holds"]
            entry["properties"].append(name)
    return list(out.values())


def whole_cell(params: Params, space: ScenarioSpace, cell: ResolvedCell) -> dict:
    """The whole-cell settings the premises speak of, as figures: the robot as the
    monitor measures it (its capsules' radii) against the real robot the properties
    measure, the robot's speed in S, the operators' body model, how hidden bodies are kept and
    how frames are gated (the proofs' premises say whether each suffices); ``cell``: what
    the params mean on their robot."""
    f, t = params.controller.safety, params.controller.tracker
    mine, real = cell.capsules, contact_capsules(space.robot,
                                                               space.contact_geometry)
    return {
        "monitor": {"robot_geometry": f.robot_geometry, "capsules": list(mine.names),
                    "radii": [float(r) for r in mine.radius],
                    "tool_length": float(mine.tool_length), "robot_speed": f.robot_speed},
        "contact": {"geometry": space.contact_geometry, "capsules": list(real.names),
                    "radii": [float(r) for r in real.radius],
                    "tool_length": float(real.tool_length),
                    "contact_distance": float(space.contact_distance)},
        "bodies": _bodies(params.controller, space),
        "hidden_bodies": {"rule": t.hidden_bodies, "occlusion_speed": float(f.occlusion_speed),
                          "exits": len(t.exits), "walls": t.cell is not None},
        "frames": {"gate": bool(t.gate), "gate_speed": float(t.gate_speed),
                   "gate_width": float(t.gate_width), "timeout": float(cell.frame_timeout)},
    }


def _bodies(config, space: ScenarioSpace) -> dict:
    """The operators as the monitor models them (``safety_systems.cell.human_body``): the
    configuration's body dimensions, its tracking allowance, and the body points the
    space's operators are tracked by (a recording space's: each recorded body's point as
    its mapping gives it)."""
    dims = {name: float(getattr(config.body, name)) for name in DIMENSION_NAMES}
    out = {"dimensions": dims, "tracking_allowance": float(config.body.tracking_allowance)}
    if space.recording is None:
        out["tracked"] = [q for _, q in tracked_bodies(space, space.parameters.heads.max >= 1)]
        return out
    from safety_systems.sensing.recording_mapping import load_mapping, mapped_point

    mapping = load_mapping(space.recording.mapping)
    out["tracked"] = {f"{o.name}/{b.name}": mapped_point(b) for o in mapping.operators
                      for b in o.bodies}
    out["mapping"] = str(space.recording.mapping)
    return out


def counterexamples(report: dict, tune: dict | None) -> list[dict]:
    """The report's confirmed counterexamples and, given a tune.json, those kept along
    the search."""
    out = [{"property": name, "found_for": "this configuration",
            "drake_robustness": c["drake_robustness"], "parameters": c["parameters"],
            "scenario": c["scenario"]}
           for name, p in report["properties"].items() for c in p["counterexamples"]]
    for k in (tune or {}).get("counterexamples", []):
        out.append({"property": k["property"], "found_for": f"{k['found_for']} (tune)",
                    "drake_robustness": k["robustness"], "parameters": {},
                    "scenario": k["file"]})
    return out


def build(config: ControllerConfig, config_path: str, report: dict, report_path: Path,
          tune: dict | None = None, tune_path: str | None = None, out: Path | None = None
          ) -> tuple[Params, dict, ScenarioSpace]:
    """(params, certificate without its file digests, space) of a configuration and the
    report of its verification, for ``out`` (params.yaml's folder: a URDF robot's file is
    written relative to it; None: the current folder)."""
    out = Path(".") if out is None else Path(out)
    sha = hashlib.sha256(read_text(config_path).encode()).hexdigest()
    if report["config_sha256"] != sha:
        raise InputError("config_sha256", report["config_sha256"][:12] + "...",
                         f"the SHA-256 of {config_path} ({sha[:12]}...): this report is of "
                         "another configuration", file=report_path)
    space, space_path, space_sha = _space(report, report_path)
    params = Params(controller=deployed_controller(config),
                    robot=deployed_robot(space.robot, out))
    cell = params_cell(params, out)
    model = cell.model
    assumptions = {"space_file": space_path, "space_sha256": space_sha, "space": plain(space),
                   "assumptions": report["assumptions"], "box": report["box"],
                   "free_parameters": report["free_parameters"],
                   "robot_mode": report["robot_mode"]}
    checksum = safety_checksum(params, assumptions, out, cell)
    properties = {name: {"verdict": p["verdict"], "min_robustness": p["min_robustness"],
                         "proved": p["proof"]["proved"], "method": p["proof"]["method"],
                         "margin_at_worst_corner": p["proof"]["margin_at_worst_corner"],
                         "needed_allowance": p["proof"].get("needed_allowance"),
                         "premises": p["proof"]["premises"],
                         "vacuous": p.get("vacuous")}
                  for name, p in report["properties"].items()}
    replays = {r["simulation"] for p in report["properties"].values()
               for r in p.get("drake_replays", [])}
    counted = report.get("evaluations")  # every evaluation by kind (verification/search/counts.py)
    evaluations = (dict(counted) if isinstance(counted, dict) else
                   {"drake": len(replays)})  # (a report from before the counts)
    sources = {"config": {"path": config_path, "sha256": sha},
               "report": {"path": str(report_path),
                          "sha256": inputs_read().get(str(report_path), "")},
               "space": {"path": space_path, "sha256": space_sha}}
    if tune_path is not None:
        sources["tune"] = {"path": tune_path,
                           "sha256": inputs_read().get(str(Path(tune_path)), "")}
    certificate = {
        "schema": SCHEMA, "schema_version": SCHEMA_VERSION,
        "checksum": checksum, "checksum_short": short(checksum),
        "checksum_covers": "SHA-256 of the canonical JSON (sorted keys, no spaces) of the "
                           "parameters, the braking table, the path and the assumptions",
        "params_file": "params.yaml", "params_file_sha256": "",
        "verdict": report["verdict"], "verdict_meaning": VERDICT_MEANING[report["verdict"]],
        "method": report["method"], "robot_mode": report["robot_mode"],
        "properties": properties, "premises": premises(report),
        "cell": whole_cell(params, space, cell),
        "braking_data": braking_data(cell), "assumptions": assumptions,
        "robot": robot_identity(model, params_log(params, out)),
        "simulations": int(report["simulations"]), "evaluations": evaluations,
        "counts_meaning": COUNTS_MEANING,
        "min_robustness": {n: p["min_robustness"] for n, p in report["properties"].items()},
        "counterexamples": counterexamples(report, tune),
        "versions": {"safety-systems": version(), "python": platform.python_version(),
                     **{d: version(d) for d in DEPENDENCIES},
                     "verified_with": {k: v for k, v in (report.get("provenance") or {}).items()
                                       if k.endswith("_version")}},
        "parameters": flat_parameters(params), "sources": sources,
        "exported": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
    }
    return params, certificate, space


def header(certificate: dict, config_path: str) -> list[str]:
    return [f"Controller parameters exported by safety-systems {version()} from {config_path}",
            f"(a ROS 2 parameter file). Verdict: {certificate['verdict']} over "
            f"{certificate['assumptions']['space_file']};",
            f"safety checksum {certificate['checksum_short']} "
            f"({certificate['checksum']}).",
            "Check before loading: safety-systems check params.yaml "
            "(certificate.json beside it). Do not edit: any edit voids the certificate."]


def write_export(params: Params, certificate: dict, space: ScenarioSpace, report: dict,
                 report_dir: Path, config_path: str, out: Path, *, plots: bool = True) -> dict:
    """Writes params.yaml, certificate.json and report.html (the parts :func:`build`
    made) into ``out``; returns the certificate as written."""
    from verification.deploy.assessor_report import write_assessor_report

    text = params_text(params, header(certificate, config_path))
    certificate = dict(certificate,
                       params_file_sha256=hashlib.sha256(text.encode("utf-8")).hexdigest())
    write_text(out / "params.yaml", text)
    write_text(out / "certificate.json", certificate_text(certificate))
    write_assessor_report(out / "report.html", certificate, params, space, report,
                          report_dir, plots=plots)
    return json.loads(certificate_text(certificate))


def read_tune(path: str) -> dict:
    """A tune.json (its kept counterexamples go into the certificate)."""
    tune = read_json(path)
    if not (isinstance(tune, dict) and isinstance(tune.get("counterexamples"), list)):
        raise InputError("counterexamples", "missing", "a tune.json of safety-systems tune",
                         file=path)
    kinds = {"file": str, "found_for": str, "property": str, "robustness": (int, float)}
    for i, k in enumerate(tune["counterexamples"]):
        if not (isinstance(k, dict) and all(isinstance(k.get(key), kind)
                                            for key, kind in kinds.items())):
            raise InputError(f"counterexamples[{i}]", k, "a counterexample of tune.json "
                             f"({', '.join(kinds)})", file=path)
    return tune
