"""The car models by name: the one place that decides which car a config gets, and the one
place that knows each model's facts.

Each ``CarModel`` says which track units it drives in (``u``, ``px``, ``m``: compared with
the track config's ``unit``), which it is the default for
(``car.model: null``), which ``car.actions`` it accepts, how to build it, its action space,
its size and limits for a config (``CarFacts``) and what it can do (wheels, throttle).
Everything above the cars layer asks the entry (``model_of(config)``); nothing compares
model names. ``choose_car_model`` applies those rules for ``gym.make`` and ``tinyrace
validate`` alike. To add a model, see ``tinyrace/cars/base.py``: one module and one
``register`` call.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass

import pymunk

from tinyrace.actions import ActionSpec
from tinyrace.cars import single_track_model
from tinyrace.cars.base import Car, Pose, TyreBatch
from tinyrace.cars.dynamic import DynamicCar
from tinyrace.cars.dynamic_batch import DynamicBatch
from tinyrace.cars.dynamic_shape import SIZE, WHEEL_POSITIONS, DynamicCarSpec
from tinyrace.cars.kinematic import KinematicCar
from tinyrace.cars.kinematic_throttle import KinematicThrottleCar
from tinyrace.cars.single_track import SingleTrackCar
from tinyrace.cars.state import CarFacts
from tinyrace.config import CarConfig, EnvConfig
from tinyrace.config.schema import track_types_in
from tinyrace.errors import ConfigError, Problem, one_of
from tinyrace.tracks.base import Track

CarBuilder = Callable[[pymunk.Space, Pose, CarConfig, Track], Car]
CARRACING_UNIT = "u"  # CarRacing's world unit: its car needs no scale there


@dataclass(frozen=True)
class CarModel:
    """One registered car model."""

    name: str
    track_units: frozenset[str]  # the track units it drives in: u (CarRacing's), px, m
    default_for: frozenset[str]  # track units where ``car.model: null`` means this model
    action_kinds: frozenset[str]  # accepted ``car.actions`` values
    build: CarBuilder  # adds the car to a space at a pose
    actions: Callable[[CarConfig], ActionSpec]  # its action space and how to read actions
    facts: Callable[[EnvConfig], CarFacts]  # its size and limits for a (resolved) config
    # (``describe`` adds ``wheels`` and ``throttle``)
    wheels: bool  # models its four wheels (wheel speeds and slip; tiles give grip)
    throttle: bool  # its speed follows the actions (False: a constant speed)
    units: str  # the unit of its own parameters: "track" (the track's px, m or u) or "m"
    doc: str
    # the tyre forces of ``n`` such cars as one computation (a vector env's), if it offers it
    batch: Callable[[int], TyreBatch] | None = None

    def describe(self, config: EnvConfig) -> CarFacts:
        """Its facts for ``config``: size and limits, with what it can do."""
        facts = self.facts(config)
        return dataclasses.replace(facts, wheels=self.wheels, throttle=self.throttle)


def _known(value: float | None) -> float:
    """A car knob whose null default ``resolve_defaults`` has filled by track kind."""
    assert value is not None, "car knobs are resolved when the config is loaded"
    return value


def _build_dynamic(space: pymunk.Space, pose: Pose, config: CarConfig, track: Track) -> Car:
    if track.unit == CARRACING_UNIT:  # CarRacing's own frame and units
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
    return ActionSpec.box((-1.0, -1.0), (1.0, 1.0), "steer_throttle")


def _dynamic_actions(config: CarConfig) -> ActionSpec:
    if config.actions == "discrete":
        return ActionSpec.discrete()
    return ActionSpec.box((-1.0, 0.0, 0.0), (1.0, 1.0, 1.0), "pedals")


def _kinematic_actions(config: CarConfig) -> ActionSpec:
    return ActionSpec.box((-1.0,), (1.0,), "steer")


def _dynamic_scale(config: EnvConfig) -> float:
    """[track units per CarRacing unit] of the dynamic car on this config's track."""
    return 1.0 if config.facts.unit == CARRACING_UNIT else _known(config.car.pixels_per_unit)


def _dynamic_facts(config: EnvConfig) -> CarFacts:
    scale = _dynamic_scale(config)
    fps = config.sim.fps or 50.0
    spec = DynamicCarSpec()
    length = (WHEEL_POSITIONS[0][1] - WHEEL_POSITIONS[2][1]) * SIZE * scale
    width = (WHEEL_POSITIONS[1][0] - WHEEL_POSITIONS[0][0]) * SIZE * scale
    # a steer action s asks for s rad, which the servo stops at its lock
    top = spec.max_translation * scale * fps
    return CarFacts(length, width, top, 2 * math.pi * fps, spec.steer_limit, 1.0)


def _kinematic_facts(config: EnvConfig) -> CarFacts:
    car = config.car
    lock = math.radians(car.max_steering_angle)
    speed, wheelbase = _known(car.velocity), _known(car.wheelbase)
    yaw_rate = speed * math.tan(lock) / wheelbase
    return CarFacts(wheelbase, _known(car.track_width), speed, yaw_rate, lock, 1.0 / lock)


def single_track_parameters(car: CarConfig) -> single_track_model.VehicleParameters:
    """The preset of ``car.preset`` with the config's overrides."""
    params = single_track_model.PRESETS[car.preset]
    if car.kinematic_below is not None:
        params = dataclasses.replace(params, kinematic_below=car.kinematic_below)
    return params


