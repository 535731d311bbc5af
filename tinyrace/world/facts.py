"""The facts of one step: what the world's contacts and the episode's rules found.

Episodes turn contacts into ``StepFacts``; the rule parts' reward terms and end reasons
are decided from those facts alone. The fields are the built-in parts' findings; a part
of one's own writes its findings under its name in ``more``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass
class StepFacts:
    """What happened during one step, as the sensors saw it."""

    dt: float = 0.0  # [s] the step's sim time (a rule "per second" scales by it)
    new_tiles: int = 0  # tiles visited for the first time
    tiles: list[int] = field(default_factory=list)  # which: the tiles first visited this step
    tiles_total: int = 0
    lap_finished: bool = False
    out_of_bounds: bool = False  # left the playfield or the image
    wheels_on_grass: int = 0
    obstacles_hit: list[int] = field(default_factory=list)  # indices into color_obstacles
    cte: float | None = None  # [track units] distance to the trajectory
    cones_hit: int = 0  # cones knocked over during this step (each counts once per episode)
    wall_hit: bool = False  # the car touched a wall this step (and was stopped)
    collision_ends: bool = False  # the source ends the episode on this step's collision
    more: dict[str, Any] = field(default_factory=dict)  # other parts' findings, by part
