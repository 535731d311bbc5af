"""The sensor types by name (the ``type`` of a ``sensors:`` entry).

Adding a type is one module plus one entry here (see ``tinyrace/sensors/base.py``).
"""

from __future__ import annotations

from tinyrace.config import METRIC_KINDS, CameraConfig
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
    from tinyrace.sensors import (
        chase_view,
        cones,
        lidar,
        lookahead,
        perspective_camera,
        state,
        top_view,
    )

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
    ):
        register(SensorType(name, config, module.build, kinds, doc))
    register(
        SensorType(
            "chase_view",
            configs.ChaseViewConfig,
            chase_view.build,
            frozenset({"procedural"}),
            "CarRacing's 96x96 view: the car from behind and above, its dashboard below",
            default=True,
        )
    )
    register(
        SensorType(
            "top_view",
            configs.TopViewConfig,
            top_view.build,
            frozenset(METRIC_KINDS),
            "the road ahead from above with the car drawn in",
            default=True,
        )
    )


_register_built_in()


def default_sensor(context: SensorContext) -> Sensor | None:
    """The observation of an env with no sensor configured: the first default type made for
    its track kind, under its type's name (None if no type is)."""
    kind = context.env.kind
    for name, found in SENSOR_TYPES.items():
        if found.default and found.track_kinds is not None and kind in found.track_kinds:
            return found.build(found.config(id=name), context)
    return None


def build_sensors(context: SensorContext, source: str) -> list[Sensor]:
    """The sensors of the env config's ``sensors:`` list (tinycarlo's ``cameras:`` first), in
    order; a ConfigError lists every entry that cannot work with this config (its type, its
    track kind, or its knobs), by the key the user wrote."""
    config = context.env
    built, problems = [], []
    for i, entry in enumerate(config.sensors):
        key = config.sensor_key(i)  # as written: cameras[i] or sensors[j]
        kind = sensor_type(entry.type, source, f"{key}.type")
        if kind.track_kinds is not None and config.kind not in kind.track_kinds:
            kinds = ", ".join(sorted(kind.track_kinds))
            allowed = f"a {entry.type} sensor works on track kinds: {kinds}"
            problems.append(Problem(source, f"{key}.type", entry.type, allowed))
            continue
        try:
            built.append(kind.build(entry, context))
        except Unsupported as exc:
            problems.append(Problem(source, key, entry.type, str(exc)))
    if problems:
        raise ConfigError(problems)
    return built
