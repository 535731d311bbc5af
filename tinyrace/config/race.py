"""The cars of a race as the config gives them: ``race.cars`` entries, or ``race.num_agents``
cars of the shared sections, each with its id, car model, colour, cameras and sensors.

A ``race.cars`` entry's ``car`` keys are laid over the top-level ``car`` section before
parsing (``lay_cars_over_car``), so that every car's knobs are one ``CarConfig``; a bad
value the entry inherited is reported once, at the top-level key (``inherited``).
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from tinyrace.config.bounds import MAX_CAMERA_PIXELS, PERSPECTIVE_PIXEL_WEIGHT, id_problem
from tinyrace.config.colors import Color, palette_color
from tinyrace.config.loader import deep_merge
from tinyrace.config.schema import MAX_RACE_CARS, CameraConfig, CarConfig, EnvConfig
from tinyrace.config.sensors import SensorConfig, cameras_first
from tinyrace.errors import Problem

CAR_KNOBS = ("wheelbase", "track_width", "velocity", "pixels_per_unit")  # null: by track kind


@dataclass(frozen=True)
class RaceCar:
    """One car of a race, every key resolved: its own, else the shared sections'."""

    index: int
    id: str  # its PettingZoo agent name
    car: CarConfig
    colour: Color
    cameras: tuple[CameraConfig, ...]
    sensors: tuple[SensorConfig, ...]  # its cameras first, as the loader lists the shared ones
    own_car: bool  # its car comes from a ``race.cars`` entry (problems name that entry)

    @property
    def written_sensors(self) -> tuple[SensorConfig, ...]:
        """Its ``sensors:`` entries as written (its own, or the shared ones): no cameras."""
        return self.sensors[len(self.cameras) :]


def default_id(index: int) -> str:
    """The name of car ``index`` when the config gives none."""
    return f"car_{index}"


def race_cars(config: EnvConfig) -> list[RaceCar]:
    """Every car of ``config``'s race, in order (car 0 first, the pole of the grid)."""
    race = config.race
    entries = race.cars or (None,) * race.num_agents
    shared = cameras_first(config.cameras, config.sensors)  # the loader's list, once resolved
    cars = []
    for index, entry in enumerate(entries):
        if entry is None:
            cars.append(
                RaceCar(
                    index,
                    default_id(index),
                    config.car,
                    palette_color(index),
                    config.cameras,
                    shared,
                    False,
                )
            )
            continue
        cameras = entry.cameras if entry.cameras is not None else config.cameras
        sensors = entry.sensors if entry.sensors is not None else config.written_sensors
        cars.append(
            RaceCar(
                index,
                entry.id if entry.id is not None else default_id(index),
                entry.car,
                entry.colour if entry.colour is not None else palette_color(index),
                cameras,
                cameras_first(cameras, sensors),  # its cameras are sensors too
                True,
            )
        )
    return cars


def lay_cars_over_car(raw: Mapping[str, Any]) -> tuple[dict[str, Any], dict[int, set[str]]]:
    """``raw`` with each ``race.cars`` entry's ``car`` laid over the top-level ``car`` (and
    ``race.num_agents`` the number of entries when left out); the keys each entry gave."""
    race, top = raw.get("race"), raw.get("car", {})
    if not isinstance(race, Mapping) or not isinstance(race.get("cars"), (list, Mapping)):
        return dict(raw), {}
    top = top if isinstance(top, Mapping) else {}
    cars = race["cars"]
    given: dict[int, set[str]] = {}
    entries = []
    for index, entry in enumerate([cars] if isinstance(cars, Mapping) else cars):
        own = entry.get("car", {}) if isinstance(entry, Mapping) else None
        if isinstance(own, Mapping):
            given[index] = set(own)
            entry = {**entry, "car": deep_merge(top, own)}
        entries.append(entry)
    race = {**race, "cars": entries}
    if "num_agents" not in race and 0 < len(entries) <= MAX_RACE_CARS:
        race["num_agents"] = len(entries)
    return {**raw, "race": race}, given


def inherited(problems: list[Problem], given: dict[int, set[str]], at: str) -> list[Problem]:
    """``problems`` without those of a ``race.cars[i].car`` key the entry did not give: the
    top-level ``car`` key it inherited reports them."""
    pattern = re.compile(rf"^{re.escape(at)}race\.cars\[(\d+)\]\.car\.([^.\[]+)")
    kept = []
    for problem in problems:
        match = pattern.match(problem.path)
        if match and match.group(2) not in given.get(int(match.group(1)), set()):
            continue
        kept.append(problem)
    return kept


