"""The other cars of a race in a picture: each car's footprint on the ground, in its colour.

A car in a race sees the others. Every camera (``birdseye_camera``, ``perspective_camera``,
the default top view of tracks in metres, CarRacing's chase view) draws each car of the
snapshot it observes but the first (the car it rides on, drawn as before, or not at all)
as its footprint: the box from its rear to its front axle, its width wide, which the lidar
and the other cars meet. Colours are ``config.car_colors``, looked up by each car's index
in the world (``Snapshot.index``: a snapshot seen from car 2 still paints car 0 red).
With one car nothing is drawn and nothing is computed. Cars gone from the track
(``Snapshot.gone``: they finished the race and stand where they stopped, met by nothing)
are drawn by no camera and no overview, and not named: they left the race.

``classes`` images label every other car ``CAR_LABEL`` (never blended). The overview and
the videos also write each car's name beside it (``draw_names``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import cv2
import numpy as np

from tinyrace.cars.state import CarState, footprint_corners, footprint_points
from tinyrace.config import EnvConfig, car_colors, car_names
from tinyrace.config.colors import palette_color
from tinyrace.ground.texture import transform_points
from tinyrace.sensors.machinery.pinhole import Pinhole
from tinyrace.world.snapshot import Snapshot

CAR_LABEL = 254  # the ``classes`` label of another car's footprint
Paint = tuple[int, ...]  # a pixel value in an image's own format: RGB, gray, or a label
_BITS = 4  # cv2 fixed-point vertices: 1/16 px
_SCALE = 1 << _BITS
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


class _Geometry(NamedTuple):
    """A car's footprint in track units, worked out once per step for every camera."""

    car: CarState  # the state it is of (kept: its id is the cache's key)
    x: float  # the middle of the footprint
    y: float
    radius: float  # of the circle around the footprint
    corners: list[tuple[float, float]]  # footprint_points(car)


_GEOMETRY: dict[int, _Geometry] = {}  # by id of the CarState: every seat's cameras share it
_GEOMETRY_SIZE = 64  # entries kept (16 cars, a few steps)


def _geometry(car: CarState) -> _Geometry:
    """The footprint of ``car`` (one computation per car and step, then looked up)."""
    found = _GEOMETRY.get(id(car))
    if found is not None and found.car is car:
        return found
    corners = footprint_points(car)
    length, width = car.footprint
    radius = math.hypot(length, width) / 2
    (x0, y0), (x2, y2) = corners[0], corners[2]
    found = _Geometry(car, (x0 + x2) / 2, (y0 + y2) / 2, radius, corners)
    if len(_GEOMETRY) >= _GEOMETRY_SIZE:
        _GEOMETRY.clear()
    _GEOMETRY[id(car)] = found
    return found


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
    than ``min_size`` [px] grown about their centre to it (an overview of a long track).
    Cars out of the picture cost a few float operations; those in it, a few numpy calls
    together and one cv2 fill each."""
    if len(snapshot.cars) < 2:
        return
    (a, b, c), (d, e, f) = world_to_pixels.tolist()
    scale = math.sqrt(abs(a * e - b * d))  # [px per track unit]
    height, width = image.shape[:2]
    seen, grown = [], []
    gone = snapshot.gone
    for k, car in enumerate(snapshot.cars[1:], start=1):
        if k in gone:
            continue  # off the track
        _, x, y, radius, _ = _geometry(car)
        u, v = a * x + b * y + c, d * x + e * y + f
        reach = radius * scale + min_size + 2  # [px]
        if -reach <= u <= width + reach and -reach <= v <= height + reach:
            seen.append(k)
            grown.append(max(1.0, min_size / (2 * radius * scale)) if min_size > 0 else 1.0)
    if not seen:
        return
    corners = np.array([_geometry(snapshot.cars[k]).corners for k in seen])  # (M, 4, 2)
    pixels = corners @ world_to_pixels[:, :2].T + world_to_pixels[:, 2]
    if min_size > 0:
        middle = pixels.mean(axis=1, keepdims=True)
        pixels = middle + (pixels - middle) * np.array(grown)[:, None, None]
    fixed = np.rint(pixels * _SCALE).astype(np.int32)
    line = cv2.LINE_AA if antialias else cv2.LINE_8
    for k, polygon in zip(seen, fixed, strict=True):
        cv2.fillConvexPoly(image, polygon, _paint(paints, snapshot.index(k)), line, _BITS)


def _fill(image: np.ndarray, points: list[tuple[float, float]], paint: Paint, line: int) -> None:
    """One convex polygon (pixel centres, plain floats) filled at 1/16 px."""
    fixed = np.array([(round(x * _SCALE), round(y * _SCALE)) for x, y in points], np.int32)
    cv2.fillConvexPoly(image, fixed, paint, line, _BITS)


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
    the pixels whose ground point lies in it. The caller paints the sky over it after.
    A car behind the camera or beyond its ``max_range`` costs a few float operations."""
    if len(snapshot.cars) < 2:
        return
    seen = _in_front(camera, world_to_car, snapshot)
    if not seen:
        return
    to_car = world_to_car[:2]
    corners = np.array([_geometry(snapshot.cars[k]).corners for k in seen])  # (M, 4, 2)
    if camera.distorted:
        local = corners @ to_car[:, :2].T + to_car[:, 2]  # ahead, right
        _fill_by_ground_points(image, camera, local, seen, snapshot, paints)
        return
    # track -> camera frame (x right, y down, z along the optical axis): one affine
    axes = camera.axes[:, :2]
    shift = axes @ (to_car[:, 2] - camera.position[:2]) - camera.axes[:, 2] * camera.position[2]
    in_camera = corners @ (axes @ to_car[:, :2]).T + shift  # (M, 4, 3)
    in_front = (in_camera[..., 2] >= _NEAR).all(axis=1)
    homogeneous = in_camera @ camera.intrinsics.T
    depth = np.where(in_front[:, None], homogeneous[..., 2], 1.0)  # cut quads: _fill_cut's
    pixels = np.clip(homogeneous[..., :2] / depth[..., None], -_LIMIT, _LIMIT)
    height, width = image.shape[:2]
    low, high = pixels.min(axis=1), pixels.max(axis=1)
    inside = (high[:, 0] >= -1) & (low[:, 0] <= width) & (high[:, 1] >= -1) & (low[:, 1] <= height)
    fixed = np.rint(pixels * _SCALE).astype(np.int32)
    line = cv2.LINE_AA if antialias else cv2.LINE_8
    for i, k in enumerate(seen):
        paint = _paint(paints, snapshot.index(k))
        if in_front[i]:
            if inside[i]:
                cv2.fillConvexPoly(image, fixed[i], paint, line, _BITS)
        else:  # cut at the camera's plane
            _fill_cut(image, camera, in_camera[i].tolist(), paint, line)


