"""The ``tracks:`` entries: one config dataclass per track type, each a ``TrackFacts``.

A track config class states the facts of its tracks as class attributes (unit, car-size
defaults, which of CarRacing's rule defaults apply, what its tracks hold), so that code
above the tracks asks the config, never its ``type``. The classes form the open family
``TrackFacts`` (``config/families.py``): a track source adds its own when it registers.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Literal

from tinyrace.config import families
from tinyrace.config.bounds import MAX_TEXTURE_SIDE
from tinyrace.config.colors import Color
from tinyrace.config.knobs import REQUIRED, knob

if TYPE_CHECKING:
    from tinyrace.config.schema import FilesConfig, RewardConfig


# Car sizes and speeds when the config leaves them null: tinycarlo 1.1's in pixels, a small
# racing car's in metres, and on ROS maps (F1TENTH's maps) F1TENTH's car: wheelbase
# lf + lr = 0.33 m, width 0.31 m (f1tenth_gym's parameters), the shipped f1tenth_loop's top
# speed, CarRacing's car scaled to about that wheelbase (3.24 u).
# wheelbase, track_width [px or m], velocity [px/s or m/s], pixels_per_unit [px/u or m/u]
PIXEL_CAR = {"wheelbase": 160.0, "track_width": 100.0, "velocity": 500.0, "pixels_per_unit": 20.0}
METRE_CAR = {"wheelbase": 2.5, "track_width": 1.6, "velocity": 20.0, "pixels_per_unit": 1.0}
F1TENTH_CAR = {"wheelbase": 0.33, "track_width": 0.31, "velocity": 5.0, "pixels_per_unit": 0.1}

Problems = list[tuple[str, object, str]]  # (key below the track, value, what is allowed)


class TrackFacts:
    """What a track config class says about its tracks, for the code above the tracks: each
    ``*TrackConfig`` sets these, so nothing needs to compare its ``type``."""

    type: str  # the entry's ``type`` (each member's dataclass field)
    unit: ClassVar[str]  # its tracks' unit: "u" (CarRacing), "px" or "m"
    y_down: ClassVar[bool] = False  # x right, y down, headings clockwise (pictures)
    carracing_rules: ClassVar[bool] = True  # tiles, laps, time penalty: 50 fps, CarRacing's pay
    car_sizes: ClassVar[Mapping[str, float]] = PIXEL_CAR  # the defaults of the null car knobs
    colour_picture: ClassVar[bool] = False  # a picture whose colours mean things (obstacles)
    default_view: ClassVar[bool] = True  # seen without cameras: by the default sensor, 96x96
    # what its tracks may hold, e.g. "cones", and their ground: "painted ground" (tiles and
    # kerbs painted per track: chase_view), "metric ground" (drawn in metres: top_view)
    holds: ClassVar[frozenset[str]] = frozenset()
    occupancy_map: ClassVar[bool] = False  # a map of occupied cells (F1TENTH's lidar on it)
    start_key: ClassVar[str] = "spawns"  # the key the start pose comes from, when not spawn
    # where the start pose comes from when no spawn is given, and how to move it (messages)
    start_advice: ClassVar[str] = "move the start pose (track.spawns)"

    def problems(self, files: FilesConfig) -> Problems:
        """What is wrong in this section that its fields alone cannot say."""
        return []

    def pose_extent(self) -> float | None:
        """[track units] the largest |x| and |y| of the car before its episode ends, when
        known from the config alone."""
        return None

    def reference_problem(self, reward: RewardConfig) -> str | None:
        """What the track needs for a reference line (None: it has one)."""
        return None


@dataclass(frozen=True)
class ProceduralTrackConfig(TrackFacts):
    """A ``track`` of ``type: procedural``: CarRacing-v3's generated track."""

    unit = "u"
    holds = frozenset({"painted ground"})

    type: Literal["procedural"] = knob("procedural", "track kind")
    checkpoints: int = knob(12, "number of checkpoints the track passes", low=3, high=64)
    radius: float = knob(900 / 6, "mean checkpoint radius (TRACK_RAD)", "u", low=10, high=2000)
    half_width: float = knob(40 / 6, "half the road width (TRACK_WIDTH)", "u", low=1, high=100)
    turn_rate: float = knob(0.31, "max heading change per detail step", "rad", low=0.01, high=3)
    detail_step: float = knob(21 / 6, "distance between track points", "u", low=0.5, high=50)
    border: float = knob(8 / 6, "kerb width on hard turns", "u", low=0, high=20)
    border_min_count: int = knob(4, "turning points in a row that make a kerb", low=1, high=50)
    playfield: float = knob(
        2000 / 6, "|x| or |y| of the car beyond this ends the episode", "u", low=10, high=10000
    )
    lap_complete_percent: float = knob(
        0.95, "fraction of tiles visited before returning to tile 0 ends a lap", low=0, high=1
    )
    domain_randomize: bool = knob(False, "draw new road/background/grass colours per reset")
    road_color: Color = knob(Color.rgb(102, 102, 102), "road colour (list BGR, #rrggbb RGB)")
    background_color: Color = knob(Color.rgb(102, 204, 102), "background colour")
    grass_color: Color = knob(Color.rgb(102, 230, 102), "grass patch colour")
    pixels_per_unit: float = knob(
        2.0,
        "resolution of the pre-drawn ground texture the cameras sample",
        "px/u",
        low=0.25,
        high=16,
    )

    def problems(self, files: FilesConfig) -> Problems:
        side = 2 * self.playfield * self.pixels_per_unit  # [px] the playfield, pre-drawn
        if side <= MAX_TEXTURE_SIDE:
            return []
        allowed = (
            f"expected 2 * playfield * pixels_per_unit (the ground texture's side, here "
            f"{side:.0f} px) <= {MAX_TEXTURE_SIDE} px: lower pixels_per_unit or playfield"
        )
        return [("pixels_per_unit", self.pixels_per_unit, allowed)]

    def pose_extent(self) -> float | None:
        return self.playfield


