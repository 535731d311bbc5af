"""CarRacing's ground drawn once per reset: background, grass patches, road tiles, kerbs."""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np

from tinyrace.ground.texture import GroundTexture, transform_points
from tinyrace.tracks.base import Track
from tinyrace.tracks.procedural_source import GroundColors

_SUBPIXEL_BITS = 4  # cv2 fixed-point vertices: 1/16 px precision
LEVEL_ALIGN = 64  # texture sides are multiples of this: levels of detail halve exactly
_KERB_RED = (255, 0, 0)
_KERB_WHITE = (255, 255, 255)


def tile_colors(road: np.ndarray, count: int) -> np.ndarray:
    """(count, 3) int colours: CarRacing shades tile i by 0.01*(i % 3) of full scale."""
    shade = 0.01 * (np.arange(count) % 3) * 255
    colors: np.ndarray = (road[None, :] + shade[:, None]).astype(int)
    return colors


class GroundPainter:
    """Paints the ground textures of a procedural course.

    Background and grass depend only on the colours, the playfield and the resolution:
    they are drawn once and copied at each reset; tiles and kerbs are drawn on top.
    """

    def __init__(self, playfield: float):
        self.playfield = playfield  # [u]
        self._bases: dict[tuple[Any, ...], np.ndarray] = {}

    def paint(self, track: Track, colors: GroundColors, pixels_per_unit: float) -> GroundTexture:
        """The whole playfield at ``pixels_per_unit``; halved levels of detail follow on demand."""
        assert track.tiles is not None, "a painted ground has tiles"
        playfield = self.playfield
        side = int(np.ceil(2 * playfield * pixels_per_unit / LEVEL_ALIGN)) * LEVEL_ALIGN
        offset = playfield * pixels_per_unit
        to_pixels = np.array([[pixels_per_unit, 0, offset], [0, pixels_per_unit, offset]])
        image = self._base(colors, pixels_per_unit, side, to_pixels).copy()
        shades = tile_colors(colors.road, len(track.tiles))
        for k in range(min(3, len(track.tiles))):  # three shades: one fill call each
            _fill(image, to_pixels, track.tiles[k::3], shades[k])
        _fill(image, to_pixels, track.kerbs[track.kerb_red], _KERB_RED)
        _fill(image, to_pixels, track.kerbs[~track.kerb_red], _KERB_WHITE)
        return GroundTexture.from_image(image, to_pixels)

    def _base(
        self, colors: GroundColors, ppu: float, side: int, to_pixels: np.ndarray
    ) -> np.ndarray:
        key = (tuple(colors.background.astype(int)), tuple(colors.grass.astype(int)), ppu)
        base = self._bases.get(key)
        if base is None:
            if len(self._bases) > 4:  # domain randomisation: a new palette every reset
                self._bases.clear()
            base = np.zeros((side, side, 4), np.uint8)  # black beyond the playfield, as CarRacing
            inside = int(np.ceil(2 * self.playfield * ppu))
            base[:inside, :inside].view(np.uint32)[:] = _pack(colors.background)  # fast fill
            _fill(base, to_pixels, _grass_squares(self.playfield), colors.grass)
            self._bases[key] = base
        return base


def repaint_tile(texture: GroundTexture, track: Track, index: int, road: np.ndarray) -> None:
    """A visited tile loses its shade and shows the plain road colour, as in CarRacing."""
    tiles = track.tiles
    assert tiles is not None, "a painted ground has tiles"
    texture.repaint(lambda image, matrix: _fill(image, matrix, tiles[index : index + 1], road))


def _pack(color: np.ndarray) -> np.uint32:
    """An RGB colour as the 32-bit word of an RGBx pixel (alpha 255)."""
    word: np.uint32 = np.array([*color.astype(int), 255], np.uint8).view(np.uint32)[0]
    return word


def _grass_squares(playfield: float) -> np.ndarray:
    """(400, 4, 2): squares of side playfield/20 at every other cell in x and y."""
    side = playfield / 20
    cells = np.arange(-20, 20, 2) * side
    x, y = np.meshgrid(cells, cells, indexing="ij")
    corners = np.array([(0, 0), (side, 0), (side, side), (0, side)])
    squares: np.ndarray = np.stack([x.ravel(), y.ravel()], axis=1)[:, None, :] + corners[None]
    return squares


def _fill(image: np.ndarray, matrix: np.ndarray, polygons: np.ndarray, color: Any) -> None:
    """Fill world-unit polygons in one colour, antialiased, in one cv2 call."""
    if len(polygons) == 0:
        return
    pixels = np.round(transform_points(matrix, polygons) * (1 << _SUBPIXEL_BITS)).astype(np.int32)
    rgbx = (*(int(c) for c in color), 255)
    cv2.fillPoly(image, list(pixels), rgbx, lineType=cv2.LINE_AA, shift=_SUBPIXEL_BITS)
