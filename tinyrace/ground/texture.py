"""A ground texture: the track drawn once, sampled by cameras with one affine warp each.

A texture holds a few levels of detail (each half the resolution of the one
before) so that a camera zoomed far out samples a small level instead of
aliasing a large one; a warp costs O(output pixels), never O(track size).
Levels are stored with four channels (RGB + padding): cv2 warps 4-channel
images about 2.5x faster than 3-channel ones.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction

import cv2
import numpy as np

from tinyrace import kernels

# Draws the ground into ``image`` given the world->pixel affine of that image.
Painter = Callable[[np.ndarray, np.ndarray], None]
# A 2x3 affine as six plain floats, row by row: (m00, m01, m02, m10, m11, m12)
Affine = tuple[float, float, float, float, float, float]
_IDENTITY = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
_SPLITTER = 134217729.0  # 2**27 + 1: splits a float64 into two 26-bit halves (Veltkamp)
_TINY, _HUGE = 2.0**-900, 2.0**900  # where Dekker's exact product holds, with margin
# 4-channel warp targets by (w, h, thread), shared by every texture of the process: a warp
# is followed at once by its colour conversion, so one buffer per size and thread serves
# them all, and envs stepped together in one process keep one in the caches, not one each
_SCRATCH: dict[tuple[int, int, int], np.ndarray] = {}


def compose(outer: np.ndarray, inner: np.ndarray) -> np.ndarray:
    """The affine ``outer ∘ inner`` (apply inner first)."""
    result: np.ndarray = outer[:, :2] @ inner
    result[:, 2] += outer[:, 2]
    return result


def fused_multiply_add(x: float, y: float, z: float) -> float:
    """``x * y + z`` rounded once, as an FMA instruction does (math.fma arrived in Python 3.13).

    The product is split exactly into ``high + low`` (Dekker), and math.fsum rounds the
    exact sum of the three once. Where that split would be inexact (a product near the
    subnormals, a value near overflow) the exact sum is taken in fractions instead;
    non-finite values take the plain formula (the same infinities and NaNs)."""
    high = x * y
    if not (math.isfinite(high) and math.isfinite(z)):
        return high + z
    if x == 0.0 or y == 0.0:
        return high + z  # an exact product: one rounding
    if not (_TINY < abs(high) < _HUGE and abs(x) < _HUGE and abs(y) < _HUGE and abs(z) < _HUGE):
        return float(Fraction(x) * Fraction(y) + Fraction(z))
    c = _SPLITTER * x
    x_high = c - (c - x)
    x_low = x - x_high
    c = _SPLITTER * y
    y_high = c - (c - y)
    y_low = y - y_high
    low = ((x_high * y_high - high) + x_high * y_low + x_low * y_high) + x_low * y_low
    return math.fsum((z, high, low))


def compose_shift_scale(outer: Affine, inner: Affine) -> Affine:
    """``compose(outer, inner)`` in plain floats, bit for bit, for an ``inner`` whose
    off-diagonal terms are zero (a scale and a shift, e.g. texture pixels -> world).

    numpy's 2x2 @ 2x3 goes through OpenBLAS, whose kernel sums each entry as
    ``fma(o[i][1], inner[1][j], o[i][0] * inner[0][j])``; with zero off-diagonal terms that
    is plain arithmetic except in the shift column, where the FMA is reproduced exactly.
    """
    o00, o01, o02, o10, o11, o12 = outer
    sx, zero_01, tx, zero_10, sy, ty = inner
    return (
        o00 * sx + o01 * zero_10,  # the second product is a zero: exact, as in the FMA
        o00 * zero_01 + o01 * sy,
        fused_multiply_add(o01, ty, o00 * tx) + o02,
        o10 * sx + o11 * zero_10,
        o10 * zero_01 + o11 * sy,
        fused_multiply_add(o11, ty, o10 * tx) + o12,
    )


def shift_scale_matrix(outer: Affine, inner: Affine) -> np.ndarray:
    """``compose_shift_scale`` as a 2x3 array (the plain path of ``compose_kernel``)."""
    return as_matrix(compose_shift_scale(outer, inner))


def compose_kernel(wanted: str | None = None) -> tuple[str, Callable[[Affine, Affine], np.ndarray]]:
    """(path name, ``shift_scale_matrix``'s path) that ``wanted`` names (auto | numba |
    numpy; None: ``TINYRACE_DRAWING``'s value, else auto): numba's compiled one
    (``kernels/texture.py``) when numba imports, else the plain one. Same bits."""
    name, module = kernels.choose(
        kernels.DRAWING_VARIABLE, "numpy", "tinyrace.ground.kernels.texture", wanted
    )
    return name, shift_scale_matrix if module is None else module.shift_scale_matrix


def _six(matrix: np.ndarray) -> Affine:
    """A 2x3 array as six floats."""
    a, b, c, d, e, f = matrix.ravel().tolist()
    return (a, b, c, d, e, f)


def as_matrix(affine: Affine | np.ndarray) -> np.ndarray:
    """Six floats as a 2x3 array (an array is returned as it is)."""
    if isinstance(affine, np.ndarray):
        return affine
    a, b, c, d, e, f = affine
    return np.array([[a, b, c], [d, e, f]])


def invert(matrix: np.ndarray) -> np.ndarray:
    return cv2.invertAffineTransform(matrix)


def transform_points(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply a 2x3 affine to an (..., 2) array of points."""
    shape = points.shape
    flat = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 1, 2)
    return cv2.transform(flat, matrix).reshape(shape)


