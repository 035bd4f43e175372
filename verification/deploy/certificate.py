"""certificate.json: what a verification established about exported parameters, and the
check that a params.yaml is what was certified.

The **safety checksum** (``checksum``) works like the one a robot controller shows: the
SHA-256 of the canonical form (:func:`canonical`: JSON, keys sorted, no spaces, floats
in their shortest exact spelling) of four parts: the parameters (the controller
configuration without its stopping data), the braking table as the robot uses it (the
configured rows, or the built-in placeholder's, with its origin), the path and robot
settings verified, the robot itself (its model's name, joints and the SHA-256 of its URDF:
an edited robot description voids the certificate; a path that is the robot's own log
adds the log's file and SHA-256: an edited log voids it too) and the assumptions (the
scenario space, the assumptions in words and the proof's box). Any change to a safety
setting changes it; layout and comments do not.

Two more digests make any edit of either file visible (they detect edits, they are not
signatures: whoever can write the files can write new digests):
``params_file_sha256``, the SHA-256 of params.yaml's bytes, and ``certificate_sha256``,
the SHA-256 of certificate.json's own text with that field's value written as 64
zeros.

:func:`check` exits (``CheckResult.code``) 0 only when both files are as exported, the
checksum matches and the verdict is ``proved`` (or ``passed``, reported as weaker;
``require="proved"`` refuses it with ``EXIT_REQUIREMENT``); 1 when the parameters are
not certified (no certificate, an altered one, an edited value, a falsified or
inconclusive verdict); 2 when a file cannot be read (``InputError``, including a file
of another schema version).
"""

import dataclasses
import hashlib
import json
import os
import re
import typing
from pathlib import Path

from safety_systems.files.documents import decode_text, read_input
from safety_systems.files.input_error import InputError
from safety_systems.cell.robot_model import RobotModel
from safety_systems.config.params_file import (
    Params,
    flat_parameters,
    params_from_text,
    robot_config,
)
from safety_systems.config.scenario import RobotConfig, robot_log_of, robot_model_of
from safety_systems.files.ranges import type_hints
from safety_systems.config.resolved_cell import ResolvedCell, resolve
from verification.verdicts import EXIT_REQUIREMENT, VERDICTS

SCHEMA = "safety-systems certificate"
# 2: ``evaluations`` by kind, as report.json's (was model_evaluations); 3: ``robot`` (the
# model, its joints and its URDF's SHA-256), in the checksum too. A robot log path adds
# ``robot.log`` (its file and SHA-256) in version 3: no other certificate changes.
SCHEMA_VERSION = 3
DIGEST = "certificate_sha256"
_ZEROS = "0" * 64
_DIGEST_TEXT = re.compile(r'"certificate_sha256": "([0-9a-f]{64})"')
_HEX64 = re.compile(r"[0-9a-f]{64}")
MAX_CERTIFICATE_BYTES = 16 * 1024 * 1024
FIELDS = {  # every key of a certificate and the type of its value
    "schema": str, "schema_version": int, "checksum": str, "checksum_short": str,
    "checksum_covers": str, "params_file": str, "params_file_sha256": str, "verdict": str,
    "verdict_meaning": str, "method": str, "robot_mode": str, "properties": dict,
    "premises": list, "cell": dict, "braking_data": dict, "assumptions": dict,
    "simulations": int, "evaluations": dict, "counts_meaning": str,
    "min_robustness": dict, "counterexamples": list, "versions": dict, "parameters": dict,
    "sources": dict, "exported": str, "robot": dict, DIGEST: str,
}
EXIT_NOT_CERTIFIED = 1
EXIT_UNREADABLE = 2


