"""The other cars of a race in a picture: each car's footprint on the ground, in its colour.

A car in a race sees the others. Every camera (``birdseye_camera``, ``perspective_camera``,
the default top view of tracks in metres, CarRacing's chase view) draws each car of the
snapshot it observes but the first (the car it rides on, drawn as before, or not at all)
as its footprint: the box from its rear to its front axle, its width wide, which the lidar
and the other cars meet. Colours are ``config.car_colors``, looked up by each car's index
in the world (``Snapshot.index``: a snapshot seen from car 2 still paints car 0 red).
With one car nothing is drawn and nothing is computed.

``classes`` images label every other car ``CAR_LABEL`` (never blended). The overview and
the videos also write each car's name beside it (``draw_names``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from tinyrace.cars.state import footprint_corners
from tinyrace.config import EnvConfig, car_colors, car_names
from tinyrace.config.colors import palette_color
from tinyrace.sensors.pinhole import Pinhole
from tinyrace.sensors.texture import transform_points
from tinyrace.world.snapshot import Snapshot

CAR_LABEL = 254  # the ``classes`` label of another car's footprint
Paint = tuple[int, ...]  # a pixel value in an image's own format: RGB, gray, or a label
_BITS = 4  # cv2 fixed-point vertices: 1/16 px
_LIMIT = float(1 << 20)  # [px] vertices are kept within this (cv2's int32 fixed point)
_NEAR = 1e-3  # [track units] footprint parts nearer to a camera's plane than this are cut


@dataclass(frozen=True)
class CarLooks:
    """Every car's colour (RGB) and name, by the car's index in the world."""

    colors: tuple[tuple[int, int, int], ...]
    names: tuple[str, ...]

    @classmethod
    def of(cls, config: EnvConfig) -> CarLooks:
        """The colours and names of ``config``'s cars (``car_colors``, ``car_names``)."""
        colors = tuple((int(c[0]), int(c[1]), int(c[2])) for c in car_colors(config))
        return cls(colors, tuple(car_names(config)))

    def paints(self, format: str) -> tuple[Paint, ...]:
        """Each car's paint in an image of ``format``: rgb (its colour), gray (as cv2 turns
        its colour to gray) or classes (``CAR_LABEL``)."""
        if format == "classes":
            return tuple((CAR_LABEL,) for _ in self.colors)
        if format == "gray":
            rgb = np.array([self.colors], np.uint8)
            gray = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY).reshape(-1).tolist()
            return tuple((int(g),) for g in gray)
        return self.colors


def _paint(paints: Sequence[Paint], index: int) -> Paint:
    """Car ``index``'s paint (the palette's colour when ``paints`` has none for it)."""
    return paints[index] if index < len(paints) else palette_color(index)


def fill_footprints(
    image: np.ndarray,
    world_to_pixels: np.ndarray,
    snapshot: Snapshot,
    paints: Sequence[Paint],
    antialias: bool = True,
    min_size: float = 0.0,
) -> None:
    """Every car of ``snapshot`` but the first, its footprint filled with its paint, through
    ``world_to_pixels`` (2x3: track -> pixel centres of ``image``); footprints smaller
    than ``min_size`` [px] grown about their centre to it (an overview of a long track)."""
    cars = snapshot.cars
    if len(cars) < 2:
        return
    corners = np.stack([footprint_corners(car) for car in cars[1:]])
    pixels = transform_points(world_to_pixels, corners)  # (K, 4, 2)
    if min_size > 0:
        centre = pixels.mean(axis=1, keepdims=True)
        span = np.ptp(pixels, axis=1).max(axis=1)[:, None, None]
        pixels = centre + (pixels - centre) * np.maximum(1.0, min_size / np.maximum(span, 1e-9))
    height, width = image.shape[:2]
    low, high = pixels.min(axis=1), pixels.max(axis=1)
    inside = (high[:, 0] >= -1) & (low[:, 0] <= width) & (high[:, 1] >= -1) & (low[:, 1] <= height)
    line = cv2.LINE_AA if antialias else cv2.LINE_8
    fixed = np.round(np.clip(pixels, -_LIMIT, _LIMIT) * (1 << _BITS)).astype(np.int32)
    for k in np.flatnonzero(inside).tolist():
        cv2.fillConvexPoly(image, fixed[k], _paint(paints, snapshot.index(k + 1)), line, _BITS)


