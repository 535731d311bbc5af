"""CarRacing's view draws its dashboard and its car with compiled kernels or with numpy, and
both paths give the same pixels bit for bit: the bars of any instrument values (negative,
huge, rounding on half steps) at the observation's and the video's size, the car's patch
blended at any place; ``TINYRACE_DRAWING`` chooses the path of the views built afterwards."""

from __future__ import annotations

from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis_budget import examples

from tinyrace.ground import texture
from tinyrace.sensors.kernels import drawing as drawing_numba
from tinyrace.sensors.machinery import drawing
from tinyrace.sensors.machinery.dashboard import BAR_STEPS, Dashboard

SIZES = [(96, 96, 4), (600, 400, 1), (1000, 800, 1), (150, 120, 2)]  # (w, h, supersample)


def car(
    speed: float, omegas: list[float], steer: float, yaw_rate: float, sign: float, scale: float
):
    """The fields of a CarState that the dashboard reads."""
    wheels = [SimpleNamespace(omega=omega, steer=steer) for omega in omegas]
    return SimpleNamespace(
        speed=speed, wheels=wheels, yaw_rate=yaw_rate, steer_sign=sign, scale=scale
    )


# values in bar steps: whole steps, half steps (rounding), and far beyond the frame
STEPS = st.one_of(
    st.integers(-3000, 3000).map(lambda k: k / (BAR_STEPS * 4)),
    st.integers(-3000, 3000).map(lambda k: (k + 0.5) / (BAR_STEPS * 4)),
    st.floats(-1e4, 1e4),
)


@settings(max_examples=examples(400), deadline=None)
@given(
    size=st.sampled_from(SIZES),
    speed=STEPS.map(abs),
    omegas=st.lists(STEPS, min_size=4, max_size=4),
    steer=STEPS,
    yaw_rate=STEPS,
    sign=st.sampled_from([-1.0, 1.0]),
    scale=st.sampled_from([0.5, 1.0, 3.0]),
    score=st.one_of(st.floats(-1e7, 1e7), st.integers(-99, 99).map(float)),
)
def test_both_paths_draw_the_same_dashboard(
    size, speed, omegas, steer, yaw_rate, sign, scale, score
):
    width, height, factor = size
    state = car(speed * 50, [o * 100 for o in omegas], steer / 10, yaw_rate, sign, scale)
    frames = []
    for path in ("numba", "numpy"):
        dashboard = Dashboard(width, height, factor, drawing=path)
        assert dashboard.drawing == path
        frame = np.full((height, width, 3), 77, np.uint8)
        dashboard.draw(frame, state, score)
        frames.append(frame)
    np.testing.assert_array_equal(*frames)


def test_a_dashboard_redrawn_step_after_step_keeps_matching():
    """The numpy path caches layers and skips steps whose values stay put; the kernel
    draws every step: over a drive of changing and repeated values, frame for frame alike."""
    rng = np.random.default_rng(5)
    dashboards = [Dashboard(96, 96, 4, drawing=path) for path in ("numba", "numpy")]
    score = 0.0
    for step in range(3000):
        if step % 3 != 2:  # every third step repeats the last values
            state = car(
                abs(rng.normal(0, 60)), list(rng.normal(0, 80, 4)), rng.normal(0, 0.3),
                rng.normal(0, 3), 1.0, 1.0,
            )  # fmt: skip
            score += rng.normal(0, 3)
        frames = [np.zeros((96, 96, 3), np.uint8) for _ in dashboards]
        for dashboard, frame in zip(dashboards, frames, strict=True):
            dashboard.draw(frame, state, score)
        np.testing.assert_array_equal(*frames)
    assert frames[0][84:].any()  # bars were drawn


@settings(max_examples=examples(300), deadline=None)
@given(
    shape=st.tuples(st.integers(1, 30), st.integers(1, 30)),
    corner=st.tuples(st.integers(0, 40), st.integers(0, 40)),
    seed=st.integers(0, 2**32 - 1),
)
def test_both_paths_blend_the_same_patch(shape, corner, seed):
    rng = np.random.default_rng(seed)
    rows, cols = shape
    alpha = rng.choice([0.0, 1.0, rng.random()], (rows, cols, 1)).astype(np.float32)
    alpha = np.where(rng.random((rows, cols, 1)) < 0.5, alpha, rng.random((rows, cols, 1)))
    weight = np.repeat(1.0 - alpha.astype(np.float32), 3, axis=2)
    color = (rng.integers(0, 256, (rows, cols, 3)) * (1.0 - weight) + 0.5).astype(np.float32)
    image = rng.integers(0, 256, (80, 80, 3), dtype=np.uint8)
    expected = image.copy()
    top, left = corner
    drawing.blend(expected, top, left, weight, color, np.empty_like(weight))
    drawing_numba.blend(image, top, left, weight, color)
    np.testing.assert_array_equal(image, expected)


@pytest.mark.parametrize("path", ["numba", "numpy"])
def test_the_variable_chooses_the_path_of_new_views(monkeypatch, path):
    monkeypatch.setenv(drawing.DRAWING_VARIABLE, path)
    env = gym.make("tinyrace/CarRacing-v0")
    env.reset(seed=0)
    sensor = env.unwrapped.sensors[0]  # the chase_view sensor: the observation
    for view in (sensor.view, env.unwrapped.pictures.chase_view((96, 96))):
        assert (view.dashboard.drawing, view.sprite.drawing) == (path, path)
    env.close()


def test_both_paths_give_the_same_observations(monkeypatch):
    """A drive with the zoom-in, skids and score changes: the observations are equal."""
    observations = {}
    for path in ("numba", "numpy"):
        monkeypatch.setenv(drawing.DRAWING_VARIABLE, path)
        env = gym.make("tinyrace/CarRacing-v0")
        env.reset(seed=3)
        env.action_space.seed(3)
        observations[path] = [env.step(env.action_space.sample())[0] for _ in range(300)]
        env.close()
    np.testing.assert_array_equal(observations["numba"], observations["numpy"])


# camera affines: ordinary scales and shifts, exact zeros, and magnitudes down to the
# subnormals (where the plain path's exact product takes fractions); not near overflow,
# where a product that overflows alone can be finite in a fused multiply-add
ENTRIES = st.one_of(
    st.floats(-1e4, 1e4),
    st.just(0.0),
    st.floats(-1e150, 1e150),
    st.floats(-1e-300, 1e-300),
)


@settings(max_examples=examples(2000), deadline=None)
@given(
    outer=st.tuples(*[ENTRIES] * 6),
    scale=st.tuples(ENTRIES, ENTRIES),
    shift=st.tuples(ENTRIES, ENTRIES),
)
def test_both_paths_compose_the_same_texture_affine(outer, scale, shift):
    inner = (scale[0], 0.0, shift[0], 0.0, scale[1], shift[1])
    compiled = texture.compose_kernel("numba")[1](outer, inner)
    plain = texture.compose_kernel("numpy")[1](outer, inner)
    assert compiled.dtype == plain.dtype and compiled.shape == plain.shape == (2, 3)
    assert compiled.tobytes() == plain.tobytes()


def test_a_texture_warps_with_the_composition_the_variable_chooses(monkeypatch):
    for path in ("numba", "numpy"):
        monkeypatch.setenv(drawing.DRAWING_VARIABLE, path)
        env = gym.make("tinyrace/CarRacing-v0")
        env.reset(seed=0)
        env.step(env.action_space.sample())
        sensor = env.unwrapped.sensors[0]  # the chase_view sensor: the observation
        assert sensor.view.texture.drawing == path
        env.close()
