"""Loading the parameters the runtime runs: certified ones only (one function)."""

import dataclasses
import sys
from pathlib import Path

from safety_systems.files.input_error import InputError
from safety_systems.config.scenario import ControllerConfig, RobotConfig

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
    verdict: str | None = None  # the certificate's, when check could read one
    pivot_offset: float = 0.0  # m: the certified space's largest pivot offset


def load_certified_params(path: str | Path, *, unverified: bool = False) -> CertifiedParams:
    """The parameters at ``path`` if ``check`` certifies them (issue 14's
    ``verification.deploy.certificate.check``: params.yaml against the certificate.json export
    wrote beside it; its safety checksum, both files' digests, a proved or passed
    verdict); the runtime refuses exactly what ``check`` refuses, by calling it.

    Refused: raises NotCertified with check's line and exit code, unless ``unverified``:
    then a params.yaml that fails its check, or a plain controller configuration (which
    has no certificate at all), is returned with ``certified`` False and the reason (the
    caller says that it is unverified). A file that is neither raises NotCertified
    (``unverified`` or not) with check's line.
    """
    from safety_systems.config.params_file import robot_config
    from verification.deploy.certificate import check

    path = Path(path)
    result = check(path)
    if result.code == 0:
        return CertifiedParams(result.params.controller,
                               robot_config(result.params.robot, RobotConfig(), path.parent), True,
                               result.line, result.verdict, result.pivot_offset)
    if not unverified:
        raise NotCertified(result.line + " (--unverified runs it anyway)", result.code)
    if result.params is not None:
        return CertifiedParams(result.params.controller,
                               robot_config(result.params.robot, RobotConfig(), path.parent),
                               False,
                               result.line)
    from safety_systems.config.params_file import looks_like_params
    from safety_systems.config.scenario import load_controller_config

    if looks_like_params(path):  # a params.yaml check could not read
        raise NotCertified(result.line, result.code)
    try:
        controller = load_controller_config(path)
    except InputError:
        raise NotCertified(result.line, result.code) from None
    return CertifiedParams(controller, RobotConfig(), False,
                           f"{path}: a controller configuration, not an exported params.yaml "
                           "with its certificate.json")


def warn_unverified(params: CertifiedParams) -> None:
    """Says on stderr that parameters are unverified, or certified only as passed (as
    simulate and verify say it)."""
    if not params.certified:
        print(f"safety-systems: warning: UNVERIFIED parameters (--unverified): {params.line}",
              file=sys.stderr)
    elif params.verdict == "passed":
        print(f"safety-systems: warning: {params.line}", file=sys.stderr)


__all__ = ["CertifiedParams", "InputError", "NotCertified", "load_certified_params",
           "warn_unverified"]
