"""numba's compiler as tinyrace's kernels use it (only imported where numba is installed).

``compiler(what)`` gives a decorator that compiles a function with ``njit`` (no fastmath:
the kernels must give the Python or numpy path's bits) and caches its machine code beside
the module, or in numba's user cache directory when that is read-only. Where neither is
writable numba refuses ``cache=True``; the function then compiles at every start, with a
warning that names the kernel.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import TypeVar
from typing import cast as typed

from numba import njit

F = TypeVar("F")


def compiler(what: str) -> Callable[[F], F]:
    """A decorator compiling functions of the ``what`` kernel (e.g. "lidar")."""

    def compile_(function: F) -> F:
        try:
            return typed(F, njit(cache=True, nogil=True)(function))
        except RuntimeError as error:  # "cannot cache function ...: no locator available"
            warnings.warn(f"numba cannot cache the {what} kernel: {error}", stacklevel=2)
            return typed(F, njit(nogil=True)(function))

    return compile_
