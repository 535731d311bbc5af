"""The car contract: what the world steps and what a snapshot of a car holds.

How to add a car model:
1. Write ``tinyrace/cars/<model>.py`` with a class satisfying ``Car`` (a pymunk body plus
   its own state; ``control`` takes the controls of one action, ``apply_forces`` moves it
   for one step, ``stop`` halts it after a crash, ``state()`` copies what sensors and
   pictures may read). The world (``tinyrace/world/world.py``) owns the built car and
   calls these; nothing above the world sees the car itself.
2. Register it: ``register(CarModel(...))`` (``tinyrace/cars/registry.py``) with its
   builder, the track kinds it can drive on, the track kinds it is the default for, its
   ``car.actions`` and action space, its facts for a config (``CarFacts``: size, limits,
   grip) and what it can do (wheels, throttle). That entry is the only place that decides
   which car a config gets, and the only place sensors, episodes and drivers learn about
   the car from; ``car.model`` takes any registered name (``tests/test_toy_car_model.py``
   registers one from its test file alone).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Protocol

import numpy as np

from tinyrace.cars.state import CarState, Point, Pose, WheelState

if TYPE_CHECKING:
    import pymunk

__all__ = ["Car", "CarState", "Point", "Pose", "TyreBatch", "WheelState"]


class Car(Protocol):
    """One car in a world: controls in, forces out, state readable."""

    @property
    def body(self) -> pymunk.Body: ...

    @property
    def control(self) -> Callable[..., None]:
        """Sets the controls of one action (e.g. steer, gas, brake) for the coming steps."""
        ...

    def apply_forces(self, dt: float, on_road: Sequence[bool]) -> None:
        """Prepare the body for a world step of ``dt`` seconds; ``on_road`` per wheel."""

    def stop(self) -> None:
        """A crash: the car stands still (as far as its model lets it; the world has put the
        body back where it stood before the step)."""

    @property
    def pose(self) -> Pose: ...

    @property
    def speed(self) -> float: ...

    @property
    def footprint(self) -> tuple[float, float]: ...

    @property
    def rear_axle(self) -> Point: ...

    @property
    def front_axle(self) -> Point: ...

    def state(self) -> CarState:
        """A copy of the car's state now."""
        ...


class TyreBatch(Protocol):
    """The tyre forces of many cars of one model as one computation, one row per car: a
    capability a car model may offer (``CarModel.batch``), for a vector env that steps
    many envs' cars together. Controls are (steer, gas, brake) columns."""

    def load(self, row: int, car: Car) -> None:
        """Copy ``car`` (a car of this model) into ``row`` (after a reset or a change)."""

    def control(self, steer: np.ndarray, gas: np.ndarray, brake: np.ndarray) -> None:
        """Every row's controls (``Car.control`` for each car)."""

    def apply_forces(self, dt: np.ndarray, rows: Sequence[int], on_road: np.ndarray) -> None:
        """``Car.apply_forces`` for the cars of ``rows`` (``dt`` [s] and ``on_road`` per
        wheel, per row)."""

    def store(self, rows: Sequence[int]) -> None:
        """Copy the rows' state back to their cars (what ``Car.state`` reads)."""

    def track_skids(self, rows: Sequence[int], on_road: np.ndarray) -> None:
        """The rows' skid marks, as each car draws its own."""

    def stop(self, row: int) -> None:
        """``Car.stop`` for the car of ``row`` (a crash)."""
