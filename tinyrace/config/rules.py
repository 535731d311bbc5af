"""The ``rules:`` entries: the knobs of rule parts that have their own (an open family,
as ``sensors:`` is: registering a rule part with a config dataclass adds it, see
``tinyrace.episodes.rules``). Each entry adds its part to every car's episode."""

from __future__ import annotations

from typing import Protocol

from tinyrace.config import families


class RuleConfig(Protocol):
    """A ``rules:`` entry: the dataclass its ``type`` names."""

    @property
    def type(self) -> str: ...


families.declare(RuleConfig, type_required=True)  # no part is what an entry means


def rule_configs() -> dict[str, type]:
    """Every rule part's config class by type name (registered so far)."""
    return families.members(RuleConfig) or {}