def plain(obj: typing.Any, hint: typing.Any = None) -> typing.Any:
    """Plain JSON data of a dataclass value: records as mappings, a float field's numbers
    as floats (so 1 and 1.0 give one canonical form), None kept."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        hints = type_hints(type(obj))
        return {f.name: plain(getattr(obj, f.name), hints[f.name])
                for f in dataclasses.fields(obj)}
    if isinstance(obj, (list, tuple)):
        args = typing.get_args(hint)
        return [plain(x, args[0] if args else None) for x in obj]
    if isinstance(obj, bool) or obj is None or isinstance(obj, str):
        return obj
    floating = hint is float or float in typing.get_args(hint)
    if isinstance(obj, (int, float)):
        return float(obj) if floating or isinstance(obj, float) else int(obj)
    return float(obj)  # numpy numbers


def canonical(data: typing.Any) -> bytes:
    """The canonical form: JSON with sorted keys and no spaces (ASCII; floats by repr,
    their shortest exact spelling; no NaN or infinity)."""
    return json.dumps(data, sort_keys=True, separators=(",", ":"), ensure_ascii=True,
                      allow_nan=False).encode("ascii")


def params_model(params: Params, folder: str | Path | None) -> RobotModel:
    """The model of the robot params.yaml certifies (a URDF relative to ``folder``, the
    params file's)."""
    return robot_model_of(robot_config(params.robot, RobotConfig(),
                                       None if folder is None else Path(folder)))


def robot_identity(model: RobotModel, log: dict | None = None) -> dict:
    """The robot as the certificate names it: its model, joints, URDF and the URDF's
    SHA-256; and the log it runs, when its path is one (:func:`params_log`)."""
    identity = {"model": model.name, "joints": list(model.joint_names),
                "urdf": model.urdf.name, "urdf_sha256": model.sha256}
    if log is not None:
        identity["log"] = log
    return identity


def params_log(params: Params, folder: str | Path | None) -> dict | None:
    """The robot log params.yaml's path runs (None: its path is not a log): its file as
    params.yaml names it (relative to ``folder``, params.yaml's) and the SHA-256 of its
    bytes (a bag folder's: ``sensing.ros_bag.bag_digest``), so that an edited log voids
    the certificate."""
    log = params.robot.path.log
    if log is None:
        return None
    robot = robot_config(params.robot, RobotConfig(), None if folder is None else Path(folder))
    return {"file": log.file, "sha256": robot_log_of(robot).sha256}


def params_cell(params: Params, folder: str | Path | None,
                model: RobotModel | None = None) -> ResolvedCell:
    """What params.yaml's configuration means on the robot it certifies (files relative
    to ``folder``, the params file's; ``model``: that robot's model if already built)."""
    robot = robot_config(params.robot, RobotConfig(), None if folder is None else Path(folder))
    return resolve(params.controller, robot, model=model)


def braking_data(cell: ResolvedCell) -> dict:
    """The braking table the robot uses and its origin: ``measured`` (the configuration's
    rows, entered as measured on the cell) or ``placeholder`` (the built-in placeholder
    of the cell's robot: the UR5e's UR5/CB3 figures, ``safety_systems.cell.placeholder_stops``)."""
    table = cell.braking
    return {"origin": "placeholder" if cell.braking_source == "placeholder" else "measured",
            "stop_category": int(cell.config.braking.stop_category),
            "speed_fraction": [float(x) for x in table.speed_fraction],
            "stopping_time": [float(x) for x in table.stopping_time],
            "stopping_distance": [float(x) for x in table.stopping_distance]}


def checksum_parts(params: Params, assumptions: dict, folder: str | Path | None = None,
                   cell: ResolvedCell | None = None) -> dict:
    """What the safety checksum covers (see the module docstring); ``folder``: the params
    file's, which a URDF robot's file is relative to; ``cell``: the params' resolved cell
    if the caller has it (None: resolved here, :func:`params_cell`)."""
    parameters = plain(params.controller)
    del parameters["braking"]
    cell = params_cell(params, folder) if cell is None else cell
    model = cell.model
    return {"schema_version": SCHEMA_VERSION, "parameters": parameters,
            "braking": braking_data(cell), "path": plain(params.robot),
            "robot": robot_identity(model, params_log(params, folder)),
            "assumptions": assumptions}


def safety_checksum(params: Params, assumptions: dict, folder: str | Path | None = None,
                    cell: ResolvedCell | None = None) -> str:
    return hashlib.sha256(canonical(checksum_parts(params, assumptions, folder, cell))
                          ).hexdigest()


def short(checksum: str) -> str:
    """The checksum's first 8 hex digits, as a controller's display shows one."""
    return checksum[:8].upper()


def certificate_text(certificate: dict) -> str:
    """certificate.json's text, its ``certificate_sha256`` filled in."""
    body = dict(certificate, **{DIGEST: _ZEROS})
    text = json.dumps(body, indent=2, allow_nan=False) + "\n"
    digest = hashlib.sha256(text.encode("utf-8")).hexdigest()
    return text.replace(f'"{DIGEST}": "{_ZEROS}"', f'"{DIGEST}": "{digest}"', 1)


def own_digest_holds(text: str) -> bool:
    """Whether certificate.json's text carries its own SHA-256 (see the docstring)."""
    found = _DIGEST_TEXT.findall(text)
    if len(found) != 1:
        return False
    blank = _DIGEST_TEXT.sub(f'"{DIGEST}": "{_ZEROS}"', text)
    return hashlib.sha256(blank.encode("utf-8")).hexdigest() == found[0]


def _pairs(pairs: list) -> dict:
    keys = [k for k, _ in pairs]
    twice = next((k for k in keys if keys.count(k) > 1), None)
    if twice is not None:
        raise ValueError(f"duplicate key {twice!r}")
    return dict(pairs)


def _no_constant(name: str):
    raise ValueError(f"{name} (JSON has no such number)")


def json_document(path: str | Path) -> tuple[typing.Any, str]:
    """(the data, the text) of a JSON input file: UTF-8, valid JSON, no duplicate keys, no
    NaN or infinity; raises InputError (one line)."""
    data = read_input(path, max_bytes=MAX_CERTIFICATE_BYTES)
    try:
        text = data.decode("utf-8")
        return json.loads(text, object_pairs_hook=_pairs, parse_constant=_no_constant), text
    except UnicodeDecodeError as e:
        raise InputError("<file>", f"byte {data[e.start]:#04x} at offset {e.start}",
                         "a UTF-8 text file", file=path) from None
    except json.JSONDecodeError as e:
        raise InputError(f"line {e.lineno}, column {e.colno}", e.msg, "JSON", file=path) \
            from None
    except (ValueError, RecursionError) as e:
        raise InputError("<document>", str(e) or type(e).__name__,
                         "JSON without duplicate keys or NaN", file=path) from None


def read_json(path: str | Path) -> typing.Any:
    """The data of a JSON input file (:func:`json_document`'s rules)."""
    return json_document(path)[0]


def read_certificate(path: str | Path) -> tuple[dict, str]:
    """(the certificate, its text): :func:`json_document`'s rules, every field of
    ``FIELDS`` of its type and no other, this schema and version; raises InputError."""
    cert, text = json_document(path)
    if not isinstance(cert, dict):
        raise InputError("<document>", cert, "a JSON object (a certificate)", file=path)
    if cert.get("schema") != SCHEMA or type(cert.get("schema_version")) is not int:
        raise InputError("schema", cert.get("schema"), f"{SCHEMA!r} with a schema_version",
                         file=path)
    if cert["schema_version"] != SCHEMA_VERSION:
        raise InputError("schema_version", cert["schema_version"],
                         f"{SCHEMA_VERSION} (this safety-systems reads certificate schema "
                         f"{SCHEMA_VERSION}; the file was written for another)", file=path)
    for key, value in cert.items():
        if key not in FIELDS:
            raise InputError(key, value, f"one of the certificate's fields {sorted(FIELDS)} "
                             "(unknown key)", file=path)
        kind = FIELDS[key]
        if type(value) is not kind:
            raise InputError(key, value, f"a JSON {kind.__name__}", file=path)
    missing = sorted(set(FIELDS) - set(cert))
    if missing:
        raise InputError(missing[0], "missing", "every field of a certificate", file=path)
    for key in ("checksum", "params_file_sha256", DIGEST):
        if not _HEX64.fullmatch(cert[key]):
            raise InputError(key, cert[key], "64 lowercase hex digits (a SHA-256)", file=path)
    if cert["verdict"] not in VERDICTS:
        raise InputError("verdict", cert["verdict"], " | ".join(VERDICTS), file=path)
    return cert, text


@dataclasses.dataclass(frozen=True)
class CheckResult:
    """The outcome of :func:`check`: the exit code and its one line."""

    code: int
    line: str
    verdict: str | None = None
    checksum: str | None = None
    params: Params | None = None
    # m: how far the certified space let a tracked body be reported from its point
    # (``verification.spaces.box`` ``pivot_offset``; 0 for a space that did not say)
    pivot_offset: float = 0.0

    @property
    def certified(self) -> bool:
        return self.code == 0


def _fail(line: str, code: int = EXIT_NOT_CERTIFIED, **kw) -> CheckResult:
    return CheckResult(code, line, **kw)


def check(params_path: str | Path, certificate_path: str | Path | None = None, *,
          require: str = "passed") -> CheckResult:
    """Whether ``params_path`` is what ``certificate_path`` (default: certificate.json
    beside it) certifies (see the module docstring)."""
    params_path = Path(params_path)
    certificate_path = (params_path.parent / "certificate.json" if certificate_path is None
                        else Path(certificate_path))
    try:
        raw = read_input(params_path)
        params = params_from_text(decode_text(raw, params_path), params_path)
    except InputError as e:
        return _fail(str(e), EXIT_UNREADABLE)
    if not certificate_path.is_file():
        return _fail(f"{certificate_path}: missing: {params_path} is not certified without "
                     "the certificate.json export wrote beside it", params=params)
    try:
        cert, text = read_certificate(certificate_path)
    except InputError as e:
        return _fail(str(e), EXIT_UNREADABLE, params=params)
    if not own_digest_holds(text):
        return _fail(f"{certificate_path}: {DIGEST}: got {cert[DIGEST][:12]}...; allowed: the "
                     "SHA-256 of this file as export wrote it (the certificate was altered)",
                     params=params)
    model = params_model(params, params_path.parent)
    certified = cert.get("robot", {})
    if model.sha256 != certified.get("urdf_sha256"):
        return _fail(f"{model.urdf}: urdf_sha256: got {model.sha256[:12]}...; allowed: the "
                     f"certified {str(certified.get('urdf_sha256'))[:12]}... (the robot's "
                     f"description is not the one verified: {certified.get('model')})",
                     params=params)
    log, certified_log = params_log(params, params_path.parent), certified.get("log") or {}
    if (log is not None and log["file"] == certified_log.get("file")
            and log["sha256"] != certified_log.get("sha256")):
        where = os.path.normpath(params_path.parent / log["file"])
        return _fail(f"{where}: sha256: got {log['sha256'][:12]}...; "
                     f"allowed: the certified {str(certified_log.get('sha256'))[:12]}... (the "
                     "robot's log is not the one verified)", params=params)
    checksum = safety_checksum(params, cert["assumptions"], params_path.parent)
    if hashlib.sha256(raw).hexdigest() != cert["params_file_sha256"]:
        return _fail(_what_changed(params, params_path, cert, checksum), params=params,
                     checksum=checksum)
    if checksum != cert["checksum"]:
        return _fail(f"{params_path}: checksum: got {short(checksum)}; allowed: the "
                     f"certified {short(cert['checksum'])}", params=params, checksum=checksum)
    verdict = cert["verdict"]
    if verdict not in ("proved", "passed"):
        return _fail(f"{certificate_path}: verdict: got {verdict}; allowed: proved (or "
                     f"passed): these parameters were {verdict} and must not be deployed",
                     verdict=verdict, params=params, checksum=checksum)
    line = (f"{params_path}: certified {verdict}, checksum {short(checksum)} "
            f"(braking data: {cert['braking_data'].get('origin')})")
    if verdict == "passed":
        line += ("; passed is weaker than proved: the search found no counterexample but "
                 "there is no proof")
        if require == "proved":
            return CheckResult(EXIT_REQUIREMENT, f"{line}; --require proved refuses it",
                               verdict, checksum, params)
    return CheckResult(0, line, verdict, checksum, params, certified_pivot_offset(cert))


def certified_pivot_offset(cert: dict) -> float:
    """The largest pivot offset (m) the certificate's space let a tracked body's reported
    position have from its point (0 where the space does not say)."""
    space = (cert.get("assumptions") or {}).get("space") or {}
    r = ((space.get("parameters") or {}).get("pivot_offset")) or {}
    value = r.get("max", 0.0) if isinstance(r, dict) else 0.0
    return float(value) if isinstance(value, (int, float)) else 0.0


def _what_changed(params: Params, path: Path, cert: dict, checksum: str) -> str:
    """One line naming the first parameter that differs from the certified ones, or
    saying that only bytes outside the values differ."""
    now, then = flat_parameters(params), cert["parameters"]
    for key in list(then) + [k for k in now if k not in then]:
        if now.get(key) != then.get(key):
            return (f"{path}: {key}: got {now.get(key, 'nothing')}; allowed: the certified "
                    f"{then.get(key, 'nothing')} (an edited value: checksum "
                    f"{short(checksum)}, certified {short(cert['checksum'])})")
    return (f"{path}: <file>: got bytes other than the certified file's (SHA-256 "
            f"{cert['params_file_sha256'][:12]}...); allowed: params.yaml as exported (its "
            "values still match; comments, layout or spelling were edited)")