Spawn = tuple[float, float, float]


@dataclass(frozen=True)
class ImageTrackConfig(TrackFacts):
    """A ``track`` of ``type: image`` (the default for tinycarlo files): a picture of the track."""

    unit = "px"
    y_down = True
    carracing_rules = False
    colour_picture = True
    default_view = False
    holds = frozenset({"cones"})  # blobs of the cone colours

    type: Literal["image"] = knob("image", "track kind")
    image: str | None = knob(
        None, "image path relative to track.yaml (PNG/JPEG); null: an empty black plane"
    )
    spawns: tuple[Spawn, ...] = knob(
        ((500.0, 500.0, 0.0),),
        "start poses [x, y, heading]; heading 0 along +x, clockwise",
        "px, px, rad",
    )
    plane_size: tuple[int, int] = knob(
        (1000, 1000),
        "[height, width] of the black plane used when image is null",
        "px",
        low=16,
        high=20000,
    )
    pixels_per_meter: float | None = knob(
        None,
        "the image's scale, when known: the track's metres per pixel is its inverse "
        "(null: unknown, everything stays in pixels as in tinycarlo 1.1)",
        "px/m",
        low=0,
        low_open=True,
    )

    def problems(self, files: FilesConfig) -> Problems:
        found: Problems = []
        if not self.spawns:
            found.append(("spawns", [], "expected at least one start pose"))
        height, width = self.plane_size
        if self.image is None and height * width > files.max_image_pixels:
            allowed = (
                f"expected at most {files.max_image_pixels:,} px in all (files.max_image_pixels)"
            )
            found.append(("plane_size", [height, width], allowed))
        return found

    def reference_problem(self, reward: RewardConfig) -> str | None:
        if reward.cross_track_error.use_cte:
            return None
        return (
            "expected reward_design.cross_track_error.use_cte: true (with its "
            "trajectory_color) on an image track"
        )


def _lap_percent() -> Any:
    return knob(
        0.95, "fraction of tiles visited before returning to tile 0 ends a lap", low=0, high=1
    )


def _ground_resolution() -> Any:
    return knob(
        8.0,
        "pixels per metre of the pre-drawn ground texture (lowered to fit 8192 px a side)",
        "px/m",
        low=0.25,
        high=200,
    )


class MetreTrackFacts(TrackFacts):
    """Tracks in metres read from files (the start pose is a file's first point)."""

    unit = "m"
    car_sizes = METRE_CAR
    start_key = "file"
    start_advice = (
        "the start pose is the file's first point, facing along the road: start the file "
        "at another row"
    )
    holds = frozenset({"metric ground"})


