"""Each compiled kernel's plain twin serves without numba: ``auto`` falls back to it, and
asking for ``numba`` is an error that says what to install (``tinyrace.kernels.choose``)."""

from __future__ import annotations

import sys

import pytest

from tinyrace.cars import dynamic_python
from tinyrace.cars.dynamic import physics_kernel
from tinyrace.render import drawing
from tinyrace.sensors import cones, lidar, raycast_numpy, texture
from tinyrace.tracks import procedural, procedural_source

KERNELS = {  # name: (compiled module, chooser, plain path's name, plain path)
    "lidar": ("tinyrace.sensors.raycast_numba", lidar.kernel, "numpy", raycast_numpy.cast),
    "tyres": ("tinyrace.cars.dynamic_numba", physics_kernel, "python", dynamic_python.car_forces),
    "cones": ("tinyrace.sensors.cones_numba", cones.kernel, "numpy", cones.NUMPY_PATH),
    "drawing": ("tinyrace.render.drawing_numba", drawing.kernel, "numpy", None),
    "trace": (
        "tinyrace.tracks.procedural_numba",
        procedural_source.trace_kernel,
        "python",
        procedural.trace_path,
    ),
    "texture": (
        "tinyrace.sensors.texture_numba",
        texture.compose_kernel,
        "numpy",
        texture.shift_scale_matrix,
    ),
}


@pytest.mark.parametrize("kernel", sorted(KERNELS))
def test_without_numba_auto_takes_the_plain_path_and_numba_is_an_error(monkeypatch, kernel):
    module, choose, plain, path = KERNELS[kernel]
    monkeypatch.setitem(sys.modules, "numba", None)  # import numba raises ImportError
    monkeypatch.delitem(sys.modules, module, raising=False)
    monkeypatch.delitem(sys.modules, "tinyrace.compiled", raising=False)  # imports numba too
    package, _, name = module.rpartition(".")
    monkeypatch.delattr(sys.modules[package], name, raising=False)
    for variable in (
        "TINYRACE_LIDAR",
        "TINYRACE_PHYSICS",
        "TINYRACE_CONES",
        "TINYRACE_DRAWING",
        "TINYRACE_TRACE",
    ):
        monkeypatch.delenv(variable, raising=False)
    assert choose() == (plain, path)
    assert choose("auto") == (plain, path)
    missing = r"=numba needs numba, which did not import: pip install numba"
    with pytest.raises(ImportError, match=missing):
        choose("numba")
