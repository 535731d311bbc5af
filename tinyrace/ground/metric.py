"""The ground of a track in metres, drawn once per track.

The road (tiles), a start line, the cones by class and a ROS map's cells are drawn
into one RGBx texture with y up (north at the top of the picture); cameras sample it
with one affine warp, as on the other track kinds. ``shared_ground`` gives every env of
the same track the same read-only texture (``tinyrace.cache``: one per process, pages
shared between processes through a cache file).
"""

from __future__ import annotations

import cv2
import numpy as np

from tinyrace import cache
from tinyrace.cache.codec import DataclassCodec
from tinyrace.ground import texture
from tinyrace.ground.texture import GroundTexture, transform_points
from tinyrace.tracks.base import Track

MAX_SIDE = 8192  # [px] the texture's longest side
GROUND_PIXELS_PER_METER = 20.0  # [px/m] when the track names no resolution
ROAD = (102, 102, 102)  # RGB, CarRacing's road
GRASS = (102, 204, 102)  # RGB, CarRacing's background
START_LINE = (255, 255, 255)
CONE_COLORS = {  # RGB by class id (tinyrace.tracks.cone_map.CLASSES order, from 1)
    1: (0, 70, 255),
    2: (255, 220, 0),
    3: (255, 140, 0),
    4: (255, 90, 0),
    5: (160, 160, 160),
}
MAP_COLORS = {"free": ROAD, "unknown": (40, 40, 40), "occupied": (0, 0, 0)}
_BITS = 4  # cv2 fixed-point vertices: 1/16 px
TEXTURES = DataclassCodec(GroundTexture, GroundTexture.complete)  # stored with every level


def shared_ground(track: Track, settings: cache.Settings) -> GroundTexture:
    """``paint_ground`` of ``track`` at its ``ground_pixels_per_unit``, one read-only texture
    for every env of this track; in the cache folder of ``settings``."""
    pixels_per_meter = track.ground_pixels_per_unit or GROUND_PIXELS_PER_METER
    key = ("metric ground", cache.content(track), pixels_per_meter,
           cache.code(__file__, texture.__file__))  # fmt: skip
    return cache.shared(key, lambda: paint_ground(track, pixels_per_meter), settings, TEXTURES)


def paint_ground(track: Track, pixels_per_meter: float) -> GroundTexture:
    """The whole track (its bounds) at up to ``pixels_per_meter``, as a ground texture."""
    x0, y0, x1, y1 = track.bounds
    ppm = min(pixels_per_meter, MAX_SIDE / max(x1 - x0, y1 - y0))
    width, height = max(int(np.ceil((x1 - x0) * ppm)), 1), max(int(np.ceil((y1 - y0) * ppm)), 1)
    to_pixels = np.array([[ppm, 0.0, -x0 * ppm], [0.0, -ppm, y1 * ppm]])  # y up -> rows down
    image = np.zeros((height, width, 4), np.uint8)
    image[:] = (*GRASS, 255)
    if track.occupancy is not None:
        _paint_map(image, to_pixels, track)
    elif track.tiles is not None:
        _fill(image, to_pixels, track.tiles, ROAD)
    if track.circuit is not None and track.occupancy is None:
        _fill(image, to_pixels, _start_line(track), START_LINE)
    for (x, y, cls), radius in zip(track.cones, track.cone_radii, strict=True):
        centre = np.round(transform_points(to_pixels, np.array([x, y])) * (1 << _BITS))
        size = max(round(radius * ppm * (1 << _BITS)), 1 << _BITS)
        color = (*CONE_COLORS[int(cls)], 255)
        cv2.circle(image, tuple(int(v) for v in centre), size, color, -1, cv2.LINE_AA, _BITS)
    return GroundTexture.from_image(image, to_pixels, border=GRASS)


def _paint_map(image: np.ndarray, to_pixels: np.ndarray, track: Track) -> None:
    """The ROS map's cells, warped from map pixels into the texture."""
    occupancy = track.occupancy
    assert occupancy is not None
    cells = np.zeros((*occupancy.shape, 4), np.uint8)
    cells[:] = (*MAP_COLORS["unknown"], 255)
    cells[occupancy.free] = (*MAP_COLORS["free"], 255)
    cells[occupancy.occupied] = (*MAP_COLORS["occupied"], 255)
    # map pixel (col, row) -> world, from three pixel centres
    corners = occupancy.to_world(np.array([0, 0, 1]), np.array([0, 1, 0]))
    origin, along_col, along_row = corners[0], corners[1] - corners[0], corners[2] - corners[0]
    map_to_world = np.column_stack((along_col, along_row, origin))
    matrix = to_pixels[:, :2] @ map_to_world
    matrix[:, 2] += to_pixels[:, 2]
    cv2.warpAffine(
        cells,
        matrix,
        (image.shape[1], image.shape[0]),
        dst=image,
        flags=cv2.INTER_NEAREST,
        borderMode=cv2.BORDER_TRANSPARENT,
    )


def _start_line(track: Track) -> np.ndarray:
    """A 1 m band across the road at point 0."""
    circuit = track.circuit
    assert circuit is not None
    left, right = circuit.edges()
    heading = circuit.headings[0]
    ahead = 0.5 * np.array([np.cos(heading), np.sin(heading)])
    return np.array([[left[0] - ahead, right[0] - ahead, right[0] + ahead, left[0] + ahead]])


def _fill(
    image: np.ndarray, matrix: np.ndarray, polygons: np.ndarray, color: tuple[int, int, int]
) -> None:
    if len(polygons) == 0:
        return
    pixels = np.round(transform_points(matrix, polygons) * (1 << _BITS)).astype(np.int32)
    cv2.fillPoly(image, list(pixels), (*color, 255), lineType=cv2.LINE_AA, shift=_BITS)