def _fill_cut(
    image: np.ndarray, camera: Pinhole, quad: list[list[float]], paint: Paint, line: int
) -> None:
    """A quad ((x, y, z) corners in the camera frame) partly behind ``camera``: its part in
    front projected and filled."""
    kept = _clip_near([tuple(corner) for corner in quad])
    if len(kept) < 3:
        return
    (fx, _, cx), (_, fy, cy) = camera.intrinsics[:2].tolist()
    polygon = [
        (min(max(fx * x / z + cx, -_LIMIT), _LIMIT), min(max(fy * y / z + cy, -_LIMIT), _LIMIT))
        for x, y, z in kept
    ]
    height, width = image.shape[:2]
    us, vs = [p[0] for p in polygon], [p[1] for p in polygon]
    if max(us) < -1 or min(us) > width or max(vs) < -1 or min(vs) > height:
        return
    _fill(image, polygon, paint, line)


def _in_front(camera: Pinhole, world_to_car: np.ndarray, snapshot: Snapshot) -> list[int]:
    """The cars (indices in ``snapshot``) whose footprint may show in ``camera``'s
    picture: not wholly behind its image plane, nor beyond its ``max_range``."""
    (a, b, c), (d, e, f) = world_to_car[:2].tolist()
    px, py, pz = camera.position
    ox, oy, oz = camera.axes[2].tolist()  # the optical axis in the car frame
    reach = camera.max_range
    seen = []
    gone = snapshot.gone
    for k, car in enumerate(snapshot.cars[1:], start=1):
        if k in gone:
            continue  # off the track
        _, x, y, radius, _ = _geometry(car)
        ahead, right = a * x + b * y + c - px, d * x + e * y + f - py
        if ox * ahead + oy * right - oz * pz < -radius:
            continue  # behind the camera
        if reach is not None and math.hypot(ahead, right) - radius > reach:
            continue
        seen.append(k)
    return seen


def _clip_near(points: list[tuple[float, ...]]) -> list[tuple[float, ...]]:
    """The convex polygon ``points`` ((x, y, z) in the camera frame) where z >= _NEAR (one
    Sutherland-Hodgman pass)."""
    if all(p[2] >= _NEAR for p in points):
        return points
    kept: list[tuple[float, ...]] = []
    for a, b in zip(points, points[1:] + points[:1], strict=True):
        a_in, b_in = a[2] >= _NEAR, b[2] >= _NEAR
        if a_in:
            kept.append(a)
        if a_in != b_in:
            t = (_NEAR - a[2]) / (b[2] - a[2])
            kept.append(tuple(pa + t * (pb - pa) for pa, pb in zip(a, b, strict=True)))
    return kept


def _fill_by_ground_points(
    image: np.ndarray,
    camera: Pinhole,
    local: np.ndarray,
    seen: list[int],
    snapshot: Snapshot,
    paints: Sequence[Paint],
) -> None:
    """Through a distorting lens: every pixel below the sky rows whose ground point
    (``Pinhole.ground_points``) lies inside a footprint ((K, 4, 2) in the car frame, of
    the cars ``seen``)."""
    rows = camera.sky_rows
    ahead, right = camera.ground_points[:, rows:]
    below = image[rows:]
    for k, quad in zip(seen, local, strict=True):
        origin, along, across = quad[0], quad[3] - quad[0], quad[1] - quad[0]
        length, width = float(np.hypot(*along)), float(np.hypot(*across))
        if length == 0 or width == 0:
            continue
        da, dr = ahead - np.float32(origin[0]), right - np.float32(origin[1])
        u = (da * np.float32(along[0]) + dr * np.float32(along[1])) / np.float32(length**2)
        v = (da * np.float32(across[0]) + dr * np.float32(across[1])) / np.float32(width**2)
        inside = (u >= 0) & (u <= 1) & (v >= 0) & (v <= 1)
        below[inside] = _paint(paints, snapshot.index(k))


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
        if k and k in snapshot.gone:
            continue  # off the track (the car seen from is named: the picture is of it)
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
