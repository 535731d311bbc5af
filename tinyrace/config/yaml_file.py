"""Reading YAML the user wrote, with bounds: nothing read whole before it is known to be small.

A file is refused with a ConfigError (file, line, what is allowed) when it is not a regular
file (a folder, FIFO or device), larger than ``MAX_YAML_BYTES``, not UTF-8, nested deeper than
``MAX_DEPTH``, expands (aliases included) to more than ``MAX_VALUES`` values, holds a recursive
alias, or repeats a key in one mapping (the message names both lines). The shape is checked on
the parser's event stream, which needs no recursion, before any object is built.
"""

from __future__ import annotations

import os
import re
import stat
import unicodedata
from pathlib import Path
from typing import Any

import yaml  # type: ignore[import-untyped, unused-ignore]

from tinyrace.errors import ConfigError, Problem, file_kind

_LINE_BREAK = re.compile("\r\n|[\n\r\x85\u2028\u2029]")  # YAML's line breaks
MAX_YAML_BYTES = 1 << 20  # [bytes] a track.yaml or experiment file (1 MiB)
MAX_DEPTH = 32  # nested mappings and lists; the schema itself nests 4 deep
MAX_VALUES = 200_000  # scalars and collections after alias expansion

_BaseLoader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # libyaml when installed
# libyaml (bundled with PyYAML >= 6.0.4) refuses 1,000 open flow collections while it scans
# tokens ahead, before the depth check below sees their events: the same refusal, said ours
LIBYAML_DEPTH = "exceeded maximum nesting depth"
_COLLECTION_START = (yaml.MappingStartEvent, yaml.SequenceStartEvent)
_COLLECTION_END = (yaml.MappingEndEvent, yaml.SequenceEndEvent)
_MERGE_TAG = "tag:yaml.org,2002:merge"
Anchors = dict[str, tuple[int, int]]  # anchor -> (expanded size, depth below)


class _Refused(Exception):
    """A bound was crossed at ``mark`` (a YAML mark or None)."""

    def __init__(self, mark: Any, reason: str):
        super().__init__(reason)
        self.mark, self.reason = mark, reason


def read_yaml(path: Path) -> Any:
    """Read and parse a YAML file the user wrote; every failure is a ConfigError naming it."""
    return parse_yaml(read_text(path), str(path))


def read_text(path: Path, limit: int = MAX_YAML_BYTES) -> str:
    """The UTF-8 text of a regular file of at most ``limit`` bytes."""
    source = str(path)
    data = read_bytes(path, limit, "a YAML file")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        allowed = f"the file is unreadable: expected UTF-8 text (byte {exc.start} is not)"
        raise ConfigError(Problem(source, "", source, allowed)) from None


def read_bytes(path: Path, limit: int, what: str) -> bytes:
    """The bytes of a regular file of at most ``limit`` bytes, opened without blocking.

    A FIFO, device or folder is refused before anything is read from it.
    """
    source = str(path)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except FileNotFoundError:
        raise ConfigError(Problem(source, "", source, "the file does not exist")) from None
    except (OSError, ValueError) as exc:  # permissions, a NUL byte, a name too long
        allowed = f"expected {what} that can be read ({_reason(exc)})"
        raise ConfigError(Problem(source, "", source, allowed)) from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            allowed = f"expected {what} (a regular file), not {file_kind(info.st_mode)}"
            raise ConfigError(Problem(source, "", source, allowed))
        if info.st_size > limit:
            allowed = f"expected {what} of at most {limit:,} bytes (it has {info.st_size:,})"
            raise ConfigError(Problem(source, "", source, allowed))
        with os.fdopen(fd, "rb", closefd=False) as file:
            data = file.read(limit + 1)  # a file that grows while read is cut here
    finally:
        os.close(fd)
    if len(data) > limit:
        allowed = f"expected {what} of at most {limit:,} bytes"
        raise ConfigError(Problem(source, "", source, allowed))
    return data


