"""The sensor types by name (the ``type`` of a ``sensors:`` entry).

Adding a type is one module plus one entry here (see ``tinyrace/sensors/base.py``).
"""

from __future__ import annotations

from tinyrace.config import CameraConfig
from tinyrace.errors import ConfigError, Problem, one_of
from tinyrace.sensors import birdseye_camera
from tinyrace.sensors.base import Sensor, SensorContext, SensorType
from tinyrace.sensors.common import Unsupported

SENSOR_TYPES: dict[str, SensorType] = {}


def register(sensor_type: SensorType) -> SensorType:
    """Add a type to the registry (the built-in types are added below)."""
    SENSOR_TYPES[sensor_type.name] = sensor_type
    return sensor_type


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
    from tinyrace.sensors import cones, lidar, lookahead, opponents, perspective_camera, state

    for name, config, module, kinds, doc in (
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
            frozenset({"image", "cone_map"}),
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
        register(SensorType(name, config, module.build, kinds, doc))


_register_built_in()


def build_sensors(context: SensorContext, source: str) -> list[Sensor]:
    """The sensors of the env config's ``sensors:`` list, in order; a ConfigError lists every
    entry that cannot work with this config (its type, its track kind, or its knobs)."""
    config = context.env
    built, problems = [], []
    for i, entry in enumerate(config.sensors):
        kind = sensor_type(entry.type, source, f"sensors[{i}].type")
        if kind.track_kinds is not None and config.kind not in kind.track_kinds:
            kinds = ", ".join(sorted(kind.track_kinds))
            allowed = f"a {entry.type} sensor works on track kinds: {kinds}"
            problems.append(Problem(source, f"sensors[{i}].type", entry.type, allowed))
            continue
        try:
            built.append(kind.build(entry, context))
        except Unsupported as exc:
            problems.append(Problem(source, f"sensors[{i}]", entry.type, str(exc)))
    if problems:
        raise ConfigError(problems)
    return built
