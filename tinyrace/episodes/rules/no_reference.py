"""A track without a reference line: no progress, and info says why there is no cte."""

from __future__ import annotations

from typing import Any

from tinyrace.episodes.rules.base import Info, RuleBase, RulePart
from tinyrace.tracks.base import Track


class NoReference(RuleBase):
    """One car's info without a reference line."""

    def __init__(self, track: Track, settings: Any = None) -> None:
        self.note = track.reference_note or "no reference line"

    def info(self, info: Info) -> None:
        info["tiles_visited"] = 0
        info["tiles_total"] = 0
        info["on_road"] = True
        info["cte_unavailable"] = self.note


PART = RulePart("no_reference", NoReference, doc="no reference line: no progress, no cte")
