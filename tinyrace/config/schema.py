"""Every configuration section as a dataclass: one schema for YAML files, dicts and kwargs.

Field metadata carries the documentation, the unit and the allowed range; the
loader validates against it and the YAML reference (docs/reference.md) is generated from it.
``None`` defaults mean "the track decides" (see ``resolve_defaults``): each track
config class (``config/tracks.py``) states its facts (``TrackFacts``: unit, default car),
so that code above asks the track config, never its ``type``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from tinyrace.config.bounds import MAX_CAMERA_PIXELS as MAX_CAMERA_PIXELS  # re-exported
from tinyrace.config.colors import Color
from tinyrace.config.image_file import DEFAULT_MAX_IMAGE_PIXELS
from tinyrace.config.knobs import REQUIRED, knob
from tinyrace.config.rules import RuleConfig
from tinyrace.config.sensors import CameraConfig as CameraConfig  # re-exported
from tinyrace.config.sensors import SensorConfig
from tinyrace.config.tracks import (  # re-exported: the schema's sections in one place
    METRE_CAR as METRE_CAR,
)
from tinyrace.config.tracks import (
    PIXEL_CAR as PIXEL_CAR,
)
from tinyrace.config.tracks import (
    CenterlineTrackConfig as CenterlineTrackConfig,
)
from tinyrace.config.tracks import (
    ConeMapTrackConfig as ConeMapTrackConfig,
)
from tinyrace.config.tracks import (
    ImageTrackConfig as ImageTrackConfig,
)
from tinyrace.config.tracks import (
    MetreTrackFacts as MetreTrackFacts,
)
from tinyrace.config.tracks import (
    ProceduralTrackConfig as ProceduralTrackConfig,
)
from tinyrace.config.tracks import (
    RosMapTrackConfig as RosMapTrackConfig,
)
from tinyrace.config.tracks import (
    Spawn as Spawn,
)
from tinyrace.config.tracks import (
    TrackConfig as TrackConfig,
)
from tinyrace.config.tracks import (
    TrackFacts as TrackFacts,
)
from tinyrace.config.tracks import (
    track_configs as track_configs,
)
from tinyrace.config.tracks import (
    track_types_in as track_types_in,
)

F1TENTH_GYM_RATE = 100.0  # [Hz] sim.fps under car.compat: f1tenth_gym (its 0.01 s step)
MAX_FRAME_PIXELS = 32 << 20  # [px] an overview frame; a larger one is downscaled further


@dataclass(frozen=True)
class SimConfig:
    """``sim``: time step and episode length."""

    fps: float | None = knob(
        None,
        "simulation steps per second; null: 30 on image tracks, 50 on the others",
        "Hz",
        low=1,
        high=1000,
    )
    render_realtime: bool = knob(True, "the human window waits so that it plays in real time")
    step_limit: int | None = knob(
        None, "truncate the episode after this many steps (null: no limit)", "steps", low=1
    )
    overview_downscale: float = knob(
        1.0,
        "divide the track image size by this in the overview (rgb_array/human render); "
        "the overview is at most 32 Mpx whatever this says",
        low=0.05,
        high=100,
    )


@dataclass(frozen=True)
class CarConfig:
    """``car``: the car model and its parameters, in the track's unit (px or m)."""

    model: str | None = knob(
        None,
        "a registered car model (the car.model table below lists them); null: by track kind",
    )
    actions: Literal["continuous", "discrete", "raw"] = knob(
        "continuous",
        "dynamic: Box [steer, gas, brake] or CarRacing's Discrete(5); single_track: continuous "
        "[steering angle rad, speed m/s] through F1TENTH's controllers, or raw [steering "
        "velocity rad/s, acceleration m/s^2]",
    )
    preset: Literal["f1tenth", "vehicle1", "vehicle2", "vehicle3"] = knob(
        "f1tenth",
        "single_track: parameters of F1TENTH's car, or CommonRoad's vehicle 1 (Ford Escort), "
        "2 (BMW 320i) or 3 (VW Vanagon); the preset sets the car's size",
    )
    substeps: int | None = knob(
        None,
        "single_track: RK4 steps per sim step (null: as many as the speed needs to be stable)",
        low=1,
        high=1000,
    )
    kinematic_below: float | None = knob(
        None,
        "single_track: below this speed the kinematic model moves the car (null: the preset's, "
        "0.5 for f1tenth as F1TENTH's gym, 0.1 for CommonRoad's vehicles)",
        "m/s",
        low=0.01,
        high=10,
    )
    compat: Literal["f1tenth_gym"] | None = knob(
        None,
        "single_track: f1tenth_gym's car step by step (its 2-step steering delay, bang-bang "
        "steering controller, kinematic model about the rear axle below 0.5 m/s, one RK4 "
        "step per sim step at its 100 Hz, the lidar at the pose), to port results; null: "
        "tinyrace's car (see docs/tracks.md)",
    )
    wheelbase: float | None = knob(
        None,
        "kinematic cars: rear to front axle (null: 160 px, 2.5 m on metric tracks, 0.33 m "
        "on ROS maps: F1TENTH's car)",
        "px or m",
        low=0.01,
        high=10000,
    )
    track_width: float | None = knob(
        None,
        "kinematic cars: width of the footprint (null: 100 px, 1.6 m on metric tracks, 0.31 "
        "m on ROS maps)",
        "px or m",
        low=0.01,
        high=10000,
    )
    velocity: float | None = knob(
        None,
        "kinematic: constant speed; kinematic_throttle: top speed "
        "(null: 500 px/s, 20 m/s on metric tracks, 5 m/s on ROS maps)",
        "px/s or m/s",
        low=0,
        high=100000,
    )
    max_steering_angle: float = knob(33.0, "kinematic cars: full lock", "deg", low=1, high=89)
    max_steering_change: float | None = knob(
        None, "kinematic cars: steering rate limit (null: none)", "deg/s", low=0, low_open=True
    )
    max_acceleration: float = knob(
        6.0, "kinematic_throttle: acceleration at full throttle", "m/s^2", low=0, low_open=True
    )
    max_deceleration: float = knob(
        10.0, "kinematic_throttle: deceleration at full brake", "m/s^2", low=0, low_open=True
    )
    pixels_per_unit: float | None = knob(
        None,
        "dynamic car: track units (image px, or m) per CarRacing world unit, which scales the "
        "car (null: 20 px/u on image tracks, 1 m/u on metric tracks, 0.1 m/u on ROS maps)",
        "px/u or m/u",
        low=0.001,
        high=1000,
    )


