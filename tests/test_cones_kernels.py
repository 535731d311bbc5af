"""The cone detector's two paths, the numpy passes and the compiled numba kernel, give the
same detections bit for bit, on any cone set, pose, range, field of view and capacity, with
and without noise; which path a sensor takes."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis_budget import examples

from tinyrace.sensors.cones import (
    KERNEL_VARIABLE,
    NUMPY_PATH,
    ConeNoise,
    ConesSensor,
    ConeTable,
    Frame,
    detect,
    kernel,
)
from tinyrace.sensors.kernels import cones as cones_numba

NUMBA_PATH = kernel("numba")[1]
RANGES = [0.5, 3.0, 10.0, 150.0, 1500.0]  # [track units]


@st.composite
def scenes(draw) -> tuple[np.ndarray, tuple[float, float, float], float]:
    """(cones (K, 3), pose, max_range): scattered cones, duplicates (ties in distance) and
    cones exactly at the range ahead, aside and behind (the boundary of every test)."""
    max_range = draw(st.sampled_from(RANGES))
    x, y = draw(st.floats(-1e3, 1e3)), draw(st.floats(-1e3, 1e3))
    heading = draw(st.sampled_from([0.0, math.pi / 2, math.pi, draw(st.floats(-7.0, 7.0))]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    count = draw(st.integers(0, 300))
    spread = max_range * draw(st.sampled_from([0.5, 1.5, 4.0]))
    points = rng.uniform(-spread, spread, (count, 2)) + np.array([x, y])
    ring = [(x + max_range * math.cos(a), y + max_range * math.sin(a)) for a in (0, 1.5, 3.1)]
    edges = [(x + max_range, y), (x, y + max_range), (x - max_range, y), *ring]
    points = np.concatenate([points, points[: draw(st.integers(0, 5))], np.array(edges)])
    classes = rng.integers(1, 4, len(points))
    cones = np.column_stack([points, classes]).astype(np.float64)
    return rng.permutation(cones), (x, y, heading), max_range


FOVS = st.sampled_from([1.0, 90.0, 179.0, 180.0, 181.0, 270.0, 360.0])  # [deg]


@settings(max_examples=examples(300), deadline=None)
@given(scene=scenes(), y_down=st.booleans(), fov=FOVS, capacity=st.sampled_from([1, 3, 32, 500]))
def test_both_paths_give_the_same_detections(scene, y_down, fov, capacity):
    cones, pose, max_range = scene
    table = ConeTable(cones)
    frame = Frame.of(pose, y_down, max_range, math.radians(fov))
    rows, count = NUMBA_PATH.nearest(table, frame, capacity)
    expected, expected_count = NUMPY_PATH.nearest(table, frame, capacity)
    assert count == expected_count and rows.dtype == expected.dtype == np.float32
    assert rows.tobytes() == expected.tobytes()
    found, expected_found = NUMBA_PATH.found(table, frame), NUMPY_PATH.found(table, frame)
    assert found.shape == expected_found.shape and found.tobytes() == expected_found.tobytes()


@settings(max_examples=examples(60), deadline=None)
@given(scene=scenes(), y_down=st.booleans(), fov=FOVS, seed=st.integers(0, 2**32 - 1))
def test_both_paths_draw_the_same_noise(scene, y_down, fov, seed):
    cones, pose, max_range = scene
    noise = ConeNoise(position_std=0.1 * max_range, miss_probability=0.3, false_positives=2.0)
    args = (pose, y_down, max_range, math.radians(fov), 32, noise)
    numba_rows = detect(cones, *args, np.random.default_rng(seed), NUMBA_PATH)
    numpy_rows = detect(cones, *args, np.random.default_rng(seed), NUMPY_PATH)
    assert numba_rows[1] == numpy_rows[1] and numba_rows[0].tobytes() == numpy_rows[0].tobytes()


def test_the_boundary_cones_are_found_by_the_compiled_path():
    """Cones exactly at the range (ahead and aside) and exactly abeam with a 180 deg fov: the
    kernel's shortcut (no hypot for cones out of range or behind) must not drop them."""
    cones = np.array([[5.0, 0.0, 1], [0.0, 5.0, 2], [0.0, -5.0, 3], [-1e-9, 1.0, 1]])
    frame = Frame.of((0.0, 0.0, 0.0), False, 5.0, math.radians(360))
    rows, count = NUMBA_PATH.nearest(ConeTable(cones), frame, 8)
    assert count == 4
    np.testing.assert_array_equal(rows[:4, 2], [1, 1, 2, 3])  # nearest, then in index order
    behind = Frame.of((0.0, 0.0, 0.0), False, 5.0, math.radians(180))
    assert NUMBA_PATH.nearest(ConeTable(cones), behind, 8)[1] == 1  # only the one ahead


def test_the_variable_chooses_the_path(monkeypatch):
    monkeypatch.setenv(KERNEL_VARIABLE, "numpy")
    assert kernel() == ("numpy", NUMPY_PATH)
    monkeypatch.setenv(KERNEL_VARIABLE, "NumBa")
    name, paths = kernel()
    assert name == "numba" and paths.nearest is cones_numba.nearest
    monkeypatch.delenv(KERNEL_VARIABLE)
    assert kernel()[0] == "numba"  # numba is a test dependency: the default path when present
    assert kernel("numpy")[0] == "numpy"  # an explicit choice wins over the variable
    monkeypatch.setenv(KERNEL_VARIABLE, "fortran")
    with pytest.raises(ValueError, match="TINYRACE_CONES='fortran': expected auto, numba or numpy"):
        kernel()


@pytest.mark.parametrize("environment", ["formula_student", "autocross"])
def test_an_env_observes_the_same_cones_on_both_paths(monkeypatch, environment):
    """Whole episodes, with the noise of configs/sensors.yaml: the same observations."""
    cone = {"id": "cones", "type": "cones", "position_std": 0.5, "miss_probability": 0.1}
    observed = {}
    for path in ("numba", "numpy"):
        monkeypatch.setenv(KERNEL_VARIABLE, path)
        env = gym.make("tinyrace/TinyRace-v0", environment=environment, sensors=[cone])
        sensor = next(s for s in env.unwrapped.sensors if isinstance(s, ConesSensor))
        assert sensor.kernel == path
        env.action_space.seed(3)
        observation, _ = env.reset(seed=3)
        frames = [observation["cones"]]
        for _ in range(150):
            observation, _, terminated, truncated, _ = env.step(env.action_space.sample())
            frames.append(observation["cones"])
            if terminated or truncated:
                observation, _ = env.reset()
        env.close()
        observed[path] = frames
    assert sum(frame["count"] for frame in observed["numba"]) > 0  # cones were seen
    for a, b in zip(observed["numba"], observed["numpy"], strict=True):
        assert a["count"] == b["count"] and a["cones"].tobytes() == b["cones"].tobytes()
