"""One learner against driven opponents: a single-agent env whose other cars have drivers.

``gym.make("tinyrace/TinyRace-v0", environment=..., opponents=[{"driver": "centerline",
"speed": 0.8}, ...])`` makes the track's env with one more car per opponent on the start
grid (``race`` knobs; a ``race.num_agents`` keyword must count the learner and the
opponents). Car 0 is the learner's: its observation, reward and end are the
env's as without opponents. Before every step each opponent's driver reads its car's
pose and speed and sets its controls; an opponent whose episode ends leaves the race as a
``RaceEnv``'s car does (after its last lap taken off the track, else parked where it
stands). ``info`` adds the learner's ``position`` in the race, the ``cars_hit`` this
step, its ``lap_times`` and ``best_lap`` [s].

An opponent's ``driver`` is a registered driver name (``centerline``; ``speed`` scales
its speed profile) or any object with ``controls(pose, speed) -> (steer, gas, brake)``
and, optionally, ``follow(route, action_space, dt)`` (called at every reset).
"""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium as gym

from tinyrace.cars import CARRACING_WHEELBASE
from tinyrace.drivers import DRIVERS, ActionAdapter, CenterlineDriver
from tinyrace.drivers.base import CONTROLS_EXPECTED, checked_controls
from tinyrace.drivers.centerline import Route, route_of
from tinyrace.env import TinyRaceEnv
from tinyrace.errors import ConfigError, Problem
from tinyrace.race.checks import race_with_cars
from tinyrace.race.env import race_info

SOURCE = "<kwargs>"
OPPONENT_KEYS = ("driver", "speed")
RACING_DRIVERS = ("centerline",)  # registered drivers that drive from a car's pose and speed


def make_env(*, opponents: Sequence[Any] | None = None, **kwargs: Any) -> gym.Env[Any, Any]:
    """``tinyrace/TinyRace-v0``'s entry point: a ``TinyRaceEnv``; with ``opponents``, one
    with a car per opponent, each driven by its driver (see the module's docstring)."""
    if opponents is None:
        return TinyRaceEnv(**kwargs)
    drivers = opponent_drivers(opponents)
    asked_by = f"opponents (the learner's car and {len(drivers)} more)"
    race = race_with_cars(kwargs.pop("race", None), 1 + len(drivers), asked_by)
    return Opponents(TinyRaceEnv(race=race, **kwargs), drivers)


# gym.make reads the entry point's render modes: with them it turns "rgb_array_list" (and
# every "<mode>_list") into the mode and a RenderCollection wrapper, as for CarRacing-v0's class
make_env.metadata = TinyRaceEnv.metadata  # type: ignore[attr-defined]


def opponent_drivers(opponents: object) -> list[Any]:
    """One driver per opponent spec; a ConfigError names every bad spec (``opponents[i]``)."""
    if isinstance(opponents, (str, bytes)) or not isinstance(opponents, Sequence):
        allowed = "expected a list of opponents, each {driver: <name or object>, speed: 0..2}"
        raise ConfigError(Problem(SOURCE, "opponents", opponents, allowed))
    drivers, problems = [], []
    for i, spec in enumerate(opponents):
        try:
            drivers.append(_driver(spec))
        except ValueError as exc:
            key = getattr(exc, "key", None)  # the entry's key at fault, if one is
            at, value = (f"opponents[{i}].{key}", spec[key]) if key else (f"opponents[{i}]", spec)
            problems.append(Problem(SOURCE, at, _short(value), str(exc)))
    if len(opponents) > 15:
        problems.append(
            Problem(SOURCE, "opponents", len(opponents), "at most 15 opponents (16 cars)")
        )
    if problems:
        raise ConfigError(problems)
    return drivers


class _BadKey(ValueError):
    """A problem of one key of an opponent's entry."""

    def __init__(self, key: str, message: str) -> None:
        super().__init__(message)
        self.key = key


def _driver(spec: object) -> Any:
    if not isinstance(spec, Mapping):
        raise ValueError("expected a mapping {driver: <name or object>, speed: <factor>}")
    unknown = [key for key in spec if key not in OPPONENT_KEYS]
    if unknown:
        raise ValueError(f"unknown keys {unknown}; known: {', '.join(OPPONENT_KEYS)}")
    driver, speed = spec.get("driver", "centerline"), spec.get("speed", 1.0)
    if isinstance(speed, bool) or not isinstance(speed, (int, float)) or not 0 < speed <= 2:
        raise _BadKey("speed", "expected a number in (0, 2]: the factor of the line's speeds")
    if isinstance(driver, str):
        if driver not in RACING_DRIVERS:
            other = " (it cannot drive a car of a race)" if driver in DRIVERS else ""
            known = ", ".join(RACING_DRIVERS)
            raise _BadKey("driver", f"unknown opponent driver {driver!r}{other}; drivers: {known}")
        return _scaled_centerline(float(speed))
    if not callable(getattr(driver, "controls", None)):
        raise _BadKey("driver", "a driver object needs a method controls(pose, speed) -> controls")
    return driver


