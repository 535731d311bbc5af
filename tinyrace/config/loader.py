"""Turn YAML files, dicts and kwargs into the schema's dataclasses, reporting every problem.

The parser walks a dataclass's type hints; it knows bools, numbers, strings,
``None``, ``Literal`` choices, tuples, colours, nested dataclasses and unions of
dataclasses told apart by their ``type`` key.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import types
import typing
from collections.abc import Mapping
from typing import Any, Literal, Union

from tinyrace.config import families
from tinyrace.config.colors import Color
from tinyrace.config.yaml_file import read_yaml  # re-exported: the one way to read YAML
from tinyrace.errors import ConfigError, Problem, did_you_mean

__all__ = ["Parser", "deep_merge", "read_yaml"]

_INVALID = object()  # a value that failed to parse; the problem is already recorded
# No float knob means anything beyond this; larger values overflow rewards and drawings.
MAX_MAGNITUDE = 1e9
MAX_INT = 2**63 - 1  # whole-number knobs (seeds, step counts) fit a signed 64-bit integer


class Parser:
    """Parses one source (a file or a dict) and collects its problems."""

    def __init__(self, source: str):
        self.source = source
        self.problems: list[Problem] = []

    def problem(self, path: str, value: object, allowed: str) -> object:
        self.problems.append(Problem(self.source, path, value, allowed))
        return _INVALID

    def check(self) -> None:
        if self.problems:
            raise ConfigError(self.problems)

    @staticmethod
    def parsed(value: object) -> bool:
        """False for a value that could not be parsed at all (its problem is recorded)."""
        return value is not _INVALID

    # -- dataclasses -------------------------------------------------------------------------
    def dataclass(self, cls: type, data: object, path: str) -> Any:
        """Build ``cls`` from a mapping; unknown keys, bad values and missing keys are problems."""
        if not isinstance(data, Mapping):
            keys = ", ".join(f.name for f in dataclasses.fields(cls))
            return self.problem(path, data, f"expected a mapping with keys: {keys}")
        fields = {f.name: f for f in dataclasses.fields(cls)}
        aliases = {a: f.name for f in fields.values() for a in f.metadata.get("aliases", ())}
        hints = typing.get_type_hints(cls)
        values: dict[str, Any] = {}
        for key, raw in data.items():
            name = aliases.get(key, key)
            sub = _join(path, key)
            if name not in fields:
                self.problem(sub, raw, _unknown_key_hint(key, [*fields, *aliases]))
            elif name in values:
                self.problem(sub, raw, f"'{name}' is given twice (under two spellings)")
            else:
                value = self.value(hints[name], raw, sub, fields[name].metadata)
                if value is not _INVALID:
                    values[name] = value
        for f in fields.values():
            if _required(f) and f.name not in values and f.name not in data:
                self.problem(
                    _join(path, f.name), None, f"a required key is missing: {f.metadata['doc']}"
                )
        if any(_required(f) and f.name not in values for f in fields.values()):
            return _INVALID
        return cls(**values)

    def union_of_dataclasses(self, options: tuple[type, ...], data: object, path: str) -> Any:
        """Pick the member whose ``type`` matches ``data["type"]`` (the first if absent)."""
        kinds: dict[str, type] = {
            str(f.default): cls
            for cls in options
            for f in dataclasses.fields(cls)
            if f.name == "type"
        }
        first = next(iter(kinds), None)  # None: a family with no member registered yet
        kind = data.get("type", first) if isinstance(data, Mapping) else first
        if not isinstance(kind, str) or kind not in kinds:  # a list or dict is unhashable
            known = ", ".join(kinds) or "(none registered)"
            allowed = f"{did_you_mean(kind, kinds)}expected one of: {known}"
            return self.problem(_join(path, "type"), kind, allowed)
        return self.dataclass(kinds[kind], data, path)

    # -- values ------------------------------------------------------------------------------
    def value(self, hint: Any, raw: object, path: str, meta: Mapping[str, Any]) -> Any:
        family = families.members(hint)
        if family is not None:  # an open union: told apart by type
            if raw is None:
                return self.problem(path, raw, f"expected {_describe(hint, meta)}")
            if families.type_required(hint) and isinstance(raw, Mapping) and "type" not in raw:
                known = ", ".join(family) or "(none registered)"
                allowed = f"a required key is missing: the entry's type, one of: {known}"
                return self.problem(_join(path, "type"), None, allowed)
            return self.union_of_dataclasses(tuple(family.values()), raw, path)
        origin, args = typing.get_origin(hint), typing.get_args(hint)
        if origin in (Union, types.UnionType):
            return self.union(args, raw, path, meta)
        if origin is Literal:
            if type(raw) is type(args[0]) and raw in args:  # type first: arrays can't be in
                return raw
            choices = ", ".join(map(str, args))
            hint = did_you_mean(raw, [str(a) for a in args])
            return self.problem(path, raw, f"{hint}expected one of: {choices}")
        if origin is tuple:
            return self.tuple(args, raw, path, meta)
        if origin is dict:  # free-form mapping (e.g. driver arguments), checked by its user
            numbers = int in typing.get_args(args[0]) if args else False  # dict[str | int, ...]
            if isinstance(raw, Mapping) and all(_key_ok(k, numbers) for k in raw):
                return dict(raw)
            keys = "string or whole-number keys" if numbers else "string keys"
            return self.problem(path, raw, f"expected a mapping with {keys}")
        if isinstance(hint, type) and dataclasses.is_dataclass(hint):
            return self.dataclass(hint, raw, path)
        if hint is Color:
            try:
                return Color.from_yaml(raw, binary=meta.get("binary", False))
            except ValueError as exc:
                return self.problem(path, raw, str(exc))
        return self.scalar(hint, raw, path, meta)

    def union(self, args: tuple[Any, ...], raw: object, path: str, meta: Mapping[str, Any]) -> Any:
        members = [a for a in args if a is not type(None)]
        if raw is None:
            if len(members) < len(args):
                return None
            return self.problem(path, raw, f"expected {_describe(members[0], meta)}")
        if all(dataclasses.is_dataclass(m) for m in members):
            return self.union_of_dataclasses(tuple(members), raw, path)
        if len(members) == 1 and typing.get_origin(members[0]) is tuple:
            return self.value(members[0], raw, path, meta)  # its own count, each entry's problems
        for member in members:  # try each member quietly, keep the first that fits
            trial = Parser(self.source)
            value = trial.value(member, raw, path, meta)
            if not trial.problems:
                return value
        allowed = " or ".join(_describe(m, meta) for m in members)
        names = [str(a) for m in members if typing.get_origin(m) is Literal for a in m.__args__]
        if int in members or float in members:
            allowed += _number_as_text(raw)
        return self.problem(path, raw, f"{did_you_mean(raw, names)}expected {allowed}")

    def tuple(self, args: tuple[Any, ...], raw: object, path: str, meta: Mapping[str, Any]) -> Any:
        if isinstance(raw, Mapping) and len(args) == 2 and args[1] is Ellipsis:
            raw = [raw]  # tinycarlo's singular sections: a mapping stands for a list of one
        if not isinstance(raw, (list, tuple)):
            return self.problem(path, raw, f"expected a list ({_describe_tuple(args, meta)})")
        if len(args) == 2 and args[1] is Ellipsis:
            items = [(args[0], item) for item in raw]
        elif len(raw) != len(args):
            return self.problem(
                path, raw, f"expected a list of {len(args)} ({_describe_tuple(args, meta)})"
            )
        else:
            items = list(zip(args, raw, strict=True))
        values = [self.value(h, item, f"{path}[{i}]", meta) for i, (h, item) in enumerate(items)]
        return _INVALID if any(v is _INVALID for v in values) else tuple(values)

    def scalar(self, hint: type, raw: object, path: str, meta: Mapping[str, Any]) -> Any:
        if hint is bool:
            return (
                raw if isinstance(raw, bool) else self.problem(path, raw, "expected true or false")
            )
        if hint is str:
            if isinstance(raw, str) and raw.strip():
                return raw
            allowed = "expected a non-empty string"
            if isinstance(raw, bool):  # a name written yes, no, on or off
                allowed += " (YAML reads yes, no, on, off, true and false as booleans: quote it)"
            return self.problem(path, raw, allowed)
        if hint in (int, float):
            return self.number(hint, raw, path, meta)
        raise TypeError(f"schema type {hint!r} at {path} has no parser")  # a bug in the schema

    def number(self, hint: type, raw: object, path: str, meta: Mapping[str, Any]) -> Any:
        allowed = f"expected {_describe(hint, meta)}"
        if isinstance(raw, bool) or not isinstance(raw, numbers.Real):
            return self.problem(path, raw, allowed + _number_as_text(raw))
        if not isinstance(raw, (int, float)):  # a numpy number (np.int64, np.float32): as Python's
            raw = int(raw) if isinstance(raw, numbers.Integral) else float(raw)
        if isinstance(raw, float) and not math.isfinite(raw):
            return self.problem(path, raw, allowed)
        magnitude = meta.get("magnitude", MAX_MAGNITUDE)
        if hint is float and abs(raw) > magnitude:  # an int may be too big for a float
            return self.problem(path, raw, f"{allowed}, at most {magnitude:g} in magnitude")
        if hint is int:
            if isinstance(raw, float) and not raw.is_integer():
                return self.problem(path, raw, allowed)
            raw = int(raw)
            if abs(raw) > MAX_INT:
                return self.problem(path, raw, f"{allowed}, at most 2**63 - 1 in magnitude")
        low, high = meta.get("low"), meta.get("high")
        too_low = low is not None and (raw <= low if meta.get("low_open") else raw < low)
        if too_low or (high is not None and raw > high):
            return self.problem(path, raw, allowed)
        return hint(raw)


def _number_as_text(raw: object) -> str:
    """A hint for a number YAML read as text: ``1e3`` (YAML 1.1 wants ``1.0e+3``) or a quoted
    ``'30'``; empty for anything else."""
    if not isinstance(raw, str) or len(raw) > 40:
        return ""
    try:
        number = float(raw)
    except ValueError:
        return ""
    if not math.isfinite(number):
        return ""
    written = str(int(number)) if number.is_integer() and abs(number) < 1e15 else repr(number)
    return f" ({raw!r} is text in YAML: write {written}, unquoted)"


def _key_ok(key: object, numbers: bool) -> bool:
    """A free-form mapping's key: a string, or (``numbers``) a whole number."""
    return isinstance(key, str) or (numbers and type(key) is int)