def parse_yaml(text: str, source: str) -> Any:
    """Parse YAML text within the bounds above; ``source`` names it in errors."""
    try:
        _check_shape(text)
        return yaml.load(text, Loader=_StrictLoader)
    except _Refused as exc:
        raise ConfigError(
            Problem(source, _line(exc.mark), _text_at(text, exc.mark), exc.reason)
        ) from None
    except yaml.reader.ReaderError as exc:  # a character YAML takes in no file
        line, text_of_line = _line_at(text, exc.position)
        allowed = (
            f"invalid YAML: the character {_character(exc.character)} cannot be in a YAML file"
        )
        if exc.character == 0:
            allowed += " (NUL bytes: a UTF-16 file? save it as UTF-8)"
        raise ConfigError(Problem(source, f"line {line}", text_of_line, allowed)) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        reason = getattr(exc, "problem", None) or str(exc)
        if reason == LIBYAML_DEPTH:  # libyaml's own bound, met while scanning ahead
            reason = f"nesting deeper than {MAX_DEPTH} levels"
        problem = Problem(source, _line(mark), _text_at(text, mark), f"invalid YAML: {reason}")
        raise ConfigError(problem) from None
    except (ValueError, OverflowError, TypeError, RecursionError) as exc:  # e.g. 2001-13-45
        allowed = f"invalid YAML: a value cannot be read ({_reason(exc)})"
        raise ConfigError(Problem(source, "", source, allowed)) from None


def _check_shape(text: str) -> None:
    """Depth, alias expansion and recursion, from the event stream (no recursion, no objects)."""
    stack: list[list[Any]] = []  # open collections: [expanded size, depth below, anchor]
    anchors: Anchors = {}
    total = 0
    for event in yaml.parse(text, Loader=_BaseLoader):
        if isinstance(event, _COLLECTION_START):
            stack.append([1, 0, event.anchor])
            if len(stack) > MAX_DEPTH:
                raise _Refused(event.start_mark, f"nesting deeper than {MAX_DEPTH} levels")
            size = 1
        elif isinstance(event, _COLLECTION_END):
            size, below, anchor = stack.pop()
            _add(stack, size, below + 1, anchor, anchors)
            continue
        elif isinstance(event, yaml.ScalarEvent):
            size = 1
            _add(stack, size, 0, event.anchor, anchors)
        elif isinstance(event, yaml.AliasEvent):
            size, depth = _alias(event, stack, anchors)
            _add(stack, size, depth, None, anchors)
        else:
            continue
        total += size
        if total > MAX_VALUES:
            raise _Refused(event.start_mark, f"more than {MAX_VALUES:,} values (aliases expanded)")


def _alias(event: yaml.AliasEvent, stack: list[list[Any]], anchors: Anchors) -> tuple[int, int]:
    if any(frame[2] == event.anchor for frame in stack):
        raise _Refused(event.start_mark, f"an alias *{event.anchor} inside its own anchor")
    size, depth = anchors.get(event.anchor, (1, 0))  # an unknown alias: the loader says so
    if len(stack) + depth > MAX_DEPTH:
        reason = f"nesting deeper than {MAX_DEPTH} levels (alias *{event.anchor} expanded)"
        raise _Refused(event.start_mark, reason)
    return size, depth


def _add(
    stack: list[list[Any]], size: int, depth: int, anchor: str | None, anchors: Anchors
) -> None:
    """Count a finished node into its parent; remember what an anchor expands to."""
    if anchor is not None:
        anchors[anchor] = (size, depth)
    if stack:
        stack[-1][0] += size
        stack[-1][1] = max(stack[-1][1], depth)


