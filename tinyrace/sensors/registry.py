"""The sensor types by name (the ``type`` of a ``sensors:`` entry).

Adding a type is one module plus one entry here (see ``tinyrace/sensors/base.py``).
"""

from __future__ import annotations

from tinyrace.config import EnvConfig
from tinyrace.errors import ConfigError, Problem
from tinyrace.sensors.base import Sensor, SensorType
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
        allowed = f"expected a sensor type, one of: {', '.join(sorted(SENSOR_TYPES))}"
        raise ConfigError(Problem(source, key_path, name, allowed))
    return found


def _register_built_in() -> None:
    from tinyrace.config import sensors as configs
    from tinyrace.sensors import cones, lidar, lookahead, perspective_camera, state

    every = None
    for name, config, module, kinds, doc in (
        (
            "perspective_camera",
            configs.PerspectiveCameraConfig,
            perspective_camera,
            every,
            "a pinhole camera on the car: the ground by one perspective warp, sky above",
        ),
        (
            "lidar",
            configs.LidarConfig,
            lidar,
            every,
            "planar ranges by ray marching a distance map",
        ),
        ("state", configs.StateConfig, state, every, "speeds, yaw rate, steering, wheels, pose"),
        (
            "lookahead",
            configs.LookaheadConfig,
            lookahead,
            every,
            "the next points of the reference line, with curvature",
        ),
        ("cones", configs.ConesConfig, cones, frozenset({"image"}), "cones in range, padded"),
    ):
        register(SensorType(name, config, module.build, kinds, doc))


_register_built_in()


def build_sensors(config: EnvConfig, source: str) -> list[Sensor]:
    """The sensors of ``config.sensors``, in order; a ConfigError lists every entry that
    cannot work with this config (its type, its track kind, or its knobs)."""
    built, problems = [], []
    for i, entry in enumerate(config.sensors):
        kind = sensor_type(entry.type, source, f"sensors[{i}].type")
        if kind.track_kinds is not None and config.kind not in kind.track_kinds:
            allowed = (
                f"a {entry.type} sensor works on track kinds: {', '.join(sorted(kind.track_kinds))}"
            )
            problems.append(Problem(source, f"sensors[{i}].type", entry.type, allowed))
            continue
        try:
            built.append(kind.build(entry, config))
        except Unsupported as exc:
            problems.append(Problem(source, f"sensors[{i}]", entry.type, str(exc)))
    if problems:
        raise ConfigError(problems)
    return built
