"""The car seen from above: hull, wheels and skid marks, drawn from a physics snapshot.

Small frames (the 96x96 observation) would lose the car's shape to cv2's
antialiasing, so the car is drawn there at 4x into a patch, area-averaged
down (like the reference's smooth scaling) and blended. A chase camera turns
with the hull, so that patch only depends on the zoom and the steering angle:
it is cached and reused from step to step. A cached patch is drawn from the placement
its key stands for, never from the pose of the step that first asked for it, so it is
the same picture whichever env or step drew it: the envs of a process (and thread)
that draw the same car at the same frame size share one cache.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Sequence
from typing import Any

import cv2
import numpy as np

from tinyrace.cars.dynamic_shape import HULL_POLYGONS, SIZE, WHEEL_HALF_WIDTH, WHEEL_RADIUS
from tinyrace.cars.state import CarState, SkidView
from tinyrace.ground.texture import Affine, as_matrix, compose, transform_points
from tinyrace.sensors.machinery.drawing import blend as numpy_blend
from tinyrace.sensors.machinery.drawing import kernel as drawing_kernel

HULL_COLOR = (204, 0, 0)  # RGB
WHEEL_COLOR = (0, 0, 0)
SKID_ROAD_COLOR = (0, 0, 0)
SKID_GRASS_COLOR = (102, 102, 0)  # mud
SUPERSAMPLE = 4
_BITS = 3  # subpixel precision of cv2 vertices
_WHEEL_BOX = np.array([(-1, -1), (1, -1), (1, 1), (-1, 1)], float) * (
    WHEEL_HALF_WIDTH,
    WHEEL_RADIUS,
)
# top row, left column, weight, premultiplied colour (float32, rows x columns x 3), float32
# scratch of the same shape (the numpy path's)
Patch = tuple[int, int, np.ndarray, np.ndarray, np.ndarray]
Patches = dict[tuple[float, int], Patch | None]  # by (zoom, steering step)
Placement = Callable[[float], Affine]  # a cache key -> the car body frame -> output pixels
_STEER_STEP = 0.005  # [rad] steering resolution of cached patches
_MAX_PATCHES = 2048  # cached car pictures per view size (a few kB each)
# the process's patches by (frame shape, thread, car scale, wheel positions): a thread's
# own, as the numpy path blends through a patch's scratch
_SHARED: dict[tuple[Any, ...], Patches] = {}
_MISSING: Any = object()  # not cached yet (a cached None: the car is outside the frame)


class CarSprite:
    """Draws CarRacing's car from its state; polygons are prepared per car size, transformed
    per frame."""

    def __init__(self, supersample: bool, drawing: str | None = None):
        """``drawing``: the blend's path (auto | numba | numpy; see ``drawing.kernel``)."""
        self.supersample = supersample
        self.drawing, module = drawing_kernel(drawing)
        self._blend = None if module is None else module.blend
        self._patches: Patches | None = None  # the shared cache of this car and frame shape
        self._where: tuple[Any, ...] = ()  # (frame shape, thread) ``_patches`` is for
        self._scale: float | None = None  # the car size the polygons below are for
        self.hull: list[np.ndarray] = []
        self.wheel_box = _WHEEL_BOX

    def draw(
        self,
        image: np.ndarray,
        car: CarState,
        world_to_out: np.ndarray | Affine,
        skid_width: int,
        cache_key: float | None = None,
        placement: Placement | None = None,
    ) -> None:
        """Skid marks (unless ``skid_width`` is 0), wheels, then hull into ``image``.

        ``world_to_out`` is a 2x3 array or six floats (row by row). ``cache_key`` (e.g. a
        chase camera's zoom) with ``placement`` promises that the car's body frame ->
        output pixels is ``placement(cache_key)`` at every step with that key: its patches
        are drawn from that once and reused.
        """
        if car.scale != self._scale:
            unit = SIZE * car.scale
            self.hull = [np.array(poly, float) * unit for poly in HULL_POLYGONS]
            self.wheel_box = _WHEEL_BOX * unit
            self._scale = car.scale
            self._patches = None  # another car: its own patches
        if skid_width and car.skids is not None and car.skids.lengths.any():
            _draw_skids(image, as_matrix(world_to_out), car.skids, skid_width)
        if self.supersample:
            steer = round(car.wheels[0].steer / _STEER_STEP)
            if cache_key is None or placement is None:
                patch = self._patch(image.shape, car, _local_to_out(car, world_to_out), steer)
            else:
                patches = self._patches_for(image.shape, car)
                key = (cache_key, steer)
                patch = patches.get(key, _MISSING)
                if patch is _MISSING:
                    body_to_out = as_matrix(placement(cache_key))
                    patch = self._patch(image.shape, car, body_to_out, steer)
                    if len(patches) >= _MAX_PATCHES:
                        patches.clear()
                    patches[key] = patch
            if patch is not None:
                top, left, weight, color, scratch = patch
                if self._blend is None:
                    numpy_blend(image, top, left, weight, color, scratch)
                else:
                    self._blend(image, top, left, weight, color)
            return
        polygons = self._polygons(car, car.wheels[0].steer)
        local_to_out = _local_to_out(car, world_to_out)
        _fill(image, local_to_out, polygons[:4], WHEEL_COLOR)
        _fill(image, local_to_out, polygons[4:], HULL_COLOR)

    def _patch(
        self, shape: tuple[int, ...], car: CarState, body_to_out: np.ndarray, steer: int
    ) -> Patch | None:
        """The car with its steering at ``steer`` steps, placed by ``body_to_out``, cut to
        a frame of ``shape`` (None: outside it)."""
        return _clip(shape, *self._render_patch(car, body_to_out, steer * _STEER_STEP))

    def _patches_for(self, shape: tuple[int, ...], car: CarState) -> Patches:
        """The shared patches of ``car``'s shape in frames of ``shape``."""
        patches, where = self._patches, (shape, threading.get_ident())
        if patches is None or where != self._where:
            spots = tuple(wheel.position for wheel in car.wheels)
            patches = self._patches = _SHARED.setdefault((*where, car.scale, spots), {})
            self._where = where
        return patches

    def _polygons(self, car: CarState, steer: float) -> list[np.ndarray]:
        """Four wheels (front ones steered) then the hull, in the body's frame."""
        cos_s, sin_s = math.cos(steer), math.sin(steer)
        front = self.wheel_box @ np.array([[cos_s, sin_s], [-sin_s, cos_s]])
        boxes = (front, front, self.wheel_box, self.wheel_box)
        return [box + w.position for box, w in zip(boxes, car.wheels, strict=True)] + self.hull

    def _render_patch(
        self, car: CarState, local_to_out: np.ndarray, steer: float
    ) -> tuple[int, int, np.ndarray, np.ndarray]:
        """The car drawn at 4x around its bounding box, averaged down: (x0, y0, rgb, alpha).

        All polygons go through each transform together (cv2 maps every point alike, so
        this is the per-polygon result); the two fills share their vertices."""
        polygons = self._polygons(car, steer)
        points = transform_points(local_to_out, np.concatenate(polygons))
        (left, top), (right, bottom) = points.min(axis=0).tolist(), points.max(axis=0).tolist()
        x0, y0 = math.floor(left) - 1, math.floor(top) - 1
        x1, y1 = math.ceil(right) + 1, math.ceil(bottom) + 1
        # into the 4x patch with _BITS subpixel bits: powers of two scale exactly, so this is
        # the affine (4, 0, -4 x0; 0, 4, -4 y0) then the subpixel scaling, rounded alike
        scale = SUPERSAMPLE << _BITS
        vertices = np.round(points * scale - (x0 * scale, y0 * scale)).astype(np.int32)
        pixels, start = [], 0
        for polygon in polygons:
            pixels.append(vertices[start : start + len(polygon)])
            start += len(polygon)
        size = ((x1 - x0) * SUPERSAMPLE, (y1 - y0) * SUPERSAMPLE)
        color = np.zeros((size[1], size[0], 3), np.uint8)
        alpha = np.zeros((size[1], size[0]), np.uint8)
        for polys, rgb in ((pixels[:4], WHEEL_COLOR), (pixels[4:], HULL_COLOR)):
            cv2.fillPoly(color, polys, rgb, cv2.LINE_8, _BITS)
            cv2.fillPoly(alpha, polys, 255, cv2.LINE_8, _BITS)
        small = (x1 - x0, y1 - y0)
        color = cv2.resize(color, small, interpolation=cv2.INTER_AREA).astype(np.float32) + 0.5
        alpha = cv2.resize(alpha, small, interpolation=cv2.INTER_AREA).astype(np.float32) / 255
        # premultiplied: frame = frame * (1 - a) + color * a, color already holds color * a
        weight = np.repeat(1.0 - alpha[:, :, None], 3, axis=2)
        return x0, y0, color, weight


