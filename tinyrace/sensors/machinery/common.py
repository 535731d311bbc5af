"""What several sensor types share: mounts in the car frame, and the ground of a track
drawn as colours or as class labels (the car's size comes from ``SensorContext.car``).

Car frame: x ahead, y to the left [track units]; headings follow the track's convention
(counter-clockwise on y-up tracks, clockwise on y-down picture tracks).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Generic, TypeVar

import cv2
import numpy as np

from tinyrace import cache
from tinyrace.tracks.base import Track

_SUBPIXEL_BITS = 4  # cv2 fixed-point vertices: 1/16 px
MAX_MAP_SIDE = 4096  # [cells] largest side of a map a sensor draws of a whole track

RGB = tuple[int, int, int]
LabelTable = tuple[tuple[str, RGB | None], ...]
FillValue = int | tuple[int, ...]
_T = TypeVar("_T")


def mount(
    front: tuple[float, float], heading: float, y_down: bool, ahead: float, left: float
) -> tuple[float, float]:
    """The track point ``ahead`` and ``left`` [track units] of the front axle's middle."""
    c, s = math.cos(heading), math.sin(heading)
    lx, ly = (s, -c) if y_down else (-s, c)
    return front[0] + ahead * c + left * lx, front[1] + ahead * s + left * ly


@dataclass(frozen=True, eq=False)
class PlanePoints:
    """Track points ready to be seen from a car: as complex numbers x + iy and as their
    mirror image x - iy (a y-down track is the mirror image of a y-up one), so that moving
    them into the car's frame is one subtraction and one multiplication (few numpy calls: at
    tens of points each call costs more than its arithmetic)."""

    points: np.ndarray  # (N,) complex x + iy [track units]
    mirrored: np.ndarray  # (N,) complex x - iy

    @classmethod
    def of(cls, xy: np.ndarray) -> PlanePoints:
        """From (N, 2) track points."""
        xy = np.asarray(xy, np.float64).reshape(-1, 2)
        points = xy[:, 0] + 1j * xy[:, 1]
        return cls(points, points.conj())

    def seen_from(
        self, pose: tuple[float, float, float], y_down: bool, part: slice = slice(None)
    ) -> np.ndarray:
        """(N,) complex ahead + i left [track units] of the points (``part`` of them) in the
        frame of a car at ``pose`` (heading counter-clockwise on y-up tracks, clockwise on
        y-down ones): the offset turned by -heading."""
        x, y, heading = pose
        c, s = math.cos(heading), math.sin(heading)
        local: np.ndarray
        if y_down:
            local = (self.mirrored[part] - complex(x, -y)) * complex(c, s)
        else:
            local = (self.points[part] - complex(x, y)) * complex(c, -s)
        return local


@dataclass(frozen=True, eq=False)
class GroundImage:
    """A whole-track image (colours RGBx, or labels) and the track -> pixel affine."""

    image: np.ndarray
    to_pixels: np.ndarray  # 2x3


def grid(track: Track, cell: float) -> tuple[np.ndarray, tuple[int, int], float]:
    """The track -> cell affine of a map covering ``track.bounds``, its (w, h), and the cell
    size [track units] used (grown so that no side passes MAX_MAP_SIDE)."""
    x0, y0, x1, y1 = track.bounds
    cell = max(cell, (x1 - x0) / MAX_MAP_SIDE, (y1 - y0) / MAX_MAP_SIDE)
    size = (math.ceil((x1 - x0) / cell), math.ceil((y1 - y0) / cell))
    to_cells = np.array([[1 / cell, 0, -x0 / cell - 0.5], [0, 1 / cell, -y0 / cell - 0.5]])
    return to_cells, size, cell


def fill_quads(
    image: np.ndarray, to_pixels: np.ndarray, quads: np.ndarray, value: FillValue
) -> None:
    """Fill (N, 4, 2) track-unit quads with ``value``, no antialiasing (labels stay pure)."""
    if len(quads) == 0:
        return
    flat = np.asarray(quads, np.float64).reshape(-1, 1, 2)
    pixels = cv2.transform(flat, to_pixels).reshape(-1, 4, 2)
    fixed = np.round(pixels * (1 << _SUBPIXEL_BITS)).astype(np.int32)
    cv2.fillPoly(image, list(fixed), value, lineType=cv2.LINE_8, shift=_SUBPIXEL_BITS)


def color_mask(picture: np.ndarray, rgb: tuple[int, int, int]) -> np.ndarray:
    """(H, W) bool: the pixels of an RGBx picture that have colour ``rgb``."""
    packed = picture.view(np.uint32)[:, :, 0] | np.uint32(0xFF000000)
    mask: np.ndarray = packed == np.array([*rgb, 255], np.uint8).view(np.uint32)[0]
    return mask


