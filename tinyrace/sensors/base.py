"""The sensor contract: an observation space and ``observe(snapshot, track, rng)``.

A sensor reads a ``Snapshot`` (``tinyrace.world.snapshot``) and the episode's ``Track``
(``tinyrace.tracks.base``); it never touches the physics. Its randomness (noise,
dropouts) comes from the ``rng`` it is given: the env's ``np_random``.

How to add a sensor type:
1. Write ``tinyrace/sensors/<type>.py`` with a class satisfying ``Sensor`` (it describes
   itself, and says whether its image is a picture from above), a builder
   ``build(entry, context) -> Sensor`` and its config entry: a dataclass of ``knob()``
   fields (units, bounds, docs) with ``id`` and ``type: Literal["<type>"]``, subclassing
   ``SensorDefaults`` (``tinyrace.config.sensors``). The ``SensorContext`` gives the env
   config, the ground and the car's facts; what sensor types share is in
   ``sensors/machinery/``. For a type in the package the config dataclass lives in
   ``tinyrace/config/sensors.py`` (so that ``import tinyrace`` alone knows it);
   ``tinyrace/sensors/birdseye_camera.py`` with ``CameraConfig`` there is the
   example to copy.
2. Register it in ``tinyrace/sensors/registry.py``: one ``SensorType`` entry with its
   name (the entry's ``type``), config class, builder and what its tracks must hold; the
   loader then parses ``type: <type>`` entries into its config class.
``tests/test_toy_recipes.py`` does both from a test file alone.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np
from gymnasium import spaces

if TYPE_CHECKING:
    from tinyrace.cars.state import CarFacts
    from tinyrace.config import EnvConfig
    from tinyrace.ground.texture import GroundTexture
    from tinyrace.tracks.base import Track
    from tinyrace.world.snapshot import Snapshot


class Sensor(Protocol):
    """One sensor of the observation: its key, its space, and how it observes."""

    @property
    def id(self) -> str:
        """Its key in the Dict observation."""
        ...

    @property
    def space(self) -> spaces.Space[Any]:
        """The observation space of what ``observe`` returns (fixed at construction)."""
        ...

    def reset(self, track: Track) -> None:
        """A new episode on ``track``: prepare per-track caches (textures, distance maps)."""

    def observe(self, snapshot: Snapshot, track: Track, rng: np.random.Generator) -> Any:
        """The observation now; noise from ``rng`` only."""
        ...

    def describe(self) -> str:
        """What it observes, in a few words (``tinyrace validate`` prints it beside its id
        and the shapes of its space)."""
        ...

    def top_down(self, snapshot: Snapshot, track: Track) -> TopDown | None:
        """Its image as a top-down picture of the ground around the car, for ``render()``'s
        overview, or None: its observation is no such picture."""
        ...


@runtime_checkable
class DrawsInto(Protocol):
    """A sensor whose reading is one image that it can draw into an array it is given (a
    row of a vector env's observations): no frame of its own, no copy into the row."""

    def observe_into(
        self, snapshot: Snapshot, track: Track, rng: np.random.Generator, out: np.ndarray
    ) -> np.ndarray:
        """``observe``'s reading, the same pixels, drawn into ``out`` (of the space's shape
        and dtype, its rows contiguous); returns ``out``."""
        ...


def drawer(sensor: Sensor) -> DrawsInto | None:
    """The sensor as a ``DrawsInto`` when it offers that capability, else None (the one
    place that asks: callers outside sensors/ ask this, not the sensor's class)."""
    return sensor if isinstance(sensor, DrawsInto) else None


@dataclass(frozen=True)
class TopDown:
    """A sensor's image seen as a top-down picture: the track window it shows (its corners,
    drawn on the overview), or None for a view whose window is not drawn."""

    window: np.ndarray | None = None


@runtime_checkable
class Labelled(Protocol):
    """A sensor whose observation holds class labels (a ``classes`` camera); ``labels``
    names each label value it may observe on the current track (empty: it observes no
    labels), sky included."""

    @property
    def labels(self) -> dict[int, str]:
        """The name of each label value."""
        ...


class Ground(Protocol):
    """The episode's picture of the ground, shared by the cameras (and kept up to date:
    CarRacing's visited tiles change colour)."""

    def texture(self, track: Track) -> GroundTexture:
        """The ground texture of ``track`` in the current episode."""
        ...


@dataclass(frozen=True, eq=False)
class SensorContext:
    """What a sensor may use when it is built: the env's config, its ground pictures and
    its car model's facts (size, limits, wheels)."""

    env: EnvConfig
    ground: Ground
    car: CarFacts


SensorBuilder = Callable[[Any, SensorContext], Sensor]


@dataclass(frozen=True)
class SensorType:
    """One registered sensor type."""

    name: str  # the ``type`` of a sensor entry
    config: type  # dataclass of its entry's knobs
    build: SensorBuilder
    needs: str | None = None  # what its tracks must hold (a ``TrackFacts.holds`` entry); None: any
    doc: str = ""
    default: bool = False  # the observation of the tracks holding its needs when none is configured