@dataclass(frozen=True)
class ColorObstacle:
    """``reward_design.color_obstacles[i]``: pixels of one colour the car must not touch."""

    color: Color = knob(
        REQUIRED, "obstacle colour ([b, g, r] with 0/255 channels, or #rrggbb)", binary=True
    )
    reward: float | Literal["done"] = knob(
        REQUIRED, "reward for each step the footprint touches it, or done to end the episode"
    )


CteShaping = Literal["none", "linear", "quadratic", "exponential", "gaussian"]


@dataclass(frozen=True)
class CrossTrackErrorConfig:
    """``reward_design.cross_track_error``: distance to a trajectory drawn in the image."""

    use_cte: bool = knob(False, "compute info['cte'] from trajectory pixels (image tracks)")
    trajectory_color: Color = knob(
        Color.rgb(255, 255, 255),
        "colour of the trajectory pixels (removed from the view)",
        binary=True,
    )
    shaping: CteShaping = knob(
        "none",
        "reward from cte: linear -w*e/s, quadratic -w*(e/s)^2, exponential w*exp(-e/s), "
        "gaussian w*exp(-(e/s)^2/2); a cte_shaping callable kwarg overrides it",
    )
    scale: float = knob(50.0, "s in the shapings above", "px", low=0.01)
    weight: float = knob(1.0, "w in the shapings above")


