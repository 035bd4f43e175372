"""The path of a configuration from ``verify`` enters the configuration room once (issue
52): ``verify`` resolves the configuration's cell once (``spaces.space.space_cell``) and
the search, the replays and the report read that cell; none of them calls a derivation
``resolved_cell.MEANING`` names.

Every name bound to a derivation (or to ``resolve`` / ``resolve_scenario``) in any loaded
module is wrapped to record who called it; only the outermost call counts (a derivation
that calls another, as ``braking_table`` calls ``placeholder_braking``, is one call)."""

import sys
import types
from pathlib import Path

import pytest

import verification.verify as verify_module  # noqa: F401 (loaded before the wrapping)
from safety_systems.config import configuration, resolved_cell
from safety_systems.config.scenario import load_controller_config
from safety_systems.diagrams import simulation, workcell  # noqa: F401 (likewise)
from verification.report import write_report
from verification.search import evaluate_drake, ranking, strategies  # noqa: F401
from verification.spaces.space import load_space
from verification.verify import verify

MODELS = Path(__file__).parents[2] / "models"
ISO = MODELS / "configs" / "iso.yaml"
SPACE = MODELS / "spaces" / "default.yaml"
ROOT = Path(__file__).parents[2].resolve()
# The modules this branch migrated (issue 52's search path): none may call a derivation.
SEARCH_PATH = ("verification/search/", "verification/verify.py", "verification/report.py",
               "verification/spaces/")
RESOLVERS = ("resolve", "resolve_scenario")


class Calls:
    """The outermost calls of the wrapped functions: (name, the caller's file relative to
    the repository)."""

    def __init__(self):
        self.calls: list[tuple[str, str]] = []
        self.depth = 0

    def wrap(self, name: str, fn):
        def wrapped(*args, **kwargs):
            if self.depth == 0:
                caller = Path(sys._getframe(1).f_code.co_filename).resolve()
                where = (str(caller.relative_to(ROOT)) if caller.is_relative_to(ROOT)
                         else str(caller))
                self.calls.append((name, where))
            self.depth += 1
            try:
                return fn(*args, **kwargs)
            finally:
                self.depth -= 1
        return wrapped

    def of(self, names) -> list[tuple[str, str]]:
        return [c for c in self.calls if c[0] in names]


def _wrap_everywhere(monkeypatch, calls: Calls) -> None:
    """Replaces every module-level name bound to a derivation or a resolver, in every
    loaded module (``from configuration import braking_table`` binds its own name), by
    ``calls``' recording wrapper. Modules loaded later take the wrapped one from
    ``configuration`` or ``resolved_cell``."""
    originals = {id(getattr(configuration, n)): (n, getattr(configuration, n))
                 for n in resolved_cell.MEANING}
    originals.update({id(getattr(resolved_cell, n)): (n, getattr(resolved_cell, n))
                      for n in RESOLVERS})
    wrappers = {key: calls.wrap(n, fn) for key, (n, fn) in originals.items()}
    for module in list(sys.modules.values()):
        try:
            names = list(vars(module).items())
        except TypeError:
            continue
        for attr, value in names:
            if callable(value) and id(value) in originals and originals[id(value)][1] is value:
                monkeypatch.setattr(module, attr, wrappers[id(value)])


@pytest.fixture(scope="module")
def verified(tmp_path_factory):
    """The calls a whole verification made: iso.yaml over the default space, a budget of 3
    (the search's phases all run; the proofs and each property's Drake replays too), in
    this process (one worker), its report written."""
    out = tmp_path_factory.mktemp("resolves_once")
    config, space = load_controller_config(ISO), load_space(SPACE)
    calls = Calls()
    with pytest.MonkeyPatch.context() as monkeypatch:
        _wrap_everywhere(monkeypatch, calls)
        outcome = verify(config, space, out, budget=3, workers=1, seed=0)
        write_report(outcome, out, config_path=str(ISO), space_path=str(SPACE), replay=False)
    assert len(outcome.log.points) == 3 and any(p.replays for p in
                                                outcome.properties.values())
    return calls


def test_the_wrapping_sees_every_call(monkeypatch):
    # (so the tests below can fail: a derivation called here is seen, and so is one
    # called through a name another module bound to it at its import)
    elsewhere = types.ModuleType("bound_elsewhere")
    elsewhere.timeout = configuration.frame_timeout
    monkeypatch.setitem(sys.modules, "bound_elsewhere", elsewhere)
    calls = Calls()
    _wrap_everywhere(monkeypatch, calls)
    config = load_controller_config(ISO)
    configuration.frame_timeout(config)
    resolved_cell.resolve(config)
    elsewhere.timeout(config)
    here = "tests/verification/test_verify_resolves_once.py"
    # (resolve's own derivations are inside it: not outermost)
    assert calls.calls == [("frame_timeout", here), ("resolve", here), ("frame_timeout", here)]


def test_verify_resolves_the_cell_once(verified):
    assert verified.of(RESOLVERS) == [("resolve", "verification/spaces/space.py")]


def test_the_search_path_calls_no_derivation(verified):
    derived = verified.of(resolved_cell.MEANING)
    assert derived  # (resolve's own, at least)
    bad = sorted({c for c in derived if c[1].startswith(SEARCH_PATH)})
    assert bad == []


def test_only_resolve_calls_the_derivations(verified):
    derived = verified.of(resolved_cell.MEANING)
    assert sorted({c for c in derived if c[1] != "safety_systems/config/resolved_cell.py"}) \
        == []
