"""Declared ranges of numbers: every numeric field of a schema carries its allowed range
and unit on its declaration (:func:`number`), and one function checks them all
(:func:`check_limits`); :func:`unranged_fields` finds a numeric field without one (a
test keeps that list empty for every schema the project reads)."""

import dataclasses as dc
import functools
import math
import typing

from safety_systems.files.input_error import InputError

SEED_MAX = 2**32 - 1  # numpy's legacy seeding accepts no more


@functools.lru_cache(maxsize=None)
def type_hints(schema: type) -> dict[str, typing.Any]:
    """``typing.get_type_hints(schema)``, once per class."""
    return typing.get_type_hints(schema)


@dc.dataclass(frozen=True)
class Limits:
    """The allowed range of a number (or of each number of a list), with its unit."""

    low: float
    high: float
    low_open: bool = False
    high_open: bool = False
    unit: str = ""
    infinite: bool = False  # +inf allowed (e.g. "never")

    def holds(self, x: float) -> bool:
        if self.infinite and x == math.inf:
            return True
        if not math.isfinite(x):
            return False
        return ((self.low < x if self.low_open else self.low <= x)
                and (x < self.high if self.high_open else x <= self.high))

    def describe(self, name: str, integer: bool) -> str:
        low = f"{_g(self.low)} {'<' if self.low_open else '<='} "
        high = f" {'<' if self.high_open else '<='} {_g(self.high)}"
        text = f"{low}{name}{high}" + (f" {self.unit}" if self.unit else "")
        text += " (or .inf)" if self.infinite else ""
        return f"an integer, {text}" if integer else text


def _g(x: float) -> str:
    return f"{x:g}" if abs(x) < 1e6 or not float(x).is_integer() else f"{int(x):,}"


def number(default: typing.Any = 0.0, *, ge: float | None = None, gt: float | None = None,
           le: float | None = None, lt: float | None = None, unit: str = "",
           infinite: bool = False) -> typing.Any:
    """A dataclass field holding a number (or a list of numbers, each) within a range:
    ``ge``/``gt`` the lower bound (inclusive/exclusive), ``le``/``lt`` the upper one.
    A list default is copied for every instance."""
    if (ge is None) == (gt is None) or (le is None) == (lt is None):
        raise TypeError("number(): give one lower bound (ge or gt) and one upper (le or lt)")
    limits = Limits(gt if ge is None else ge, lt if le is None else le, ge is None,
                    le is None, unit, infinite)
    metadata = {"limits": limits}
    if isinstance(default, list):
        return dc.field(default_factory=lambda: [list(x) if isinstance(x, list) else x
                                                 for x in default], metadata=metadata)
    return dc.field(default=default, metadata=metadata)


def field_limits(schema: type, name: str) -> Limits | None:
    """The declared range of ``schema``'s field ``name`` (None: not a ranged field)."""
    for f in dc.fields(schema):
        if f.name == name:
            return f.metadata.get("limits")
    raise KeyError(name)


def check_limits(obj: typing.Any, prefix: str = "") -> None:
    """Raises InputError at the first number of the dataclass ``obj`` (and of the
    dataclasses it holds) outside its declared range."""
    for name, limits in _fields_to_check(type(obj)):
        value = getattr(obj, name)
        if limits is None:
            _check_nested(value, f"{prefix}.{name}" if prefix else name)
        elif type(value) is float and limits.holds(value):
            continue  # the common cases first
        elif type(value) is list and all(type(x) is float and limits.holds(x) for x in value):
            continue
        else:
            _check_numbers(value, limits, f"{prefix}.{name}" if prefix else name, name)


@functools.lru_cache(maxsize=None)
def _fields_to_check(schema: type) -> tuple:
    """(name, limits) of the ranged fields, (name, None) of those that may hold
    dataclasses, in field order."""
    return tuple((f.name, f.metadata["limits"]) if "limits" in f.metadata else (f.name, None)
                 for f in dc.fields(schema)
                 if "limits" in f.metadata
                 or any(dc.is_dataclass(t) for t in _leaf_types(type_hints(schema)[f.name])))


def _check_numbers(value, limits: Limits, path: str, name: str) -> None:
    if value is None:
        return
    if isinstance(value, list):
        for i, item in enumerate(value):
            _check_numbers(item, limits, f"{path}[{i}]", name)
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(path, value, limits.describe(name, False))
    integer = isinstance(value, int)
    if not limits.holds(float(value) if not integer or abs(value) < 1e308 else math.nan):
        raise InputError(path, value, limits.describe(name, integer))


def _check_nested(value, path: str) -> None:
    if dc.is_dataclass(value) and not isinstance(value, type):
        check_limits(value, path)
    elif isinstance(value, list):
        for i, item in enumerate(value):
            _check_nested(item, f"{path}[{i}]")


def unranged_fields(schema: type, seen: set | None = None) -> list[str]:
    """``Class.field`` of every numeric field of ``schema`` and the dataclasses it holds
    that declares no range (a test keeps this list empty)."""
    seen = set() if seen is None else seen
    if schema in seen or hasattr(schema, "limits_checked_by"):
        return []  # (a class naming the function that checks its numbers' ranges)
    seen.add(schema)
    missing = []
    for f in dc.fields(schema):
        hint = type_hints(schema)[f.name]
        leaves = _leaf_types(hint)
        if leaves & {int, float} and "limits" not in f.metadata:
            missing.append(f"{schema.__name__}.{f.name}")
        for leaf in leaves:
            if dc.is_dataclass(leaf):
                missing += unranged_fields(leaf, seen)
    return missing


def _leaf_types(hint) -> set:
    args = typing.get_args(hint)
    if not args:
        return {hint}
    return set().union(*(_leaf_types(a) for a in args))