@dataclass
class GroundTexture:
    """Images of the ground at decreasing resolution, each with its world->pixel affine.

    Level 0 is the full image; level k halves it k times. Levels past 0 are made from
    level 0 (area-averaged) the first time a camera needs them.
    """

    levels: list[np.ndarray | None]
    to_pixels: list[np.ndarray]  # per level: 2x3 world -> texture pixel
    sizes: list[tuple[int, int]]  # per level: (w, h)
    border: tuple[int, int, int] = (0, 0, 0)  # colour outside the texture
    interpolation: int = cv2.INTER_LINEAR
    # Sample level 0 only: no pixel is ever averaged with its neighbours before the warp, so
    # the inside of a marking keeps its exact colour however far a camera zooms out (as
    # tinycarlo's crop-and-resize camera does). Picture tracks need it; their colours mean
    # things. Off: pick the level that matches the camera's scale (smooth, no aliasing).
    exact_colors: bool = False

    @classmethod
    def from_image(
        cls,
        image: np.ndarray,
        to_pixels: np.ndarray | None = None,
        border: tuple[int, int, int] = (0, 0, 0),
        min_side: int = 64,
        exact_colors: bool = False,
    ) -> GroundTexture:
        """An RGBx image (world->pixel affine ``to_pixels``, identity if None) and its levels."""
        if to_pixels is None:
            to_pixels = np.array([[1.0, 0, 0], [0, 1.0, 0]])
        h, w = image.shape[:2]
        sizes, matrices = [(w, h)], [to_pixels]
        while min(sizes[-1]) > min_side:
            pw, ph = sizes[-1]
            half = ((pw + 1) // 2, (ph + 1) // 2)
            sizes.append(half)
            matrices.append(to_pixels * [[half[0] / w], [half[1] / h]])
        levels: list[np.ndarray | None] = [image, *[None] * (len(sizes) - 1)]
        return cls(levels, matrices, sizes, border, exact_colors=exact_colors)

    def image(self, level: int) -> np.ndarray:
        """The pixels of ``level``, made on first use by halving the level above it
        (an exact 2x area average when the sizes are even: cv2's fast path)."""
        pixels = self.levels[level]
        if pixels is None:
            finer = self.image(level - 1)
            pixels = cv2.resize(finer, self.sizes[level], interpolation=cv2.INTER_AREA)
            pixels.setflags(write=finer.flags.writeable)  # a shared texture stays read-only
            self.levels[level] = pixels
        return pixels

    def complete(self) -> None:
        """Make every level now (a texture about to be stored whole)."""
        for level in range(len(self.levels)):
            self.image(level)

    def __post_init__(self) -> None:
        # [texture px per world unit] of each level, for picking one by the output's scale
        self.scales = [float(np.sqrt(abs(np.linalg.det(m[:, :2])))) for m in self.to_pixels]
        self.from_pixels = [invert(m) for m in self.to_pixels]
        # levels whose pixels are the world's units (image tracks' level 0): no compose needed
        self._unit = [bool(np.array_equal(m, _IDENTITY)) for m in self.from_pixels]
        # levels whose pixels -> world is a scale and a shift: composed in plain floats
        self._shift_scale: list[Affine | None] = [
            _six(m) if m[0, 1] == 0 and m[1, 0] == 0 else None for m in self.from_pixels
        ]
        self._border_value = (*self.border, 0)  # the warp's RGBx outside the texture
        self.drawing: str | None = None  # the composition's path (numba | numpy), at first use
        self._compose: Callable[[Affine, Affine], np.ndarray] | None = None

    def level_for(self, out_pixels_per_unit: float) -> int:
        """The smallest level that still has at least one texture pixel per output pixel
        (always 0 with ``exact_colors``)."""
        if self.exact_colors:
            return 0
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
        texture_to_out = (
            world_to_out if self._unit[level] else compose(world_to_out, self.from_pixels[level])
        )
        return self._warp_level(level, texture_to_out, size, out)

    def warp_affine(
        self, world_to_out: Affine, size: tuple[int, int], out: np.ndarray, pixels_per_unit: float
    ) -> np.ndarray:
        """``warp`` for a world -> output affine given as six floats (the same pixels; the
        composition with the level's affine costs no numpy call on scale-and-shift levels)."""
        level = self.level_for(pixels_per_unit)
        inner = self._shift_scale[level]
        if self._unit[level]:
            texture_to_out = as_matrix(world_to_out)
        elif inner is not None:
            compose_to = self._compose or self._choose_compose()
            texture_to_out = compose_to(world_to_out, inner)
        else:
            texture_to_out = compose(as_matrix(world_to_out), self.from_pixels[level])
        return self._warp_level(level, texture_to_out, size, out)

    def _choose_compose(self) -> Callable[[Affine, Affine], np.ndarray]:
        """The composition's path, chosen at the first warp (numba is imported then)."""
        self.drawing, self._compose = compose_kernel()
        return self._compose

    def _warp_level(
        self, level: int, texture_to_out: np.ndarray, size: tuple[int, int], out: np.ndarray | None
    ) -> np.ndarray:
        """Sample ``level`` through ``texture_to_out`` into an RGB image of ``size`` (w, h)."""
        key = (*size, threading.get_ident())
        scratch = _SCRATCH.get(key)
        if scratch is None:
            scratch = _SCRATCH[key] = np.empty((size[1], size[0], 4), np.uint8)
        pixels = self.levels[level]
        cv2.warpAffine(
            self.image(level) if pixels is None else pixels,
            texture_to_out,
            size,
            dst=scratch,
            flags=self.interpolation,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=self._border_value,
        )
        return cv2.cvtColor(scratch, cv2.COLOR_RGBA2RGB, dst=out)

    def repaint(self, painter: Painter) -> None:
        """Draw on level 0 (e.g. a tile that changed colour); smaller levels are made anew
        from it when next needed, so a level never depends on when it was first made."""
        base = self.levels[0]
        assert base is not None  # level 0 is never dropped
        painter(base, self.to_pixels[0])
        for level in range(1, len(self.levels)):
            self.levels[level] = None
