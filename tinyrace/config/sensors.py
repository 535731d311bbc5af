"""The ``sensors:`` entries: one dataclass per sensor type, told apart by ``type``.

Lengths are in the track's unit (u on the procedural track, px on picture tracks, m on
metric ones). A null length means "scaled to the car": so many car lengths (rear to front
axle), which fits every track unit. The car frame is x ahead, y to the left, z up; angles
are positive to the left (counter-clockwise seen from above).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal, Protocol

from tinyrace.config import families
from tinyrace.config.bounds import MAX_INTRINSIC, PERSPECTIVE_PIXEL_WEIGHT
from tinyrace.config.calibration import Found, calibration_problems
from tinyrace.config.colors import Color
from tinyrace.config.knobs import REQUIRED, knob

CameraFormat = Literal["rgb", "gray", "classes"]
LENGTH = "track units"
_ID = "observation key of this sensor"
_FORMAT = (
    "rgb: (H, W, 3) uint8; gray: (H, W) uint8; classes: (H, W) uint8 labels of the track's "
    "layers, 255 the sky (never blended; the table {label: name} is in info['sensor_labels'])"
)


def _type(name: str) -> Any:
    return knob(name, "sensor type")


class SensorDefaults:
    """What a sensor entry says of itself (``SensorConfig``), as a sensor of one array that
    draws no camera pixels says it: a sensor config subclasses this and overrides what
    differs."""

    @property
    def dict_observation(self) -> bool:
        """Whether its observation is a Dict of arrays (then ``observation: box`` cannot be
        it), not one array."""
        return False

    def problems(self) -> list[Found]:
        """(key, value, allowed) of each inconsistency between its own knobs."""
        return []

    def camera_pixels(self) -> tuple[tuple[int, int], int] | None:
        """Its image's [y, x] size and the weight of each pixel against
        ``MAX_CAMERA_PIXELS`` (None: no camera pixels to count)."""
        return None


@dataclass(frozen=True)
class PerspectiveCameraConfig(SensorDefaults):
    """``sensors[i]`` of ``type: perspective_camera``: a pinhole camera on the car."""

    id: str = knob(REQUIRED, _ID)
    type: Literal["perspective_camera"] = _type("perspective_camera")
    resolution: tuple[int, int] = knob(
        (120, 160), "[y, x] output image size", "px", low=1, high=4096
    )
    position: tuple[float, float, float] | None = knob(
        None,
        "[x, y, z] from the front axle's middle: ahead, left, up (null: [0, 0, 0.4] car lengths)",
        LENGTH,
    )
    yaw: float = knob(0.0, "turn from straight ahead, + left", "deg", low=-360, high=360)
    pitch: float = knob(20.0, "tilt toward the ground, + down", "deg", low=-89, high=89)
    roll: float = knob(
        0.0,
        "turn about the optical axis, + clockwise as the camera sees",
        "deg",
        low=-180,
        high=180,
    )
    fov: float | None = knob(
        None,
        "horizontal field of view, the principal point at the image centre (null: 90 unless "
        "intrinsics or camera_info are given)",
        "deg",
        low=1,
        high=170,
    )
    intrinsics: tuple[float, float, float, float] | None = knob(
        None,
        "[fx, fy, cx, cy] focal lengths and principal point, pixel centres on integer "
        "coordinates (OpenCV's camera matrix); instead of fov",
        "px",
        magnitude=MAX_INTRINSIC,
    )
    distortion: tuple[float, float, float, float, float] | None = knob(
        None,
        "plumb_bob distortion of the intrinsics: [k1, k2, p1, p2, k3] (OpenCV's order; null: none)",
    )
    camera_info: str | None = knob(
        None,
        "a ROS camera_info YAML (camera_calibration's: image_width, image_height, "
        "camera_matrix, distortion_model plumb_bob, distortion_coefficients), relative to the "
        "config's folder; instead of fov and intrinsics (its camera matrix is scaled to "
        "resolution)",
    )
    max_range: float | None = knob(
        None,
        "ground farther than this (from the camera's foot) is sky (null: no limit)",
        LENGTH,
        low=0,
        low_open=True,
    )
    format: CameraFormat = knob("rgb", _FORMAT)
    sky_color: Color = knob(
        Color.rgb(135, 206, 235), "colour above the horizon and beyond max_range"
    )

    def problems(self) -> list[Found]:
        """Its calibration knobs' inconsistencies, and a camera below the ground."""
        found = self.calibration_problems()
        if self.position and not self.position[2] > 0:
            allowed = "expected a camera above the ground: position [x, y, z] with z > 0"
            found.append(("position", list(self.position), allowed))
        return found

    def calibration_problems(self) -> list[Found]:
        """(key, value, allowed) of each inconsistency of its calibration knobs."""
        return calibration_problems(self)

    def camera_pixels(self) -> tuple[tuple[int, int], int] | None:
        """Each pixel counts PERSPECTIVE_PIXEL_WEIGHT times: it keeps a ray and its ground
        point."""
        return self.resolution, PERSPECTIVE_PIXEL_WEIGHT


