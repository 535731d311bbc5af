"""The car models by name: the one place that decides which car a config gets.

Each ``CarModel`` says which track kinds it drives on, which it is the default for
(``car.model: null``), which ``car.actions`` it accepts, how to build it and its action
space. ``choose_car_model`` applies those rules for ``gym.make`` and ``tinyrace
validate`` alike. To add a model, see ``tinyrace/cars/base.py``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import pymunk

from tinyrace.actions import ActionSpec
from tinyrace.cars.base import Car, Pose
from tinyrace.cars.dynamic import DynamicCar
from tinyrace.cars.kinematic import KinematicCar
from tinyrace.cars.kinematic_throttle import KinematicThrottleCar
from tinyrace.config import METRIC_KINDS, CarConfig, EnvConfig
from tinyrace.errors import ConfigError, Problem, one_of
from tinyrace.tracks.base import Track

CarBuilder = Callable[[pymunk.Space, Pose, CarConfig, Track], Car]


@dataclass(frozen=True)
class CarModel:
    """One registered car model."""

    name: str
    track_kinds: frozenset[str]  # the ``track.type`` values it can drive on
    default_for: frozenset[str]  # track kinds where ``car.model: null`` means this model
    action_kinds: frozenset[str]  # accepted ``car.actions`` values
    build: CarBuilder  # adds the car to a space at a pose
    actions: Callable[[CarConfig], ActionSpec]  # its action space and how to read actions
    doc: str


def _known(value: float | None) -> float:
    """A car knob whose null default ``resolve_defaults`` has filled by track kind."""
    assert value is not None, "car knobs are resolved when the config is loaded"
    return value


def _build_dynamic(space: pymunk.Space, pose: Pose, config: CarConfig, track: Track) -> Car:
    if track.kind == "procedural":  # CarRacing's own frame and units
        return DynamicCar.build(space, pose)
    return DynamicCar.build(space, pose, scale=_known(config.pixels_per_unit), y_down=track.y_down)


def _build_kinematic(space: pymunk.Space, pose: Pose, config: CarConfig, track: Track) -> Car:
    return KinematicCar.build(
        space,
        pose,
        _known(config.wheelbase),
        _known(config.track_width),
        _known(config.velocity),
        config.max_steering_angle,
        config.max_steering_change,
    )


def _build_kinematic_throttle(
    space: pymunk.Space, pose: Pose, config: CarConfig, track: Track
) -> Car:
    return KinematicThrottleCar.build(
        space,
        pose,
        (_known(config.wheelbase), _known(config.track_width)),
        (_known(config.velocity), config.max_acceleration, config.max_deceleration),
        (config.max_steering_angle, config.max_steering_change),
        y_down=track.y_down,
    )


def _kinematic_throttle_actions(config: CarConfig) -> ActionSpec:
    return ActionSpec.for_car("kinematic_throttle", config.actions)


def _dynamic_actions(config: CarConfig) -> ActionSpec:
    return ActionSpec.for_car("dynamic", config.actions)


def _kinematic_actions(config: CarConfig) -> ActionSpec:
    return ActionSpec.for_car("kinematic", config.actions)


CAR_MODELS: dict[str, CarModel] = {
    "dynamic": CarModel(
        name="dynamic",
        track_kinds=frozenset({"procedural", "image", *METRIC_KINDS}),
        default_for=frozenset({"procedural"}),
        action_kinds=frozenset({"continuous", "discrete"}),
        build=_build_dynamic,
        actions=_dynamic_actions,
        doc="CarRacing-v3's rear-wheel-drive car with tyre slip",
    ),
    "kinematic": CarModel(
        name="kinematic",
        track_kinds=frozenset({"image"}),
        default_for=frozenset({"image"}),
        action_kinds=frozenset({"continuous"}),
        build=_build_kinematic,
        actions=_kinematic_actions,
        doc="tinycarlo's constant-speed kinematic bicycle",
    ),
    "kinematic_throttle": CarModel(
        name="kinematic_throttle",
        track_kinds=frozenset(METRIC_KINDS),
        default_for=frozenset(METRIC_KINDS),
        action_kinds=frozenset({"continuous"}),
        build=_build_kinematic_throttle,
        actions=_kinematic_throttle_actions,
        doc="a kinematic bicycle with throttle in metres (tinycarlo 2's car): [steer, throttle]",
    ),
}


def car_model_problems(config: EnvConfig, source: str) -> list[Problem]:
    """Every problem of the config's car choice: unknown model, track kind, actions."""
    kind = config.kind
    name = config.car.model or _default_name(kind)
    if name is None:
        allowed = f"expected a car model for track kind {kind!r}; models: {_listing()}"
        return [Problem(source, "car.model", config.car.model, allowed)]
    model = CAR_MODELS.get(name)
    if model is None:
        return [Problem(source, "car.model", name, one_of(name, CAR_MODELS))]
    problems = []
    if kind not in model.track_kinds:
        allowed = (
            f"car model {name!r} drives on track kinds {', '.join(sorted(model.track_kinds))}, "
            f"not {kind!r}; models: {_listing()}"
        )
        problems.append(Problem(source, "car.model", name, allowed))
    if config.car.actions not in model.action_kinds:
        allowed = f"car model {name!r} takes car.actions: {', '.join(sorted(model.action_kinds))}"
        problems.append(Problem(source, "car.actions", config.car.actions, allowed))
    return problems


def choose_car_model(config: EnvConfig, source: str) -> CarModel:
    """The car model of a config (its ``car.model`` or the track kind's default).

    Raises ConfigError naming the file, ``car.model``, the value and the supported kinds.
    """
    problems = car_model_problems(config, source)
    if problems:
        raise ConfigError(problems)
    name = config.car.model or _default_name(config.kind)
    assert name is not None  # car_model_problems found none
    return CAR_MODELS[name]


def _default_name(kind: str) -> str | None:
    return next((m.name for m in CAR_MODELS.values() if kind in m.default_for), None)


def _listing() -> str:
    return "; ".join(f"{m.name} ({', '.join(sorted(m.track_kinds))})" for m in CAR_MODELS.values())
