"""Bad track folders: one ConfigError naming the file, key path, value and what is allowed."""

from __future__ import annotations

import tempfile
from pathlib import Path

import pytest
from synthetic import blank, make_env, write_track

from tinyrace.errors import ConfigError


def folder_with(tmp_path: Path, config: dict, image=True) -> Path:
    return write_track(tmp_path / "track", blank() if image else None, config)


def missing_folder(tmp_path):
    return tmp_path / "nowhere"


def missing_yaml(tmp_path):
    (tmp_path / "empty").mkdir()
    return tmp_path / "empty"


def missing_image(tmp_path):
    return folder_with(tmp_path, {"tracks": [{"image": "gone.png"}]}, image=False)


def garbage_image(tmp_path):
    folder = folder_with(tmp_path, {"tracks": [{"image": "bad.png"}]}, image=False)
    (folder / "bad.png").write_bytes(b"\x89not a png at all" * 20)
    return folder


def unknown_key(tmp_path):
    return folder_with(tmp_path, {"car": {"wheelbse": 150}})


def unknown_section(tmp_path):
    return folder_with(tmp_path, {"rewards_design": {}})


def wrong_type(tmp_path):
    return folder_with(tmp_path, {"car": {"velocity": "fast"}})


def wrong_list_type(tmp_path):
    return folder_with(tmp_path, {"cameras": [{"id": "c", "resolution": "120x160"}]})


def spawn_outside(tmp_path):
    return folder_with(tmp_path, {"tracks": [{"image": "track.png", "spawns": [[700, 10, 0]]}]})


def roi_too_large(tmp_path):
    return folder_with(tmp_path, {"cameras": [{"id": "c", "roi": [480, 640]}]})


def colour_channel(tmp_path):
    obstacle = {"color": [0, 128, 255], "reward": -1}
    return folder_with(tmp_path, {"reward_design": {"color_obstacles": [obstacle]}})


def trajectory_channel(tmp_path):
    cte = {"use_cte": True, "trajectory_color": [255, 255, 100]}
    return folder_with(tmp_path, {"reward_design": {"cross_track_error": cte}})


def no_cameras(tmp_path):
    return folder_with(tmp_path, {"cameras": []})


def bad_obstacle_reward(tmp_path):
    obstacle = {"color": [0, 0, 255], "reward": "stop"}
    return folder_with(tmp_path, {"reward_design": {"color_obstacles": [obstacle]}})


# (make the folder, the key path, the value as shown, words of what is allowed)
# (the YAML file is named in every message, also when it or its folder is missing)
CASES = {
    "missing image": (missing_image, "tracks[0].image", "'gone.png'", "does not exist"),
    "unreadable image": (garbage_image, "tracks[0].image", "'bad.png'", "PNG or JPEG"),
    "unknown key": (unknown_key, "car.wheelbse", "150", "did you mean 'wheelbase'?"),
    "unknown section": (unknown_section, "rewards_design", "{{}}", "did you mean 'reward_design'?"),
    "wrong type": (wrong_type, "car.velocity", "'fast'", "a number >= 0"),
    "wrong list": (wrong_list_type, "cameras[0].resolution", "'120x160'", "expected a list"),
    "spawn outside": (spawn_outside, "tracks[0].spawns[0]", "[700.0, 10.0, 0.0]", "0 <= x < 600"),
    "roi too large": (roi_too_large, "cameras[0].roi", "[480.0, 640.0]", "no larger than"),
    "colour channel": (
        colour_channel,
        "reward_design.color_obstacles[0].color",
        "[0, 128, 255]",
        "0 or 255",
    ),
    "trajectory channel": (
        trajectory_channel,
        "reward_design.cross_track_error.trajectory_color",
        "[255, 255, 100]",
        "0 or 255",
    ),
    "no cameras": (no_cameras, "cameras", "[]", "at least one camera"),
    "obstacle reward": (
        bad_obstacle_reward,
        "reward_design.color_obstacles[0].reward",
        "'stop'",
        "a number or one of: done",
    ),
}


