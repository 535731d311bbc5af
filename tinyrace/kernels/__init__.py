"""Which path a kernel runs: compiled (numba) or plain (numpy or Python), by environment variable.

Each compiled kernel (the lidar's ray casting, the tyre model, the cone detector, CarRacing's
drawing and its track's path) has a plain twin with the same results, and an environment
variable that chooses between them for what is built afterwards: ``auto`` (or unset) takes
the compiled module when numba imports (numba is a dependency of tinyrace; the plain twin
serves where it does not install or import), ``numba`` requires
it, and the plain path's name forces that.

The compiled twins live in a ``kernels/`` folder of the layer whose plain twin they match
(``tracks/kernels/``, ``cars/kernels/``, ``ground/kernels/``, ``sensors/kernels/``), each
module named as its plain twin; this bottom-layer package holds what they share: this
choice and numba's compiler (``compiled.py``).
"""

from __future__ import annotations

import importlib
import os
from types import ModuleType

# The drawing kernels span two layers (ground.texture's affine composition, the sensors'
# machinery.drawing's car and dashboard), so their one variable lives here: auto | numba | numpy
DRAWING_VARIABLE = "TINYRACE_DRAWING"


def choose(
    variable: str, plain: str, compiled: str, wanted: str | None = None
) -> tuple[str, ModuleType | None]:
    """(path name, the ``compiled`` module or None for the ``plain`` path) that ``wanted``
    (auto | numba | ``plain``; None: ``variable``'s value, else auto) names."""
    if wanted is None:
        wanted = os.environ.get(variable, "auto").strip().lower() or "auto"
    if wanted not in ("auto", "numba", plain):
        raise ValueError(f"{variable}={wanted!r}: expected auto, numba or {plain}")
    if wanted == plain:
        return plain, None
    try:
        module = importlib.import_module(compiled)  # numba is optional
    except ImportError as error:
        if wanted == "numba":
            raise ImportError(
                f"{variable}=numba needs numba, which did not import: pip install numba"
            ) from error
        return plain, None
    return "numba", module
