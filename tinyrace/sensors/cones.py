"""Cone detection core: the track's cones in range and field of view, in the car's frame.

Car frame: x ahead, y to the left [track units]. Detections come nearest first as a
fixed-size array of rows (x, y, class) padded with zeros, plus a count. Classes are the
cone map's (``tracks.cone_map.CLASSES``): 1 blue, 2 yellow, 3 orange, 4 big orange,
5 unknown (0 marks padding). Noise, misses and false positives are drawn from the
generator given, in a fixed order, so that the same seed gives the same detections.

A track that lists its cones (a cone map) is read as it is, by class; on picture tracks the
cones are the connected components of the cone colours (``cones_from_picture``), found once
per track.

Speed: when numba imports (a dependency of tinyrace), ``kernels/cones.py``'s compiled
passes do the detection in one call, with the numpy passes' results bit for bit;
``TINYRACE_CONES`` (auto | numba | numpy) chooses the path of sensors built afterwards.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

import cv2
import numpy as np
from gymnasium import spaces

from tinyrace import kernels
from tinyrace.config.sensors import ConesConfig
from tinyrace.sensors.base import SensorContext, TopDown
from tinyrace.sensors.machinery.common import PerTrack
from tinyrace.tracks.base import Track
from tinyrace.tracks.cone_map import CLASSES
from tinyrace.world.snapshot import Snapshot

CONE_CLASSES = CLASSES  # class id = index + 1; 0 is padding
MADE_UP_CLASSES = 3  # false positives are blue, yellow or orange
KERNEL_VARIABLE = "TINYRACE_CONES"  # environment variable: auto | numba | numpy


@dataclass(frozen=True)
class ConeNoise:
    """How imperfect the detector is."""

    position_std: float = 0.0  # [track units] Gaussian noise on x and y of each detection
    miss_probability: float = 0.0  # chance that a visible cone is not reported
    false_positives: float = 0.0  # mean count per observation (Poisson) of made-up cones


def to_car_frame(points: np.ndarray, pose: tuple[float, float, float], y_down: bool) -> np.ndarray:
    """(N, 2) track points -> (N, 2) car frame (x ahead, y left) of a car at ``pose``
    (heading counter-clockwise on y-up tracks, clockwise on y-down image tracks)."""
    x, y, heading = pose
    c, s = math.cos(heading), math.sin(heading)
    return np.stack(_car_frame(points[:, 0], points[:, 1], x, y, c, s, y_down), axis=1)


def _car_frame(
    xs: np.ndarray, ys: np.ndarray, x: float, y: float, c: float, s: float, y_down: bool
) -> tuple[np.ndarray, np.ndarray]:
    """(ahead, left) [track units] of points (xs, ys) from (x, y) with heading cos ``c``,
    sin ``s``: the formula both detection paths compute (``kernels/cones.py`` in a loop)."""
    dx, dy = xs - x, ys - y
    return dx * c + dy * s, (dx * s - dy * c if y_down else dy * c - dx * s)


class ConeTable:
    """A track's cones ready for detection: x, y [track units] and class ids, each a
    contiguous float64 array (classes also as float32, as detections hold them)."""

    def __init__(self, cones: np.ndarray):
        rows = np.asarray(cones, np.float64).reshape(-1, 3)  # x, y [track units], class id
        self.xs, self.ys = rows[:, 0].copy(), rows[:, 1].copy()
        self.classes = rows[:, 2].copy()
        self.classes32 = self.classes.astype(np.float32)

    def __len__(self) -> int:
        return len(self.classes)


class Frame(NamedTuple):
    """Where a detector looks from and how far: the arguments of both paths' passes."""

    x: float  # [track units] the car's point the detections are relative to
    y: float
    c: float  # cos and sin of the heading
    s: float
    y_down: bool  # heading clockwise on y-down picture tracks
    max_range: float  # [track units]
    half: float  # cos(fov / 2): a cone is in the fov when ahead >= half * distance

    @classmethod
    def of(
        cls, pose: tuple[float, float, float], y_down: bool, max_range: float, fov: float
    ) -> Frame:
        """The frame of a car at ``pose`` seeing ``max_range`` [track units] and ``fov``
        [rad] centred ahead."""
        x, y, heading = pose
        half = math.cos(min(fov, 2 * math.pi) / 2)
        return cls(x, y, math.cos(heading), math.sin(heading), y_down, max_range, half)


class Sight(NamedTuple):
    """What a noisy detection needs besides its draws."""

    miss_probability: float
    max_range: float  # [track units]
    fov: float  # [rad], at most 2 pi


class Draws(NamedTuple):
    """A noisy detection's random numbers (``draw``), all uniform or Gaussian numbers that
    both paths turn into detections alike."""

    misses: np.ndarray  # (n,) uniform per visible cone: missed below miss_probability; (0,)
    offsets: np.ndarray  # (n, 2) [track units] position noise per visible cone; (0, 2)
    made_up: np.ndarray  # (k, 3) uniform per false positive: its distance, bearing, class


