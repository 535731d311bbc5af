"""The sensor types by name (the ``type`` of a ``sensors:`` entry).

Adding a type is one module plus one ``register`` call (see ``tinyrace/sensors/base.py``):
its config class then parses as a ``sensors:`` entry too.
"""

from __future__ import annotations

from tinyrace.config import CameraConfig, families
from tinyrace.config.sensors import SensorConfig
from tinyrace.errors import ConfigError, Problem, one_of
from tinyrace.sensors import birdseye_camera
from tinyrace.sensors.base import Sensor, SensorContext, SensorType
from tinyrace.sensors.machinery.common import Unsupported

SENSOR_TYPES: dict[str, SensorType] = {}


def register(sensor_type: SensorType) -> SensorType:
    """Add a type to the registry (the built-in types are added below); its config class
    joins the ``sensors:`` entries the loader parses (its ``type`` field names it)."""
    if families.type_of(sensor_type.config) != sensor_type.name:
        named = families.type_of(sensor_type.config)
        raise ValueError(f"sensor type {sensor_type.name!r}: its config's type is {named!r}")
    SENSOR_TYPES[sensor_type.name] = sensor_type
    families.add(SensorConfig, sensor_type.config)
    return sensor_type


def unregister(name: str) -> None:
    """Take sensor type ``name`` away again (a test's toy, when the test ends)."""
    SENSOR_TYPES.pop(name, None)
    families.remove(SensorConfig, name)


def sensor_type(name: object, source: str, key_path: str) -> SensorType:
    """The registered type ``name``; a ConfigError listing the valid names otherwise."""
    found = SENSOR_TYPES.get(name) if isinstance(name, str) else None
    if found is None:
        allowed = one_of(name, SENSOR_TYPES, "a sensor type, one of")
        raise ConfigError(Problem(source, key_path, name, allowed))
    return found


register(
    SensorType(
        name="birdseye_camera",
        config=CameraConfig,
        build=birdseye_camera.build,
        doc="a top-down camera fixed to the car (tinycarlo's cameras: list)",
    )
)


def _register_built_in() -> None:
    from tinyrace.config import sensors as configs
    from tinyrace.sensors import (
        chase_view,
        cones,
        lidar,
        lookahead,
        opponents,
        perspective_camera,
        state,
        top_view,
    )

    for name, config, module, needs, doc in (
        (
            "perspective_camera",
            configs.PerspectiveCameraConfig,
            perspective_camera,
            None,
            "a pinhole camera on the car: the ground by one perspective warp, sky above",
        ),
        ("lidar", configs.LidarConfig, lidar, None, "planar ranges by ray marching a distance map"),
        ("state", configs.StateConfig, state, None, "speeds, yaw rate, steering, wheels, pose"),
        (
            "lookahead",
            configs.LookaheadConfig,
            lookahead,
            None,
            "the next points of the reference line, with curvature",
        ),
        (
            "cones",
            configs.ConesConfig,
            cones,
            "cones",
            "cones in range by class, padded",
        ),
        (
            "opponents",
            configs.OpponentsConfig,
            opponents,
            None,
            "the nearest other cars of a race: position, relative velocity, heading, padded",
        ),
    ):
        register(SensorType(name, config, module.build, needs, doc))
    register(
        SensorType(
            "chase_view",
            configs.ChaseViewConfig,
            chase_view.build,
            "painted ground",  # CarRacing's tiles and kerbs, painted per track
            "CarRacing's 96x96 view: the car from behind and above, its dashboard below",
            default=True,
        )
    )
    register(
        SensorType(
            "top_view",
            configs.TopViewConfig,
            top_view.build,
            "metric ground",  # a ground in metres, drawn from the track
            "the road ahead from above with the car drawn in",
            default=True,
        )
    )


_register_built_in()


def default_sensor(context: SensorContext) -> Sensor | None:
    """The observation of an env with no sensor configured: the first default type whose
    needs its track holds (chase_view on a painted ground, top_view on a ground in metres),
    under its type's name; None where the track is seen through cameras only
    (``TrackFacts.default_view``)."""
    facts = context.env.facts
    if not facts.default_view:
        return None
    for name, found in SENSOR_TYPES.items():
        if found.default and (found.needs is None or found.needs in facts.holds):
            return found.build(found.config(id=name), context)
    return None


def build_sensors(context: SensorContext, source: str) -> list[Sensor]:
    """The sensors of the env config's ``sensors:`` list (tinycarlo's ``cameras:`` first), in
    order; a ConfigError lists every entry that cannot work with this config (its type, what
    its track holds, or its knobs), by the key the user wrote."""
    config = context.env
    built, problems = [], []
    for i, entry in enumerate(config.sensors):
        key = config.sensor_key(i)  # as written: cameras[i] or sensors[j]
        kind = sensor_type(entry.type, source, f"{key}.type")
        if kind.needs is not None and kind.needs not in config.facts.holds:
            allowed = (
                f"a {entry.type} sensor needs a track that holds {kind.needs}, "
                f"not a {config.kind} track"
            )
            problems.append(Problem(source, f"{key}.type", entry.type, allowed))
            continue
        try:
            built.append(kind.build(entry, context))
        except Unsupported as exc:
            problems.append(Problem(source, key, entry.type, str(exc)))
    if problems:
        raise ConfigError(problems)
    return built
