"""The verdicts of ``safety-systems verify``, their strength and their exit codes.

Kept apart from ``verification.verify`` (which imports Drake) so that the command line
can build its help from it cheaply.
"""

VERDICTS = ("proved", "passed", "falsified", "inconclusive")
# From the weakest: the verdict of a run is the weakest of its properties' verdicts.
VERDICT_ORDER = ("inconclusive", "falsified", "passed", "proved")
EXIT_CODES = {"proved": 0, "passed": 0, "falsified": 1, "inconclusive": 3}
EXIT_REQUIREMENT = 4  # the verdict is weaker than ``--require`` asks for
REQUIREMENTS = ("proved", "passed", "none")
_STRENGTH = {"inconclusive": 0, "falsified": 0, "none": 0, "passed": 1, "proved": 2}

EXIT_TABLE = """exit codes:
  0  proved (a proof over the whole box), or passed (no counterexample, no proof)
  1  falsified (a counterexample confirmed in the Drake diagram)
  2  bad input (one line naming the file or option, the value and what is allowed)
  3  inconclusive (the search, the Drake replays and the proof contradict each
     other: report.md shows both figures and the scenario file that reproduces it)
  4  the verdict is weaker than --require asks for (passed under --require proved)"""


def exit_code(verdict: str, require: str = "none") -> int:
    """The exit code of ``verdict`` under ``--require`` (``REQUIREMENTS``): the
    verdict's own code (``EXIT_CODES``: falsified and inconclusive fail whatever is
    required), or ``EXIT_REQUIREMENT`` when that is 0 but the verdict is weaker than
    required (``passed`` where ``proved`` is)."""
    if verdict not in VERDICTS:
        raise ValueError(f"verdict: got {verdict!r}; allowed: {' | '.join(VERDICTS)}")
    if require not in REQUIREMENTS:
        raise ValueError(f"require: got {require!r}; allowed: {' | '.join(REQUIREMENTS)}")
    code = EXIT_CODES[verdict]
    if code == 0 and _STRENGTH[verdict] < _STRENGTH[require]:
        return EXIT_REQUIREMENT
    return code