@dataclass(frozen=True)
class LidarConfig(SensorDefaults):
    """``sensors[i]`` of ``type: lidar``: a planar scanner; float32 ranges, rightmost beam first."""

    id: str = knob(REQUIRED, _ID)
    type: Literal["lidar"] = _type("lidar")
    beams: int = knob(1080, "number of beams", low=1, high=20000)
    fov: float = knob(270.0, "field of view, centred ahead", "deg", low=1, high=360)
    max_range: float | None = knob(
        None,
        "range of a beam that hits nothing (null: 10 car lengths; 30 m on ROS maps, as F1TENTH's)",
        LENGTH,
        low=0,
        low_open=True,
    )
    position: tuple[float, float] = knob(
        (0.0, 0.0), "[x, y] from the point that mount names: ahead, left", LENGTH
    )
    mount: Literal["front_axle", "rear_axle", "pose"] | None = knob(
        None,
        "the point position is measured from: the middle of the front or the rear axle, or the "
        "car's pose (its reference point: the single-track car's centre of gravity) (null: the "
        "car model's: the front axle, or the pose on single_track's f1tenth preset and under "
        "car.compat, as f1tenth_gym scans from its car's pose plus lidar_dist, 0 m by "
        "default; a lidar 0.275 m ahead of the rear axle: mount: rear_axle, position: [0.275, 0])",
    )
    range_std: float = knob(0.0, "std of Gaussian range noise", LENGTH, low=0)
    dropout: float = knob(0.0, "chance that a beam returns max_range", low=0, high=1)
    blocks: tuple[Literal["off_road", "walls", "obstacles", "cones"], ...] | None = knob(
        None,
        "what stops a beam: off_road (beyond the road surfaces), walls, obstacles (colour "
        "obstacles of picture tracks), cones (null: walls and cones on ROS maps, where "
        "beams cross the map's pixels exactly and stop at the first occupied one; all four "
        "elsewhere)",
    )
    hit_classes: bool = knob(
        False,
        "also report what each beam hit: a Dict of ranges and classes (uint8: 0 nothing, "
        "1 wall, off-road or obstacle, 1 + k a cone of class k: 1 blue, 2 yellow, 3 orange, "
        "4 big orange, 5 unknown)",
    )
    cell: float | None = knob(
        None,
        "cell size of the blocking map built once per track (null: 1/8 car length; picture "
        "pixels pool into cells, so that small cones and obstacles stay)",
        LENGTH,
        low=0,
        low_open=True,
    )

    @property
    def dict_observation(self) -> bool:
        """With ``hit_classes``: a Dict of ranges and classes."""
        return self.hit_classes


@dataclass(frozen=True)
class StateConfig(SensorDefaults):
    """``sensors[i]`` of ``type: state``: the car's motion in its own frame, float32."""

    id: str = knob(REQUIRED, _ID)
    type: Literal["state"] = _type("state")
    pose: bool = knob(
        False,
        "append x, y [track units] (bounded by the playfield on procedural tracks, unbounded "
        "elsewhere) and heading [rad]",
    )


@dataclass(frozen=True)
class LookaheadConfig(SensorDefaults):
    """``sensors[i]`` of ``type: lookahead``: next points of the reference line, car frame."""

    id: str = knob(REQUIRED, _ID)
    type: Literal["lookahead"] = _type("lookahead")
    points: int = knob(10, "how many points (K)", low=1, high=1000)
    spacing: float | None = knob(
        None,
        "distance between points along the line (null: 1 car length)",
        LENGTH,
        low=0,
        low_open=True,
    )


@dataclass(frozen=True)
class ConesConfig(SensorDefaults):
    """``sensors[i]`` of ``type: cones``: cones in range, car frame, nearest first."""

    id: str = knob(REQUIRED, _ID)
    type: Literal["cones"] = _type("cones")
    max_cones: int = knob(32, "rows of the padded array", low=1, high=4096)
    max_range: float | None = knob(
        None, "farthest cone reported (null: 10 car lengths)", LENGTH, low=0, low_open=True
    )
    fov: float = knob(180.0, "field of view, centred ahead", "deg", low=1, high=360)
    position_std: float = knob(0.0, "std of Gaussian noise on x and y", LENGTH, low=0)
    miss_probability: float = knob(0.0, "chance that a visible cone is not reported", low=0, high=1)
    false_positives: float = knob(
        0.0, "mean count of made-up cones per observation", low=0, high=1000
    )
    blue_color: Color | None = knob(
        Color.rgb(0, 0, 255), "picture tracks: colour of blue cones", binary=True
    )
    yellow_color: Color | None = knob(
        Color.rgb(255, 255, 0), "picture tracks: colour of yellow cones", binary=True
    )
    orange_color: Color | None = knob(
        None, "picture tracks: colour of orange cones (null: none)", binary=True
    )

    @property
    def dict_observation(self) -> bool:
        """A Dict of the cones' rows and their count."""
        return True


