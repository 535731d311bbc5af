"""First contact, fourth round: what a newcomer's walk through the README and the docs from
a built wheel found (the same session as hostile input's fifth round).

An experiment file given as ``config=`` says what it is and how to run it; ``tinyrace run``
says "1 episode", and no "(video included)" without a video.
"""

from __future__ import annotations

import gymnasium as gym
import pytest

import tinyrace  # noqa: F401  (registers the ids)
from tinyrace.errors import ConfigError


def test_an_experiment_file_given_as_config_says_what_it_is(tmp_path):
    path = tmp_path / "my_experiment.yaml"
    path.write_text("env:\n  track: {type: procedural}\ndriver: centerline\nepisodes: 2\n")
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", config=str(path))
    ((key, allowed),) = [(p.path, p.allowed) for p in caught.value.problems]
    assert key == "driver"
    assert "this is an experiment file (it has driver, env, episodes)" in allowed
    assert f"tinyrace run {path}" in allowed and "env: section as config=" in allowed


def test_one_episode_without_video_is_said_so(tmp_path, capsys):
    from tinyrace import cli

    out = tmp_path / "runs"
    assert cli.main(["run", "f1tenth", "--episodes", "1", "--no-video", "-o", str(out)]) == 0
    captured = capsys.readouterr()
    assert "(1 episode, driver" in captured.out
    assert " s wall" in captured.err and "video included" not in captured.err
