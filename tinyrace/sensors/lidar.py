"""Lidar core: a distance field of the blocking layers, and vectorised ray marching on it.

The field is built once per track with ``cv2.distanceTransform``: for every free cell, the
distance to the nearest blocking cell, turned into a safe marching step. All beams march
together (sphere tracing): each round, every beam samples the step under its tip with one
``cv2.remap`` and moves by it; a beam whose tip lies in a blocking cell gets a step of 0 and
stays. A few bisection rounds then put each hit on the boundary of the cell it entered.
There is a Python loop over rounds, never over beams.

With ``hit_classes``, each beam also reports what it hit: 0 nothing (max_range), 1 a wall
(off-road, walls, obstacles), 1 + k a cone of class k (``tracks.cone_map.CLASSES``).

Units: the field works in cells; ``to_cells`` maps track units to cell coordinates (a cell's
centre on integer coordinates, as image pixels) and ranges come back in track units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
from gymnasium import spaces

from tinyrace.config.sensors import LidarConfig
from tinyrace.sensors.base import SensorContext
from tinyrace.sensors.common import (
    RGB,
    PerTrack,
    car_length,
    color_mask,
    fill_boxes,
    fill_quads,
    grid,
    mount,
)
from tinyrace.tracks.base import Track
from tinyrace.tracks.cone_map import CLASSES, RADII
from tinyrace.world.snapshot import Snapshot

MIN_STEP = 1.0  # [cells] smallest step of a free beam: near walls it keeps beams moving
STEP_CAP = 127.5  # [cells] largest step (uint8 half cells)
OVERSHOOT = 2.0  # [cells] a tip enters a blocking cell less than this far past its edge
BISECTIONS = 3  # rounds that halve the overshoot bracket: error <= OVERSHOOT / 8
CHECK_EVERY = 4  # rounds between checks whether every beam has stopped
NO_HIT, WALL_CLASS = 0, 1  # hit classes; a cone of class k is WALL_CLASS + k
CONE_RADII = np.array([0.0, *(RADII[name] for name in CLASSES)])  # [m] by cone class id


@dataclass(frozen=True, eq=False)
class DistanceField:
    """Marching steps of one blocking map: 0 in blocking cells, >= MIN_STEP elsewhere.

    Steps are stored in half cells as uint8 (a quarter of float32's bytes: the samples of a
    scan land all over the map, and a smaller map stays in the caches), rounded down so
    that they stay safe; a step is at most STEP_CAP cells.
    """

    steps: np.ndarray  # (H, W) uint8 [half cells]
    to_cells: np.ndarray  # 2x3 affine: track units -> cell coordinates
    cells_per_unit: float  # [cells per track unit]
    classes: np.ndarray | None = None  # (H, W) uint8 hit class of blocking cells and their rim

    @property
    def shape(self) -> tuple[int, int]:
        return self.steps.shape


def distance_field(
    blocking: np.ndarray, to_cells: np.ndarray, classes: np.ndarray | None = None
) -> DistanceField:
    """The field of a boolean (H, W) map of blocking cells, ``to_cells`` track -> cell affine;
    ``classes`` (H, W) uint8 hit classes of the blocking cells, when beams report them.

    A free cell's step is its centre's Euclidean distance to the nearest blocking cell's centre
    less half a cell (the blocking cell's edge), never below MIN_STEP. Outside the map counts
    as blocking (``cast`` samples it as 0).
    """
    free = np.where(blocking, 0, 255).astype(np.uint8)
    distance = cv2.distanceTransform(free, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)  # [cells]
    halves = np.floor(2 * np.clip(distance - 0.5, MIN_STEP, STEP_CAP))
    steps = halves.astype(np.uint8)
    steps[blocking] = 0
    scale = math.sqrt(abs(np.linalg.det(to_cells[:, :2])))
    if classes is not None:  # a tip may stop a rounding error short: its rim has the class too
        classes = np.where(classes > 0, classes, cv2.dilate(classes, np.ones((3, 3), np.uint8)))
    return DistanceField(steps, np.asarray(to_cells, np.float64), scale, classes)


def hit_classes(
    field: DistanceField,
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
    inside = (col >= 0) & (col < width) & (row >= 0) & (row < height) & (ranges < max_range)
    found = np.zeros(len(ranges), np.uint8)
    found[inside] = field.classes[row[inside], col[inside]]
    return found


def cast(
    field: DistanceField,
    origin: tuple[float, float],
    directions: np.ndarray,
    max_range: float,
    max_rounds: int = 256,
) -> np.ndarray:
    """Ranges [track units] (float32) of beams from ``origin`` along ``directions``.

    ``directions`` is (B, 2): unit vectors in track units (see ``directions``). A beam that
    hits nothing within ``max_range`` [track units] returns ``max_range``; a beam that starts
    in a blocking cell returns 0. ``max_rounds`` bounds the marching rounds (beams still
    moving then report where they got to).
    """
    linear = field.to_cells[:, :2] / field.cells_per_unit  # a rotation (or a reflection)
    start = (field.to_cells @ (origin[0], origin[1], 1.0)).astype(np.float32)
    d = (directions @ linear.T).astype(np.float32)  # (B, 2) unit vectors in cells
    dx, dy = np.ascontiguousarray(d[:, 0]), np.ascontiguousarray(d[:, 1])
    limit = np.float32(max_range * field.cells_per_unit)  # [cells]
    t = _march(field.steps, start, dx, dy, limit, max_rounds)
    t = _refine(field.steps, start, dx, dy, t)
    # clipped after the division: limit / cells_per_unit may round past max_range in float32
    ranges: np.ndarray = np.minimum(t / np.float32(field.cells_per_unit), np.float32(max_range))
    return ranges


def _march(
    steps: np.ndarray,
    start: np.ndarray,
    dx: np.ndarray,
    dy: np.ndarray,
    limit: np.float32,
    max_rounds: int,
) -> np.ndarray:
    """Distance [cells] each beam travels before it stops in a blocking cell or passes
    ``limit``. Every CHECK_EVERY rounds the beams that stopped leave the working arrays."""
    t_all = np.zeros(len(dx), np.float32)
    index = np.arange(len(dx))
    t = t_all.copy()
    px, py = np.full_like(dx, start[0]), np.full_like(dy, start[1])
    for round_ in range(max_rounds):
        step = _sample(steps, px, py)
        t += step
        px += step * dx
        py += step * dy
        if round_ % CHECK_EVERY == CHECK_EVERY - 1:
            going = (step > 0) & (t < limit)
            if not going.all():
                t_all[index] = t
                index, t, px, py = index[going], t[going], px[going], py[going]
                dx, dy = dx[going], dy[going]
                if len(index) == 0:
                    return t_all
    t_all[index] = t
    return t_all


def _sample(steps: np.ndarray, px: np.ndarray, py: np.ndarray) -> np.ndarray:
    """The step [cells] in the cell under each tip (nearest cell); 0 outside the map."""
    found = cv2.remap(steps, px[None], py[None], cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT)
    step: np.ndarray = found[0] * np.float32(0.5)
    return step


def _refine(
    steps: np.ndarray, start: np.ndarray, dx: np.ndarray, dy: np.ndarray, t: np.ndarray
) -> np.ndarray:
    """Bisect each hit back toward the edge of the blocking cell it entered: a tip overshoots
    an edge by less than OVERSHOOT cells."""
    blocked = _sample(steps, start[0] + t * dx, start[1] + t * dy) == 0
    low = np.where(blocked, np.maximum(t - OVERSHOOT, 0), t)
    high = t
    for _ in range(BISECTIONS):
        mid = (low + high) * np.float32(0.5)
        hit = _sample(steps, start[0] + mid * dx, start[1] + mid * dy) == 0
        high = np.where(hit, mid, high)
        low = np.where(hit, low, mid)
    refined: np.ndarray = np.where(blocked, high, t)
    return refined


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


def blocking_map(
    track: Track,
    blocks: tuple[str, ...],
    cell: float,
    cone_colors: tuple[RGB, ...],
    classes: bool = False,
) -> DistanceField:
    """The distance field of what ``blocks`` names on ``track``, ``cell`` [track units] per
    cell: off_road (outside the road surfaces, on tracks that have them), walls (a ROS map's
    occupied cells), obstacles (picture tracks' obstacle colours), cones (the track's cones,
    e.g. a cone map's, or the picture's cone colours, ``cone_colors`` by class id - 1).
    ``classes``: keep each blocking cell's hit class for ``hit_classes``."""
    to_cells, (w, h), cell = grid(track, cell)
    labels = np.zeros((h, w), np.uint8)  # hit class of each cell, 0 free
    roads = [s.quads for s in track.surfaces if s.name == "road"]
    if "off_road" in blocks and roads:
        labels[:] = WALL_CLASS
        for quads in roads:
            fill_quads(labels, to_cells, quads, NO_HIT)
    if "walls" in blocks:
        fill_boxes(labels, to_cells, track.walls, WALL_CLASS)
    if "cones" in blocks and len(track.cones):
        _draw_cones(labels, to_cells, track, 1.0 / cell)
    if track.picture is not None:
        colors = [layer.color for layer in track.obstacles] if "obstacles" in blocks else []
        picture = _picture_labels(track.picture, colors, cone_colors if "cones" in blocks else ())
        if picture.shape != labels.shape:
            picture = cv2.resize(picture, (w, h), interpolation=cv2.INTER_NEAREST)
        labels = np.where(picture > 0, picture, labels)
    return distance_field(labels > 0, to_cells, labels if classes else None)


def _draw_cones(labels: np.ndarray, to_cells: np.ndarray, track: Track, per_unit: float) -> None:
    """The track's cones as discs of their class's base radius (tracks in metres), or one
    cell each (tracks of unknown scale), labelled by class."""
    ids = np.clip(track.cones[:, 2].astype(np.int64), 0, len(CLASSES))
    metres = track.metres_per_unit
    radii = CONE_RADII[ids] / metres * per_unit if metres else np.zeros(len(ids))  # [cells]
    for (x, y, _), class_id, radius in zip(track.cones.tolist(), ids, radii, strict=True):
        cx, cy = to_cells @ (x, y, 1.0)
        cv2.circle(labels, (round(cx), round(cy)), round(radius), WALL_CLASS + int(class_id), -1)


def _picture_labels(
    picture: np.ndarray, obstacles: list[RGB], cone_colors: tuple[RGB, ...]
) -> np.ndarray:
    """(H, W) uint8 hit classes of a picture track's obstacle and cone colours."""
    labels = np.zeros(picture.shape[:2], np.uint8)
    for rgb in obstacles:
        labels[color_mask(picture, rgb)] = WALL_CLASS
    for class_id, rgb in enumerate(cone_colors, start=1):
        labels[color_mask(picture, rgb)] = WALL_CLASS + class_id
    return labels


class LidarSensor:
    """``type: lidar``: (beams,) float32 ranges [track units], rightmost beam first."""

    def __init__(
        self, config: LidarConfig, max_range: float, cell: float, cone_colors: tuple[RGB, ...]
    ):
        self.config = config
        self.max_range = max_range  # [track units]
        self.cell = cell  # [track units]
        self.cone_colors = cone_colors
        self.angles = beam_angles(config.beams, math.radians(config.fov))  # [rad] + left
        ranges = spaces.Box(0.0, max_range, (config.beams,), np.float32)
        self.space: spaces.Space[Any] = ranges
        if config.hit_classes:
            hits = spaces.Box(0, WALL_CLASS + len(CLASSES), (config.beams,), np.uint8)
            self.space = spaces.Dict({"ranges": ranges, "classes": hits})
        self._fields: PerTrack[DistanceField] = PerTrack()
        self.field: DistanceField | None = None

    @property
    def id(self) -> str:
        return self.config.id

    def reset(self, track: Track) -> None:
        c = self.config
        self.field = self._fields.get(
            track, lambda t: blocking_map(t, c.blocks, self.cell, self.cone_colors, c.hit_classes)
        )

    def origin(self, snapshot: Snapshot, track: Track) -> tuple[float, float]:
        """[track units] where the beams start."""
        car = snapshot.car
        ahead, left = self.config.position
        return mount(car.front_axle, car.pose[2], track.y_down, ahead, left)

    def observe(self, snapshot: Snapshot, track: Track, rng: np.random.Generator) -> Any:
        """The ranges; with ``hit_classes``, {"ranges", "classes"} (dropped beams: NO_HIT)."""
        heading = snapshot.car.pose[2]
        beams = directions(self.angles, heading, track.y_down)
        assert self.field is not None, "reset() before observe()"
        origin = self.origin(snapshot, track)
        ranges = cast(self.field, origin, beams, self.max_range)
        c = self.config
        classes = (
            hit_classes(self.field, origin, beams, ranges, self.max_range)
            if c.hit_classes
            else None
        )
        if c.range_std > 0 or c.dropout > 0:
            ranges = add_noise(ranges, rng, c.range_std, c.dropout, self.max_range)
        if classes is None:
            return ranges
        classes[ranges >= self.max_range] = NO_HIT
        return {"ranges": ranges, "classes": classes}


def build(config: LidarConfig, context: SensorContext) -> LidarSensor:
    """The lidar of ``config``; null knobs scale with the car (see LidarConfig)."""
    env = context.env
    length = car_length(env)
    max_range = config.max_range if config.max_range is not None else 10 * length
    cell = config.cell if config.cell is not None else (1.0 if env.kind == "image" else length / 8)
    cone_colors = ((0, 0, 255), (255, 255, 0))  # picture tracks: blue and yellow cones
    return LidarSensor(config, max_range, cell, cone_colors)