def label_table(track: Track) -> LabelTable:
    """Class labels of ``track``'s ground, label = position: background, road, then every
    obstacle colour, then the picture's other colours (markings), brightest last."""
    table: list[tuple[str, RGB | None]] = [("background", None), ("road", None)]
    named: set[RGB] = set()
    for layer in track.obstacles:
        rgb = _rgb(layer.color)
        table.append((f"{layer.name} #{_hex(rgb)}", rgb))
        named.add(rgb)
    if track.picture is not None:
        for rgb in _picture_colors(track.picture):
            if rgb not in named and rgb != (0, 0, 0):
                table.append((f"marking #{_hex(rgb)}", rgb))
    return tuple(table)


def label_names(table: LabelTable) -> dict[int, str]:
    """The name of each label value of ``table`` (label = position), as info shows them."""
    return {label: name for label, (name, _) in enumerate(table)}


def _hex(rgb: Sequence[float]) -> str:
    return "".join(f"{int(c):02x}" for c in rgb)


def _picture_colors(picture: np.ndarray) -> list[tuple[int, int, int]]:
    """The distinct colours of a binarised picture (each channel 0 or 255), in order."""
    bits = (picture[:, :, :3] > 127).astype(np.uint8)
    codes = np.unique(bits[:, :, 0] * 4 + bits[:, :, 1] * 2 + bits[:, :, 2])
    return [(255 * (c >> 2 & 1), 255 * (c >> 1 & 1), 255 * (c & 1)) for c in codes.tolist()]


def paint_labels(track: Track, table: LabelTable, pixels_per_unit: float) -> GroundImage:
    """The track's ground as uint8 labels (positions in ``label_table``)."""
    if track.picture is not None:
        labels = np.zeros(track.picture.shape[:2], np.uint8)
        for label, (_, rgb) in enumerate(table):
            if rgb is not None:
                labels[color_mask(track.picture, rgb)] = label
        return GroundImage(labels, np.array([[1.0, 0, 0], [0, 1.0, 0]]))
    to_pixels, (w, h), _ = grid(track, 1.0 / pixels_per_unit)
    labels = np.zeros((h, w), np.uint8)
    for surface in track.surfaces:
        if surface.name == "road":
            fill_quads(labels, to_pixels, surface.quads, 1)
    return GroundImage(labels, to_pixels)


def paint_colors(track: Track, pixels_per_unit: float) -> GroundImage:
    """The track's ground as RGBx colours: the picture, or the palette's background with
    the surfaces drawn in their palette colours."""
    if track.picture is not None:
        return GroundImage(track.picture, np.array([[1.0, 0, 0], [0, 1.0, 0]]))
    to_pixels, (w, h), _ = grid(track, 1.0 / pixels_per_unit)
    image = np.zeros((h, w, 4), np.uint8)
    image[:] = (*_rgb(track.palette.get("background", (0, 0, 0))), 255)
    for surface in track.surfaces:
        color = track.palette.get(surface.name, (128, 128, 128))
        fill_quads(image, to_pixels, surface.quads, (*_rgb(color), 255))
    return GroundImage(image, to_pixels)


def shared_ground(
    track: Track, what: str, pixels_per_unit: float, paint: Callable[[], GroundImage]
) -> GroundImage:
    """``paint()``, made once for every env of this process on a fixed track (read-only,
    ``tinyrace.cache``); on a procedural track, for this episode alone."""
    if track.drawn_per_reset:
        return paint()
    return cache.shared((what, cache.content(track), pixels_per_unit), paint)


def _rgb(color: Sequence[float]) -> RGB:
    r, g, b = (round(float(c)) for c in color[:3])
    return r, g, b


class Unsupported(ValueError):
    """A sensor entry that cannot work with this env config; the message says what can."""


class PerTrack(Generic[_T]):
    """What a sensor computes once per track (distance maps, cone lists, lines).

    Picture tracks last the env's life and each keeps its entry; a track that is made anew
    at every reset (procedural) keeps only the newest. Entries hold their track, so that
    an id is never reused while its entry lives.
    """

    def __init__(self) -> None:
        self._entries: dict[int, tuple[Track, _T]] = {}

    def get(self, track: Track, make: Callable[[Track], _T]) -> _T:
        entry = self._entries.get(id(track))
        if entry is None or entry[0] is not track:
            if track.drawn_per_reset:
                self._entries.clear()
            entry = self._entries[id(track)] = (track, make(track))
        return entry[1]
