"""Messages a newcomer met that named the wrong thing (the eighth walk through the docs)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import pytest

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.errors import ConfigError
from tinyrace.examples import find_track
from tinyrace.tracks.ros_map import read_info


def test_a_missing_map_key_is_called_missing(tmp_path: Path):
    path = tmp_path / "map.yaml"
    text = "image: map.pgm\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
    (tmp_path / "map.pgm").write_bytes(b"P5\n2 2\n255\n" + bytes(4))
    path.write_text(text)
    with pytest.raises(ConfigError) as caught:
        read_info(path, text)
    (problem,) = caught.value.problems
    assert problem.path == "resolution"
    assert problem.allowed.startswith("the key is missing; expected a number from")


@pytest.mark.parametrize(
    ("entry", "path", "value"),
    [
        ({"speed": -3}, "opponents[0].speed", -3),
        ({"speed": True}, "opponents[0].speed", True),
        ({"driver": "nobody"}, "opponents[0].driver", "nobody"),
        ({"colour": 1}, "opponents[0]", "{'colour': 1}"),
    ],
)
def test_an_opponents_bad_key_is_named_with_its_value(entry, path, value):
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", environment="circuit", opponents=[entry])
    (problem,) = caught.value.problems
    assert (problem.path, problem.value) == (path, value)


def test_show_into_the_track_folder_says_the_path_is_inside_it(tmp_path: Path):
    folder = find_track("circuit")
    assert folder is not None
    copy = tmp_path / "circuit"
    copy.mkdir()
    for name in ("track.yaml", "circuit.csv"):
        (copy / name).write_bytes((folder / name).read_bytes())
    result = subprocess.run(
        [sys.executable, "-m", "tinyrace", "show", str(copy), "-o", str(copy / "x.png")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode != 0
    assert f"expected a path outside the track folder {copy}" in result.stderr
    assert "(this one is inside it)" in result.stderr
    assert not (copy / "x.png").exists()


def test_the_commands_help_shows_no_markup():
    result = subprocess.run(
        [sys.executable, "-m", "tinyrace", "--help"], capture_output=True, text=True, timeout=60
    )
    assert "The tinyrace command" in result.stdout and "``" not in result.stdout


def test_show_with_an_empty_output_name_writes_nothing(tmp_path: Path):
    result = subprocess.run(
        [sys.executable, "-m", "tinyrace", "show", "autocross", "-o", ""],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=tmp_path,
    )
    assert result.returncode == 2
    assert "-o/--output: got ''; expected a PNG file's path" in result.stderr
    assert list(tmp_path.iterdir()) == []