@dataclass(frozen=True, kw_only=True)
class CenterlineTrackConfig(MetreTrackFacts):
    """A ``track`` of ``type: centerline``: a racetrack-database centreline CSV, in metres.

    Rows ``x_m,y_m,w_tr_right_m,w_tr_left_m`` of one closed loop in driving order."""

    type: Literal["centerline"] = knob("centerline", "track kind")
    file: str = knob(REQUIRED, "the CSV, relative to the config's folder")
    spacing: float = knob(2.0, "resample the centreline (and tiles) this far apart", "m", low=0.05)
    scale: float = knob(1.0, "multiply every coordinate and width by this", low=1e-6)
    default_width: float = knob(
        10.0, "road width when the file gives only x, y", "m", low=0, low_open=True
    )
    lap_complete_percent: float = _lap_percent()
    margin: float = knob(
        50.0, "leaving the road's bounding box by more than this ends the episode", "m", low=0
    )
    pixels_per_meter: float = _ground_resolution()


@dataclass(frozen=True, kw_only=True)
class ConeMapTrackConfig(MetreTrackFacts):
    """A ``track`` of ``type: cone_map``: a Formula Student Driverless cone map CSV, in metres.

    Rows ``tag,x,y,direction,x_variance,y_variance,covariance``; blue left, yellow right;
    a ``car_start`` row (EUFS's tracks) places the car: x, y, direction."""

    holds = frozenset({"cones", "metric ground"})
    start_advice = (
        "the start pose is the file's car_start row if it has one, else the centreline point "
        "nearest the middle of the big_orange cones (of the orange cones when there are "
        "none; with neither, beside the file's first blue cone), facing along the road: "
        "move the car_start row or those cones"
    )

    type: Literal["cone_map"] = knob("cone_map", "track kind")
    file: str = knob(REQUIRED, "the CSV, relative to the config's folder")
    spacing: float = knob(0.5, "distance between centreline points (and tiles)", "m", low=0.05)
    scale: float = knob(1.0, "multiply every coordinate by this", low=1e-6)
    max_cone_gap: float = knob(
        6.0, "cones of one edge further apart than this do not close a loop", "m", low=0.1
    )
    cone_hit_ends_episode: bool = knob(False, "knocking a cone over ends the episode")
    lap_complete_percent: float = _lap_percent()
    margin: float = knob(
        10.0, "leaving the cones' bounding box by more than this ends the episode", "m", low=0
    )
    pixels_per_meter: float = knob(
        20.0,
        "pixels per metre of the pre-drawn ground texture (lowered to fit 8192 px a side)",
        "px/m",
        low=0.25,
        high=200,
    )


@dataclass(frozen=True, kw_only=True)
class RosMapTrackConfig(MetreTrackFacts):
    """A ``track`` of ``type: ros_map``: a ROS map_server map with a raceline, in metres.

    The map YAML and its picture (F1TENTH's maps), and optionally a waypoint CSV."""

    car_sizes = F1TENTH_CAR
    occupancy_map = True
    start_key = "waypoints"
    start_advice = (
        "the start pose is the waypoints' first point, facing along them: give track.spawn "
        "[x, y, heading] or start the waypoints at another row"
    )

    type: Literal["ros_map"] = knob("ros_map", "track kind")
    file: str = knob(REQUIRED, "the map YAML, relative to the config's folder")
    waypoints: str | None = knob(
        None,
        "reference line CSV (x, y; or F1TENTH's s; x; y; psi; kappa; vx; ax), relative to the "
        "config's folder; null: no tiles, laps, cte or look-ahead",
    )
    spawn: tuple[float, float, float] | None = knob(
        None, "start pose [x, y, heading] (null: the first waypoint)", "m, m, rad"
    )
    spacing: float = knob(0.25, "resample the waypoints (and tiles) this far apart", "m", low=0.01)
    wall_hit_ends_episode: bool = knob(False, "touching an occupied cell ends the episode")
    lap_complete_percent: float = _lap_percent()

    def reference_problem(self, reward: RewardConfig) -> str | None:
        return None if self.waypoints is not None else "expected track.waypoints on a ros_map track"


# The family of track configs (``tracks:`` entries, told apart by ``type``): a track source
# adds its own (``tinyrace.tracks.registry.register``). An entry without ``type`` is an
# image track (tinycarlo files have none): added first.
TrackConfig = TrackFacts
for _config in (
    ImageTrackConfig,
    ProceduralTrackConfig,
    CenterlineTrackConfig,
    ConeMapTrackConfig,
    RosMapTrackConfig,
):
    families.add(TrackFacts, _config)


def track_configs() -> dict[str, type]:
    """Every track type's config class by type name (built-in and registered)."""
    return families.members(TrackFacts) or {}


def track_types_in(units: Iterable[str]) -> list[str]:
    """The track types (``type:`` values) whose tracks are in one of ``units``, sorted."""
    wanted = set(units)
    return sorted(name for name, c in track_configs().items() if getattr(c, "unit", None) in wanted)
