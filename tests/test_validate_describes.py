"""``tinyrace validate`` says what the env observes: for every shipped config, every shipped
track and a set of sensor combinations, each sensor it names (id, shapes, dtypes) is a key
of the env's observation space with that space, and nothing else; a race is
named with its cars and laps. (It once said "cameras: CarRacing 96x96 view" for a
centreline track whose only sensor was a lidar.)"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import gymnasium as gym
import pytest
import yaml

from tinyrace.config import race_cars
from tinyrace.env import TinyRaceEnv
from tinyrace.race.env import RaceEnv
from tinyrace.validate import load_any, validate_path

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = sorted((ROOT / "configs").glob("*.yaml"))
TRACKS = sorted(p.parent for p in (ROOT / "example_tracks").glob("*/track.yaml"))

# sensor combinations: (track, keys laid over it)
LIDAR = {"id": "scan", "type": "lidar", "beams": 64}
COMBINATIONS: dict[str, tuple[str, dict[str, Any]]] = {
    "a lidar alone on a centreline track": ("circuit", {"cameras": [], "sensors": [LIDAR]}),
    "a lidar alone, as a box": (
        "circuit",
        {"cameras": [], "sensors": [LIDAR], "observation": "box"},
    ),
    "no sensor at all: the default top view": ("circuit", {"cameras": [], "sensors": []}),
    "vectors": (
        "circuit",
        {
            "sensors": [
                {**LIDAR, "hit_classes": True},
                {"id": "motion", "type": "state", "pose": True},
                {"id": "ahead", "type": "lookahead", "points": 5},
                {"id": "top", "type": "top_view", "resolution": [32, 48]},
            ]
        },
    ),
    "cones and a lidar on a cone map": (
        "autocross",
        {"cameras": [], "sensors": [{"id": "cones", "type": "cones", "max_cones": 8}, LIDAR]},
    ),
    "a race with opponents": (
        "circuit",
        {
            "cameras": [],
            "sensors": [{"id": "others", "type": "opponents", "count": 2}],
            "race": {"num_agents": 3, "laps": 2},
        },
    ),
    "a race whose cars have sensors of their own": (
        "circuit",
        {
            "cameras": [],
            "sensors": [{"id": "motion", "type": "state"}],
            "race": {"cars": [
                {"id": "red"},
                {"id": "blue", "sensors": [{**LIDAR, "hit_classes": True}]},
                {"id": "green", "cameras": [{"id": "eye", "resolution": [24, 32]}]},
            ]},
        },
    ),
    "perspective cameras on a picture track": (
        "formula_student",
        {
            "sensors": [
                {"id": "eye", "type": "perspective_camera", "resolution": [24, 32]},
                {"id": "labels", "type": "perspective_camera", "resolution": [24, 32],
                 "format": "classes"},
            ]
        },
    ),
    "CarRacing with a state vector beside its view": (
        "",
        {"sensors": [{"id": "view", "type": "chase_view"}, {"id": "motion", "type": "state"}]},
    ),
}  # fmt: skip


def _shape(space: gym.Space[Any]) -> str:
    if isinstance(space, gym.spaces.Dict):
        return "{" + ", ".join(f"{k}: {_shape(v)}" for k, v in space.spaces.items()) + "}"
    if isinstance(space, gym.spaces.Discrete):
        return f"{space.start}..{space.start + space.n - 1}"
    return f"{'x'.join(map(str, space.shape or ()))} {space.dtype}"


def _named(section: str) -> list[tuple[str, str]]:
    """(id, shapes) of each sensor a section (``observes: ...``) names."""
    found = []
    for entry in section.split(" observes: ", 1)[1].split("; "):
        match = re.fullmatch(r"(\S+) (\{.*\}|\S+ \S+) \((.+)\)", entry)
        assert match, f"not a sensor's description: {entry!r} in {section!r}"
        found.append((match[1], match[2]))
    return found


def _sections(summary: str) -> dict[str, list[tuple[str, str]]]:
    """What each car observes by its id ("" for the first car)."""
    observes = " " + summary.split("; observes: ", 1)[1].split("; start free:", 1)[0]
    first, *others = observes.split(" | ")
    named = {"": _named(" observes:" + first)}
    for section in others:
        named[section.split(" ", 1)[0]] = _named(" " + section)
    return named


def _agrees(named: list[tuple[str, str]], space: gym.Space[Any], first_id: str) -> None:
    """The sensors named are the observation space's keys with their spaces."""
    if isinstance(space, gym.spaces.Dict):
        expected = [(key, _shape(value)) for key, value in space.spaces.items()]
        assert sorted(named) == sorted(expected) and len(named) == len(expected)
    else:  # one sensor's observation, as a plain Box
        assert [shapes for _, shapes in named] == [_shape(space)]
        assert named[0][0] == first_id


def _check(path: Path) -> None:
    problems, summary = validate_path(path)
    assert problems == []
    loaded = load_any(path)
    env = TinyRaceEnv(config=loaded)
    try:
        sections = _sections(summary)
        _agrees(sections[""], env.observation_space, env.sensors[0].id)
        cars = race_cars(env.config)
        race = re.search(r"; race: (\d+) cars \(([^)]*)\), (\d+) laps?;", summary)
        if len(cars) > 1:
            assert race is not None, summary
            assert int(race[1]) == len(cars) and race[2] == ", ".join(c.id for c in cars)
            assert int(race[3]) == env.config.race.laps
        else:
            assert race is None and list(sections) == [""], summary
    finally:
        env.close()
    if len(cars) > 1:  # each car's seat in the PettingZoo race
        race_env = RaceEnv(config=loaded)
        try:
            for car in cars[1:]:
                named = sections.get(car.id, sections[""])
                seat = race_env.seats[car.index]
                _agrees(named, race_env.observation_space(car.id), seat.sensors[0].id)
        finally:
            race_env.close()


@pytest.mark.parametrize("path", CONFIGS + TRACKS, ids=lambda p: p.name)
def test_validate_describes_what_each_shipped_config_and_track_observes(path: Path) -> None:
    _check(path)


@pytest.mark.parametrize("case", sorted(COMBINATIONS))
def test_validate_describes_each_sensor_combination(case: str, tmp_path: Path) -> None:
    track, keys = COMBINATIONS[case]
    env = {"environment": track, **keys} if track else keys
    path = tmp_path / "experiment.yaml"
    path.write_text(yaml.safe_dump({"env": env, "driver": "centerline", "episodes": 1}))
    _check(path)


def test_a_lidar_alone_is_described_as_a_lidar(tmp_path: Path) -> None:
    path = tmp_path / "experiment.yaml"
    env = {"environment": "circuit", "cameras": [], "sensors": [LIDAR]}
    path.write_text(yaml.safe_dump({"env": env, "driver": "centerline"}))
    problems, summary = validate_path(path)
    assert problems == []
    assert "observes: scan 64 float32 (lidar, 64 beams over 270 deg" in summary
    assert "96x96" not in summary and "camera" not in summary


def test_every_shipped_config_and_track_is_checked() -> None:
    assert len(CONFIGS) >= 10 and len(TRACKS) >= 5
