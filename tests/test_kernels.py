"""Each compiled kernel's plain twin serves without numba: ``auto`` falls back to it, and
asking for ``numba`` is an error that says what to install (``tinyrace.kernels.choose``)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

import tinyrace
from tinyrace.cars import dynamic_python
from tinyrace.cars.dynamic import physics_kernel
from tinyrace.ground import texture
from tinyrace.sensors import cones, lidar
from tinyrace.sensors.machinery import drawing, other_cars, raycast_numpy
from tinyrace.tracks import procedural, procedural_source

KERNELS = {  # name: (compiled module, chooser, plain path's name, plain path)
    "lidar": ("tinyrace.sensors.kernels.raycast", lidar.kernel, "numpy", raycast_numpy.cast),
    "other_cars": (
        "tinyrace.sensors.kernels.other_cars",
        lidar.cars_kernel,
        "numpy",
        other_cars.add_cars,
    ),
    "tyres": ("tinyrace.cars.kernels.dynamic", physics_kernel, "python", dynamic_python.car_forces),
    "cones": ("tinyrace.sensors.kernels.cones", cones.kernel, "numpy", cones.NUMPY_PATH),
    "drawing": ("tinyrace.sensors.kernels.drawing", drawing.kernel, "numpy", None),
    "trace": (
        "tinyrace.tracks.kernels.procedural",
        procedural_source.trace_kernel,
        "python",
        procedural.trace_path,
    ),
    "texture": (
        "tinyrace.ground.kernels.texture",
        texture.compose_kernel,
        "numpy",
        texture.shift_scale_matrix,
    ),
}


def test_every_compiled_twin_in_a_kernels_folder_is_listed_here():
    package = Path(tinyrace.__file__).parent
    files = sorted(package.glob("*/kernels/*.py"))
    twins = {".".join(("tinyrace", *f.relative_to(package).with_suffix("").parts)) for f in files}
    twins = {t for t in twins if not t.endswith(".__init__")}
    assert twins and twins == {module for module, *_ in KERNELS.values()}


@pytest.mark.parametrize("kernel", sorted(KERNELS))
def test_without_numba_auto_takes_the_plain_path_and_numba_is_an_error(monkeypatch, kernel):
    module, choose, plain, path = KERNELS[kernel]
    monkeypatch.setitem(sys.modules, "numba", None)  # import numba raises ImportError
    monkeypatch.delitem(sys.modules, module, raising=False)
    monkeypatch.delitem(sys.modules, "tinyrace.kernels.compiled", raising=False)  # imports numba
    package, _, name = module.rpartition(".")
    if package in sys.modules:  # a layer's kernels/ package comes with its first kernel
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
