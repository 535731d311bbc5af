"""CarRacing's ground drawn once per reset: background, grass patches, road tiles, kerbs."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from tinyrace.render.texture import GroundTexture, transform_points
from tinyrace.track.procedural import ProceduralTrack

_SUBPIXEL_BITS = 4  # cv2 fixed-point vertices: 1/16 px precision
_KERB_RED = (255, 0, 0)
_KERB_WHITE = (255, 255, 255)


@dataclass(frozen=True)
class GroundColors:
    """RGB colours of one episode (domain randomisation redraws them)."""

    road: np.ndarray  # (3,) float: the tile colours add a small shade to it
    background: np.ndarray
    grass: np.ndarray


def tile_colors(road: np.ndarray, count: int) -> np.ndarray:
    """(count, 3) int colours: CarRacing shades tile i by 0.01*(i % 3) of full scale."""
    shade = 0.01 * (np.arange(count) % 3) * 255
    return (road[None, :] + shade[:, None]).astype(int)


def paint_ground(
    track: ProceduralTrack, colors: GroundColors, playfield: float, pixels_per_unit: float
) -> GroundTexture:
    """The whole playfield at ``pixels_per_unit`` plus halved levels of detail."""
    side = int(np.ceil(2 * playfield * pixels_per_unit))
    to_pixels = np.array(
        [
            [pixels_per_unit, 0, playfield * pixels_per_unit],
            [0, pixels_per_unit, playfield * pixels_per_unit],
        ]
    )
    shades = tile_colors(colors.road, len(track.tiles))

    def painter(image: np.ndarray, matrix: np.ndarray) -> None:
        image.view(np.uint32)[:] = _pack(colors.background)  # one 32-bit fill: fast
        _fill(image, matrix, _grass_squares(playfield), [colors.grass] * 400)
        _fill(image, matrix, track.tiles, shades)
        kerb_colors = [_KERB_RED if red else _KERB_WHITE for red in track.kerb_red]
        _fill(image, matrix, track.kerbs, kerb_colors)

    return GroundTexture.paint((side, side), to_pixels, painter)


def repaint_tile(
    texture: GroundTexture, track: ProceduralTrack, index: int, road: np.ndarray
) -> None:
    """A visited tile loses its shade and shows the plain road colour, as in CarRacing."""
    texture.repaint(
        lambda image, matrix: _fill(image, matrix, track.tiles[index : index + 1], [road])
    )


def _pack(color: np.ndarray) -> np.uint32:
    """An RGB colour as the 32-bit word of an RGBx pixel (alpha 255)."""
    return np.array([*color.astype(int), 255], np.uint8).view(np.uint32)[0]


def _grass_squares(playfield: float) -> np.ndarray:
    """(400, 4, 2): squares of side playfield/20 at every other cell in x and y."""
    side = playfield / 20
    cells = np.arange(-20, 20, 2) * side
    x, y = np.meshgrid(cells, cells, indexing="ij")
    corners = np.array([(0, 0), (side, 0), (side, side), (0, side)])
    return np.stack([x.ravel(), y.ravel()], axis=1)[:, None, :] + corners[None]


def _fill(image: np.ndarray, matrix: np.ndarray, polygons: np.ndarray, colors: list) -> None:
    """Fill world-unit polygons, antialiased, each in its colour (grouped by colour)."""
    if len(polygons) == 0:
        return
    pixels = np.round(transform_points(matrix, polygons) * (1 << _SUBPIXEL_BITS)).astype(np.int32)
    groups: dict[tuple[int, ...], list[np.ndarray]] = {}
    for poly, color in zip(pixels, colors, strict=True):
        groups.setdefault(tuple(int(c) for c in color), []).append(poly)
    for color, polys in groups.items():
        cv2.fillPoly(image, polys, (*color, 255), lineType=cv2.LINE_AA, shift=_SUBPIXEL_BITS)
