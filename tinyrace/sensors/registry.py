"""The sensor types by name (the ``type`` of a ``sensors:`` entry).

Adding a type is one module plus one entry here (see ``tinyrace/sensors/base.py``).
"""

from __future__ import annotations

from tinyrace.config import CameraConfig, ConeSensorConfig, LidarConfig
from tinyrace.errors import ConfigError, Problem
from tinyrace.sensors import birdseye_camera, cones, lidar
from tinyrace.sensors.base import SensorType

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


register(
    SensorType(
        name="birdseye_camera",
        config=CameraConfig,
        build=birdseye_camera.build,
        doc="a top-down camera fixed to the car (tinycarlo's cameras: list)",
    )
)
register(
    SensorType(
        name="lidar",
        config=LidarConfig,
        build=lidar.build,
        doc="a 2D lidar: ranges to walls and cones, and the class of what each beam hit",
    )
)
register(
    SensorType(
        name="cones",
        config=ConeSensorConfig,
        build=cones.build,
        doc="the nearest cones in the car's frame, by class",
    )
)
