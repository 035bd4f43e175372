"""The rooms' import rule (docs/architecture.md), checked on every import of the project.

Every module of ``safety_systems`` and ``verification`` is parsed; each import of the
project (at module level or inside a function) must be one its room may make. A broken
variant (a maths module importing a Drake system, a system importing the verifier) is
checked to fail the rule.
"""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
MATHS = {"cell", "sensing", "ssm", "speed_alteration", "planning"}
ALLOWED = {
    "compiled_cache": set(),
    "files": set(),
    **{room: MATHS | {"files"} for room in MATHS},
    "config": MATHS | {"files"},
    "systems": MATHS | {"config", "systems"},
    "diagrams": MATHS | {"files", "config", "systems", "diagrams"},
    "outputs": MATHS | {"files", "config", "diagrams", "outputs"},
    "runtime": MATHS | {"files", "config", "outputs", "runtime", "verification"},
    "cli": MATHS | {"files", "config", "systems", "diagrams", "outputs", "runtime",
                    "verification"},
    "verification": MATHS | {"files", "config", "systems", "diagrams", "outputs",
                             "verification"},
}
ANYWHERE = {"compiled_cache", "safety_systems"}  # housekeeping; the package's __init__
# Entry points that load the verifier only inside the functions that need it: the command
# line (verify, tune, export, check) and the runtime (``run`` runs check's rule).
LAZY_VERIFIER = {"cli", "runtime"}


def room_of(module: str) -> str:
    """The room of a dotted module name: ``safety_systems.ssm.formulas`` -> ``ssm``."""
    parts = module.split(".")
    if parts[0] == "verification":
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
        if target == "verification" and room in LAZY_VERIFIER and not nested:
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
    ("safety_systems.runtime.params", "from verification.certificate import check"),
    ("safety_systems.runtime.safety_loop", "from safety_systems.systems import robot_capsules"),
])
def test_the_rule_catches_a_broken_import(module, source):
    assert violations(module, source)


def test_module_graph_has_no_cycle():
    graph = {m: {i for _, i, nested in project_imports(p.read_text()) if not nested}
             for m, p in project_modules()}
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