def _single_track_actions(config: CarConfig) -> ActionSpec:
    p = single_track_parameters(config)
    if config.actions == "raw":  # [steering velocity rad/s, acceleration m/s^2]
        limits = ((p.steer_rate_min, -p.a_max), (p.steer_rate_max, p.a_max))
        return ActionSpec.box(*limits, "rate_accel")
    return ActionSpec.box((p.steer_min, p.v_min), (p.steer_max, p.v_max), "angle_speed")


def _single_track_facts(config: EnvConfig) -> CarFacts:
    p = single_track_parameters(config.car)
    lock = max(-p.steer_min, p.steer_max)
    top = max(p.v_max, -p.v_min)
    grip = p.mu * single_track_model.G
    # the action's angle turns left (toward growing headings on the y-up metre tracks);
    # F1TENTH's gym scans from its car's rear axle (lidar_dist 0 m ahead by default)
    mount = "rear_axle" if config.car.preset == "f1tenth" else "front_axle"
    yaw_rate = top * math.tan(lock) / p.wheelbase
    return CarFacts(p.wheelbase, p.width, top, yaw_rate, lock, -1.0, grip, lidar_mount=mount)


def _build_single_track(space: pymunk.Space, pose: Pose, config: CarConfig, track: Track) -> Car:
    params = single_track_parameters(config)
    return SingleTrackCar.build(space, pose, params, config.actions == "raw", config.substeps)


CAR_MODELS: dict[str, CarModel] = {}


def register(model: CarModel) -> None:
    """Add ``model`` to the registry (a new name, or a replacement of the same name)."""
    CAR_MODELS[model.name] = model


register(
    CarModel(
        name="dynamic",
        track_units=frozenset({"u", "px", "m"}),
        default_for=frozenset({"u"}),
        action_kinds=frozenset({"continuous", "discrete"}),
        build=_build_dynamic,
        actions=_dynamic_actions,
        facts=_dynamic_facts,
        wheels=True,
        throttle=True,
        units="track",
        doc="CarRacing-v3's rear-wheel-drive car with tyre slip",
        batch=DynamicBatch,
    )
)
register(
    CarModel(
        name="kinematic",
        track_units=frozenset({"px"}),
        default_for=frozenset({"px"}),
        action_kinds=frozenset({"continuous"}),
        build=_build_kinematic,
        actions=_kinematic_actions,
        facts=_kinematic_facts,
        wheels=False,
        throttle=False,
        units="track",
        doc="tinycarlo's constant-speed kinematic bicycle",
    )
)
register(
    CarModel(
        name="kinematic_throttle",
        track_units=frozenset({"m"}),
        default_for=frozenset({"m"}),
        action_kinds=frozenset({"continuous"}),
        build=_build_kinematic_throttle,
        actions=_kinematic_throttle_actions,
        facts=_kinematic_facts,
        wheels=False,
        throttle=True,
        units="track",
        doc="a kinematic bicycle with throttle in metres (tinycarlo 2's car): [steer, throttle]",
    )
)
register(
    CarModel(
        name="single_track",
        track_units=frozenset({"m"}),  # its parameters are in metres
        default_for=frozenset(),
        action_kinds=frozenset({"continuous", "raw"}),
        build=_build_single_track,
        actions=_single_track_actions,
        facts=_single_track_facts,
        wheels=False,
        throttle=True,
        units="m",
        doc="CommonRoad's single-track dynamic car (F1TENTH's): [steering angle, speed] or raw "
        "[steering velocity, acceleration]; car.preset f1tenth or CommonRoad's vehicle1..3",
    )
)


def model_of(config: EnvConfig) -> CarModel:
    """The registry entry of a config's car (``car.model``, or the track kind's default)."""
    return choose_car_model(config, "<config>")


def car_model_problems(config: EnvConfig, source: str) -> list[Problem]:
    """Every problem of the config's car choice: unknown model, track unit, actions."""
    unit = config.facts.unit
    name = config.car.model or _default_name(unit)
    if name is None:
        allowed = f"expected a car model for tracks in {unit!r}; models: {_listing()}"
        return [Problem(source, "car.model", config.car.model, allowed)]
    model = CAR_MODELS.get(name)
    if model is None:
        return [Problem(source, "car.model", name, one_of(name, CAR_MODELS))]
    problems = []
    if unit not in model.track_units:
        allowed = (
            f"car model {name!r} drives on {', '.join(track_types_in(model.track_units))} "
            f"tracks, not {config.kind!r}; models: {_listing()}"
        )
        problems.append(Problem(source, "car.model", name, allowed))
    if config.car.actions not in model.action_kinds:
        allowed = f"car model {name!r} takes car.actions: {', '.join(sorted(model.action_kinds))}"
        problems.append(Problem(source, "car.actions", config.car.actions, allowed))
    return problems


def choose_car_model(config: EnvConfig, source: str) -> CarModel:
    """The car model of a config (its ``car.model`` or the default for the track's unit).

    Raises ConfigError naming the file, ``car.model``, the value and the supported units.
    """
    problems = car_model_problems(config, source)
    if problems:
        raise ConfigError(problems)
    name = config.car.model or _default_name(config.facts.unit)
    assert name is not None  # car_model_problems found none
    return CAR_MODELS[name]


def _default_name(unit: str) -> str | None:
    return next((m.name for m in CAR_MODELS.values() if unit in m.default_for), None)


def _listing() -> str:
    return "; ".join(
        f"{m.name} ({', '.join(track_types_in(m.track_units))})" for m in CAR_MODELS.values()
    )
