"""Rules that span sections of a parsed config (tracks of one type, the cameras a track
needs, ``observation: box``, pixels, the race, obstacle colours); each problem is
reported on the parser, with the key path it names."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

from tinyrace.cache import folder_problems
from tinyrace.config.bounds import MAX_CAMERA_PIXELS, PERSPECTIVE_PIXEL_WEIGHT
from tinyrace.config.car_models import CarModelEntry, car_models, default_model
from tinyrace.config.loader import Parser
from tinyrace.config.race import race_cars, race_pixel_problems, race_problems
from tinyrace.config.schema import MAX_RACE_CARS, CarConfig, EnvConfig, RewardConfig

# the car knobs a model may or may not read, with their defaults (a knob left at its default
# was not set); ``model`` and ``actions`` every model reads (checked by the car registry)
CAR_KNOB_DEFAULTS = {
    f.name: f.default for f in dataclasses.fields(CarConfig) if f.name not in ("model", "actions")
}


def check_consistency(
    config: EnvConfig, parser: Parser, at: str, given: Mapping[int, set[str]] | None = None
) -> None:
    """Rules that span sections; ``at`` prefixes key paths; ``given``: the car keys each
    ``race.cars`` entry wrote itself (``lay_cars_over_car``), when known."""
    kinds = {t.type for t in config.tracks}
    if len(kinds) > 1:
        parser.problem(f"{at}tracks", sorted(kinds), "all tracks of one env must be of one type")
    if not config.tracks:
        parser.problem(f"{at}tracks", [], "expected at least one track")
    facts = config.facts if config.tracks else None
    seen = facts is None or facts.default_view  # a view without cameras (96x96)
    if not seen and not config.cameras and not config.sensors:
        allowed = (
            f"an {config.kind} track needs at least one camera (id, resolution, roi, position)"
        )
        parser.problem(f"{at}cameras", [], allowed)
    _check_observation(config, parser, at, f"{at}observation")
    # the car model and its actions are checked by tinyrace.cars.registry; its knobs here,
    # before the track kind's defaults fill them
    _check_car_knobs(config, parser, at, given)
    picture = facts is not None and facts.colour_picture
    if not picture and config.reward_design.color_obstacles:
        obstacles = [repr(o.color) for o in config.reward_design.color_obstacles]
        allowed = "colour obstacles need an image track"
        parser.problem(f"{at}reward_design.color_obstacles", obstacles, allowed)
    _check_obstacle_colors(config.reward_design, parser, at)
    for i, track in enumerate(config.tracks):
        for key, value, allowed in track.problems(config.files):
            parser.problem(f"{at}tracks[{i}].{key}", value, allowed)
    _check_race(config, parser, at, not seen)
    if config.cache.dir is not None:
        parser.problems += folder_problems(config.cache.dir, parser.source, f"{at}cache.dir")


def _check_observation(config: EnvConfig, parser: Parser, at: str, observation_at: str) -> None:
    """One car's cameras and sensors: unique ids, ``observation: box``, pixels, intrinsics."""
    _check_box(config, parser, observation_at)
    ids = [c.id for c in config.cameras] + [sensor.id for sensor in config.sensors]
    cameras = len(config.cameras)
    for i, cam_id in enumerate(ids):
        if cam_id in ids[:i]:
            where = f"cameras[{i}].id" if i < cameras else f"sensors[{i - cameras}].id"
            parser.problem(f"{at}{where}", cam_id, "camera and sensor ids must be unique")
    _check_camera_pixels(config, parser, at)
    for i, sensor in enumerate(config.sensors):
        for key, value, allowed in sensor.problems():
            parser.problem(f"{at}sensors[{i}].{key}", value, allowed)


def _check_race(config: EnvConfig, parser: Parser, at: str, needs_camera: bool) -> None:
    """The race as a whole (count, ids, poses), and each car's own cameras and sensors."""
    cars = config.race.cars
    if len(cars) > MAX_RACE_CARS:
        allowed = f"expected at most {MAX_RACE_CARS} cars (one world holds {MAX_RACE_CARS})"
        parser.problem(f"{at}race.cars", f"{len(cars)} cars", allowed)
        return
    # a pose that did not parse is named already: the poses left are not the ones given
    unparsed = any(p.path.startswith(f"{at}race.poses[") for p in parser.problems)
    parser.problems += [
        p
        for p in race_problems(config, at, parser.source)
        if not (unparsed and p.path == f"{at}race.poses")
    ]
    parser.problems += race_pixel_problems(config, at, parser.source)
    for i, entry in enumerate(cars):
        if entry.cameras is None and entry.sensors is None:
            continue  # the shared ones, checked above
        car = race_cars(config)[i]
        own = dataclasses.replace(config, cameras=car.cameras, sensors=car.written_sensors)
        car_at = f"{at}race.cars[{i}]."
        if needs_camera and not own.cameras and not own.sensors:
            allowed = f"car {car.id!r} on an {config.kind} track needs at least one camera"
            parser.problem(f"{car_at}cameras", [], allowed)
        _check_observation(own, parser, car_at, f"{car_at}sensors")


