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
from tinyrace.cars.f1tenth_gym import NAME as F1TENTH_GYM
from tinyrace.cars.kinematic import KinematicCar
from tinyrace.cars.kinematic_throttle import KinematicThrottleCar
from tinyrace.cars.single_track import SingleTrackCar
from tinyrace.cars.state import CarFacts
from tinyrace.config import CarConfig, EnvConfig, car_models
from tinyrace.config.car_models import CarModelEntry
from tinyrace.config.schema import F1TENTH_GYM_RATE, track_types_in
from tinyrace.errors import ConfigError, Problem, one_of
from tinyrace.tracks.base import Track

CarBuilder = Callable[[pymunk.Space, Pose, CarConfig, Track], Car]
CARRACING_UNIT = "u"  # CarRacing's world unit: its car needs no scale there
# Where a positive steering action turns, by the track's unit, whatever the car model:
# right on CarRacing's tracks (u) and on image tracks (px), as CarRacing and tinycarlo; left
# on tracks in metres (m), as ROS (REP 103: y left, angles counter-clockwise), F1TENTH and
# CommonRoad, whose single-track car is the metre tracks' own (docs/conventions.md).
POSITIVE_STEER_TURNS = {"u": "right", "px": "right", "m": "left"}


def steer_turns_left(unit: str, actions: str = "continuous") -> bool:
    """Whether a positive steering action turns left on tracks in ``unit`` (CarRacing's
    Discrete(5) names its turns: its ``right`` turns right everywhere)."""
    return POSITIVE_STEER_TURNS.get(unit) == "left" and actions != "discrete"


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
    compat: frozenset[str] = frozenset()  # accepted ``car.compat`` values (another sim's car)
    # the ``car`` knobs it reads besides ``model`` and ``actions`` (None: every one); one it
    # does not read is refused when a config sets it (``config.checks``), never ignored
    reads: frozenset[str] | None = None
    size_keys: tuple[str, ...] = ("car.wheelbase", "car.track_width")  # what sizes it
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
    left = steer_turns_left(track.unit, config.actions)
    if track.unit == CARRACING_UNIT:  # CarRacing's own frame and units
        return DynamicCar.build(space, pose, steer_left=left)
    scale = _known(config.pixels_per_unit)
    return DynamicCar.build(space, pose, scale=scale, y_down=track.y_down, steer_left=left)


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
        steer_left=steer_turns_left(track.unit),
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
    per_rad = -1.0 if steer_turns_left(config.facts.unit, config.car.actions) else 1.0
    return CarFacts(length, width, top, 2 * math.pi * fps, spec.steer_limit, per_rad)


def _kinematic_facts(config: EnvConfig) -> CarFacts:
    car = config.car
    lock = math.radians(car.max_steering_angle)
    speed, wheelbase = _known(car.velocity), _known(car.wheelbase)
    yaw_rate = speed * math.tan(lock) / wheelbase
    per_rad = (-1.0 if steer_turns_left(config.facts.unit) else 1.0) / lock
    return CarFacts(wheelbase, _known(car.track_width), speed, yaw_rate, lock, per_rad)


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
    # f1tenth_gym scans from its car's pose (lidar_dist 0 m ahead of it by default)
    f1tenth = config.car.preset == "f1tenth" or config.car.compat is not None
    mount = "pose" if f1tenth else "front_axle"
    yaw_rate = top * math.tan(lock) / p.wheelbase
    return CarFacts(p.wheelbase, p.width, top, yaw_rate, lock, -1.0, grip, lidar_mount=mount)


def _build_single_track(space: pymunk.Space, pose: Pose, config: CarConfig, track: Track) -> Car:
    params = single_track_parameters(config)
    raw = config.actions == "raw"
    return SingleTrackCar.build(space, pose, params, raw, config.substeps, config.compat)


CAR_MODELS: dict[str, CarModel] = {}
KINEMATIC_KNOBS = frozenset(
    {"wheelbase", "track_width", "velocity", "max_steering_angle", "max_steering_change"}
)


def register(model: CarModel) -> None:
    """Add ``model`` to the registry (a new name, or a replacement of the same name); the
    config layer lists it then (``car.model``'s values in the YAML reference)."""
    CAR_MODELS[model.name] = model
    units = tuple(sorted(model.track_units))
    default_for = tuple(sorted(model.default_for))
    car_models.add(CarModelEntry(model.name, units, model.doc, default_for, model.reads))


def unregister(name: str) -> None:
    """Take car model ``name`` away again (a test's toy, when the test ends)."""
    CAR_MODELS.pop(name, None)
    car_models.remove(name)


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
        size_keys=("car.pixels_per_unit",),
        batch=DynamicBatch,
        reads=frozenset({"pixels_per_unit"}),
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
        reads=KINEMATIC_KNOBS,
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
        reads=KINEMATIC_KNOBS | {"max_acceleration", "max_deceleration"},
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
        "[steering velocity, acceleration]; car.preset f1tenth or CommonRoad's vehicle1..3; "
        "car.compat f1tenth_gym: f1tenth_gym's car step by step",
        compat=frozenset({F1TENTH_GYM}),
        size_keys=("car.preset",),
        reads=frozenset({"preset", "substeps", "kinematic_below", "compat"}),
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
    return problems + _compat_problems(config, model, source)


def _compat_problems(config: EnvConfig, model: CarModel, source: str) -> list[Problem]:
    """What ``car.compat`` needs: a model that has it, and that sim's actions and rate."""
    car, compat = config.car, config.car.compat
    if compat is None:
        return []
    if compat not in model.compat:
        names = [m.name for m in CAR_MODELS.values() if compat in m.compat]
        allowed = f"car.compat {compat} is a car of model {', '.join(names)}, not {model.name!r}"
        return [Problem(source, "car.compat", compat, allowed)]
    problems = []
    if car.actions != "continuous":
        allowed = f"continuous (f1tenth_gym's [steering angle, speed]) under car.compat {compat}"
        problems.append(Problem(source, "car.actions", car.actions, allowed))
    if config.sim.fps not in (None, F1TENTH_GYM_RATE):
        allowed = f"{F1TENTH_GYM_RATE:g} (f1tenth_gym's 0.01 s step) or null under car.compat"
        problems.append(Problem(source, "sim.fps", config.sim.fps, allowed))
    if car.substeps not in (None, 1):
        allowed = "null or 1 under car.compat (f1tenth_gym integrates one RK4 step per step)"
        problems.append(Problem(source, "car.substeps", car.substeps, allowed))
    if car.kinematic_below is not None:
        allowed = "null under car.compat (f1tenth_gym switches models at 0.5 m/s)"
        problems.append(Problem(source, "car.kinematic_below", car.kinematic_below, allowed))
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