def fill_footprints_seen(
    image: np.ndarray,
    camera: Pinhole,
    world_to_car: np.ndarray,
    snapshot: Snapshot,
    paints: Sequence[Paint],
    antialias: bool = True,
) -> None:
    """``fill_footprints`` for a pinhole ``camera`` (``image``: its whole picture) on the
    car placed by ``world_to_car`` (3x3: track -> car frame ahead, right): each footprint
    on the ground projected (cut at the camera's plane), or, through a distorting lens,
    the pixels whose ground point lies in it. The caller paints the sky over it after."""
    cars = snapshot.cars
    if len(cars) < 2:
        return
    corners = np.stack([footprint_corners(car) for car in cars[1:]])  # (K, 4, 2)
    flat = np.concatenate([corners.reshape(-1, 2), np.ones((corners.size // 2, 1))], axis=1)
    local = (flat @ world_to_car[:2].T).reshape(-1, 4, 2)  # ahead, right
    if camera.distorted:
        _fill_by_ground_points(image, camera, local, snapshot, paints)
        return
    line = cv2.LINE_AA if antialias else cv2.LINE_8
    height, width = image.shape[:2]
    for k, quad in enumerate(local):
        polygon = _project(camera, quad)
        if polygon is None:
            continue
        low, high = polygon.min(axis=0), polygon.max(axis=0)
        if high[0] < -1 or low[0] > width or high[1] < -1 or low[1] > height:
            continue
        fixed = np.round(np.clip(polygon, -_LIMIT, _LIMIT) * (1 << _BITS)).astype(np.int32)
        cv2.fillConvexPoly(image, fixed, _paint(paints, snapshot.index(k + 1)), line, _BITS)


def _project(camera: Pinhole, quad: np.ndarray) -> np.ndarray | None:
    """(M, 2) pixels of a ground quad ((4, 2) ahead, right) in front of ``camera``: the part
    behind its plane cut off (None: all of it is behind)."""
    ground = np.concatenate([quad, np.zeros((4, 1))], axis=1) - np.asarray(camera.position)
    seen = ground @ camera.axes.T  # x right, y down, z along the optical axis
    kept = _clip_near(seen)
    if len(kept) < 3:
        return None
    pixels = kept @ camera.intrinsics.T
    projected: np.ndarray = pixels[:, :2] / pixels[:, 2:3]
    return projected


def _clip_near(points: np.ndarray) -> np.ndarray:
    """The convex polygon ``points`` ((N, 3) camera frame) where z >= _NEAR (one
    Sutherland-Hodgman pass)."""
    if (points[:, 2] >= _NEAR).all():
        return points
    kept = []
    for a, b in zip(points, np.roll(points, -1, axis=0), strict=True):
        a_in, b_in = a[2] >= _NEAR, b[2] >= _NEAR
        if a_in:
            kept.append(a)
        if a_in != b_in:
            t = (_NEAR - a[2]) / (b[2] - a[2])
            kept.append(a + t * (b - a))
    return np.array(kept).reshape(-1, 3)


def _fill_by_ground_points(
    image: np.ndarray,
    camera: Pinhole,
    local: np.ndarray,
    snapshot: Snapshot,
    paints: Sequence[Paint],
) -> None:
    """Through a distorting lens: every pixel below the sky rows whose ground point
    (``Pinhole.ground_points``) lies inside a footprint ((K, 4, 2) in the car frame)."""
    rows = camera.sky_rows
    ahead, right = camera.ground_points[:, rows:]
    below = image[rows:]
    for k, quad in enumerate(local):
        origin, along, across = quad[0], quad[3] - quad[0], quad[1] - quad[0]
        length, width = float(np.hypot(*along)), float(np.hypot(*across))
        if length == 0 or width == 0:
            continue
        da, dr = ahead - np.float32(origin[0]), right - np.float32(origin[1])
        u = (da * np.float32(along[0]) + dr * np.float32(along[1])) / np.float32(length**2)
        v = (da * np.float32(across[0]) + dr * np.float32(across[1])) / np.float32(width**2)
        inside = (u >= 0) & (u <= 1) & (v >= 0) & (v <= 1)
        below[inside] = _paint(paints, snapshot.index(k + 1))


def draw_names(
    frame: np.ndarray,
    world_to_pixels: np.ndarray,
    snapshot: Snapshot,
    looks: CarLooks,
) -> None:
    """Each car's name in its colour (on a dark outline) just right of its footprint, through
    ``world_to_pixels`` (2x3: track -> pixels of ``frame``)."""
    scale = max(0.3, min(frame.shape[:2]) / 1000)
    thickness = max(1, round(scale * 1.5))
    height, width = frame.shape[:2]
    for k, car in enumerate(snapshot.cars):
        index = snapshot.index(k)
        name = looks.names[index] if index < len(looks.names) else f"car_{index}"
        corners = transform_points(world_to_pixels, footprint_corners(car))
        (_, top), (right, bottom) = corners.min(axis=0), corners.max(axis=0)
        (w, h), _ = cv2.getTextSize(name, cv2.FONT_HERSHEY_SIMPLEX, scale, thickness)
        x, y = round(right) + 4, round((top + bottom) / 2 + h / 2)  # right of the car
        if not (-w < x < width and 0 < y < height + h):
            continue
        color = looks.colors[index % len(looks.colors)]
        for paint, grow in (((0, 0, 0), 2), (color, 0)):
            cv2.putText(
                frame, name, (x, y), cv2.FONT_HERSHEY_SIMPLEX, scale, paint,
                thickness + grow, cv2.LINE_AA,
            )  # fmt: skip


def draw_race(
    frame: np.ndarray,
    world_to_pixels: np.ndarray,
    snapshot: Snapshot,
    looks: CarLooks,
    min_size: float = 0.0,
) -> None:
    """An overview's race: the other cars filled in their colours (at least ``min_size``
    [px]), then every car's name."""
    fill_footprints(frame, world_to_pixels, snapshot, looks.colors, min_size=min_size)
    draw_names(frame, world_to_pixels, snapshot, looks)
