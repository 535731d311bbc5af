"""Issue 12.5: what ``tinyrace validate`` accepts builds, resets and steps; what it refuses,
``gym.make`` refuses with the same problem. Reset options and kwargs are checked too."""

from __future__ import annotations

from pathlib import Path

import cv2
import gymnasium as gym
import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis_budget import examples

import tinyrace  # noqa: F401 (registers the ids)
from tinyrace.config.schema import ProceduralTrackConfig
from tinyrace.env import TinyRaceEnv
from tinyrace.errors import ConfigError
from tinyrace.validate import validate_path

CAMERA = {"id": "front", "resolution": [12, 16], "roi": [24, 32]}
WHITE, BLUE = [255, 255, 255], [255, 0, 0]


def _folder(tmp_path: Path, **config) -> Path:
    image = np.zeros((64, 64, 3), np.uint8)
    image[30:34, :] = 255  # a white trajectory line
    image[5:10, 5:10] = BLUE
    cv2.imwrite(str(tmp_path / "t.png"), image)
    base = {"cameras": [CAMERA], "tracks": [{"image": "t.png", "spawns": [[20, 32, 0]]}]}
    (tmp_path / "track.yaml").write_text(yaml.safe_dump({**base, **config}))
    return tmp_path


def _both_refuse(folder: Path, key_path: str) -> None:
    """validate and gym.make report the same problem at ``key_path``."""
    problems, _ = validate_path(folder)
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", environment=str(folder))
    assert [str(p) for p in caught.value.problems] == problems
    assert any(p.path == key_path for p in caught.value.problems), problems


def test_empty_spawns_are_refused(tmp_path: Path):
    folder = _folder(tmp_path, tracks=[{"image": "t.png", "spawns": []}])
    _both_refuse(folder, "tracks[0].spawns")


def test_an_obstacle_in_the_trajectory_colour_is_refused(tmp_path: Path):
    design = {
        "cross_track_error": {"use_cte": True, "trajectory_color": WHITE},
        "color_obstacles": [{"color": BLUE, "reward": -1}, {"color": WHITE, "reward": "done"}],
    }
    _both_refuse(_folder(tmp_path, reward_design=design), "reward_design.color_obstacles[1].color")


def test_an_obstacle_colour_is_fine_without_cte(tmp_path: Path):
    design = {"color_obstacles": [{"color": WHITE, "reward": -1}]}
    car = {"wheelbase": 8, "track_width": 6}  # started below the white line, clear of it
    tracks = [{"image": "t.png", "spawns": [[20, 50, 0]]}]
    folder = _folder(tmp_path, reward_design=design, car=car, tracks=tracks)
    assert validate_path(folder)[0] == []


def test_a_spawn_on_an_obstacle_colour_is_refused(tmp_path: Path):
    # the default car (160 x 100 px) at (20, 32) covers the white line, an obstacle here
    # (not the blue block at x 5-9 px, which the footprint does not reach)
    design = {"color_obstacles": [{"color": BLUE, "reward": -1}, {"color": WHITE, "reward": -1}]}
    folder = _folder(tmp_path, reward_design=design)
    _both_refuse(folder, "tracks[0].spawns[0]")
    (problem,) = validate_path(folder)[0]
    assert "it covers reward_design.color_obstacles[1] (color #ffffff, reward -1.0):" in problem
    assert "(160 x 100 px, length x width)" in problem


def test_an_obstacle_colour_no_pixel_has_is_refused_naming_the_swapped_list(tmp_path: Path):
    design = {"color_obstacles": [{"color": [0, 0, 255], "reward": -1}]}  # red, as [b, g, r]
    car = {"wheelbase": 8, "track_width": 6}
    folder = _folder(tmp_path, reward_design=design, car=car)
    _both_refuse(folder, "reward_design.color_obstacles[0].color")
    (problem,) = validate_path(folder)[0]
    assert "no pixel has it" in problem
    assert "the image has [255, 0, 0]: a list is [b, g, r]" in problem  # the blue block


@pytest.mark.parametrize("shaping", ["linear", 3, [1, 2]])
def test_cte_shaping_must_be_callable(tmp_path: Path, shaping):
    with pytest.raises(ConfigError, match="cte_shaping"):
        gym.make("tinyrace/TinyRace-v0", environment=str(_folder(tmp_path)), cte_shaping=shaping)


