"""Which path CarRacing's view draws its car and dashboard with: compiled or numpy.

``TINYRACE_DRAWING`` chooses (``tinyrace.kernels.choose``): ``auto`` (or unset) takes the
compiled kernels of ``kernels/drawing.py`` when numba imports (a dependency of tinyrace),
``numba`` requires them, ``numpy`` forces the numpy path. Same pixels.
"""

from __future__ import annotations

from types import ModuleType

import numpy as np

from tinyrace import kernels
from tinyrace.kernels import DRAWING_VARIABLE


def kernel(wanted: str | None = None) -> tuple[str, ModuleType | None]:
    """(path name, the compiled module or None for numpy) that ``wanted`` names (auto |
    numba | numpy; None: ``TINYRACE_DRAWING``'s value, else auto)."""
    return kernels.choose(DRAWING_VARIABLE, "numpy", "tinyrace.sensors.kernels.drawing", wanted)


def blend(
    image: np.ndarray,
    top: int,
    left: int,
    weight: np.ndarray,
    color: np.ndarray,
    scratch: np.ndarray,
) -> None:
    """The patch whose corner is (``top``, ``left``) over ``image``: ``pixel * weight +
    color`` in float32, truncated to uint8, in place (same-type ufuncs into the float32
    ``scratch`` skip numpy's mixed-type casting loops)."""
    rows, cols = weight.shape[:2]
    region = image[top : top + rows, left : left + cols]
    scratch[...] = region
    np.multiply(scratch, weight, out=scratch)
    np.add(scratch, color, out=scratch)
    region[...] = scratch