@pytest.mark.parametrize(
    ("make", "allowed"),
    [
        (missing_folder, "expected a track folder holding track.yaml or a shipped track"),
        (missing_yaml, "expected a track folder holding track.yaml; this folder holds no"),
    ],
)
def test_a_missing_track_folder_names_the_keyword_argument(tmp_path, make, allowed):
    """No track.yaml was read: the problem is the ``environment=`` argument itself."""
    folder = make(tmp_path)
    with pytest.raises(ConfigError) as caught:
        make_env(folder)
    (problem,) = caught.value.problems
    assert (problem.source, problem.path, problem.value) == ("<kwargs>", "environment", str(folder))
    assert problem.allowed.startswith(allowed), problem.allowed


@pytest.fixture
def short_tmp_path():
    """A temporary folder with a short path: pytest-xdist's are deep enough that a message
    naming the folder twice is shortened in the middle, so its parts could not be checked."""
    with tempfile.TemporaryDirectory(prefix="tr") as folder:
        yield Path(folder)


@pytest.mark.parametrize("case", CASES)
def test_bad_track_folder(short_tmp_path, case):
    make, key_path, value, allowed = CASES[case]
    folder = make(short_tmp_path)
    with pytest.raises(ConfigError) as caught:
        make_env(folder)
    error = caught.value
    assert len(error.problems) == 1, str(error)
    message = str(error)
    value = value.format(folder=folder)
    # a long value (a temporary folder's path) is shown by its two ends
    for part in (str(folder / "track.yaml"), f": {key_path}: ", f"got {value[:30]}", value[-30:]):
        assert part in message, (part, message)
    assert allowed in message, message
    problem = error.problems[0]
    assert problem.source == str(folder / "track.yaml") and problem.path == key_path


def test_all_problems_are_reported_together(tmp_path):
    folder = folder_with(
        tmp_path, {"sim": {"fps": 0}, "car": {"wheelbase": -1, "velocty": 3}, "cameras": []}
    )
    with pytest.raises(ConfigError) as caught:
        make_env(folder)
    paths = {p.path for p in caught.value.problems}
    assert {"sim.fps", "car.wheelbase", "car.velocty"} <= paths


def test_image_and_spawn_problems_of_every_track_are_reported(tmp_path):
    config = {
        "tracks": [
            {"image": "track.png", "spawns": [[10, 10, 0], [10, 900, 0]]},
            {"image": "missing.png"},
        ]
    }
    with pytest.raises(ConfigError) as caught:
        make_env(folder_with(tmp_path, config))
    paths = [p.path for p in caught.value.problems]
    assert paths == ["tracks[0].spawns[1]", "tracks[1].image"]


def test_bad_reset_options(tmp_path):
    env = make_env(folder_with(tmp_path, {}))
    for options, key, allowed in [
        ({"track": 1}, "track", "from 0 to 0"),
        ({"spawn": 2}, "spawn", "from 0 to 0"),
        ({"spawn": -1}, "spawn", "from 0 to 0"),
        ({"track": "0"}, "track", "from 0 to 0"),
        ({"trak": 0}, "trak", "valid: randomize, track, spawn"),
    ]:
        with pytest.raises(ConfigError) as caught:
            env.reset(options=options)
        assert caught.value.problems[0].path == key
        assert allowed in str(caught.value)


def test_config_errors_pickle_with_their_problems():
    """Vector envs carry a worker's ConfigError to the parent by pickling it."""
    import pickle

    from tinyrace.errors import ConfigError, Problem

    error = ConfigError([Problem("t.yaml", "sim.fps", -1, "expected a number >= 1")])
    again = pickle.loads(pickle.dumps(error))
    assert type(again) is ConfigError
    assert again.problems == error.problems and str(again) == str(error)
