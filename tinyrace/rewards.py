"""How a step's reward and end are made of the rule parts' terms and end reasons: summed,
and gathered, here; decided nowhere else.

A rule part (``tinyrace.episodes.rules``) says which named reward terms it can pay
(``Term``: a function of the step's facts and the ``Design``) and which end reasons it
can give (``End``). The parts' registration puts them in ``TERMS`` and ``ENDS``, in the
order they are summed and asked. This module knows no term by name: the step's reward is
the sum of its terms, reported in ``info["reward_terms"]`` so that a design can be
inspected; its end is the first end reason whose test holds.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from tinyrace.config import RewardConfig
from tinyrace.world.facts import StepFacts

CteShaping = Callable[[float], float]


@dataclass(frozen=True)
class Shaping:
    """A common cross-track-error shaping chosen in YAML (picklable, unlike a lambda)."""

    kind: str  # linear, quadratic, exponential or gaussian
    scale: float  # [track units]
    weight: float

    def __call__(self, error: float) -> float:
        e = error / self.scale
        if self.kind == "linear":
            return -self.weight * e
        if self.kind == "quadratic":
            return -self.weight * e * e
        if self.kind == "exponential":
            return self.weight * math.exp(-e)
        return self.weight * math.exp(-0.5 * e * e)


def shaping_from_config(config: RewardConfig) -> CteShaping | None:
    """The YAML's choice of cross-track-error shaping, or None for no cte reward."""
    cte = config.cross_track_error
    return None if cte.shaping == "none" else Shaping(cte.shaping, cte.scale, cte.weight)


@dataclass(frozen=True)
class Design:
    """What terms and ends read besides the facts: ``reward_design``, the cross-track-error
    shaping, and each ``rules:`` entry by its ``type`` (a rule part's own knobs)."""

    rewards: RewardConfig = field(default_factory=RewardConfig)
    shaping: CteShaping | None = None
    settings: Mapping[str, Any] = field(default_factory=dict)


def _always(design: Design) -> bool:
    return True


@dataclass(frozen=True)
class Term:
    """One named reward term: ``pay(facts, design)`` is its value, or None when it does not
    apply. ``can_pay(design)`` False: it pays nothing under that design (it is not asked).
    ``carried``: the reset's step (which is not rewarded) pays it to the first step.
    ``alone(facts)`` True: the step pays this term alone (or nothing, when it is None), and
    the running score leaves the step out (CarRacing's out-of-bounds penalty)."""

    name: str
    pay: Callable[[StepFacts, Design], float | None]
    can_pay: Callable[[Design], bool] = _always
    carried: bool = False
    alone: Callable[[StepFacts], bool] | None = None


@dataclass(frozen=True)
class End:
    """One way an episode ends: ``when(facts, design)`` True ends it, for ``reason``.
    ``crash``: the report's pictures mark an episode that ended so as a crash."""

    reason: str
    when: Callable[[StepFacts, Design], bool]
    crash: bool = False


# Every registered term and end, in the order the terms are summed (the order is part of
# the float result) and the ends asked (the first that holds is the reason). Filled by the
# rule parts' registration (``tinyrace.episodes.rules.register``).
TERMS: dict[str, Term] = {}
ENDS: dict[str, End] = {}


def add_term(term: Term) -> None:
    """Put ``term`` in ``TERMS`` (after the others); the same name twice must be one term."""
    known = TERMS.get(term.name)
    if known is not None and known != term:
        raise ValueError(f"reward term {term.name!r} is another part's already")
    TERMS.setdefault(term.name, term)


def add_end(end: End) -> None:
    """Put ``end`` in ``ENDS`` (after the others); the same reason twice must be one end."""
    known = ENDS.get(end.reason)
    if known is not None and known != end:
        raise ValueError(f"end reason {end.reason!r} is another part's already")
    ENDS.setdefault(end.reason, end)


@dataclass(frozen=True)
class Judging:
    """The terms and ends one car's step is judged by (those of its rule parts that can pay
    under the design), in ``TERMS``'s and ``ENDS``' order."""

    terms: tuple[Term, ...]
    alone: tuple[Term, ...]  # the terms that pay alone when they apply, asked first
    carried: tuple[Term, ...]  # the terms a reset's step pays to the first step
    ends: tuple[End, ...]


def judging(terms: Iterable[str], ends: Iterable[str], design: Design) -> Judging:
    """The ``Judging`` of a car whose parts pay ``terms`` and give ``ends`` (names)."""
    wanted, reasons = set(terms), set(ends)
    paid = [t for name, t in TERMS.items() if name in wanted and t.can_pay(design)]
    usual = tuple(t for t in paid if t.alone is None)
    alone = tuple(t for name, t in TERMS.items() if name in wanted and t.alone is not None)
    carried = tuple(t for t in usual if t.carried)
    return Judging(usual, alone, carried, tuple(e for r, e in ENDS.items() if r in reasons))


def reward_terms(
    facts: StepFacts, design: Design, terms: Iterable[Term], alone: Iterable[Term] = ()
) -> tuple[dict[str, float], bool]:
    """One step's named reward terms, and whether a term of ``alone`` applied (then it is
    the only one, and the score leaves the step out)."""
    for term in alone:
        assert term.alone is not None
        if term.alone(facts):
            value = term.pay(facts, design)
            return ({term.name: value} if value is not None else {}), True
    paid: dict[str, float] = {}
    for term in terms:
        value = term.pay(facts, design)
        if value is not None:
            paid[term.name] = value
    return paid, False


def end_of(facts: StepFacts, design: Design, ends: Iterable[End]) -> str | None:
    """Why the episode terminates after this step (the first end that holds), or None."""
    for end in ends:
        if end.when(facts, design):
            return end.reason
    return None