@dataclass(frozen=True)
class RewardConfig:
    """``reward_design``: the reward terms, summed; each is reported in info['reward_terms']."""

    color_obstacles: tuple[ColorObstacle, ...] = knob(
        (), "image tracks: colours the car must avoid"
    )
    cross_track_error: CrossTrackErrorConfig = knob(CrossTrackErrorConfig(), "image tracks")
    tile_progress: float | None = knob(
        None,
        "tracks with tiles: reward for visiting every tile once (null: 1000; 0 on image tracks)",
        "per lap",
    )
    time_penalty: float | None = knob(
        None, "subtracted every step (null: 0 on image tracks, 0.1 on the others)", "per step"
    )
    off_road_penalty: float = knob(
        0.0, "dynamic car on tiled tracks: subtracted per wheel on grass", "per step"
    )
    cone_penalty: float = knob(5.0, "cone maps: subtracted per cone knocked over", "per cone")
    wall_penalty: float = knob(
        1.0, "ROS maps: subtracted per step the car touches a wall", "per step"
    )
    out_of_bounds_penalty: float | None = knob(
        None,
        "subtracted when the car leaves the playfield or image; ends the episode "
        "(null: 0 on image tracks, 100 on the others)",
    )


@dataclass(frozen=True)
class FilesConfig:
    """``files``: how far the files a config names may reach, and how large they may be.

    Fixed bounds, not knobs: a YAML file is at most 1 MiB, nests at most 32 levels and expands
    (aliases included) to at most 200,000 values; a key may appear once per mapping; FIFOs and
    devices are refused. Overview frames are at most 32 Mpx (a larger one is downscaled
    further) and all cameras together (perspective_camera sensors too) at most 4096 x 4096 px;
    the other fixed bounds are listed at the end of this reference.
    """

    max_image_pixels: int = knob(
        DEFAULT_MAX_IMAGE_PIXELS,
        "a track image larger than this (width * height, read from its header) is refused "
        "before it is decoded",
        "px",
        low=1,
        high=400_000_000,
    )
    paths_outside_folder: bool = knob(
        False,
        "let image and data paths leave the config's folder: absolute paths, '..' and "
        "symlinks out of it (refused by default; a NUL byte is always refused)",
    )


MAX_RACE_CARS = 16  # cars one race (one world) holds


@dataclass(frozen=True)
class RaceCarConfig:
    """``race.cars[i]``: one car of a race. Each key left out is the shared one: the car
    model and knobs of the top-level ``car`` section (the entry's ``car`` keys are laid over
    it), the top-level ``cameras`` and ``sensors``."""

    id: str | None = knob(
        None,
        "the car's name: its PettingZoo agent and what other cars' infos call it "
        "(null: car_<index>)",
    )
    car: CarConfig = knob(
        CarConfig(), "its car model and knobs (as the car section), laid over the car section"
    )
    colour: Color | None = knob(
        None,
        "its colour in cameras, overview and videos (list BGR, #rrggbb RGB; null: the "
        "palette's colour of its index)",
        aliases=("color",),
    )
    cameras: tuple[CameraConfig, ...] | None = knob(
        None, "its own bird's-eye cameras (null: the shared cameras)"
    )
    sensors: tuple[SensorConfig, ...] | None = knob(
        None, "its own sensors (null: the shared sensors); its observation space follows them"
    )


@dataclass(frozen=True)
class RaceConfig:
    """Several cars on one track: which cars, where they start, how the tiles pay them.

    Either ``num_agents`` cars of the top-level ``car``, ``cameras`` and ``sensors``
    sections (named ``car_0`` ..), or a ``cars`` list of one entry per car. All cars share
    the track, ``sim`` and ``reward_design``."""

    num_agents: int = knob(
        1,
        "cars on the track (car 0 is the one a single-agent env drives); with cars: their "
        "number, which it may leave out",
        low=1,
        high=MAX_RACE_CARS,
    )
    cars: tuple[RaceCarConfig, ...] = knob(
        (), "one entry per car (id, car, colour, cameras, sensors); none: num_agents shared cars"
    )
    start: Literal["grid", "random", "poses"] = knob(
        "grid",
        "grid: car 0 at the spawn (pole), the others behind it along the reference line; "
        "random: seeded places along the reference line, apart; poses: the poses listed",
    )
    poses: tuple[Spawn, ...] = knob(
        (), "start: poses: one start pose [x, y, heading] per car", "track units, rad"
    )
    laps: int = knob(
        1, "laps a car races: finishing the last one ends its episode", low=1, high=1000
    )
    grid_spacing: float = knob(
        2.5,
        "start grid: each car this far behind the one before (random: at least this far "
        "apart along the line)",
        "car lengths",
        low=1.2,
    )
    grid_offset: float = knob(
        0.6,
        "start grid: cars this far left and right of the line, in turn (random: at most this far)",
        "car widths",
        low=0,
    )
    tile_reward: Literal["own", "first"] = knob(
        "own",
        "own: each car is paid for every tile it visits (CarRacing's tile reward per car); "
        "first: a tile pays only the first car to visit it (cars in index order on a tie)",
    )


