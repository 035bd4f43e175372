"""Every file the project reads goes through here: one set of rules, one kind of error.

A document (scenario, controller configuration, space, scene, task path, and later
parameters, certificates and recordings) is read by :func:`load_document`, which
applies, in order:

1. the file: readable, at most ``MAX_BYTES``, UTF-8 text (no NUL byte);
2. the YAML: valid syntax (a tab indent is a syntax error), one document, no duplicate
   key in any mapping, no tags, not empty, a mapping at the top;
3. the shape: every key a field of the schema, every value of its field's type (a
   list where a mapping belongs, or the reverse, is reported here: pydrake's loader
   would only assert), at most ``MAX_VALUES`` values in all;
4. the typed load, with ``pydrake.common.yaml.yaml_load_typed`` (strict: unknown keys
   and wrong types are errors);
5. the ranges: every number within the limits declared on its dataclass field with
   ``safety_systems.files.ranges.number`` (``check_limits``; a test holds every numeric
   field of every schema to having them);
6. the schema's own ``validate`` function (rules between fields).

Every failure is a ``safety_systems.files.input_error.InputError``: one line naming the
file, the field path, the value (shortened) and what is allowed. Other readers
(recordings, certificates) use :func:`read_input` or :func:`read_text` and
``InputError`` alike. Every file read is remembered with its
SHA-256 (:func:`inputs_read`), so that results can name their inputs.

Modules holding schemas must not use ``from __future__ import annotations`` (it breaks
pydrake's loader).
"""

import collections.abc
import difflib
import dataclasses as dc
import hashlib
import math
import re
import threading
import typing
from pathlib import Path

import yaml

from safety_systems.files.input_error import InputError
from safety_systems.files.ranges import check_limits, type_hints

MAX_BYTES = 16 * 1024 * 1024  # a YAML document's largest size
MAX_VALUES = 1_000_000  # scalars, lists and mappings in one document
_NUMBER = re.compile(r"[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?")
_INTEGER = re.compile(r"[-+]?[0-9]+")


# ---------------------------------------------------------------- files and their hashes

_READ: dict[str, str] = {}
_READ_LOCK = threading.Lock()


def inputs_read() -> dict[str, str]:
    """{path: SHA-256} of every file read since :func:`forget_inputs`, in reading order."""
    with _READ_LOCK:
        return dict(_READ)


def forget_inputs() -> None:
    with _READ_LOCK:
        _READ.clear()


def read_input(path: str | Path, *, max_bytes: int | None = None) -> bytes:
    """The bytes of an input file of at most ``max_bytes`` (default ``MAX_BYTES``),
    remembered with their SHA-256; raises InputError."""
    path = Path(path)
    max_bytes = MAX_BYTES if max_bytes is None else max_bytes
    try:
        with open(path, "rb") as f:
            data = f.read(max_bytes + 1)
    except OSError as e:
        raise InputError("path", str(path), f"a readable file ({e.strerror})") from None
    except ValueError as e:  # a NUL byte in the name
        raise InputError("path", str(path), f"a readable file ({e})") from None
    if len(data) > max_bytes:
        raise InputError("<file>", f"more than {max_bytes} bytes",
                         f"a file of at most {max_bytes} bytes", file=path)
    with _READ_LOCK:
        _READ[str(path)] = hashlib.sha256(data).hexdigest()
    return data


def read_text(path: str | Path, *, max_bytes: int | None = None) -> str:
    """An input file as text: UTF-8 (a byte-order mark is dropped), no NUL byte."""
    return decode_text(read_input(path, max_bytes=max_bytes), path)


def decode_text(data: bytes, path: str | Path) -> str:
    """The bytes of the input file ``path`` as text, under :func:`read_text`'s rules."""
    where = data.find(b"\0")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        where = e.start if where < 0 else min(where, e.start)
    if where >= 0:
        raise InputError("<file>", f"byte {data[where]:#04x} at offset {where}",
                         "a UTF-8 text file (this one is binary)", file=path)
    return text


# ------------------------------------------------------------------------------ YAML

_Loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # libyaml's where installed
_MERGE = "tag:yaml.org,2002:merge"