def _check_car_knobs(
    config: EnvConfig, parser: Parser, at: str, given: Mapping[int, set[str]] | None
) -> None:
    """A ``car`` knob that its car model does not read is refused, never ignored: set in the
    car section, some car of the env must read it; set in a ``race.cars`` entry (``given``,
    else each value other than the car section's), its car."""
    if not config.tracks:
        return
    unit = config.facts.unit
    models = car_models()
    top, entries = config.car, config.race.cars
    cars = [entry.car for entry in entries] or [top]
    chosen = [models.get(c.model) if c.model is not None else default_model(unit) for c in cars]
    found = [m for m in chosen if m is not None]
    if len(found) < len(chosen):
        return  # an unknown model: the car registry names it
    for name, default in CAR_KNOB_DEFAULTS.items():
        value = getattr(top, name)
        if value != default and not any(_reads(m, name) for m in found):
            parser.problem(f"{at}car.{name}", value, _unread(name, found))
        for i, (entry, model) in enumerate(zip(entries, found[: len(entries)], strict=True)):
            own = getattr(entry.car, name)  # the car section's value where it gave none
            written = name in given.get(i, set()) if given is not None else own != value
            if own != default and written and not _reads(model, name):
                parser.problem(f"{at}race.cars[{i}].car.{name}", own, _unread(name, [model]))


def _reads(model: CarModelEntry, knob: str) -> bool:
    return model.reads is None or knob in model.reads


def _unread(knob: str, models: list[CarModelEntry]) -> str:
    """Why ``knob`` is refused: which knobs the models read instead."""
    described = []
    for model in dict.fromkeys(models):  # each model once, in the cars' order
        reads = ", ".join(sorted(model.reads or ())) or "no other knob"
        described.append(f"car model {model.name!r} reads {reads}")
    readers = [m.name for m in car_models().values() if m.reads is not None and knob in m.reads]
    other = f", or choose a car model that reads it ({', '.join(readers)})" if readers else ""
    return f"no car of this env reads car.{knob} ({'; '.join(described)}): leave it out{other}"


def _check_box(config: EnvConfig, parser: Parser, where: str) -> None:
    """``observation: box`` is one camera's image: exactly one camera or image sensor (a
    problem names ``where``)."""
    if config.observation != "box":
        return
    ids = [c.id for c in config.cameras] + [s.id for s in config.sensors]
    allowed = ""
    if len(ids) > 1:
        allowed = f"box needs exactly one camera or sensor, not {ids} (use dict)"
    elif config.sensors and config.sensors[0].dict_observation:
        allowed = (
            f"box needs a camera or a sensor of one array, not a {config.sensors[0].type} "
            "sensor whose observation is a Dict (cones; lidar with hit_classes): use dict"
        )
    if allowed:
        parser.problem(where, "box", allowed)


def _check_obstacle_colors(reward: RewardConfig, parser: Parser, at: str) -> None:
    """An obstacle in the trajectory's colour could never be hit: its pixels are taken out."""
    cte = reward.cross_track_error
    for i, obstacle in enumerate(reward.color_obstacles):
        if cte.use_cte and obstacle.color == cte.trajectory_color:
            allowed = (
                "expected a colour other than cross_track_error.trajectory_color (trajectory "
                "pixels are taken out of the picture, so this obstacle could never be hit)"
            )
            parser.problem(f"{at}reward_design.color_obstacles[{i}].color", obstacle.color, allowed)


def _check_camera_pixels(config: EnvConfig, parser: Parser, at: str) -> None:
    """Every camera's pixels together: the ``cameras`` and the ``sensors`` that count camera
    pixels (a perspective camera's count PERSPECTIVE_PIXEL_WEIGHT times: each keeps a ray
    and its ground point)."""
    sizes = [(f"cameras[{i}]", c.resolution, 1) for i, c in enumerate(config.cameras)]
    for i, sensor in enumerate(config.sensors):
        pixels = sensor.camera_pixels()
        if pixels is not None:
            sizes.append((f"sensors[{i}]", *pixels))
    total = sum(height * width * weight for _, (height, width), weight in sizes)  # [px]
    if total > MAX_CAMERA_PIXELS:
        allowed = (
            f"expected cameras of at most {MAX_CAMERA_PIXELS:,} px together, a perspective_camera "
            f"pixel counted {PERSPECTIVE_PIXEL_WEIGHT} times (here {total:,})"
        )
        where = "cameras" if not config.sensors else "sensors"
        parser.problem(f"{at}{where}", {k: list(r) for k, r, _ in sizes}, allowed)
