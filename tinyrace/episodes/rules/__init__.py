"""The rule parts an episode is composed of, by name: each part is one module (here, or a
user's own file) and one ``register`` call.

A track lists the parts of its episodes (``Track.rules.parts``); a ``rules:`` entry of the
config adds a part with knobs to every car; a few parts are in every episode
(``RulePart.always``: the clock's time cost, the end of the last lap). The episode builds
one instance of each part per car. What a part owns (its config, the facts it adds, its
reward terms and end reasons) is its ``RulePart`` entry (``base.py``); registering it puts
its terms and ends in ``tinyrace.rewards``' registries, which sum and gather them.

How to add a rule part: a module with a ``RuleBase`` subclass and a ``RulePart`` entry
naming it, its terms, its ends and its config dataclass, then ``register(PART)``
(docs/ARCHITECTURE.md shows one whole; ``tests/test_toy_recipes.py`` does it from a test).
"""

from __future__ import annotations

from tinyrace.config import EnvConfig, families
from tinyrace.config.rules import RuleConfig
from tinyrace.episodes.rules import (
    centreline_progress,
    clock,
    collisions,
    grass,
    laps,
    no_reference,
    obstacle_colours,
    playfield,
    tile_touches,
    trajectory_error,
)
from tinyrace.episodes.rules.base import Info, Rule, RuleBase, RulePart, TileProgress
from tinyrace.errors import Problem
from tinyrace.rewards import ENDS, TERMS, add_end, add_term

__all__ = [
    "RULES",
    "Info",
    "Rule",
    "RuleBase",
    "RulePart",
    "TileProgress",
    "crash_reasons",
    "register",
    "rule_problems",
    "rule_type",
    "unregister",
]

RULES: dict[str, RulePart] = {}


def register(part: RulePart) -> RulePart:
    """Make ``part`` known by its name: track sources may list it, a ``rules:`` entry of its
    ``config``'s type adds it, its terms and ends join the sum and the ends (after the
    built-in ones). Returns ``part``."""
    known = RULES.get(part.name)
    if known is not None and known is not part:
        raise ValueError(f"rule part {part.name!r} is registered already")
    if part.config is not None:
        named = families.type_of(part.config)
        if named != part.name:
            raise ValueError(f"rule part {part.name!r}: its config's type is {named!r}")
    for term in part.terms:
        add_term(term)
    for end in part.ends:
        add_end(end)
    if part.config is not None:
        families.add(RuleConfig, part.config)
    RULES[part.name] = part
    return part


def unregister(name: str) -> None:
    """Take rule part ``name`` away again, with the terms and ends no other part has (a
    test's toy, when the test ends)."""
    part = RULES.pop(name, None)
    if part is None:
        return
    families.remove(RuleConfig, name)
    others = RULES.values()
    for term in part.terms:
        if not any(term in other.terms for other in others):
            TERMS.pop(term.name, None)
    for end in part.ends:
        if not any(end in other.ends for other in others):
            ENDS.pop(end.reason, None)


def rule_problems(config: EnvConfig, source: str) -> list[Problem]:
    """A problem for each ``rules:`` entry whose part needs what the config's tracks do not
    hold, named at the entry's ``type``."""
    problems = []
    holds = config.facts.holds
    for i, entry in enumerate(config.rules):
        needs = rule_type(entry.type).needs
        if needs is not None and needs not in holds:
            allowed = (
                f"a {entry.type} rule part needs a track that holds {needs}, "
                f"not a {config.kind} track"
            )
            problems.append(Problem(source, f"rules[{i}].type", entry.type, allowed))
    return problems


def crash_reasons() -> frozenset[str]:
    """The end reasons of the registered parts that are crashes (``End.crash``): the ones
    the report's pictures mark as a crash."""
    return frozenset(end.reason for part in RULES.values() for end in part.ends if end.crash)


def rule_type(name: str) -> RulePart:
    """The rule part called ``name``; a KeyError lists the known names."""
    try:
        return RULES[name]
    except KeyError:
        raise KeyError(f"no rule part {name!r}; known: {', '.join(RULES)}") from None


# in this order: the order their terms are summed and their ends asked
for _module in (
    clock,
    playfield,
    tile_touches,
    grass,
    obstacle_colours,
    collisions,
    trajectory_error,
    centreline_progress,
    no_reference,
    laps,
):
    register(_module.PART)
