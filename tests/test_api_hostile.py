"""Hostile input at the Python API's doors and a few commands (round 7, F15-F23).

CarRacing's true/false keywords; an empty ``config=``; the race env's unknown agents and a
step after the race; the RLlib adapters given the wrong kind of env; ``tinyrace cache`` on
a path that is no folder it can read; the ``*_list`` render modes of TinyRace-v0;
``tinyrace examples copy`` through a link or into the package; ``show --seed`` on a track
that has one picture; ``render_mode="human"`` with no display.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import tinyrace  # noqa: F401  (registers the ids)
from tinyrace.errors import ConfigError

CARRACING = "tinyrace/CarRacing-v0"
TINYRACE = "tinyrace/TinyRace-v0"


# -- F15: CarRacing's flags are true or false -----------------------------------------------------
@pytest.mark.parametrize("key", ["continuous", "verbose", "domain_randomize"])
@pytest.mark.parametrize("value", ["no", "False", "yes", 0, 2, None, [True]])
def test_a_carracing_flag_that_is_not_true_or_false_is_refused(key, value):
    with pytest.raises(ConfigError) as raised:
        gym.make(CARRACING, **{key: value})
    assert str(raised.value).splitlines()[-1].strip() == (
        f"<kwargs>: {key}: got {value!r}; expected true or false"
    )


def test_tinyrace_verbose_is_true_or_false_too():
    with pytest.raises(ConfigError, match=r"<kwargs>: verbose: got 'loud'; expected true or false"):
        gym.make(TINYRACE, verbose="loud")


@pytest.mark.parametrize("flag", [np.False_, False])
def test_carracing_flags_take_bools_and_numpy_bools(flag, capsys):
    on = np.logical_not(flag)  # a numpy bool, True
    env = gym.make(CARRACING, continuous=flag, domain_randomize=np.bool_(True), verbose=on)
    assert env.action_space == gym.spaces.Discrete(5)
    assert env.unwrapped.config.tracks[0].domain_randomize is True
    env.reset(seed=0)
    assert "Track generation" in capsys.readouterr().out  # verbose=True prints it
    assert isinstance(env.unwrapped.verbose, bool)
    env.close()


# -- F17: an empty config= names no file ----------------------------------------------------------
@pytest.mark.parametrize(
    ("kwargs", "key", "value"),
    [
        ({"config": ""}, "config", ""),
        ({"config": "  "}, "config", "  "),
        ({"config": "", "environment": "formula_student"}, "config", ""),
        ({"environment": ""}, "environment", ""),
    ],
)
def test_an_empty_config_or_environment_is_refused_as_a_keyword(kwargs, key, value):
    with pytest.raises(ConfigError) as raised:
        gym.make(TINYRACE, **kwargs)
    text = str(raised.value)
    assert f"<kwargs>: {key}: got {value!r}; expected a " in text
    assert "track.yaml: got" not in text  # not the working folder's track.yaml
    if key == "config":
        assert "a YAML file path, a track folder or a mapping" in text
    else:
        assert "formula_student" in text  # the shipped tracks it could name
