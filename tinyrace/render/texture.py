"""A ground texture: the track drawn once, sampled by cameras with one affine warp each.

A texture holds a few levels of detail (each half the resolution of the one
before) so that a camera zoomed far out samples a small level instead of
aliasing a large one; a warp costs O(output pixels), never O(track size).
Levels are stored with four channels (RGB + padding): cv2 warps 4-channel
images about 2.5x faster than 3-channel ones.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

# Draws the ground into ``image`` given the world->pixel affine of that image.
Painter = Callable[[np.ndarray, np.ndarray], None]


def affine(scale_x: float, scale_y: float, angle: float, origin: tuple[float, float]) -> np.ndarray:
    """2x3 matrix: rotate world offsets by ``angle``, scale, then translate by ``origin``."""
    cos_a, sin_a = np.cos(angle), np.sin(angle)
    return np.array(
        [
            [scale_x * cos_a, -scale_x * sin_a, origin[0]],
            [scale_y * sin_a, scale_y * cos_a, origin[1]],
        ]
    )


def compose(outer: np.ndarray, inner: np.ndarray) -> np.ndarray:
    """The affine ``outer ∘ inner`` (apply inner first)."""
    result = outer[:, :2] @ inner
    result[:, 2] += outer[:, 2]
    return result


def invert(matrix: np.ndarray) -> np.ndarray:
    return cv2.invertAffineTransform(matrix)


def transform_points(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply a 2x3 affine to an (..., 2) array of points."""
    shape = points.shape
    flat = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 1, 2)
    return cv2.transform(flat, matrix).reshape(shape)


@dataclass
class GroundTexture:
    """Images of the ground at decreasing resolution, each with its world->pixel affine."""

    levels: list[np.ndarray]
    to_pixels: list[np.ndarray]  # per level: 2x3 world -> texture pixel
    border: tuple[int, int, int]  # colour outside the texture
    interpolation: int = cv2.INTER_LINEAR

    @classmethod
    def paint(
        cls,
        size: tuple[int, int],
        to_pixels: np.ndarray,
        painter: Painter,
        border: tuple[int, int, int] = (0, 0, 0),
    ) -> GroundTexture:
        """Draw the ground with ``painter`` at ``size`` (w, h); smaller levels are area-averaged."""
        image = np.empty((size[1], size[0], 4), np.uint8)
        painter(image, to_pixels)
        return cls.from_image(image, to_pixels, border)

    @classmethod
    def from_image(
        cls,
        image: np.ndarray,
        to_pixels: np.ndarray | None = None,
        border: tuple[int, int, int] = (0, 0, 0),
        extra_levels: int = 8,
        min_side: int = 64,
    ) -> GroundTexture:
        """An RGBx image (world->pixel affine ``to_pixels``, identity if None) and halved copies."""
        if to_pixels is None:
            to_pixels = np.array([[1.0, 0, 0], [0, 1.0, 0]])
        levels, matrices = [image], [to_pixels]
        while len(levels) <= extra_levels and min(levels[-1].shape[:2]) > min_side:
            h, w = levels[-1].shape[:2]
            half = ((w + 1) // 2, (h + 1) // 2)
            levels.append(cv2.resize(levels[-1], half, interpolation=cv2.INTER_AREA))
            matrices.append(matrices[-1] * [[half[0] / w], [half[1] / h]])
        return cls(levels, matrices, border)

    def __post_init__(self) -> None:
        # [texture px per world unit] of each level, for picking one by the output's scale
        self.scales = [float(np.sqrt(abs(np.linalg.det(m[:, :2])))) for m in self.to_pixels]
        self.from_pixels = [invert(m) for m in self.to_pixels]
        self._scratch: dict[tuple[int, int], np.ndarray] = {}  # 4-channel warp targets by size

    def level_for(self, out_pixels_per_unit: float) -> int:
        """The smallest level that still has at least one texture pixel per output pixel."""
        level = 0
        while level + 1 < len(self.levels) and self.scales[level + 1] >= out_pixels_per_unit:
            level += 1
        return level

    def warp(
        self,
        world_to_out: np.ndarray,
        size: tuple[int, int],
        out: np.ndarray | None = None,
        pixels_per_unit: float | None = None,
    ) -> np.ndarray:
        """Sample the ground seen through ``world_to_out`` into an RGB image of ``size`` (w, h).

        ``pixels_per_unit`` (output pixels per world unit) may be given when known.
        """
        if pixels_per_unit is None:
            pixels_per_unit = float(np.sqrt(abs(np.linalg.det(world_to_out[:, :2]))))
        level = self.level_for(pixels_per_unit)
        texture_to_out = compose(world_to_out, self.from_pixels[level])
        scratch = self._scratch.get(size)
        if scratch is None:
            scratch = self._scratch[size] = np.empty((size[1], size[0], 4), np.uint8)
        cv2.warpAffine(
            self.levels[level],
            texture_to_out,
            size,
            dst=scratch,
            flags=self.interpolation,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=(*self.border, 0),
        )
        return cv2.cvtColor(scratch, cv2.COLOR_RGBA2RGB, dst=out)

    def repaint(self, painter: Painter) -> None:
        """Draw on every level (e.g. a tile that changed colour)."""
        for image, matrix in zip(self.levels, self.to_pixels, strict=True):
            painter(image, matrix)

    @property
    def nbytes(self) -> int:
        return sum(level.nbytes for level in self.levels)
