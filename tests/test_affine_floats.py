"""The chase view composes its affines in plain floats: the same bits as numpy's compose.

numpy's 2x2 @ 2x3 goes through OpenBLAS, which rounds each shift once with an FMA; the
float path reproduces that FMA exactly. If these tests fail on another machine, its BLAS
sums differently and the float path no longer matches its numpy results.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis_budget import examples

from tinyrace.ground.texture import (
    GroundTexture,
    compose,
    compose_shift_scale,
    fused_multiply_add,
)
from tinyrace.sensors.chase_view import chase_affine, chase_matrix

# finite, no subnormals, far from overflow: the range an affine of a track lives in
_FLOATS = st.one_of(
    st.just(0.0),
    st.floats(1e-60, 1e60),
    st.floats(-1e60, -1e-60),
    st.floats(-2000.0, 2000.0, allow_subnormal=False),
)
_ZERO = st.sampled_from([0.0, -0.0])


# any finite value whose products stay finite, subnormals included
_ANY = st.floats(-1e150, 1e150, allow_nan=False, allow_infinity=False)


@settings(max_examples=examples(1000), deadline=None)
@given(st.one_of(_FLOATS, _ANY), st.one_of(_FLOATS, _ANY), st.one_of(_FLOATS, _ANY))
def test_fused_multiply_add_rounds_the_exact_result_once(x, y, z) -> None:
    assert fused_multiply_add(x, y, z) == float(Fraction(x) * Fraction(y) + Fraction(z))


def test_fused_multiply_add_keeps_infinities_and_nans() -> None:
    assert fused_multiply_add(math.inf, 2.0, 1.0) == math.inf
    assert math.isnan(fused_multiply_add(math.inf, 0.0, 1.0))
    assert math.isnan(fused_multiply_add(1.0, 2.0, math.nan))


@settings(max_examples=examples(1000), deadline=None)
@given(
    st.tuples(*[_FLOATS] * 6),
    st.tuples(_FLOATS, _ZERO, _FLOATS, _ZERO, _FLOATS, _FLOATS),
)
def test_compose_shift_scale_gives_numpys_bits(outer, inner) -> None:
    want = compose(np.array(outer).reshape(2, 3), np.array(inner).reshape(2, 3))
    got = np.array(compose_shift_scale(outer, inner)).reshape(2, 3)
    assert np.array_equal(got, want)  # (a zero's sign aside: the warp ignores it)


def test_warp_affine_draws_what_warp_draws() -> None:
    """Random chase poses over every level of a shift-and-scale texture, pixel for pixel."""
    rng = np.random.default_rng(3)
    image = rng.integers(0, 256, (512, 384, 4), np.uint8)
    to_pixels = np.array([[1.5, 0.0, 200.0], [0.0, 1.5, 250.0]])
    texture = GroundTexture.from_image(image, to_pixels)
    size = (96, 84)
    for _ in range(150):
        position = (float(rng.uniform(-150, 150)), float(rng.uniform(-150, 150)))
        angle, zoom = float(rng.uniform(-7, 7)), float(rng.uniform(0.3, 20.0))
        ppu = zoom * math.sqrt(96 * 96 / (1000 * 800))
        want = texture.warp(chase_matrix(position, angle, zoom, (96, 96)), size, None, ppu)
        got = np.empty_like(want)
        texture.warp_affine(chase_affine(position, angle, zoom, (96, 96)), size, got, ppu)
        assert np.array_equal(got, want)
