"""The car models as the config layer knows them: each registered model's name, the track
units it drives in and what it is, for the YAML reference (``car.model``'s values).

``tinyrace.cars.registry.register`` adds each model here (the built-in ones, a user's or a
plugin's), so a model registered before ``gym.make`` is in the reference too. The models
themselves (and pymunk, which building one needs) stay in the cars layer: the first
listing imports that registry by its name, as Gymnasium imports an env's entry point, so
that the built-in models are listed even where no layer above the config was imported.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

REGISTRY = "tinyrace.cars.registry"  # the module whose import registers the built-in models


@dataclass(frozen=True)
class CarModelEntry:
    """One registered car model, as the reference shows it."""

    name: str
    track_units: tuple[str, ...]  # the track units it drives in: u (CarRacing's), px, m
    doc: str
    default_for: tuple[str, ...] = ()  # the track units where ``car.model: null`` means it
    # the ``car`` knobs it reads besides ``model`` and ``actions`` (None: every one); a knob
    # it does not read is refused when set, never silently ignored
    reads: frozenset[str] | None = None


_MODELS: dict[str, CarModelEntry] = {}


def add(entry: CarModelEntry) -> None:
    """Make ``entry`` known (a new name, or a replacement of the same name)."""
    _MODELS[entry.name] = entry


def remove(name: str) -> None:
    """Take car model ``name`` away again (a test's toy, when the test ends)."""
    _MODELS.pop(name, None)


def default_model(unit: str) -> CarModelEntry | None:
    """The model ``car.model: null`` means on tracks in ``unit``, if one is registered."""
    return next((m for m in car_models().values() if unit in m.default_for), None)


def car_models() -> dict[str, CarModelEntry]:
    """Every registered car model by name, the built-in ones first."""
    importlib.import_module(REGISTRY)  # registers the built-in models once
    return dict(_MODELS)