class Paths(NamedTuple):
    """A detection path's passes: ``nearest`` (the noiseless observation), ``found`` (the
    visible cones as (n, 3) float64 rows ahead, left, class in index order) and ``noisy``
    (the observation from those rows and their ``Draws``)."""

    nearest: Callable[[ConeTable, Frame, int], tuple[np.ndarray, int]]
    found: Callable[[ConeTable, Frame], np.ndarray]
    noisy: Callable[[np.ndarray, Draws, int, Sight], tuple[np.ndarray, int]]


def _numpy_seen(table: ConeTable, frame: Frame) -> tuple[np.ndarray, ...]:
    """(ahead, left, distance) of every cone [track units] and the indices of the visible."""
    x, y, c, s, y_down, max_range, half = frame
    ahead, left = _car_frame(table.xs, table.ys, x, y, c, s, y_down)
    distance = np.hypot(ahead, left)
    seen = ((distance <= max_range) & (ahead >= half * distance)).nonzero()[0]
    return ahead, left, distance, seen


def _numpy_nearest(table: ConeTable, frame: Frame, capacity: int) -> tuple[np.ndarray, int]:
    ahead, left, distance, seen = _numpy_seen(table, frame)
    order = seen[distance[seen].argsort(kind="stable")[:capacity]]
    count = len(order)
    rows = np.zeros((capacity, 3), np.float32)
    rows[:count, 0], rows[:count, 1] = ahead[order], left[order]
    rows[:count, 2] = table.classes32[order]
    return rows, count


def _numpy_found(table: ConeTable, frame: Frame) -> np.ndarray:
    ahead, left, _, seen = _numpy_seen(table, frame)
    return np.column_stack([ahead[seen], left[seen], table.classes[seen]])


def _numpy_noisy(
    found: np.ndarray, draws: Draws, capacity: int, sight: Sight
) -> tuple[np.ndarray, int]:
    rows = found.copy()
    if len(draws.offsets):
        rows[:, :2] += draws.offsets
    if len(draws.misses):
        rows = rows[draws.misses >= sight.miss_probability]
    rows = np.concatenate([rows, made_up(draws.made_up, sight)])
    order = np.argsort(np.hypot(rows[:, 0], rows[:, 1]), kind="stable")[:capacity]
    detected = np.zeros((capacity, 3), np.float32)
    detected[: len(order)] = rows[order]
    limit = sight.max_range
    detected[:, :2] = np.clip(detected[:, :2], -limit, limit)  # noise may pass the range
    return detected, len(order)


def made_up(uniforms: np.ndarray, sight: Sight) -> np.ndarray:
    """(k, 3) false positives ahead, left [track units], class (blue, yellow or orange) from
    (k, 3) uniform numbers: spread evenly over the visible sector's area. The C library's
    cos and sin (Python's ``math``, which numba calls too; numpy's may differ in the last
    bit on some processors)."""
    distance = sight.max_range * np.sqrt(uniforms[:, 0])
    bearing = ((uniforms[:, 1] - 0.5) * sight.fov).tolist()
    turn = np.array([[math.cos(b), math.sin(b)] for b in bearing]).reshape(-1, 2)
    classes = np.minimum(np.floor(uniforms[:, 2] * MADE_UP_CLASSES), MADE_UP_CLASSES - 1) + 1
    return np.column_stack([distance * turn[:, 0], distance * turn[:, 1], classes])


NUMPY_PATH = Paths(_numpy_nearest, _numpy_found, _numpy_noisy)


def kernel(wanted: str | None = None) -> tuple[str, Paths]:
    """The detection path ``wanted`` (auto | numba | numpy; None: ``TINYRACE_CONES``'s, else
    auto), by name: auto is ``numba`` (``kernels/cones.py``) when numba imports, else ``numpy``.
    Same results."""
    name, module = kernels.choose(
        KERNEL_VARIABLE, "numpy", "tinyrace.sensors.kernels.cones", wanted
    )
    if module is None:
        return name, NUMPY_PATH
    return name, Paths(module.nearest, module.found, module.noisy)


def detect(
    cones: np.ndarray | ConeTable,
    pose: tuple[float, float, float],
    y_down: bool,
    max_range: float,
    fov: float,
    capacity: int,
    noise: ConeNoise,
    rng: np.random.Generator,
    paths: Paths = NUMPY_PATH,
) -> tuple[np.ndarray, int]:
    """((capacity, 3) float32 rows x, y, class, count) of ``cones`` (K, 3: x, y, class id
    1-3 [track units], or their ``ConeTable``) seen from ``pose`` within ``max_range``
    [track units] and ``fov`` [rad] centred ahead, nearest first (ties in index order).
    Extra detections beyond ``capacity`` (the farthest) are dropped. ``paths``: the numpy
    passes or the compiled ones (``kernel``), with the same results."""
    table = cones if isinstance(cones, ConeTable) else ConeTable(cones)
    frame = Frame.of(pose, y_down, max_range, fov)
    if noise.miss_probability > 0 or noise.position_std > 0 or noise.false_positives > 0:
        found = paths.found(table, frame)
        sight = Sight(noise.miss_probability, max_range, min(fov, 2 * math.pi))
        return paths.noisy(found, draw(rng, noise, len(found)), capacity, sight)
    return paths.nearest(table, frame, capacity)