class _StrictLoader(_BaseLoader):  # type: ignore[misc, valid-type]
    """The safe loader, refusing a key given twice in one mapping."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: dict[Any, Any] = {}
        for key_node, _ in node.value:
            if key_node.tag == _MERGE_TAG:
                continue
            key = self.construct_object(key_node, deep=True)
            try:
                first = seen.setdefault(key, key_node.start_mark)
            except TypeError:  # an unhashable key: the base loader reports it
                continue
            if first is not key_node.start_mark:
                reason = (
                    f"the key {_short(key)} is given twice in one mapping: "
                    f"lines {first.line + 1} and {key_node.start_mark.line + 1}"
                )
                raise _Refused(key_node.start_mark, reason)
        mapping: dict[Any, Any] = super().construct_mapping(node, deep=deep)
        return mapping

    def construct_yaml_int(self, node: yaml.ScalarNode) -> int:
        _refuse_yaml11_number(node, "int")
        value: int = super().construct_yaml_int(node)
        return value

    def construct_yaml_float(self, node: yaml.ScalarNode) -> float:
        _refuse_yaml11_number(node, "float")
        value: float = super().construct_yaml_float(node)
        return value


_StrictLoader.add_constructor("tag:yaml.org,2002:int", _StrictLoader.construct_yaml_int)
_StrictLoader.add_constructor("tag:yaml.org,2002:float", _StrictLoader.construct_yaml_float)
_OCTAL = re.compile(r"[-+]?0[0-7_]+")  # YAML 1.1's octal: 010 is 8


def _refuse_yaml11_number(node: yaml.ScalarNode, kind: str) -> None:
    """Refuse YAML 1.1's numbers that read otherwise than they look: base 60 (``1:30`` is 90)
    and a leading zero (``010`` is 8). YAML 1.2 reads both as text; neither is silent here."""
    text = node.value
    if node.style not in (None, "") or not isinstance(text, str):  # quoted: text
        return
    if ":" in text:
        number = _base60(text.replace("_", ""), kind)
        reason = (
            f"{text} is YAML 1.1's base-60 number {number}: write {number}, "
            f"or quote it ('{text}') for text"
        )
        raise _Refused(node.start_mark, reason)
    digits = text.replace("_", "")
    if _OCTAL.fullmatch(text) and int(digits, 8) != int(digits, 10):
        reason = (
            f"{text} is YAML 1.1's octal number {int(digits, 8)}: write {int(digits, 10)} "
            f"without the leading zero, or quote it ('{text}') for text"
        )
        raise _Refused(node.start_mark, reason)


def _base60(text: str, kind: str) -> str:
    sign = -1 if text.startswith("-") else 1
    value = 0.0 if kind == "float" else 0
    for part in text.lstrip("+-").split(":"):
        value = value * 60 + (float(part) if kind == "float" else int(part))
    return repr(sign * value)


def _line(mark: Any) -> str:
    return f"line {mark.line + 1}" if mark is not None else ""


def _text_at(text: str, mark: Any) -> str:
    """The line a mark points at, shortened (a one-line file may be megabytes long); lines
    counted as YAML counts them (U+2028 and a lone CR end a line too)."""
    if mark is None:
        return ""
    lines = _LINE_BREAK.split(text, maxsplit=mark.line + 1)
    line = lines[mark.line] if mark.line < len(lines) else ""
    return line if len(line) <= 200 else line[:197] + "..."


def _line_at(text: str, position: int) -> tuple[int, str]:
    """The line number (from 1) and text of the character at ``position``."""
    before = text[:position]
    number = len(_LINE_BREAK.findall(before))
    return number + 1, _text_at(text, yaml.Mark("", 0, number, 0, "", 0))


def _character(code: object) -> str:
    if isinstance(code, int):
        return f"U+{code:04X} ({unicodedata.name(chr(code), 'a control character')})"
    return repr(code)


def _short(value: object) -> str:
    text = repr(value) if not isinstance(value, int) or value.bit_length() < 256 else "<int>"
    return text if len(text) <= 40 else text[:37] + "..."


def _reason(exc: BaseException) -> str:
    text = str(exc) or type(exc).__name__
    return text if len(text) <= 120 else text[:117] + "..."


def document_kind(document: object) -> str:
    """What a YAML document that is not a mapping holds, for a message that should not quote
    a whole file (a text file read as YAML is one long string)."""
    if isinstance(document, str):
        return f"a text of {len(document):,} characters, not a mapping"
    if isinstance(document, list):
        return f"a list of {len(document):,} items, not a mapping"
    return f"{type(document).__name__} {document!r}, not a mapping"