def _scaled_centerline(factor: float) -> CenterlineDriver:
    """The centreline driver with its speed profile scaled by ``factor``."""
    base = CenterlineDriver()
    return CenterlineDriver(
        top_speed=base.top_speed * factor,
        lateral_accel=base.lateral_accel * factor**2,  # speeds in curves scale by factor
        brake_accel=base.brake_accel * factor**2,
    )


class Opponents(gym.Wrapper[Any, Any, Any, Any]):
    """Drives cars 1.. of the env's world with their drivers before each learner step."""

    def __init__(self, env: TinyRaceEnv, drivers: list[Any]):
        super().__init__(env)
        self.core = env
        self.drivers = drivers
        racers = env.course.racers
        self.names = [racer.id for racer in racers]
        self.specs = [racer.model.actions(racer.car.car) for racer in racers]  # per car
        self.adapt = [ActionAdapter(spec.space, env.dt, spec.kind) for spec in self.specs]

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        observation, info = self.env.reset(**kwargs)
        route = None
        for i, driver in enumerate(self.drivers, start=1):
            if hasattr(driver, "follow"):
                route = route or route_of(self.core)
                spec = self.specs[i]
                follow(
                    driver, i - 1, (self._route_for(route, i), spec.space, self.core.dt), spec.kind
                )
        return observation, self._race_info(info)

    def step(self, action: Any) -> tuple[Any, Any, bool, bool, dict[str, Any]]:
        core = self.core
        world = core.world
        cars = core.snapshot().cars
        for i, driver in enumerate(self.drivers, start=1):
            if i not in world.parked:
                world.control(self.specs[i].read(self._action(i, driver, cars[i])), car=i)
        core.control(action)
        episode = core.episode
        assert episode is not None
        judged = episode.step()
        observation, reward, terminated, truncated, info = core.conclude(judged)
        for i, car in enumerate(judged[1:], start=1):
            if car is not None and car.reason is not None:
                episode.leave(i, car.reason)
        return observation, reward, terminated, truncated, self._race_info(info)

    def _route_for(self, route: Route, car: int) -> Route:
        """``route`` (car 0's) for car ``car``: scaled by its wheelbase, with its steering
        and grip (a race may mix car models)."""
        core = self.core
        racer = core.course.racers[car]
        if racer.model is core.course.racers[0].model and racer.car.car == core.config.car:
            return route
        facts = racer.model.describe(core.car_config(car))
        length = core.snapshot().cars[car].footprint[0]
        return dataclasses.replace(
            route,
            unit=length / CARRACING_WHEELBASE,
            steer_lock=facts.steer_lock,
            steer_per_rad=facts.steer_per_rad,
            grip=facts.grip,
        )

    def _action(self, index: int, driver: Any, car: Any) -> Any:
        """The action a driver takes for car ``index`` (``car``: its CarState): a registered
        driver's own ``act`` (it knows the car model's actions), else its controls adapted."""
        if isinstance(driver, CenterlineDriver):
            return driver.act(None, {"pose": car.pose, "speed": car.speed})
        value = driver.controls(car.pose, car.speed)
        try:
            controls = checked_controls(value, f"opponents[{index - 1}]")
        except ValueError:
            path = f"opponents[{index - 1}].driver.controls"
            allowed = f"car {self.names[index]!r}: controls(pose, speed) {CONTROLS_EXPECTED}"
            raise ConfigError(Problem(SOURCE, path, value, allowed)) from None
        return self.adapt[index](controls)

    def _race_info(self, info: dict[str, Any]) -> dict[str, Any]:
        episode = self.core.episode
        assert episode is not None
        info.update(race_info(episode, 0, self.names, self.core.dt))
        return info


def follow(driver: Any, index: int, args: tuple[Route, Any, float], kind: str | None) -> None:
    """Call an opponent driver's ``follow(route, action_space, dt)``, with the action kind as
    a fourth argument only when it takes one (the racing page's three-argument example, or
    tinyrace's drivers); a signature that takes neither is a ConfigError."""
    method = driver.follow
    try:
        signature = inspect.signature(method)
    except (TypeError, ValueError):  # a builtin without one: call as documented
        method(*args)
        return
    for call in ((*args, kind), args):
        try:
            signature.bind(*call)
        except TypeError:
            continue
        method(*call)
        return
    allowed = f"expected a method follow(route, action_space, dt), got follow{signature}"
    raise ConfigError(Problem(SOURCE, f"opponents[{index}].driver.follow", _short(driver), allowed))


def _short(value: object) -> object:
    """``value`` as a message shows it: a number or a short name itself, else its repr, cut."""
    if isinstance(value, (int, float)) or (isinstance(value, str) and len(value) <= 60):
        return value
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