def draw(rng: np.random.Generator, noise: ConeNoise, visible: int) -> Draws:
    """The random numbers of a noisy detection of ``visible`` cones, in a fixed order (in
    four calls of ``rng`` at most: each costs microseconds): a uniform per visible cone for
    its miss, two Gaussians per visible cone for its position, the count of false positives
    (Poisson) and three uniforms per false positive."""
    misses = rng.random(visible) if noise.miss_probability > 0 else np.zeros(0)
    offsets = np.zeros((0, 2))
    if noise.position_std > 0:
        offsets = rng.normal(0.0, noise.position_std, (visible, 2))
    made_up = np.zeros((0, 3))
    if noise.false_positives > 0:
        made_up = rng.random((int(rng.poisson(noise.false_positives)), 3))
    return Draws(misses, offsets, made_up)


def cones_from_picture(picture: np.ndarray, colors: dict[int, tuple[int, int, int]]) -> np.ndarray:
    """(K, 3) x, y [px] (centroid) and class id of each connected blob of a cone colour in
    an RGBx ``picture``; ``colors`` maps class id -> RGB colour."""
    packed = picture.view(np.uint32)[:, :, 0]
    found = [np.zeros((0, 3))]
    for class_id, rgb in colors.items():
        word = np.array([*rgb, 255], np.uint8).view(np.uint32)[0]
        mask = ((packed | np.uint32(0xFF000000)) == word).astype(np.uint8)
        count, _, _, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
        centres = centroids[1:count]
        found.append(np.column_stack([centres, np.full(len(centres), class_id)]))
    return np.concatenate(found)


class ConesSensor:
    """``type: cones``: {"cones": (N, 3) float32 rows x, y [track units, car frame: ahead,
    left], within max_range (noise clipped), and class (1 blue, 2 yellow, 3 orange, 4 big
    orange, 5 unknown; 0 padding), "count": how many rows are used}."""

    def __init__(self, config: ConesConfig, max_range: float, kernel_name: str | None = None):
        self.config = config
        self.kernel, self._paths = kernel(kernel_name)  # by default TINYRACE_CONES's choice
        self.max_range = max_range  # [track units]
        self.noise = ConeNoise(config.position_std, config.miss_probability, config.false_positives)
        n = config.max_cones
        high = np.tile(np.array([max_range, max_range, len(CONE_CLASSES)], np.float32), (n, 1))
        low = (high * [-1, -1, 0]).astype(np.float32)
        self.space = spaces.Dict(
            {"cones": spaces.Box(low, high, dtype=np.float32), "count": spaces.Discrete(n + 1)}
        )
        self._cones: PerTrack[ConeTable] = PerTrack()
        self.cones = ConeTable(np.zeros((0, 3)))  # of the current track
        self.fov = math.radians(config.fov)  # [rad]

    @property
    def id(self) -> str:
        return self.config.id

    def describe(self) -> str:
        c = self.config
        return f"up to {c.max_cones} cones within {self.max_range:g} over {c.fov:g} deg"

    def top_down(self, snapshot: Snapshot, track: Track) -> TopDown | None:
        return None  # its observation is no picture from above

    def reset(self, track: Track) -> None:
        self.cones = self._cones.get(track, self._track_cones)

    def _track_cones(self, track: Track) -> ConeTable:
        if track.picture is None or len(track.cones):
            return ConeTable(np.asarray(track.cones, np.float64))
        c = self.config
        colors = {
            k + 1: rgb for k, rgb in enumerate((c.blue_color, c.yellow_color, c.orange_color))
        }
        used: dict[int, tuple[int, int, int]] = {k: v for k, v in colors.items() if v is not None}
        return ConeTable(cones_from_picture(track.picture, used))

    def observe(self, snapshot: Snapshot, track: Track, rng: np.random.Generator) -> dict[str, Any]:
        car = snapshot.car
        x, y = car.front_axle
        rows, count = detect(
            self.cones,
            (x, y, car.pose[2]),
            track.y_down,
            self.max_range,
            self.fov,
            self.config.max_cones,
            self.noise,
            rng,
            self._paths,
        )
        return {"cones": rows, "count": count}


def build(config: ConesConfig, context: SensorContext) -> ConesSensor:
    """The cone detector: picture tracks (cones are blobs of the cone colours) or any track
    whose source lists cones."""
    max_range = config.max_range if config.max_range is not None else 10 * context.car.length
    return ConesSensor(config, max_range)
