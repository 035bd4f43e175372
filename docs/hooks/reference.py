"""The documentation's reference, generated from the code when the site is built.

An MkDocs hook (``mkdocs.yml``: ``hooks``): a page's line ``<!-- reference: NAME -->`` is
replaced by the reference ``NAME`` made now from the code, so it cannot fall behind it:

- ``commands``: every subcommand of ``safety-systems`` and every option, from the
  command line's own parser (``safety_systems.cli.build_parser``: usage, help, defaults);
- ``scenario``, ``config``, ``space``, ``tune``, ``mapping``, ``scene``, ``task-path``:
  every field of a file kind, from the dataclasses the file is read into (the fields of
  every nested mapping, its type, default and allowed range with its unit, declared on
  the field: ``safety_systems.files.ranges.number``), each mapping's docstring above its
  table. A text field's allowed values are what the file's own checks say when the
  field is given a value no check allows (:func:`text_choices`).

``tests/test_docs.py`` holds every field and option to appearing, and builds the site.
"""

import argparse
import dataclasses as dc
import inspect
import re
import tempfile
import typing
from pathlib import Path

MARK = re.compile(r"^<!-- reference: ([a-z-]+) -->$", re.M)
PROBE = "__no_such_value__"


def schemas() -> dict[str, tuple[type, typing.Callable]]:
    """Each file kind's dataclass and its loader (``safety-systems check KIND FILE``)."""
    from safety_systems.config.scenario import (
        ControllerConfig,
        Scenario,
        TaskPoints,
        load_controller_config,
        load_scenario,
        load_typed,
    )
    from safety_systems.planning.task_space import TaskScene, load_scene
    from safety_systems.sensing.recording_mapping import RecordingMapping, load_mapping
    from verification.spaces.box import ScenarioSpace
    from verification.spaces.space import load_space
    from verification.tune.tunable import TuneFile

    return {"scenario": (Scenario, load_scenario),
            "config": (ControllerConfig, load_controller_config),
            "space": (ScenarioSpace, load_space),
            "tune": (TuneFile, lambda path: load_typed(TuneFile, path)),
            "mapping": (RecordingMapping, load_mapping),
            "scene": (TaskScene, load_scene),
            "task-path": (TaskPoints, lambda path: load_typed(TaskPoints, path))}


# ------------------------------------------------------------------------- the files

def _inner(hint) -> tuple[typing.Any, str]:
    """(the type inside Optional/list, how it is written): ``("float", "a number")``."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin is typing.Union and type(None) in args:
        inner, words = _inner(next(a for a in args if a is not type(None)))
        return inner, f"{words} or null"
    if origin is list:
        inner, words = _inner(args[0])
        return inner, f"a list of {_plural(words)}"
    if origin is dict:
        inner, words = _inner(args[1])
        return inner, f"a mapping of names to {_plural(words)}"
    if dc.is_dataclass(hint):
        return hint, "a mapping"
    return hint, {float: "a number", int: "an integer", str: "text",
                  bool: "true or false"}.get(hint, getattr(hint, "__name__", str(hint)))


def _plural(words: str) -> str:
    for one, many in (("a number", "numbers"), ("an integer", "integers"),
                      ("a mapping", "mappings"), ("text", "texts"),
                      ("true or false", "true or false values")):
        if words.startswith(one):
            return many + words[len(one):]
    return words.removeprefix("a ")


def _default(f: dc.Field) -> str:
    if f.default is not dc.MISSING:
        value = f.default
    elif f.default_factory is not dc.MISSING:
        value = f.default_factory()
    else:
        return "required"
    if dc.is_dataclass(value):
        return "its fields' defaults"
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f"`{value}`" if value else "empty"
    if isinstance(value, list) and not value:
        return "empty"
    if isinstance(value, float) and value == float("inf"):
        return ".inf"
    return f"`{value}`"


def _cell(text: str) -> str:
    """Text for a Markdown table's cell: its bars escaped."""
    return text.replace("|", "\\|")


def _text(doc: str | None) -> str:
    """A docstring as Markdown (reST's double backticks to single ones)."""
    return inspect.cleandoc(doc or "").replace("``", "`")


def text_choices(kind: str, path: list[str]) -> str:
    """What the file's own checks allow for the text field at ``path`` (mapping keys from
    the document's top), found by giving it a value no check allows; empty where the
    checks name another field or accept any text."""
    from safety_systems.files.input_error import InputError

    schema, load = schemas()[kind]
    data: dict = {}
    node = data
    for key in path[:-1]:
        node = node.setdefault(key, {})
    node[path[-1]] = PROBE
    import yaml

    with tempfile.TemporaryDirectory() as folder:
        file = Path(folder) / "probe.yaml"
        file.write_text(yaml.safe_dump(data))
        try:
            load(file)
        except InputError as e:
            field = ".".join(path)
            if (e.field == field or e.field.endswith("." + field)) and PROBE not in e.allowed:
                return e.allowed
        except Exception:  # noqa: BLE001 - a check that needs more of the file: no words
            return ""
    return ""