def parse_yaml(text: str, file: str | Path) -> typing.Any:
    """The plain data of one YAML document (None if it has none); raises InputError on
    a syntax error, a duplicate key, a recursive alias, a tag or too deep a nesting."""
    loader = _Loader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _check_nodes(node, "", set(), set(), file)
        return loader.construct_document(node)
    except yaml.reader.ReaderError as e:
        character = e.character if isinstance(e.character, str) else chr(e.character)
        line = text.count("\n", 0, e.position)
        column = e.position - (text.rfind("\n", 0, e.position) + 1)
        raise InputError(f"line {line + 1}, column {column + 1}", character,
                         "printable text (no control characters)", file=file) from None
    except yaml.constructor.ConstructorError as e:
        mark = e.problem_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}" if mark else "<document>"
        raise InputError(where, " ".join(str(e.problem).split()),
                         "plain YAML values (no tags)", file=file) from None
    except yaml.MarkedYAMLError as e:
        mark = e.problem_mark or e.context_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}" if mark else "<document>"
        problem = " ".join(str(e.problem or e.context or "").split())
        if mark is not None and _tab_at(text, mark.line, mark.column):
            problem += " (a tab)"
        allowed = ("one YAML document" if isinstance(e, yaml.composer.ComposerError)
                   else "YAML syntax, indented with spaces (no tabs)")
        raise InputError(where, problem, allowed, file=file) from None
    except yaml.YAMLError as e:
        raise InputError("<document>", " ".join(str(e).split()), "one YAML document",
                         file=file) from None
    except RecursionError:
        raise InputError("<document>", "nested too deeply", "a YAML document of fields",
                         file=file) from None
    finally:
        loader.dispose()


def _check_nodes(node, path: str, open_nodes: set, done: set, file) -> None:
    """Duplicate keys (a merge key ``<<``'s values may be overridden, as YAML intends)
    and recursive aliases, found in the composed document with their field paths (each
    node once, however many aliases share it)."""
    if id(node) in open_nodes:
        raise InputError(path or "<document>", "an alias inside itself",
                         "a document without recursive aliases", file=file)
    if isinstance(node, yaml.ScalarNode) or id(node) in done:
        return
    open_nodes.add(id(node))
    if isinstance(node, yaml.MappingNode):
        first = {}
        for key, value in node.value:
            if key.tag == _MERGE:
                continue
            name = key.value if isinstance(key, yaml.ScalarNode) else "<key>"
            where = f"{path}.{name}" if path else name
            if isinstance(key, yaml.ScalarNode):
                line = key.start_mark.line + 1
                if (key.tag, key.value) in first:
                    raise InputError(where, f"a second {name!r} on line {line}",
                                     "each key once in a mapping (the first is on line "
                                     f"{first[key.tag, key.value]})", file=file)
                first[key.tag, key.value] = line
            _check_nodes(value, where, open_nodes, done, file)
    else:
        for i, item in enumerate(node.value):
            _check_nodes(item, f"{path}[{i}]", open_nodes, done, file)
    open_nodes.discard(id(node))
    done.add(id(node))


def _tab_at(text: str, line: int, column: int) -> bool:
    lines = text.splitlines()
    return line < len(lines) and lines[line][column:column + 1] == "\t"


# ------------------------------------------------------------------------- the shape

def _optional(schema) -> typing.Any:
    """X for Optional[X], else None."""
    if typing.get_origin(schema) is typing.Union:
        args = [a for a in typing.get_args(schema) if a is not type(None)]
        if len(args) == 1 and len(typing.get_args(schema)) == 2:
            return args[0]
    return None


def _type_name(schema) -> str:
    if dc.is_dataclass(schema):
        return f"a mapping of {schema.__name__} fields"
    inner = _optional(schema)
    if inner is not None:
        return _type_name(inner) + " or null"
    if typing.get_origin(schema) is list:
        return "a list"
    return {float: "a number", int: "an integer", str: "a string",
            bool: "true or false"}.get(schema, str(schema))