@dataclass(frozen=True)
class CacheConfig:
    """``cache``: where envs keep the read-only data of a fixed track (ground textures, lidar
    tables) that worker processes share through memory-mapped files. ``tinyrace cache info``
    shows the folder, ``tinyrace cache clear`` empties it."""

    dir: str | None = knob(
        None,
        "folder of the cache files; null: $TINYRACE_CACHE_DIR, else $XDG_CACHE_HOME/tinyrace, "
        "else ~/.cache/tinyrace",
    )
    max_size: float = knob(
        2048.0,
        "the cache files together at most (the least recently used go first); 0: no files, "
        "envs share their track within each process only",
        "MB",
        low=0,
        high=1_000_000,
    )


@dataclass(frozen=True)
class EnvConfig:
    """A whole environment: what a track.yaml holds."""

    sim: SimConfig = knob(SimConfig(), "time step and episode length")
    tracks: tuple[TrackConfig, ...] = knob(
        (ProceduralTrackConfig(),), "one or more tracks (a mapping or a list)", aliases=("track",)
    )
    car: CarConfig = knob(CarConfig(), "car model")
    cameras: tuple[CameraConfig, ...] = knob(
        (),
        "tinycarlo's bird's-eye cameras (a mapping or a list); the loader puts each first in "
        "sensors as a birdseye_camera entry. No camera and no sensor: the track's default "
        "view (chase_view on a procedural track, top_view on tracks in metres) as a Box",
        aliases=("camera",),
    )
    sensors: tuple[SensorConfig, ...] = knob(
        (),
        "more observation sensors by type (perspective_camera, lidar, state, lookahead, "
        "cones; a mapping or a list), each under its id in the Dict observation beside the "
        "cameras",
        aliases=("sensor",),
    )
    observation: Literal["dict", "box"] = knob(
        "dict",
        "dict: camera images keyed by id; box: the one camera's image as a plain Box, so "
        "image wrappers (GrayscaleObservation, ResizeObservation, ...) apply directly",
    )
    reward_design: RewardConfig = knob(RewardConfig(), "reward terms")
    rules: tuple[RuleConfig, ...] = knob(
        (),
        "more rule parts, each with its own knobs (a list of registered rule parts' configs, "
        "by type): each judges every car, with its reward terms and end reasons",
    )
    files: FilesConfig = knob(FilesConfig(), "bounds on the files this config reads")
    race: RaceConfig = knob(RaceConfig(), "several cars on the track (tinyrace.race)")
    cache: CacheConfig = knob(CacheConfig(), "where shared track data is kept on disk")

    @property
    def kind(self) -> str:
        """The tracks' ``type`` (a label for messages and results; ask ``track`` for facts)."""
        return self.tracks[0].type

    @property
    def facts(self) -> TrackFacts:
        """What the tracks' config class says of them (one type for all tracks)."""
        return self.tracks[0]

    @property
    def written_sensors(self) -> tuple[SensorConfig, ...]:
        """The ``sensors:`` entries as written: without the ``cameras`` the loader put first."""
        return self.sensors[self._cameras_first() :]

    def sensor_key(self, index: int) -> str:
        """The key the user wrote for ``sensors[index]``: ``cameras[i]`` or ``sensors[j]``."""
        cameras = self._cameras_first()
        return f"cameras[{index}]" if index < cameras else f"sensors[{index - cameras}]"

    def _cameras_first(self) -> int:
        """How many of ``sensors`` are the ``cameras`` the loader put first."""
        cameras = self.cameras
        return len(cameras) if self.sensors[: len(cameras)] == cameras else 0
