"""Tracks in metres from the three real-world formats, as one kind of data.

``MetricSource`` is the track source of the three kinds (``tracks/registry.py``);
``load_metric_track`` reads a ``centerline``, ``cone_map`` or ``ros_map`` track section
(files relative to the config's folder) into a ``MetricTrack``: the closed road
(``Circuit``: centreline, widths, tiles) when the source has one, the spawn, the
bounds, the cones and the walls. ``as_track`` gives the shared ``Track`` contract.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tinyrace.config import (
    CenterlineTrackConfig,
    ConeMapTrackConfig,
    ConfigError,
    EnvConfig,
    RosMapTrackConfig,
)
from tinyrace.config.bounds import MAX_INNER_WIDTH_OVER_RADIUS, MAX_TRACK_POINTS, MIN_ROAD_WIDTH
from tinyrace.config.paths import inside_folder
from tinyrace.config.schema import FilesConfig
from tinyrace.errors import Problem
from tinyrace.tracks import polyline
from tinyrace.tracks.base import PaintedGround, Surface, Track, TrackDraw, TrackRules, pick_index
from tinyrace.tracks.centerline_csv import Loop, read_loop
from tinyrace.tracks.circuit import Circuit
from tinyrace.tracks.cone_map import (
    RADII,
    check_cones_near_road,
    check_start_on_road,
    read_cones,
    road_between,
)
from tinyrace.tracks.ros_map import OccupancyMap, read_map

Pose = tuple[float, float, float]
FILES = FilesConfig()  # the default bounds on the files a track names
OFF_ROAD_FRICTION = 0.6  # CarRacing's grass grip, as a fraction of the road's
GROUND_PIXELS_PER_METER = 20.0  # [px/m] a drawn ground's texture when the config names none
NO_REFERENCE = "no reference line: this ros_map track has no waypoints (track.waypoints)"


@dataclass(frozen=True, eq=False)
class MetricTrack:
    """One track in metres (x right, y up, headings counter-clockwise); read-only."""

    kind: str  # the track.type it came from
    circuit: Circuit | None  # the road and its tiles; None: a ROS map without waypoints
    spawn: Pose  # (x [m], y [m], heading [rad])
    bounds: tuple[float, float, float, float]  # (x0, y0, x1, y1) [m]: leaving it ends the episode
    path: str  # the file read, for messages
    cones: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # (K, 3) x, y, class id
    cone_radii: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (K,) [m]
    walls: np.ndarray = field(default_factory=lambda: np.zeros((0, 4, 2)))  # (M, 4, 2) quads [m]
    occupancy: OccupancyMap | None = None  # the ROS map's cells

    @property
    def centerline(self) -> np.ndarray | None:
        """(N, 2) [m] the reference line (CTE, look-ahead, the centreline driver), or None."""
        return None if self.circuit is None else self.circuit.centerline

    @property
    def tiles(self) -> np.ndarray:
        """(N, 4, 2) [m] progress tiles (none without a reference line)."""
        return np.zeros((0, 4, 2)) if self.circuit is None else self.circuit.tiles

    def as_track(self, config: MetricConfig) -> Track:
        """The shared track contract (``tinyrace.tracks.base.Track``), with the rules of its
        episodes: CarRacing's on a road read from a file (tiles passed along the
        centreline, laps, the cte to it), walls that stop the car, cones knocked over."""
        tiles = None if self.circuit is None else self.circuit.tiles
        surfaces = () if tiles is None else (Surface("road", 1.0, tiles),)
        progress = ("grass", "centreline_progress") if tiles is not None else ("no_reference",)
        rules = TrackRules(
            ("collisions", "playfield", *progress),
            lap_complete_percent=config.lap_complete_percent,
            wall_hit_ends=getattr(config, "wall_hit_ends_episode", False),
            cone_hit_ends=getattr(config, "cone_hit_ends_episode", False),
            info_labels=("track", "unit"),
        )
        return Track(
            kind=self.kind,
            unit="m",
            metres_per_unit=1.0,
            y_down=False,
            bounds=self.bounds,
            spawns=(self.spawn,),
            centerline=self.centerline,
            tiles=tiles,
            surfaces=surfaces,
            off_road_friction=OFF_ROAD_FRICTION if self.occupancy is None else 1.0,
            walls=self.walls,
            cones=self.cones,
            rules=rules,
            circuit=self.circuit,
            cone_radii=self.cone_radii,
            reference_note=NO_REFERENCE if self.circuit is None else None,
            headings=None if self.circuit is None else self.circuit.headings,
            occupancy=self.occupancy,
            ground_pixels_per_unit=getattr(config, "pixels_per_meter", GROUND_PIXELS_PER_METER),
            path=self.path,
        )


MetricConfig = CenterlineTrackConfig | ConeMapTrackConfig | RosMapTrackConfig
METRIC_CONFIGS = (CenterlineTrackConfig, ConeMapTrackConfig, RosMapTrackConfig)


def load_metric_track(
    config: MetricConfig, index: int, base_dir: Path, source: str, files: FilesConfig = FILES
) -> MetricTrack:
    """Read ``tracks[index]``; a ConfigError names the file (and line) of every problem.

    Its files stay inside the config's folder unless ``files.paths_outside_folder``; a
    picture is checked against ``files.max_image_pixels`` before it is decoded."""
    where = f"tracks[{index}]"
    for key in ("file", "waypoints"):
        name = getattr(config, key, None)
        if name is not None:
            inside_folder(name, base_dir, files.paths_outside_folder, source, f"{where}.{key}")
    return LOADERS[config.type](config, where, base_dir, source, files)


def _centerline(
    config: CenterlineTrackConfig, where: str, base_dir: Path, source: str, files: FilesConfig
) -> MetricTrack:
    loop = read_loop(base_dir / config.file, source, f"{where}.file", config.scale)
    widths = loop.widths
    if widths is None:
        widths = np.full((len(loop.points), 2), config.default_width / 2)
    _check_length(loop.points, config.spacing, source, where, loop.table.path)
    circuit = Circuit.build(loop.points, widths, config.spacing)
    width_key = None if loop.widths is not None else (source, f"{where}.default_width")
    _check_folds(circuit, loop, width_key)
    return MetricTrack(
        "centerline",
        circuit,
        circuit.start_pose,
        circuit.bounds(config.margin),
        str(base_dir / config.file),
    )


def _cone_map(
    config: ConeMapTrackConfig, where: str, base_dir: Path, source: str, files: FilesConfig
) -> MetricTrack:
    cones = read_cones(base_dir / config.file, source, f"{where}.file", config.scale)
    road = road_between(cones, config.spacing, config.max_cone_gap)
    check_cones_near_road(cones, road)
    check_start_on_road(cones, road)
    _check_length(road.centerline, config.spacing, source, where, cones.path)
    narrowest = int(np.argmin(road.widths.sum(axis=1)))
    if road.widths[narrowest].sum() < MIN_ROAD_WIDTH:
        x, y = road.centerline[narrowest]
        allowed = (
            f"expected a road at least {MIN_ROAD_WIDTH:g} m wide between the blue and yellow "
            f"cones; at ({x:.2f}, {y:.2f}) m it is {road.widths[narrowest].sum():.3f} m: do "
            "the edges cross or interleave? (blue cones on the left edge, yellow cones "
            "on the right)"
        )
        raise ConfigError(Problem(cones.path, "", "the cones' road", allowed))
    circuit = Circuit.build(road.centerline, road.widths, config.spacing)
    low = cones.positions.min(axis=0) - config.margin
    high = cones.positions.max(axis=0) + config.margin
    return MetricTrack(
        "cone_map",
        circuit,
        circuit.start_pose if cones.start is None else cones.start,
        (float(low[0]), float(low[1]), float(high[0]), float(high[1])),
        cones.path,
        cones=np.column_stack((cones.positions, cones.class_ids)),
        cone_radii=np.array([RADII[t] for t in cones.tags]),
    )


def _ros_map(
    config: RosMapTrackConfig, where: str, base_dir: Path, source: str, files: FilesConfig
) -> MetricTrack:
    occupancy = read_map(base_dir / config.file, source, f"{where}.file", files)
    circuit = None
    if config.waypoints is not None:
        loop = read_loop(base_dir / config.waypoints, source, f"{where}.waypoints")
        widths = loop.widths
        if widths is None:  # the free space around each waypoint
            clearance = occupancy.clearance(loop.points)
            widths = np.column_stack((clearance, clearance))
        _check_length(loop.points, config.spacing, source, where, loop.table.path)
        circuit = Circuit.build(loop.points, widths, config.spacing)
        if loop.widths is None:
            circuit = _unfolded(circuit)
        else:
            _check_folds(circuit, loop, None)
    spawn = _ros_spawn(config, circuit, occupancy, where, source)
    corners = occupancy.to_world(
        np.array([0, 0, occupancy.shape[0] - 1, occupancy.shape[0] - 1]),
        np.array([0, occupancy.shape[1] - 1, 0, occupancy.shape[1] - 1]),
    )
    (x0, y0), (x1, y1) = corners.min(axis=0), corners.max(axis=0)
    return MetricTrack(
        "ros_map",
        circuit,
        spawn,
        (float(x0), float(y0), float(x1), float(y1)),
        str(base_dir / config.file),
        walls=occupancy.wall_quads(),
        occupancy=occupancy,
    )


def _check_folds(circuit: Circuit, loop: Loop, width_key: tuple[str, str] | None) -> None:
    """Refuse a road wider to the inside of a curve than the curve's radius allows (it
    would fold over itself), naming the file's line nearest the worst point, or the
    ``default_width`` key (``width_key``: source, key) when the widths came from there."""
    ratio = polyline.inner_width_over_radius(circuit.centerline, circuit.widths)
    worst = int(np.argmax(ratio))
    if ratio[worst] <= MAX_INNER_WIDTH_OVER_RADIUS:
        return
    x, y = circuit.centerline[worst]
    side = int(polyline.curve_turns_left(circuit.centerline, circuit.widths)[worst])
    width = float(circuit.widths[worst, side])
    radius = width / float(ratio[worst])
    allowed = (
        f"expected the road's width to the inside of a curve at most "
        f"{MAX_INNER_WIDTH_OVER_RADIUS:g} x the curve's radius: at ({x:.2f}, {y:.2f}) m it is "
        f"{width:.3g} m to the {('right', 'left')[side]} of a curve of radius {radius:.3g} m "
        f"({float(ratio[worst]):.3g} x). Above 1 x the inner edge passes the curve's centre "
        f"and the road folds over itself; up to {MAX_INNER_WIDTH_OVER_RADIUS:g} x is let "
        "through only because surveyed circuits' hairpin apexes reach about 1 x (the "
        "racetrack-database's do)"
    )
    if width_key is not None:
        source, key = width_key
        raise ConfigError(Problem(source, key, 2 * width, allowed + "; give a narrower width"))
    row = polyline.nearest_index(loop.points, circuit.centerline[worst])
    value = f"{width:.3g} m to the {('right', 'left')[side]}"
    raise ConfigError(Problem(loop.table.path, loop.table.where(row), value, allowed))


def _unfolded(circuit: Circuit) -> Circuit:
    """The circuit with its widths cut where a curve's radius is narrower (free space
    measured around waypoints can be wider than the curve they turn), so that no tile folds."""
    ratio = polyline.inner_width_over_radius(circuit.centerline, circuit.widths)
    if ratio.max() <= 1.0:
        return circuit
    return circuit.with_widths(circuit.widths / np.maximum(ratio, 1.0)[:, None])


def _check_length(points: np.ndarray, spacing: float, source: str, where: str, path: str) -> None:
    """A loop at least 3 spacings long, resampled into at most MAX_TRACK_POINTS points."""
    length = polyline.perimeter(points)  # [m]
    if length < 3 * spacing:
        allowed = f"expected a loop at least 3 x {where}.spacing ({3 * spacing:g} m) long"
        raise ConfigError(Problem(path, "", f"a loop of {length:.3g} m", allowed))
    if length / spacing > MAX_TRACK_POINTS:
        allowed = (
            f"expected a spacing >= {length / MAX_TRACK_POINTS:.3g} m: the {length:.0f} m loop "
            f"in at most {MAX_TRACK_POINTS:,} points"
        )
        raise ConfigError(Problem(source, f"{where}.spacing", spacing, allowed))


def _ros_spawn(
    config: RosMapTrackConfig,
    circuit: Circuit | None,
    occupancy: OccupancyMap,
    where: str,
    source: str,
) -> Pose:
    if config.spawn is not None:
        if not occupancy.is_free(np.array([config.spawn[:2]]))[0]:
            allowed = "expected a spawn on a free cell of the map"
            raise ConfigError(Problem(source, f"{where}.spawn", list(config.spawn), allowed))
        return config.spawn
    if circuit is None:
        allowed = "expected waypoints (a reference line) or a spawn [x, y, heading] [m, m, rad]"
        raise ConfigError(Problem(source, f"{where}.spawn", None, allowed))
    start = circuit.start_pose
    if not occupancy.is_free(np.array([start[:2]]))[0]:
        x, y, heading = start
        height, width = occupancy.shape
        outside = not occupancy.on_map(np.array([start[:2]]))[0]
        on = "outside the map" if outside else "on a cell that is not free"
        allowed = (
            f"expected waypoints whose first point, the start pose [{x:.3f}, {y:.3f}, "
            f"{heading:.3f}] [m, m, rad], lies on a free cell of the map ({width} x {height} "
            f"cells from {list(occupancy.info.origin[:2])} m); it lies {on}: check the "
            "waypoints' frame against the map's origin and resolution, or give track.spawn"
        )
        raise ConfigError(Problem(source, f"{where}.waypoints", config.waypoints, allowed))
    return start


LOADERS: dict[str, Callable[..., MetricTrack]] = {
    "centerline": _centerline,
    "cone_map": _cone_map,
    "ros_map": _ros_map,
}


class MetricSource:
    """``track.type: centerline``, ``cone_map`` or ``ros_map``: every track read once per env."""

    painted: PaintedGround | None = (
        None  # the ground is drawn once per track from its road, cones and cells
    )

    def __init__(self, config: EnvConfig, base_dir: Path, source: str):
        self.kind = config.kind
        loaded: list[MetricTrack] = []
        problems: list[Problem] = []
        for index, track_config in enumerate(config.tracks):
            assert isinstance(track_config, METRIC_CONFIGS)  # one kind per env, checked at load
            try:
                loaded.append(
                    load_metric_track(track_config, index, base_dir, source, config.files)
                )
            except ConfigError as error:
                problems += error.problems
        if problems:
            raise ConfigError(problems)
        configs = [c for c in config.tracks if isinstance(c, METRIC_CONFIGS)]
        self.tracks = tuple(
            track.as_track(track_config)
            for track, track_config in zip(loaded, configs, strict=True)
        )

    def draw(self, rng: np.random.Generator, options: Mapping[str, object]) -> TrackDraw:
        """A track drawn from ``rng`` unless ``options['track']`` picks it (one spawn each)."""
        track_index = pick_index(options, "track", len(self.tracks), rng)
        spawn_index = pick_index(options, "spawn", 1, rng)
        return TrackDraw(self.tracks[track_index], track_index, spawn_index)