def file_reference(kind: str) -> str:
    """Every field of a file kind, mapping by mapping (see the module docstring)."""
    from safety_systems.files.ranges import type_hints

    schema, _ = schemas()[kind]
    out, done = [], set()

    def section(cls, where: list[str], in_list: bool) -> None:
        if (cls, tuple(where)) in done:
            return
        done.add((cls, tuple(where)))
        name = ".".join(where) or "the file"
        anchor = f"{kind}-{'-'.join(where) or 'top'}".replace("_", "-")
        out.append(f"### `{name}` {{ #{anchor} }}\n\n_{cls.__name__}_. {_text(cls.__doc__)}\n")
        rows, nested = [], []
        hints = type_hints(cls)
        for f in dc.fields(cls):
            inner, words = _inner(hints[f.name])
            limits = f.metadata.get("limits")
            allowed = limits.describe(f.name, inner is int) if limits is not None else ""
            if dc.is_dataclass(inner):
                child = where + [f.name]
                child_anchor = f"{kind}-{'-'.join(child)}".replace("_", "-")
                allowed = f"its fields: [`{'.'.join(child)}`](#{child_anchor})"
                nested.append((inner, child, "list" in words))
            elif inner is str and not in_list and "list" not in words:
                allowed = text_choices(kind, where + [f.name])
            rows.append(f"| `{f.name}` | {words} | {_default(f)} | {_cell(allowed)} |")
        out.append("| field | type | default | allowed |\n|---|---|---|---|\n"
                   + "\n".join(rows) + "\n")
        for inner, child, listed in nested:
            section(inner, child, in_list or listed)

    section(schema, [], False)
    return "\n".join(out)


def file_fields(kind: str) -> list[str]:
    """Every field's dotted path in a file kind (the test's list of what must appear)."""
    from safety_systems.files.ranges import type_hints

    schema, _ = schemas()[kind]
    found = []

    def walk(cls, where, seen):
        for f in dc.fields(cls):
            found.append(".".join(where + [f.name]))
            inner, _ = _inner(type_hints(cls)[f.name])
            if dc.is_dataclass(inner) and inner not in seen:
                walk(inner, where + [f.name], seen | {inner})

    walk(schema, [], {schema})
    return found


# ------------------------------------------------------------------------- the commands

def _parsers() -> dict[str, argparse.ArgumentParser]:
    from safety_systems.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return {"": parser, **sub.choices}


def _invocation(action: argparse.Action) -> str:
    if not action.option_strings:
        return f"`{action.metavar or action.dest}`"
    if action.nargs == 0:
        return ", ".join(f"`{o}`" for o in action.option_strings)
    value = action.metavar or ("{" + ",".join(map(str, action.choices)) + "}"
                               if action.choices else action.dest.upper())
    return ", ".join(f"`{o} {value}`" for o in action.option_strings)


def command_reference() -> str:
    """Every subcommand, its usage and every option with its help (defaults included)."""
    out = []
    for name, parser in _parsers().items():
        formatter = parser._get_formatter()
        out.append(f"## `safety-systems{' ' + name if name else ''}` "
                   f"{{ #{name or 'safety-systems'} }}\n")
        out.append("```text\n" + " ".join(parser.format_usage().split())
                   .removeprefix("usage: ") + "\n```\n")
        about = parser.description or ""
        if about:
            out.append(about + "\n")
        rows = []
        for action in parser._actions:
            if isinstance(action, (argparse._HelpAction, argparse._SubParsersAction)):
                continue
            text = formatter._expand_help(action) if action.help else ""
            rows.append(f"| {_cell(_invocation(action))} | {_cell(' '.join(text.split()))} |")
        if rows:
            out.append("| argument | what it does |\n|---|---|\n" + "\n".join(rows) + "\n")
        if parser.epilog:
            out.append("```text\n" + parser.epilog.strip("\n") + "\n```\n")
    return "\n".join(out)


def command_options() -> list[str]:
    """Every subcommand's option strings and positionals (the test's list)."""
    return [f"{name} {o}" for name, parser in _parsers().items() for a in parser._actions
            if not isinstance(a, (argparse._HelpAction, argparse._SubParsersAction))
            for o in (a.option_strings or [a.metavar or a.dest])]


def reference(name: str) -> str:
    return command_reference() if name == "commands" else file_reference(name)


def on_page_markdown(markdown: str, page, config, files) -> str:
    """MkDocs' hook: each ``<!-- reference: NAME -->`` line replaced by its reference."""
    return MARK.sub(lambda m: reference(m.group(1)), markdown)