class _Walk:
    """Finds the first value that does not fit a schema (path, value, allowed)."""

    def __init__(self):
        self.count = 0

    def __call__(self, schema, raw, path: str, root: bool = False):
        self.count += 1
        if self.count > MAX_VALUES:
            return "<document>", f"more than {MAX_VALUES} values", \
                f"a document of at most {MAX_VALUES} values"
        inner = _optional(schema)
        if inner is not None:
            return None if raw is None else self(inner, raw, path)
        if dc.is_dataclass(schema):
            if not isinstance(raw, dict):
                return path or "<document>", raw, _type_name(schema)
            fields = {f.name for f in dc.fields(schema)}
            hints = type_hints(schema)
            for key, value in raw.items():
                if root and isinstance(key, str) and key.startswith("_"):
                    continue  # pydrake's loader drops these (YAML anchors' templates)
                name = f"{path}.{key}" if path else str(key)
                if not isinstance(key, str) or key not in fields:
                    return name, value, _field_words(key, fields)
                found = self(hints[key], value, name)
                if found is not None:
                    return found
            return None
        origin = typing.get_origin(schema)
        if origin is list:
            if not isinstance(raw, list):
                return path, raw, _type_name(schema)
            (item,) = typing.get_args(schema)
            for i, value in enumerate(raw):
                found = self(item, value, f"{path}[{i}]")
                if found is not None:
                    return found
            return None
        if origin in (dict, collections.abc.Mapping):
            _, item = typing.get_args(schema)
            if not isinstance(raw, dict):
                return path, raw, "a mapping"
            for key, value in raw.items():
                if not isinstance(key, str):
                    return f"{path}.{key}", value, "string keys"
                found = self(item, value, f"{path}.{key}")
                if found is not None:
                    return found
            return None
        if schema is float and not _fits_float(raw):
            return path, raw, "a number"
        if schema is int and not _fits_int(raw):
            return path, raw, "an integer"
        if schema is str and not isinstance(raw, str):
            return path, raw, "a string (quote it if it looks like something else)"
        if schema is bool and not (isinstance(raw, bool) or raw in ("true", "false")):
            return path, raw, "true or false"
        return None


def _field_words(key, fields: set[str]) -> str:
    """What a mapping of ``fields`` allows, for an unknown ``key``: the nearest field
    first where one is near (a typo), then every field."""
    near = difflib.get_close_matches(str(key), sorted(fields), n=1, cutoff=0.6)
    every = f"one of the fields {sorted(fields)}"
    return f"did you mean {near[0]}? ({every})" if near else every


def _fits_float(raw) -> bool:
    if isinstance(raw, bool):
        return False
    if isinstance(raw, int):
        return abs(raw) < 1e308
    if isinstance(raw, float):
        return True
    return isinstance(raw, str) and _NUMBER.fullmatch(raw) is not None


def _fits_int(raw) -> bool:
    if isinstance(raw, bool):
        return False
    if isinstance(raw, int):
        return True
    if isinstance(raw, float):
        return math.isfinite(raw) and raw.is_integer()
    return isinstance(raw, str) and _INTEGER.fullmatch(raw) is not None


def check_shape(schema: type, raw: typing.Any, file: str | Path) -> None:
    """Raises InputError at the first value of ``raw`` (plain YAML data) that does not
    fit the dataclass ``schema``."""
    if raw is None:
        raise InputError("<document>", "an empty document",
                         f"{_type_name(schema)} (this file has none)", file=file)
    found = _Walk()(schema, raw, "", root=True)
    if found is not None:
        raise InputError(*found, file=file)


# ------------------------------------------------------------------------ documents

def parse_typed(schema: type, text: str, file: str | Path) -> typing.Any:
    """Rules 2-5 of the module docstring on YAML ``text``: an instance of ``schema``."""
    from pydrake.common.yaml import yaml_load_typed

    check_shape(schema, parse_yaml(text, file), file)
    try:
        obj = yaml_load_typed(schema=schema, data=text)
    except Exception as e:  # noqa: BLE001 - whatever the loader says, as one line
        message = " ".join(str(e).split()) or type(e).__name__
        raise InputError("<file>", message, _type_name(schema), file=file) from None
    try:
        check_limits(obj)
    except InputError as e:
        raise e.in_file(file) from None
    return obj


def load_document(path: str | Path, schema: type,
                  validate: typing.Callable[[typing.Any], None] | None = None) -> typing.Any:
    """Reads the YAML file ``path`` into the dataclass ``schema`` under every rule of
    the module docstring, then ``validate(obj)``; raises InputError (one line)."""
    obj = parse_typed(schema, read_text(path), path)
    if validate is not None:
        try:
            validate(obj)
        except InputError as e:
            raise e.in_file(path) from None
    return obj
