"""The car model is chosen in one place, the cars registry, for gym.make and validate alike."""

from __future__ import annotations

import dataclasses
import typing
from pathlib import Path

import gymnasium as gym
import pytest
import yaml

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.cars.registry import CAR_MODELS
from tinyrace.config import TrackConfig
from tinyrace.errors import ConfigError
from tinyrace.examples import TRACKS_DIR
from tinyrace.tracks.registry import TRACK_SOURCES
from tinyrace.validate import validate_path

KINEMATIC_ON_PROCEDURAL = {"track": {"type": "procedural"}, "car": {"model": "kinematic"}}


def test_kinematic_car_on_procedural_track_is_refused_at_make():
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", config=KINEMATIC_ON_PROCEDURAL)
    (problem,) = caught.value.problems
    assert (problem.source, problem.path, problem.value) == ("<dict>", "car.model", "kinematic")
    assert "image" in problem.allowed and "procedural" in problem.allowed


def test_validate_gives_the_same_problem(tmp_path: Path):
    path = tmp_path / "track.yaml"
    path.write_text(yaml.safe_dump(KINEMATIC_ON_PROCEDURAL))
    lines, summary = validate_path(path)
    assert summary == ""
    assert len(lines) == 1 and f"{path}: car.model: got 'kinematic'" in lines[0]


def test_discrete_actions_need_a_model_that_takes_them():
    config = {"environment": str(TRACKS_DIR / "segmented"), "car": {"actions": "discrete"}}
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", **config)
    assert [p.path for p in caught.value.problems] == ["car.actions"]


CONFIGS = {dataclasses.fields(c)[0].default: c for c in typing.get_args(TrackConfig)}


@pytest.mark.parametrize("kind", sorted(TRACK_SOURCES))
def test_every_track_kind_has_exactly_one_default_model(kind):
    unit = CONFIGS[kind].unit  # a car model drives in the track's unit
    defaults = [m.name for m in CAR_MODELS.values() if unit in m.default_for]
    assert len(defaults) == 1
    assert unit in CAR_MODELS[defaults[0]].track_units


@pytest.mark.parametrize(
    ("environment", "model", "expected"),
    [
        (None, None, "dynamic"),
        ("segmented", None, "kinematic"),
        ("segmented", "dynamic", "dynamic"),
    ],
)
def test_the_resolved_model_is_the_one_that_drives(environment, model, expected):
    kwargs = {} if environment is None else {"environment": str(TRACKS_DIR / environment)}
    if model is not None:
        kwargs["car"] = {"model": model}
    env = gym.make("tinyrace/TinyRace-v0", **kwargs)
    env.reset(seed=0)
    assert env.unwrapped.config.car.model == expected
    assert env.unwrapped.car.state().model == expected
    env.step(env.action_space.sample())