def _required(f: dataclasses.Field[Any]) -> bool:
    return f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING


def _join(path: str, key: object) -> str:
    return f"{path}.{key}" if path else str(key)


def _unknown_key_hint(key: object, valid: list[str]) -> str:
    hint = did_you_mean(str(key), valid, cutoff=0.5)
    return f"unknown key; {hint}valid keys: {', '.join(sorted(valid))}"


def _describe(hint: Any, meta: Mapping[str, Any]) -> str:
    """A human description of an accepted value, with range and unit."""
    if typing.get_origin(hint) is Literal:
        return "one of: " + ", ".join(map(str, typing.get_args(hint)))
    if hint in (int, float):
        text = "a whole number" if hint is int else "a number"
        low, high = meta.get("low"), meta.get("high")
        if low is not None:
            text += f" {'>' if meta.get('low_open') else '>='} {low:g}"
        if high is not None:
            text += f"{' and' if low is not None else ''} <= {high:g}"
        unit = meta.get("unit")
        return f"{text} [{unit}]" if unit else text
    if hint is Color:
        return "a colour"
    if hint is str:
        return "a non-empty string"
    family = families.members(hint)
    if family is not None:
        return f"a mapping with a type ({', '.join(family)})"
    members = typing.get_args(hint) if typing.get_origin(hint) in (Union, types.UnionType) else ()
    if members and all(dataclasses.is_dataclass(m) for m in members):  # told apart by type
        kinds = [str(f.default) for m in members for f in dataclasses.fields(m) if f.name == "type"]
        return f"a mapping with a type ({', '.join(kinds)})"
    if dataclasses.is_dataclass(hint):
        return "a mapping with keys: " + ", ".join(f.name for f in dataclasses.fields(hint))
    return getattr(hint, "__name__", str(hint))


def _describe_tuple(args: tuple[Any, ...], meta: Mapping[str, Any]) -> str:
    if len(args) == 2 and args[1] is Ellipsis:
        return f"each {_describe(args[0], meta)}"
    if len(set(args)) == 1:  # the unit already names every element: [px, px, rad]
        return f"each {_describe(args[0], meta)}"
    return ", ".join(_describe(a, meta) for a in args)


def deep_merge(base: Mapping[str, Any], overrides: Mapping[str, Any]) -> dict[str, Any]:
    """Overrides win; mappings merge key by key, anything else replaces."""
    merged = dict(base)
    for key, value in overrides.items():
        if isinstance(value, Mapping) and isinstance(merged.get(key), Mapping):
            merged[key] = deep_merge(merged[key], value)
        else:
            merged[key] = value
    return merged
