"""The rooms' import rule (docs/architecture.md), checked on every import of the project.

Every module of ``safety_systems`` and ``verification`` is parsed; each import of the
project (at module level or inside a function) must be one its room may make. The
verifier's rooms (its top, spaces, proof, search, verify, tune, deploy) are ordered: each
may import only the ones before it. A broken variant (a maths module importing a Drake
system, a system importing the verifier, the proof importing the search) is checked to
fail the rule. No module imports itself through others, whether at module level or
inside a function.
"""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
MATHS = {"cell", "sensing", "ssm", "pfl", "speed_alteration", "planning"}
PRODUCT = MATHS | {"files", "config", "systems", "diagrams", "outputs"}
# The verifier's rooms in order: each may import the product's rooms and the ones above it.
# ``verification`` is its top (properties.py, verdicts.py); ``verification.verify`` the
# verify command's modules at the top (verify.py, report.py).
VERIFIER = ("verification", "verification.spaces", "verification.proof", "verification.search",
            "verification.verify", "verification.tune", "verification.deploy")
VERIFIER_ALLOWED = {
    "verification": set(),
    "verification.spaces": {"verification"},
    "verification.proof": {"verification", "verification.spaces"},
    "verification.search": {"verification", "verification.spaces", "verification.proof"},
    "verification.verify": {"verification", "verification.spaces", "verification.proof",
                            "verification.search"},
    "verification.tune": {"verification", "verification.spaces", "verification.proof",
                          "verification.search", "verification.verify"},
    "verification.deploy": {"verification", "verification.spaces"},
}
VERIFIER_TOP = {"verification.verify": "verification.verify",
                "verification.report": "verification.verify",
                "verification.phases": "verification.verify"}
# Housekeeping of a process, importing nothing of the project: numba's cache, the line
# before a first compile, Ctrl-C, third-party warnings.
HOUSEKEEPING = {"compiled_cache", "compile_notice", "interrupts", "third_party_noise"}
ALLOWED = {
    **{room: set() for room in HOUSEKEEPING},
    "files": set(),
    **{room: MATHS | {"files"} for room in MATHS},
    "config": MATHS | {"files"},
    "systems": MATHS | {"config", "systems"},
    "diagrams": MATHS | {"files", "config", "systems", "diagrams"},
    "outputs": MATHS | {"files", "config", "diagrams", "outputs"},
    "runtime": MATHS | {"files", "config", "outputs", "runtime"} | set(VERIFIER),
    "cli": PRODUCT | {"runtime"} | set(VERIFIER),
    **{room: PRODUCT | {room} | inner for room, inner in VERIFIER_ALLOWED.items()},
}
ANYWHERE = HOUSEKEEPING | {"safety_systems"}  # housekeeping; the package's __init__
# Entry points that load the verifier only inside the functions that need it: the command
# line (verify, tune, export, check) and the runtime (``run`` runs check's rule).
LAZY_VERIFIER = {"cli", "runtime"}


def room_of(module: str) -> str:
    """The room of a dotted module name: ``safety_systems.ssm.formulas`` -> ``ssm``,
    ``verification.proof.margins`` -> ``verification.proof``, ``verification.verify`` ->
    ``verification.verify``, ``verification.properties`` -> ``verification``."""
    parts = module.split(".")
    if parts[0] == "verification":
        if module in VERIFIER_TOP:
            return VERIFIER_TOP[module]
        if len(parts) >= 2 and ".".join(parts[:2]) in VERIFIER_ALLOWED:
            return ".".join(parts[:2])
        return "verification"
    if len(parts) == 1:
        return "safety_systems"
    return parts[1]


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def project_imports(source: str) -> list[tuple[int, str, bool]]:
    """(line, imported module, inside a function) for every import of the project."""
    found = []

    def visit(node, nested):
        for child in ast.iter_child_nodes(node):
            inner = nested or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef))
            if isinstance(child, ast.ImportFrom) and child.level == 0 and child.module:
                if child.module == "safety_systems":
                    found.extend((child.lineno, f"safety_systems.{a.name}", inner)
                                 for a in child.names)
                elif child.module.split(".")[0] in ("safety_systems", "verification"):
                    found.append((child.lineno, child.module, inner))
            elif isinstance(child, ast.Import):
                found.extend((child.lineno, a.name, inner) for a in child.names
                             if a.name.split(".")[0] in ("safety_systems", "verification"))
            visit(child, inner)

    visit(ast.parse(source), False)
    return found


