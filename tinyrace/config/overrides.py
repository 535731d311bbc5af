"""Keys laid over a config file (``gym.make``'s keyword arguments, an experiment's ``env:``)
and the blame that names each problem where its value came from."""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from tinyrace.errors import Problem

KWARGS = "<kwargs>"  # the source named by problems of ``gym.make``'s keyword arguments


DEFAULTS = "<defaults>"  # the source of a config made of defaults and overrides only


@dataclass(frozen=True)
class Overrides:
    """Keys laid over a config file (``gym.make``'s keyword arguments, an experiment's
    ``env:``), and what a problem in one of them names: their source and a key prefix."""

    keys: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    source: str = KWARGS
    prefix: str = ""  # e.g. "env." inside an experiment file


def blame(
    problems: list[Problem],
    source: str,
    overrides: Overrides,
    spelling: Mapping[str, tuple[str, bool]] | None = None,
) -> list[Problem]:
    """``problems`` found in ``source`` merged with ``overrides``, each renamed to the
    overrides' source when its key path lies in an override (or no file was read); the
    others with their list sections named as the file writes them (``spelling``)."""
    renamed = []
    laid = spelling_of(overrides.keys)  # the overrides' own spelling (``env: {track: ...}``)
    for p in problems:
        if p.source == source and (source == DEFAULTS or _overridden(p.path, overrides.keys)):
            path = f"{overrides.prefix}{as_written(p.path, laid)}"
            p = dataclasses.replace(
                p, source=overrides.source, path=path, allowed=as_written(p.allowed, laid)
            )
        elif spelling:  # a message of a data file may name the key that named the file
            path = as_written(p.path, spelling) if p.source == source else p.path
            p = dataclasses.replace(p, path=path, allowed=as_written(p.allowed, spelling))
        renamed.append(p)
    return renamed


_SINGULAR = {"tracks": "track", "cameras": "camera", "sensors": "sensor"}  # key aliases
_LIST_KEY = re.compile(r"^(tracks|track|cameras|camera|sensors|sensor)(?=$|[.\[])")
_LIST_ITEM = re.compile(r"(?<![\w.])(tracks|track|cameras|camera|sensors|sensor)\[(\d+)\]")


def spelled_as(overrides: Mapping[str, Any], raw: Mapping[str, Any]) -> dict[str, Any]:
    """``overrides`` with a section named as the file names it (``track=`` over a file's
    ``tracks:`` replaces it, rather than being the same key given twice)."""
    renamed = dict(overrides)
    for plural, singular in _SINGULAR.items():
        for given, written in ((plural, singular), (singular, plural)):
            if given in renamed and written in raw and written not in renamed:
                renamed[written] = renamed.pop(given)
    return renamed


def _overridden(path: str, keys: Mapping[str, Any]) -> bool:
    """Whether the value at ``path`` (``cameras[0].roi``) came from ``keys``: mappings merge
    key by key, anything else an override gives replaces the file's value whole."""
    tokens = re.findall(r"\[\d+\]|[^.\[\]]+", path)
    if not tokens:  # a top-level key of brackets and dots alone (``[``): itself or not
        return path in keys
    node: Any = keys
    for token in tokens:
        if not isinstance(node, Mapping):
            return True  # inside a list or value the override replaced
        if token.startswith("["):
            continue  # a mapping standing for a list of one (``track:``)
        token = token if token in node else _SINGULAR.get(token, token)  # tracks: track:
        if token not in node:
            return False
        node = node[token]
    return bool(path)


def spelling_of(raw: Mapping[str, Any]) -> dict[str, tuple[str, bool]]:
    """How ``raw`` writes each list section it has: plural name -> (the key as written,
    whether its value is a list). ``track: {...}`` is a list of one written as a mapping."""
    spelling = {}
    for plural, singular in _SINGULAR.items():
        for key in (plural, singular):
            if key in raw:
                spelling[plural] = (key, isinstance(raw[key], list | tuple))
    return spelling


def as_written(text: str, spelling: Mapping[str, tuple[str, bool]]) -> str:
    """A key path (``tracks[0].file``, the parser's ``track[0].file``), or the key paths in a
    message, as the file writes them: ``track.file`` under ``track: {file: ...}``,
    ``track[0].file`` under a list."""

    def item(match: re.Match[str]) -> str:
        plural = _plural(match.group(1))
        if plural not in spelling:
            return match.group(0)
        written, is_list = spelling[plural]
        index = match.group(2)
        return written if index == "0" and not is_list else f"{written}[{index}]"

    def section(match: re.Match[str]) -> str:
        plural = _plural(match.group(1))
        return spelling[plural][0] if plural in spelling else match.group(0)

    return _LIST_KEY.sub(section, _LIST_ITEM.sub(item, text), count=1)


def _plural(name: str) -> str:
    return name if name in _SINGULAR else next(p for p, s in _SINGULAR.items() if s == name)
