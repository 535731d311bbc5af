"""``type: lidar``: ranges of a fan of beams against the track's blocking layers.

``lidar_map.blocking_map`` draws what ``blocks`` names (off-road, walls, obstacle colours,
cones) into a grid of cells once per track; ``tinyrace.sensors.machinery.raycast_numpy`` casts the
beams on it (sample tables and two vectorised passes, no loop over beams), or, when numba imports
(a dependency of tinyrace), ``tinyrace.sensors.kernels.raycast``'s compiled kernel: the
same float32 ranges bit for bit, several times faster and without the sample tables (about
38 MB per 1080-beam lidar). The environment variable ``TINYRACE_LIDAR`` chooses the path of
the lidars built afterwards: ``numpy`` forces the numpy path, ``numba`` requires the compiled
one, ``auto`` (or unset) takes numba when it imports. With ``hit_classes``, each beam also
reports what it hit: 0 nothing (max_range), 1 a wall (off-road, walls, obstacles, the edge
of the map), 1 + k a cone of class k (``tracks.cone_map.CLASSES``). Ranges are in track
units.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any
from typing import cast as typed

import numpy as np
from gymnasium import spaces

from tinyrace import cache, kernels
from tinyrace.cache.codec import DataclassCodec
from tinyrace.config import cache_settings
from tinyrace.config.sensors import LidarConfig
from tinyrace.sensors.base import SensorContext, TopDown
from tinyrace.sensors.machinery import (
    common,
    lidar_map,
    other_cars,
    raycast,
    raycast_exact,
    raycast_numpy,
)
from tinyrace.sensors.machinery.common import (
    RGB,
    PerTrack,
    Unsupported,
    mount,
)
from tinyrace.sensors.machinery.lidar_map import NO_HIT, WALL_CLASS, blocking_map, occupancy_map
from tinyrace.sensors.machinery.raycast import (
    DistanceField,
    Fan,
    beam_fan,
    fan_angle,
    table_bytes,
)
from tinyrace.sensors.machinery.raycast_exact import ExactField, exact_fan, exact_turn
from tinyrace.sensors.machinery.raycast_numpy import cast
from tinyrace.tracks.base import Track
from tinyrace.tracks.cone_map import CLASSES
from tinyrace.world.snapshot import Snapshot

KERNEL_VARIABLE = "TINYRACE_LIDAR"  # environment variable: auto | numba | numpy
TABLE_LIMIT = 256 * 2**20  # [bytes] the numpy path's sample tables of one lidar, at most
ROS_MAX_RANGE = 30.0  # [m] max_range on ROS maps unless given: F1TENTH's (f1tenth_gym)
ROS_BLOCKS = ("walls", "cones")  # what stops a beam on a ROS map unless ``blocks`` says
ALL_BLOCKS = ("off_road", "walls", "obstacles", "cones")  # ... and on the other tracks
FIELDS = DataclassCodec(DistanceField)  # cache files of shared fields and fans
FANS = DataclassCodec(Fan)


def hit_classes(
    field: DistanceField | ExactField,
    origin: tuple[float, float],
    directions: np.ndarray,
    ranges: np.ndarray,
    max_range: float,
) -> np.ndarray:
    """(B,) uint8 class of what each beam of ``ranges`` [track units] hit (NO_HIT at
    ``max_range``), read from the field's class map at the beam's end."""
    assert field.classes is not None, "blocking_map(..., classes=True) keeps them"
    ends = np.asarray(origin, np.float64) + ranges[:, None] * directions  # [track units]
    cells = np.rint(ends @ field.to_cells[:, :2].T + field.to_cells[:, 2]).astype(np.int64)
    height, width = field.classes.shape
    col, row = cells[:, 0], cells[:, 1]
    inside = (col >= 0) & (col < width) & (row >= 0) & (row < height)
    found = np.full(len(ranges), WALL_CLASS, np.uint8)  # beyond the map: its edge, a wall
    found[inside] = field.classes[row[inside], col[inside]]
    found[ranges >= max_range] = NO_HIT
    return found


def directions(angles: np.ndarray, heading: float, y_down: bool) -> np.ndarray:
    """(B, 2) unit vectors [track units] of beams at ``angles`` [rad, + left] from a car at
    ``heading`` [rad] (counter-clockwise on y-up tracks, clockwise on y-down image tracks)."""
    world = heading - angles if y_down else heading + angles
    return np.stack([np.cos(world), np.sin(world)], axis=1)


def beam_angles(beams: int, fov: float) -> np.ndarray:
    """Beam directions [rad] relative to the car, rightmost first, evenly over ``fov`` [rad].

    A full circle (fov >= 2 pi) leaves out the end that would repeat the start.
    """
    full = fov >= 2 * math.pi - 1e-9
    return np.linspace(-fov / 2, fov / 2, beams, endpoint=not full or beams == 1)


def add_noise(
    ranges: np.ndarray,
    rng: np.random.Generator,
    std: float,
    dropout: float,
    max_range: float,
) -> np.ndarray:
    """Gaussian range noise of ``std`` [track units] and dropped beams (reported as max_range),
    drawn from ``rng``, clipped to [0, max_range]; float32. Draws nothing when both are 0."""
    noisy = ranges.astype(np.float32, copy=True)
    if std > 0:
        noisy += rng.normal(0.0, std, noisy.shape).astype(np.float32)
    if dropout > 0:
        noisy[rng.random(noisy.shape) < dropout] = max_range
    return np.clip(noisy, 0.0, max_range, out=noisy)


Cast = Callable[[DistanceField, Fan, tuple[float, float], float, bool], np.ndarray]
CastExact = Callable[[np.ndarray, tuple[float, float], np.ndarray, np.ndarray, float], np.ndarray]
AddCars = Callable[
    [np.ndarray, tuple[float, float], float, bool, other_cars.BeamFan, np.ndarray, float],
    np.ndarray,
]


def kernel(wanted: str | None = None) -> tuple[str, Cast]:
    """The ray-casting path ``wanted`` (auto | numba | numpy; None: ``TINYRACE_LIDAR``'s,
    else auto), by name, and its ``cast``: auto is ``numba`` when numba imports, else
    ``numpy``."""
    name, module = kernels.choose(
        KERNEL_VARIABLE, "numpy", "tinyrace.sensors.kernels.raycast", wanted
    )
    return name, cast if module is None else typed(Cast, module.cast)


def exact_kernel(name: str) -> CastExact:
    """The exact traversal of the path ``name`` (numba | numpy)."""
    if name == "numpy":
        return raycast_numpy.cast_exact
    from tinyrace.sensors.kernels import raycast as compiled  # imported: kernel() chose it

    return typed(CastExact, compiled.cast_exact)


def cars_kernel(wanted: str | None = None) -> tuple[str, AddCars]:
    """The path ``wanted`` (as ``kernel``'s, the same variable) of the other cars' ranges in
    a race, by name, and its ``add_cars`` (``other_cars.add_cars`` or its compiled twin)."""
    name, module = kernels.choose(
        KERNEL_VARIABLE, "numpy", "tinyrace.sensors.kernels.other_cars", wanted
    )
    return name, other_cars.add_cars if module is None else typed(AddCars, module.add_cars)


class LidarSensor:
    """``type: lidar``: (beams,) float32 ranges [track units], rightmost beam first.

    ``kernel`` names the ray-casting path chosen when it was built (``kernel(kernel_name)``,
    by default ``TINYRACE_LIDAR``'s or auto): ``numba`` (compiled, no sample tables) or
    ``numpy``; both give the same ranges bit for bit.
    """

    def __init__(
        self,
        config: LidarConfig,
        max_range: float,
        cell: float,
        cone_colors: tuple[RGB, ...],
        kernel_name: str | None = None,
        exact_only: bool = False,
        settings: cache.Settings | None = None,
        mount: str = "front_axle",
    ):
        self.config = config
        self.mount = config.mount or mount  # the axle the lidar's position is measured from
        self.cache = settings  # where the fields and fans of fixed tracks are shared
        self.max_range = max_range  # [track units]
        self.cell = cell  # [track units]
        self.cone_colors = cone_colors
        self.angles = beam_angles(config.beams, math.radians(config.fov))  # [rad] + left
        ranges = spaces.Box(0.0, max_range, (config.beams,), np.float32)
        self.space: spaces.Space[Any] = ranges
        if config.hit_classes:
            hits = spaces.Box(0, WALL_CLASS + len(CLASSES), (config.beams,), np.uint8)
            self.space = spaces.Dict({"ranges": ranges, "classes": hits})
        self._fields: PerTrack[tuple[DistanceField, Fan] | ExactField] = PerTrack()
        self.field: DistanceField | None = None
        self.fan: Fan | None = None
        self.exact: ExactField | None = None  # the field of a ROS map (exact traversal)
        self.exact_fan: tuple[np.ndarray, ...] | None = None  # its beams' (cos, sin)
        self._fans: dict[tuple[Any, ...], Fan] = {}
        self.kernel, self._cast = kernel(kernel_name)
        self._cast_exact = exact_kernel(self.kernel)
        self._beam_fan = other_cars.fan(self.angles)  # the other cars' ranges (a race's)
        _, self._add_cars = cars_kernel(self.kernel)
        if self.kernel == "numpy" and not exact_only:  # ROS maps need no tables
            _check_tables(config, self.angles)

    def blocks(self, track: Track) -> tuple[str, ...]:
        """What stops a beam on ``track``: ``blocks``, or by default ROS_BLOCKS on ROS maps
        (their occupied pixels) and ALL_BLOCKS elsewhere."""
        if self.config.blocks is not None:
            return tuple(self.config.blocks)
        return ROS_BLOCKS if track.occupancy is not None else ALL_BLOCKS

    @property
    def id(self) -> str:
        return self.config.id

    def describe(self) -> str:
        c = self.config
        hits = ", and what each beam hit" if c.hit_classes else ""
        return f"lidar, {c.beams} beams over {c.fov:g} deg, ranges up to {self.max_range:g}{hits}"

    def top_down(self, snapshot: Snapshot, track: Track) -> TopDown | None:
        return None  # its observation is no picture from above

    def reset(self, track: Track) -> None:
        made = self._fields.get(track, self._tables)
        if isinstance(made, ExactField):
            self.exact, self.field, self.fan = made, None, None
            self.exact_fan = exact_fan(made, self.angles, track.y_down)
        else:
            self.exact, (self.field, self.fan) = None, made

    def _tables(self, track: Track) -> tuple[DistanceField, Fan] | ExactField:
        """The field of ``track`` and this lidar's fan on it (built once per track; on a
        fixed track, once for every env of the process, and kept in the cache folder); on a
        ROS map, the exact field of its pixels (per env)."""
        blocks = self.blocks(track)
        exact = occupancy_map(track, blocks, self.config.hit_classes)
        if exact is not None:
            return exact
        if track.drawn_per_reset:  # a track of its own at every reset
            field = self._field(track, blocks)
            return field, self._fan(field, track.y_down)
        c = self.config
        key = ("lidar field", cache.content(track), blocks, self.cell, self.cone_colors,
               c.hit_classes, self.max_range, self.kernel, _CODE)  # fmt: skip
        field = cache.shared(key, lambda: self._field(track, blocks), self.cache, FIELDS)
        fan_key = (key, self.angles, track.y_down)
        fan = cache.shared(fan_key, lambda: self._fan(field, track.y_down), self.cache, FANS)
        return field, fan

    def _field(self, track: Track, blocks: tuple[str, ...]) -> DistanceField:
        c = self.config
        numpy = self.kernel == "numpy"  # the compiled kernel needs neither NEAR maps nor tables
        field = blocking_map(
            track, blocks, self.cell, self.cone_colors, c.hit_classes, self.max_range, numpy
        )
        if not numpy:  # the compiled kernel's skip maps by direction, where they fit
            from tinyrace.sensors.kernels import raycast as raycast_numba  # kernel() chose it

            field = raycast_numba.with_sectors(field)
        return field

    def _fan(self, field: DistanceField, y_down: bool) -> Fan:
        # a fan depends on the map's width and cell frame only: tracks made anew at every
        # reset (procedural) share it
        key = (field.shape[1], *field.to_cells[:, :2].ravel().tolist(), y_down)
        if key not in self._fans:
            self._fans.clear()
            numpy = self.kernel == "numpy"
            self._fans[key] = beam_fan(field, self.angles, self.max_range, y_down, numpy)
        return self._fans[key]

    def origin(self, snapshot: Snapshot, track: Track) -> tuple[float, float]:
        """[track units] where the beams start."""
        car = snapshot.car
        ahead, left = self.config.position
        if self.mount == "pose":
            axle = car.pose[0], car.pose[1]
        else:
            axle = car.rear_axle if self.mount == "rear_axle" else car.front_axle
        return mount(axle, car.pose[2], track.y_down, ahead, left)

    def scan(self, origin: tuple[float, float], heading: float, y_down: bool) -> np.ndarray:
        """float32 ranges [track units] of the beams from ``origin`` [track units] of a car
        at ``heading`` [rad], without noise."""
        if self.exact is not None:
            assert self.exact_fan is not None
            return exact_ranges(
                self.exact, self._cast_exact, origin, self.exact_fan, heading, self.max_range
            )
        assert self.field is not None and self.fan is not None, "reset() before observe()"
        first, reverse = fan_angle(self.field, self.angles, heading, y_down)
        return self._cast(self.field, self.fan, origin, first, reverse)

    def observe(self, snapshot: Snapshot, track: Track, rng: np.random.Generator) -> Any:
        """The ranges; with ``hit_classes``, {"ranges", "classes"} (dropped beams: NO_HIT)."""
        heading = snapshot.car.pose[2]
        origin = self.origin(snapshot, track)
        ranges = self.scan(origin, heading, track.y_down)
        others = snapshot.others
        if others:  # a race: the other cars on the track stop beams too
            rows = other_cars.car_rows(others)
            y_down, fan = track.y_down, self._beam_fan
            ranges = self._add_cars(ranges, origin, heading, y_down, fan, rows, self.max_range)
        c = self.config
        classes = None
        if c.hit_classes:
            beams = directions(self.angles, heading, track.y_down)
            field = self.exact if self.exact is not None else self.field
            assert field is not None
            classes = hit_classes(field, origin, beams, ranges, self.max_range)
        if c.range_std > 0 or c.dropout > 0:
            ranges = add_noise(ranges, rng, c.range_std, c.dropout, self.max_range)
        if classes is None:
            return ranges
        classes[ranges >= self.max_range] = NO_HIT
        return {"ranges": ranges, "classes": classes}


def exact_ranges(
    field: ExactField,
    cast_exact: CastExact,
    origin: tuple[float, float],
    fan: tuple[np.ndarray, ...],
    heading: float,
    max_range: float,
) -> np.ndarray:
    """float32 ranges [track units] of the beams of ``fan`` (``raycast_exact.exact_fan``) of a car
    at ``heading`` [rad] from ``origin`` [track units] by the exact traversal of ``field``
    (``cast_exact``: either path's), at most ``max_range``; 0 from a blocking cell or off the
    map."""
    ca, sa = fan
    cb, sb = exact_turn(field, heading)
    dx, dy = ca * cb - sa * sb, sa * cb + ca * sb  # [cells] the beams turned
    limit = max_range * field.cells_per_unit
    cells = cast_exact(field.cells, field.cell(origin), dx, dy, limit)
    ranges: np.ndarray = np.minimum(cells / field.cells_per_unit, max_range).astype(np.float32)
    return ranges


# what makes a field: the code of these modules is in its cache key
_CODE = cache.code(
    __file__, common.__file__, raycast.__file__, raycast_exact.__file__, lidar_map.__file__
)


def _check_tables(config: LidarConfig, angles: np.ndarray) -> None:
    """Unsupported when the numpy path's tables for these beams would exceed TABLE_LIMIT
    (beams packed closer than the tables' angle step multiply their rows)."""
    size = table_bytes(angles)
    if size > TABLE_LIMIT:
        raise Unsupported(
            f"beams: {config.beams} over fov: {config.fov} deg would need "
            f"{size / 2**20:,.0f} MB of ray-casting tables on the numpy path (at most "
            f"{TABLE_LIMIT // 2**20} MB): use fewer beams or a wider fov, or "
            "the compiled path (numba, a dependency of tinyrace; not TINYRACE_LIDAR=numpy), "
            "whose lidar needs no tables"
        )


def build(config: LidarConfig, context: SensorContext) -> LidarSensor:
    """The lidar of ``config``; null knobs scale with the car (see LidarConfig)."""
    env = context.env
    length = context.car.length
    if config.max_range is not None:
        max_range = config.max_range
    else:  # F1TENTH's lidar on its maps, else 10 car lengths
        max_range = ROS_MAX_RANGE if env.facts.occupancy_map else 10 * length
    cell = config.cell if config.cell is not None else length / 8
    cone_colors = ((0, 0, 255), (255, 255, 0))  # picture tracks: blue and yellow cones
    return LidarSensor(
        config,
        max_range,
        cell,
        cone_colors,
        exact_only=env.facts.occupancy_map,
        settings=cache_settings(env),
        mount=context.car.lidar_mount,
    )