def resolve_race_cars(config: EnvConfig) -> EnvConfig:
    """Each ``race.cars`` entry's null car knobs as the resolved top-level car's (the track
    kind's defaults, or the values the car section gives)."""
    race = config.race
    if not race.cars:
        return config
    top = config.car
    entries = []
    for entry in race.cars:
        fill = {k: getattr(top, k) for k in CAR_KNOBS if getattr(entry.car, k) is None}
        entries.append(dataclasses.replace(entry, car=dataclasses.replace(entry.car, **fill)))
    return dataclasses.replace(config, race=dataclasses.replace(race, cars=tuple(entries)))


def race_problems(config: EnvConfig, at: str, source: str) -> list[Problem]:
    """Problems of the ``race`` section as a whole: the count, ids, start poses."""
    race = config.race
    problems = []

    def problem(path: str, value: object, allowed: str) -> None:
        problems.append(Problem(source, f"{at}race.{path}", value, allowed))

    if race.cars and len(race.cars) != race.num_agents:
        n = len(race.cars)
        problem("num_agents", race.num_agents, f"expected {n}: race.cars lists {n} cars")
    cars = race_cars(config)
    seen: dict[str, int] = {}
    for car in cars:
        wrong = id_problem(car.id) if car.own_car else None
        if wrong is not None:
            problem(f"cars[{car.index}].id", car.id, f"{wrong} (it names the car in files)")
        if car.id in seen:
            allowed = f"expected a unique car id; car {seen[car.id]} is called {car.id!r} too"
            problem(f"cars[{car.index}].id", car.id, allowed)
        seen.setdefault(car.id, car.index)
    if race.start == "poses" and len(race.poses) != len(cars):
        missing = [car.id for car in cars[len(race.poses) :]]
        which = f"; no pose for {', '.join(missing)}" if missing else ""
        allowed = f"expected one pose per car ({len(cars)} cars){which}"
        problem("poses", [list(p) for p in race.poses], allowed)
    elif race.start != "poses" and race.poses:
        allowed = f"poses are read with start: poses only (start is {race.start})"
        problem("poses", [list(p) for p in race.poses], allowed)
    return problems


def car_colors(config: EnvConfig) -> list[Color]:
    """Each car's colour, in car order (what cameras, the overview and videos draw): its
    ``race.cars[i].colour``, else the palette's colour of its index."""
    return [car.colour for car in race_cars(config)]


def car_names(config: EnvConfig) -> list[str]:
    """Each car's name, in car order: its agent name in a race (its ``race.cars[i].id``, else
    ``car_<i>``), the label the overview and videos write beside it."""
    return [car.id for car in race_cars(config)]


def car_pixels(car: RaceCar) -> int:
    """[px] the pixels of one car's cameras: each bird's-eye camera's, and each sensor's
    ``camera_pixels()`` by its weight (a perspective camera's count PERSPECTIVE_PIXEL_WEIGHT)."""
    total = sum(h * w for h, w in (camera.resolution for camera in car.cameras))
    for sensor in car.written_sensors:
        pixels = sensor.camera_pixels()
        if pixels is not None:
            (height, width), weight = pixels
            total += height * width * weight
    return total


def race_pixel_problems(config: EnvConfig, at: str, source: str) -> list[Problem]:
    """The cameras of every car of the env together within MAX_CAMERA_PIXELS (each car's own
    are checked with its sensors; this bounds the env, which draws them all)."""
    cars = race_cars(config)
    pixels = {car.id: car_pixels(car) for car in cars}
    total = sum(pixels.values())
    if len(cars) < 2 or total <= MAX_CAMERA_PIXELS or max(pixels.values()) > MAX_CAMERA_PIXELS:
        return []  # one car's own excess is told at its cameras and sensors
    allowed = (
        f"expected the cameras of all {len(cars)} cars of one env to have at most "
        f"{MAX_CAMERA_PIXELS:,} px together, a perspective_camera pixel counted "
        f"{PERSPECTIVE_PIXEL_WEIGHT} times (here {total:,}: fewer cars or smaller cameras)"
    )
    where = "race.cars" if config.race.cars else "race.num_agents"
    return [Problem(source, f"{at}{where}", f"{len(cars)} cars", allowed)]
