"""Where a result came from: versions, input files, seeds and the command line.

Every result file that names its inputs (``summary.json``, ``report.json``,
``comparison.json``, ``plan.json``) carries :func:`provenance` under the key
``provenance``.
"""

import importlib.metadata
import shlex
import sys

from safety_systems.files import documents

PROJECT = "safety-systems"


def version(distribution: str = PROJECT) -> str:
    """The installed version of ``distribution`` ("unknown" when it is not installed)."""
    try:
        return importlib.metadata.version(distribution)
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


def version_line() -> str:
    """What ``safety-systems --version`` prints."""
    return f"{PROJECT} {version()} (Drake {version('drake')})"


def provenance(seeds: dict[str, int], command: list[str] | None = None) -> dict:
    """The versions of this project and of Drake, the SHA-256 of every input file read
    in this process since ``documents.forget_inputs()`` (the CLI forgets before each
    command), the named ``seeds`` and the command line (default: this process's)."""
    argv = list(sys.argv if command is None else command)
    return {"safety_systems_version": version(), "drake_version": version("drake"),
            "command_line": shlex.join(argv),
            "inputs": documents.inputs_read(),
            "seeds": {name: int(seed) for name, seed in seeds.items()}}


def scenario_seeds(scenario, prefix: str = "") -> dict[str, int]:
    """The seeds a scenario's run draws from: its real sensor's noise and the speed
    alteration controllers' genetic algorithm."""
    from safety_systems.config.scenario import actual_sensor

    return {f"{prefix}sensor": actual_sensor(scenario).seed,
            f"{prefix}alteration": scenario.controller.alteration.seed}