@dataclass(frozen=True)
class CameraConfig(SensorDefaults):
    """``cameras[i]`` (or ``sensors[i]`` of ``type: birdseye_camera``): a bird's-eye camera
    fixed to the car."""

    id: str = knob(REQUIRED, "observation key of this camera")
    type: Literal["birdseye_camera"] = _type("birdseye_camera")
    resolution: tuple[int, int] = knob(
        (480, 640), "[y, x] output image size", "px", low=1, high=4096
    )
    roi: tuple[float, float] = knob(
        (480.0, 640.0),
        "[y, x] size of the track window seen (ahead of the front axle)",
        "track px (u on procedural tracks)",
        low=1,
    )
    position: tuple[float, float] = knob(
        (0.0, 0.0),
        "[y, x] shift of the window from the front axle middle; +y ahead, +x right",
        "track px (u on procedural tracks)",
    )
    yaw: float = knob(
        0.0, "camera rotation from straight ahead; 90 right, 180 back", "deg", low=-360, high=360
    )
    format: Literal["rgb", "gray", "classes"] = knob(
        "rgb",
        "rgb: (H, W, 3) uint8; gray: (H, W) uint8; classes: (H, W) uint8 labels of the "
        "track's layers, never blended (table in info['sensor_labels'])",
    )


@dataclass(frozen=True)
class ChaseViewConfig(SensorDefaults):
    """``sensors[i]`` of ``type: chase_view``: CarRacing's view (procedural tracks), uint8 RGB.

    The camera follows the car and turns with it (the car near the bottom, nose up), zooms
    in during the first second, and the dashboard (speed, ABS, steering, gyro, score) is
    drawn along the bottom. The default observation of a procedural track.
    """

    id: str = knob(REQUIRED, _ID)
    type: Literal["chase_view"] = _type("chase_view")
    resolution: tuple[int, int] = knob(
        (96, 96), "[y, x] output image size (CarRacing's: 96 x 96)", "px", low=1, high=160
    )


@dataclass(frozen=True)
class TopViewConfig(SensorDefaults):
    """``sensors[i]`` of ``type: top_view``: the road ahead from above with the car drawn in,
    uint8 RGB (tracks in metres; their default observation)."""

    id: str = knob(REQUIRED, _ID)
    type: Literal["top_view"] = _type("top_view")
    resolution: tuple[int, int] = knob((96, 96), "[y, x] output image size", "px", low=1, high=4096)
    span: float = knob(
        14.0,
        "side of the square window seen; a quarter of it behind the car",
        "wheelbases",
        low=0,
        low_open=True,
    )


@dataclass(frozen=True)
class OpponentsConfig(SensorDefaults):
    """``sensors[i]`` of ``type: opponents``: the nearest other cars of a race, car frame,
    nearest first; float32 rows (present, x, y, vx, vy, heading), zeros past the last car."""

    id: str = knob(REQUIRED, _ID)
    type: Literal["opponents"] = _type("opponents")
    count: int = knob(
        3, "rows: how many of the nearest other cars are reported (K)", low=1, high=15
    )
    max_range: float | None = knob(
        None,
        "cars farther than this (the middle of their footprint from the front axle's middle) "
        "are not reported (null: 10 car lengths)",
        LENGTH,
        low=0,
        low_open=True,
    )


class SensorConfig(Protocol):
    """A ``sensors:`` entry: the dataclass its ``type`` names (the family of sensor configs:
    a sensor type's registry entry adds its config, see ``tinyrace.sensors.registry``), and
    what the config checks ask of it (``SensorDefaults`` gives a sensor of one array's)."""

    @property
    def id(self) -> str: ...

    @property
    def type(self) -> str: ...

    @property
    def dict_observation(self) -> bool:
        """Whether its observation is a Dict of arrays, not one array."""
        ...

    def problems(self) -> list[Found]:
        """(key, value, allowed) of each inconsistency between its own knobs."""
        ...

    def camera_pixels(self) -> tuple[tuple[int, int], int] | None:
        """Its image's [y, x] size and each pixel's weight against ``MAX_CAMERA_PIXELS``."""
        ...


for _config in (
    PerspectiveCameraConfig,
    LidarConfig,
    StateConfig,
    LookaheadConfig,
    ConesConfig,
    OpponentsConfig,
    CameraConfig,
    ChaseViewConfig,
    TopViewConfig,
):
    families.add(SensorConfig, _config)


def sensor_configs() -> dict[str, type]:
    """Every sensor type's config class by type name (built-in and registered)."""
    return families.members(SensorConfig) or {}


def cameras_first(
    cameras: tuple[CameraConfig, ...], sensors: tuple[SensorConfig, ...]
) -> tuple[SensorConfig, ...]:
    """tinycarlo's ``cameras:`` as ``birdseye_camera`` sensors, first in the ``sensors``
    list (in their order; once: a list that starts with them already is kept)."""
    if sensors[: len(cameras)] == cameras:
        return sensors
    return (*cameras, *sensors)
