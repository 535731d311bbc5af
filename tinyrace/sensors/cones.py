"""Cone detection core: the track's cones in range and field of view, in the car's frame.

Car frame: x ahead, y to the left [track units]. Detections come nearest first as a
fixed-size array of rows (x, y, class) padded with zeros, plus a count. Classes are the
cone map's (``tracks.cone_map.CLASSES``): 1 blue, 2 yellow, 3 orange, 4 big orange,
5 unknown (0 marks padding). Noise, misses and false positives are drawn from the
generator given, in a fixed order, so that the same seed gives the same detections.

A track that lists its cones (a cone map) is read as it is, by class; on picture tracks the
cones are the connected components of the cone colours (``cones_from_picture``), found once
per track.

Speed: a track's cones are kept as complex numbers (``ConeTable``, ``PlanePoints``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
from gymnasium import spaces

from tinyrace.config.sensors import ConesConfig
from tinyrace.sensors.base import SensorContext
from tinyrace.sensors.common import PerTrack, PlanePoints, Unsupported, car_length
from tinyrace.tracks.base import Track
from tinyrace.tracks.cone_map import CLASSES
from tinyrace.world.snapshot import Snapshot

CONE_CLASSES = CLASSES  # class id = index + 1; 0 is padding
MADE_UP_CLASSES = 3  # false positives are blue, yellow or orange
PAIRS = np.dtype((np.float64, (2,)))  # a complex array viewed as (N, 2) real rows


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
    dx, dy = points[:, 0] - x, points[:, 1] - y
    ahead = dx * c + dy * s
    left = dx * s - dy * c if y_down else dy * c - dx * s
    return np.stack([ahead, left], axis=1)


class ConeTable:
    """A track's cones ready for detection: positions (``PlanePoints``) and class ids."""

    def __init__(self, cones: np.ndarray):
        rows = np.asarray(cones, np.float64).reshape(-1, 3)  # x, y [track units], class id
        self.plane = PlanePoints.of(rows[:, :2])
        self.classes = rows[:, 2].copy()
        self.classes32 = self.classes.astype(np.float32)  # as detections hold them

    def __len__(self) -> int:
        return len(self.classes)


def detect(
    cones: np.ndarray | ConeTable,
    pose: tuple[float, float, float],
    y_down: bool,
    max_range: float,
    fov: float,
    capacity: int,
    noise: ConeNoise,
    rng: np.random.Generator,
) -> tuple[np.ndarray, int]:
    """((capacity, 3) float32 rows x, y, class, count) of ``cones`` (K, 3: x, y, class id
    1-3 [track units], or their ``ConeTable``) seen from ``pose`` within ``max_range``
    [track units] and ``fov`` [rad] centred ahead. Extra detections beyond ``capacity`` (the
    farthest) are dropped."""
    table = cones if isinstance(cones, ConeTable) else ConeTable(cones)
    local = table.plane.seen_from(pose, y_down)  # ahead + i left
    distance = np.abs(local)
    # within the fov: the bearing's cosine is at least cos(fov / 2), i.e. x >= cos * distance
    half = math.cos(min(fov, 2 * math.pi) / 2)
    seen = ((distance <= max_range) & (local.real >= half * distance)).nonzero()[0]
    if noise.miss_probability > 0 or noise.position_std > 0 or noise.false_positives > 0:
        found = local[seen].view(PAIRS)
        return _noisy(found, table.classes[seen], capacity, noise, rng, max_range, fov)
    order = seen[distance[seen].argsort(kind="stable")[:capacity]]
    count = len(order)
    rows = np.zeros((capacity, 3), np.float32)
    rows[:count, :2] = local[order].view(PAIRS)
    rows[:count, 2] = table.classes32[order]
    return rows, count


def _noisy(
    local: np.ndarray,
    classes: np.ndarray,
    capacity: int,
    noise: ConeNoise,
    rng: np.random.Generator,
    max_range: float,
    fov: float,
) -> tuple[np.ndarray, int]:
    """Misses, position noise and false positives, drawn from ``rng`` in that order."""
    found = np.column_stack([local, classes])
    if noise.miss_probability > 0:
        found = found[rng.random(len(found)) >= noise.miss_probability]
    if noise.position_std > 0:
        found[:, :2] += rng.normal(0.0, noise.position_std, (len(found), 2))
    if noise.false_positives > 0:
        found = np.concatenate([found, _false_positives(rng, noise, max_range, fov)])
    order = np.argsort(np.hypot(found[:, 0], found[:, 1]), kind="stable")[:capacity]
    rows = np.zeros((capacity, 3), np.float32)
    rows[: len(order)] = found[order]
    rows[:, :2] = np.clip(rows[:, :2], -max_range, max_range)  # noise may push past the range
    return rows, len(order)


def _false_positives(
    rng: np.random.Generator, noise: ConeNoise, max_range: float, fov: float
) -> np.ndarray:
    """Made-up cones spread evenly over the visible sector, of random classes."""
    count = int(rng.poisson(noise.false_positives))
    distance = max_range * np.sqrt(rng.random(count))  # even over the sector's area
    bearing = (rng.random(count) - 0.5) * min(fov, 2 * math.pi)
    classes = rng.integers(1, MADE_UP_CLASSES + 1, count)
    return np.column_stack([distance * np.cos(bearing), distance * np.sin(bearing), classes])


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

    def __init__(self, config: ConesConfig, max_range: float):
        self.config = config
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
        )
        return {"cones": rows, "count": count}


def build(config: ConesConfig, context: SensorContext) -> ConesSensor:
    """The cone detector: picture tracks (cones are blobs of the cone colours) or any track
    whose source lists cones."""
    env = context.env
    if env.kind == "procedural":
        raise Unsupported("expected a track with cones (an image track with cone colours)")
    max_range = config.max_range if config.max_range is not None else 10 * car_length(env)
    return ConesSensor(config, max_range)