def violations(module: str, source: str) -> list[str]:
    room = room_of(module)
    if room == "safety_systems":
        return []
    allowed = ALLOWED[room] | ANYWHERE | {room}
    out = []
    for line, imported, nested in project_imports(source):
        target = room_of(imported)
        if target.startswith("verification") and room in LAZY_VERIFIER and not nested:
            out.append(f"{module}:{line} imports {imported} at module level (only lazily)")
        elif target not in allowed:
            out.append(f"{module}:{line} ({room}) imports {imported} ({target})")
    return out


def project_modules():
    for package in ("safety_systems", "verification"):
        for path in sorted((ROOT / package).rglob("*.py")):
            yield module_name(path), path


def test_every_room_has_a_rule():
    rooms = {room_of(m) for m, _ in project_modules()} - ANYWHERE
    assert rooms <= set(ALLOWED), rooms - set(ALLOWED)


def test_every_import_follows_the_rooms_rule():
    found = [v for m, p in project_modules() for v in violations(m, p.read_text())]
    assert not found, "\n".join(found)


@pytest.mark.parametrize("module, source", [
    ("safety_systems.ssm.formulas", "from safety_systems.systems.speed_override import X"),
    ("safety_systems.cell.braking", "def f():\n    from safety_systems.outputs import metrics"),
    ("safety_systems.systems.speed_override", "import verification.properties"),
    ("safety_systems.systems.speed_override", "from safety_systems.diagrams import workcell"),
    ("safety_systems.outputs.metrics", "from safety_systems import cli"),
    ("safety_systems.cli", "from verification.verify import verify"),
    ("safety_systems.runtime.params", "from verification.deploy.certificate import check"),
    ("safety_systems.runtime.safety_loop", "from safety_systems.systems import robot_capsules"),
    ("verification.proof.margins", "from verification.search.ranking import bound_scores"),
    ("verification.spaces.space", "def f():\n    from verification.proof import theorems"),
    ("verification.properties", "from verification.spaces.box import ScenarioSpace"),
    ("verification.search.runner", "from verification.verify import verify"),
    ("verification.deploy.export", "from verification.tune.tuner import Tuner"),
    ("verification.verify", "from verification.deploy.certificate import check"),
])
def test_the_rule_catches_a_broken_import(module, source):
    assert violations(module, source)


def test_the_verifiers_rooms_are_ordered():
    # each room imports only rooms before it in VERIFIER: the rooms' graph has no cycle
    for i, room in enumerate(VERIFIER):
        assert VERIFIER_ALLOWED[room] <= set(VERIFIER[:i]), room
    assert {room_of(m) for m, _ in project_modules() if m.startswith("verification")} \
        == set(VERIFIER)


def _imported_module(module: str, graph: dict) -> str:
    """``from package import module`` names a module: the edge goes to it."""
    return module if module in graph else module.rsplit(".", 1)[0]


def test_module_graph_has_no_cycle():
    # every import, inside functions too: a cycle through a lazy import is still a circle
    modules = dict(project_modules())
    graph = {m: {i for _, i, _ in project_imports(p.read_text())} for m, p in modules.items()}
    graph = {m: {_imported_module(i, graph) for i in deps} - {m} for m, deps in graph.items()}
    state: dict[str, int] = {}

    def walk(node, stack):
        state[node] = 1
        for nxt in graph.get(node, ()):
            if state.get(nxt) == 1:
                pytest.fail(" -> ".join(stack + [node, nxt]))
            if nxt in graph and not state.get(nxt):
                walk(nxt, stack + [node])
        state[node] = 2

    for node in graph:
        if not state.get(node):
            walk(node, [])


def test_the_documented_table_lists_the_verifiers_rooms_in_order():
    # docs/architecture.md's rows for the verifier name the rooms in VERIFIER's order: each
    # row's first path, ``verification/proof/`` -> ``verification.proof``, and
    # ``verification/verify.py`` -> ``verification.verify``
    rows = [line.split("`")[1] for line in
            (ROOT / "docs" / "architecture.md").read_text().splitlines()
            if line.startswith("| `verification")]
    named = [row.removesuffix(".py").strip("/").replace("/", ".") for row in rows]
    assert named == list(VERIFIER), rows


def test_the_documented_maths_rooms_are_the_rules():
    # docs/architecture.md's sentence "The maths rooms (`cell`, ...) are plain functions"
    text = " ".join((ROOT / "docs" / "architecture.md").read_text().split())
    sentence = text.split("The maths rooms (", 1)[1].split(")", 1)[0]
    assert set(sentence.replace("`", "").split(", ")) == MATHS, sentence
