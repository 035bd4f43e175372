"""Loading the parameters the runtime runs: certified ones only (one function)."""

import dataclasses
import importlib.util
import sys
from pathlib import Path

from safety_systems.input_error import InputError
from safety_systems.scenario import ControllerConfig, RobotConfig

CERTIFICATE = "certificate.json"
EXIT_NOT_CERTIFIED = 1


class NotCertified(Exception):
    """Parameters the runtime must not run: ``line`` says why, ``code`` is the exit code
    (1: not certified, 2: unreadable)."""

    def __init__(self, line: str, code: int = EXIT_NOT_CERTIFIED):
        super().__init__(line)
        self.line, self.code = line, code


@dataclasses.dataclass(frozen=True)
class CertifiedParams:
    """What the runtime runs: the controller configuration, the robot it was verified
    for (its path, rate and tool), whether the certificate check passed, and its line."""

    controller: ControllerConfig
    robot: RobotConfig
    certified: bool
    line: str


def _certificate_check():
    """Issue 14's check of params.yaml against its certificate.json
    (``verification.certificate.check``), or None in a build that has none yet."""
    if importlib.util.find_spec("verification.certificate") is None:
        return None
    from verification.certificate import check

    return check


def load_certified_params(path: str | Path, *, unverified: bool = False) -> CertifiedParams:
    """The parameters at ``path`` if they pass the certificate check; raises NotCertified
    (or InputError for a file that cannot be read) otherwise, unless ``unverified``: then
    they are returned with ``certified`` False and the check's line (the caller says that
    they are unverified).

    The check is issue 14's ``verification.certificate.check`` (params.yaml against the
    certificate.json export wrote beside it: the safety checksum, both files' digests, a
    proved or passed verdict). In a build without it, an interim rule stands in: the
    file is a controller configuration (``load_controller_config``) and it is refused
    unless a file named certificate.json lies beside it; that presence is all the
    interim rule checks, and its line says so.
    """
    path = Path(path)
    check = _certificate_check()
    if check is not None:
        result = check(path)
        if result.params is None:  # not a params.yaml: a plain configuration is uncertified
            from safety_systems.scenario import load_controller_config

            try:
                controller = load_controller_config(path)
            except InputError:
                raise NotCertified(result.line, result.code) from None
            line = f"{path}: not certified: a controller configuration, not an exported " \
                   "params.yaml with its certificate.json"
            if not unverified:
                raise NotCertified(line + " (--unverified runs it anyway)")
            return CertifiedParams(controller, RobotConfig(), False, line)
        if not result.certified and not unverified:
            raise NotCertified(result.line + " (--unverified runs it anyway)", result.code)
        return CertifiedParams(result.params.controller, result.params.robot,
                               result.certified, result.line)
    from safety_systems.scenario import load_controller_config

    controller = load_controller_config(path)
    certificate = path.parent / CERTIFICATE
    if not certificate.is_file():
        line = (f"{path}: not certified: no {CERTIFICATE} beside it (the interim check of "
                "this build: issue 14's certificate check is not in it)")
        if not unverified:
            raise NotCertified(line + " (--unverified runs it anyway)")
        return CertifiedParams(controller, RobotConfig(), False, line)
    return CertifiedParams(controller, RobotConfig(), True,
                           f"{path}: {CERTIFICATE} present (interim check of this build: "
                           "its presence only, not its contents)")


def warn_unverified(params: CertifiedParams) -> None:
    if not params.certified:
        print(f"safety-systems: warning: UNVERIFIED parameters (--unverified): {params.line}",
              file=sys.stderr)


__all__ = ["CertifiedParams", "InputError", "NotCertified", "load_certified_params",
           "warn_unverified"]
