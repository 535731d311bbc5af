"""What sensors and pictures read: a copy of the world's state after a step.

Sensors and renderers take a ``Snapshot`` and the episode's ``Track``; they never see
the pymunk space, so they cannot change it.
"""

from __future__ import annotations

from dataclasses import dataclass

from tinyrace.cars.state import CarState


@dataclass(frozen=True)
class Snapshot:
    """The world at time ``t``: every car's state (the controlled car first), and which cars
    are gone from the track (they finished: they stand where they stopped, met by nothing)."""

    t: float  # [s] since reset
    steps: int  # steps since reset
    cars: tuple[CarState, ...]
    gone: frozenset[int] = frozenset()  # indices into ``cars`` of the cars off the track
    score: float = 0.0  # the controlled car's running reward (CarRacing's dashboard shows it)
    # each car's index in the world (its colour, its name), in the order of ``cars``; ()
    # when the order is the world's own
    order: tuple[int, ...] = ()

    @property
    def car(self) -> CarState:
        """The controlled car."""
        return self.cars[0]

    @property
    def others(self) -> tuple[CarState, ...]:
        """The other cars on the track (what the controlled car's sensors can meet)."""
        gone = self.gone
        return tuple(car for i, car in enumerate(self.cars) if i and i not in gone)

    def seen_from(self, car: int) -> Snapshot:
        """The same moment with car ``car`` first (the car a sensor rides on), the others
        after it in their order."""
        if car == 0:
            return self
        cars = self.cars
        seen = (cars[car], *cars[:car], *cars[car + 1 :])
        gone = frozenset(0 if i == car else i + 1 if i < car else i for i in self.gone)
        order = self.order or tuple(range(len(cars)))
        return Snapshot(
            self.t,
            self.steps,
            seen,
            gone=gone,
            score=self.score,
            order=(order[car], *order[:car], *order[car + 1 :]),
        )

    def index(self, k: int) -> int:
        """The world's index of ``cars[k]`` (what its colour and name are looked up by)."""
        return self.order[k] if self.order else k