def _local_to_out(car: CarState, world_to_out: np.ndarray | Affine) -> np.ndarray:
    """The car's body frame -> output pixels."""
    x, y, _ = car.pose
    cos_a, sin_a = math.cos(car.hull_angle), math.sin(car.hull_angle)
    return compose(as_matrix(world_to_out), np.array([[cos_a, -sin_a, x], [sin_a, cos_a, y]]))


def _clip(
    shape: tuple[int, ...], x0: int, y0: int, color: np.ndarray, weight: np.ndarray
) -> Patch | None:
    """A patch cut to the frame: (top row, left column, weight, premultiplied colour,
    scratch)."""
    h, w = color.shape[:2]
    ax, ay, bx, by = max(x0, 0), max(y0, 0), min(x0 + w, shape[1]), min(y0 + h, shape[0])
    if ax >= bx or ay >= by:
        return None
    if (bx - ax, by - ay) != (w, h):  # cut: keep contiguous copies of the part inside
        inside = (slice(ay - y0, by - y0), slice(ax - x0, bx - x0))
        weight, color = weight[inside].copy(), color[inside].copy()
    return ay, ax, weight, color, np.empty_like(weight)


def _draw_skids(image: np.ndarray, world_to_out: np.ndarray, skids: SkidView, width: int) -> None:
    """All skid marks in one transform and one polyline call per colour."""
    points = np.round(transform_points(world_to_out, skids.points) * (1 << _BITS)).astype(np.int32)
    road: list[np.ndarray] = []
    grass: list[np.ndarray] = []
    for slot in np.flatnonzero(skids.lengths).tolist():
        (grass if skids.on_grass[slot] else road).append(points[slot, : skids.lengths[slot]])
    for lines, color in ((road, SKID_ROAD_COLOR), (grass, SKID_GRASS_COLOR)):
        if lines:
            cv2.polylines(image, lines, False, color, width, cv2.LINE_AA, _BITS)


def _fill(
    image: np.ndarray,
    matrix: np.ndarray,
    polygons: Sequence[np.ndarray],
    color: tuple[int, ...] | int,
    antialias: bool = True,
) -> None:
    pixels = [
        np.round(transform_points(matrix, p) * (1 << _BITS)).astype(np.int32) for p in polygons
    ]
    cv2.fillPoly(image, pixels, color, cv2.LINE_AA if antialias else cv2.LINE_8, _BITS)