@pytest.mark.parametrize("result", [float("nan"), "far", None, np.array([1.0, 2.0])])
def test_cte_shaping_must_return_a_finite_number(tmp_path: Path, result):
    design = {"cross_track_error": {"use_cte": True}}
    env = TinyRaceEnv(
        environment=_folder(tmp_path, reward_design=design), cte_shaping=lambda cte: result
    )
    env.reset(seed=0)
    with pytest.raises(ConfigError, match="cte_shaping"):
        env.step(np.zeros(1, np.float32))


@pytest.mark.parametrize(
    "options, key",
    [
        ({"randomize": "yes"}, "randomize"),
        ({"randomize": np.array([True, False])}, "randomize"),
        ({"track": 1}, "track"),
        ({"spawn": np.array([0, 1])}, "spawn"),
        ({("a", "b"): 1}, "('a', 'b')"),
        ({"x" * 10_000: 1}, "x" * 37 + "..."),
    ],
)
def test_reset_options_are_checked_on_procedural_tracks(options: dict, key: str):
    env = gym.make("tinyrace/CarRacing-v0")
    with pytest.raises(ConfigError) as caught:
        env.reset(options=options)
    assert caught.value.problems[0].path == key
    assert len(str(caught.value)) < 400


@pytest.mark.parametrize("options", [{"track": np.array([0])}, {"spawn": 0.5}, {"spawn": True}])
def test_reset_options_are_checked_on_image_tracks(tmp_path: Path, options: dict):
    env = TinyRaceEnv(environment=_folder(tmp_path))
    with pytest.raises(ConfigError, match="reset options"):
        env.reset(options=options)


def _bounded(name: str):
    """A strategy over the documented bounds of a procedural knob."""
    meta = next(f for f in ProceduralTrackConfig.__dataclass_fields__.values() if f.name == name)
    low, high = meta.metadata["low"], meta.metadata["high"]
    if isinstance(meta.default, int):
        return st.integers(low, high)
    return st.floats(low, high, allow_nan=False)


KNOBS = ("checkpoints", "radius", "half_width", "turn_rate", "detail_step", "border")
KNOBS += ("border_min_count", "playfield")


@settings(max_examples=examples(25), deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    knobs=st.fixed_dictionaries({}, optional={name: _bounded(name) for name in KNOBS}),
    seed=st.integers(0, 2**32 - 1),
)
def test_procedural_knobs_inside_their_bounds_make_a_track_or_say_why(knobs: dict, seed: int):
    track = {"type": "procedural", "pixels_per_unit": 0.25, **knobs}
    try:
        env = TinyRaceEnv(tracks=[track])
        env.reset(seed=seed)
        env.step(np.array([0.0, 1.0, 0.0], np.float32))
    except ConfigError as exc:
        assert all(p.path.startswith("tracks[0]") for p in exc.problems), str(exc)


def test_the_one_point_lap_found_by_a_sweep():
    """These knobs made a one-point lap at seed 0, and an IndexError in the kerb code."""
    knobs = {"radius": 1447.532566122936, "half_width": 1.0, "border_min_count": 12}
    env = TinyRaceEnv(tracks=[{"type": "procedural", "pixels_per_unit": 0.25, **knobs}])
    try:
        env.reset(seed=0)
        env.step(np.array([0.0, 1.0, 0.0], np.float32))
    except ConfigError as exc:  # no lap: said so, naming the knobs
        assert "tracks[0]" in str(exc)


def test_validate_refuses_a_view_that_is_no_camera(tmp_path: Path):
    folder = _folder(tmp_path)
    experiment = tmp_path / "exp.yaml"
    experiment.write_text(
        yaml.safe_dump({"env": {"environment": "."}, "output": {"view": "roof"}, "episodes": 1})
    )
    problems, _ = validate_path(experiment)
    assert folder == tmp_path and len(problems) == 1
    assert "output.view" in problems[0] and "front" in problems[0]


def test_a_sensors_view_needs_a_sensors_list_not_only_cameras(tmp_path: Path):
    _folder(tmp_path)  # a track with cameras: only, which the loader lists as sensors
    experiment = tmp_path / "exp.yaml"
    experiment.write_text(
        yaml.safe_dump({"env": {"environment": "."}, "output": {"view": "sensors"}, "episodes": 1})
    )
    problems, _ = validate_path(experiment)
    assert len(problems) == 1 and "output.view" in problems[0]
    assert "one of: default, front" in problems[0]  # each camera once, no sensors view
