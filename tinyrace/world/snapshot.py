"""What sensors and pictures read: a copy of the world's state after a step.

Sensors and renderers take a ``Snapshot`` and the episode's ``Track``; they never see
the pymunk space, so they cannot change it.
"""

from __future__ import annotations

from dataclasses import dataclass

from tinyrace.cars.state import CarState


@dataclass(frozen=True)
class Snapshot:
    """The world at time ``t``: every car's state (the controlled car first)."""

    t: float  # [s] since reset
    steps: int  # steps since reset
    cars: tuple[CarState, ...]
    score: float = 0.0  # the controlled car's running reward (CarRacing's dashboard shows it)

    @property
    def car(self) -> CarState:
        """The controlled car."""
        return self.cars[0]

    def seen_from(self, car: int) -> Snapshot:
        """The same moment with car ``car`` first (the car a sensor rides on), the others
        after it in their order."""
        if car == 0:
            return self
        cars = self.cars
        return Snapshot(self.t, self.steps, (cars[car], *cars[:car], *cars[car + 1 :]), self.score)
