"""Image tracks: tinycarlo 1.1 track folders, loaded unchanged.

The folder's track.yaml, every key of tinycarlo's schema with its default, both
spellings of its sections, its image formats and colour conventions; episodes
(step limit, several tracks and spawns), the overview, the shipped examples,
determinism and pickling.
"""

from __future__ import annotations

import collections
import math
import os
import pickle
import subprocess
import sys
import warnings

import cv2
import gymnasium as gym
import numpy as np
import pytest
import yaml
from gymnasium import spaces
from gymnasium.utils.env_checker import check_env
from synthetic import (
    BGR,
    ENV_ID,
    EXAMPLES,
    ROOT,
    blank,
    color_mask,
    make_env,
    square,
    straight,
    write_track,
)

from tinyrace.config import Color
from tinyrace.errors import ConfigError
from tinyrace.render.overview import CAR_COLOR, ROI_COLORS

EXAMPLE_NAMES = ["segmented", "formula_student", "carolo_cup"]


# -- the track folder and its schema --------------------------------------------------------


def test_formula_student_folder_loads_its_track_yaml(monkeypatch):
    monkeypatch.chdir(ROOT)
    env = gym.make(ENV_ID, environment="./example_tracks/formula_student")
    raw = yaml.safe_load((EXAMPLES / "formula_student" / "track.yaml").read_text())
    config = env.unwrapped.config
    assert config.kind == "image"
    for key, value in raw["sim"].items():
        assert getattr(config.sim, key) == value, key
    for key, value in raw["car"].items():
        assert getattr(config.car, key) == value, key
    obstacles = raw["reward_design"]["color_obstacles"]
    assert [o.color.bgr for o in config.reward_design.color_obstacles] == [
        tuple(o["color"]) for o in obstacles
    ]
    assert [o.reward for o in config.reward_design.color_obstacles] == [
        o["reward"] for o in obstacles
    ]
    cte = raw["reward_design"]["cross_track_error"]
    assert config.reward_design.cross_track_error.use_cte == cte["use_cte"]
    assert config.reward_design.cross_track_error.trajectory_color.bgr == tuple(
        cte["trajectory_color"]
    )
    assert [(c.id, list(c.resolution), list(c.roi)) for c in config.cameras] == [
        (c["id"], c["resolution"], c["roi"]) for c in raw["cameras"]
    ]
    assert [list(s) for s in config.tracks[0].spawns] == raw["tracks"][0]["spawns"]
    # the picture is the folder's image, binarised, with the trajectory taken out
    observation, info = env.reset(seed=0)
    assert set(observation) == {c["id"] for c in raw["cameras"]}
    assert list(info["pose"]) == raw["tracks"][0]["spawns"][info["spawn"]]
    bgr = cv2.imread(str(EXAMPLES / "formula_student" / raw["tracks"][0]["image"]))
    expected = np.where(bgr > 100, 255, 0).astype(np.uint8)[..., ::-1]
    expected[np.all(expected == 255, axis=-1)] = 0  # the white trajectory
    np.testing.assert_array_equal(env.unwrapped.track.picture[..., :3], expected)


# tinycarlo 1.1's defaults, by key path (colours as written in YAML: BGR)
TINYCARLO_DEFAULTS = {
    "sim.fps": 30,
    "sim.render_realtime": True,
    "sim.step_limit": None,
    "sim.overview_downscale": 1,
    "reward_design.color_obstacles": (),
    "reward_design.cross_track_error.use_cte": False,
    "reward_design.cross_track_error.trajectory_color.bgr": (255, 255, 255),
    "car.wheelbase": 160,
    "car.track_width": 100,
    "car.velocity": 500,
    "car.max_steering_change": None,
    "cameras[0].resolution": (480, 640),
    "cameras[0].roi": (480, 640),
    "cameras[0].position": (0, 0),
    "tracks[0].spawns": ((500, 500, 0),),
}


def lookup(config, key_path: str):
    value = config
    for part in key_path.split("."):
        name, _, index = part.partition("[")
        value = getattr(value, name)
        if index:
            value = value[int(index[:-1])]
    return value


def test_tinycarlo_defaults(tmp_path):
    """A folder that gives only an image and a camera id gets tinycarlo 1.1's defaults."""
    config = {"cameras": [{"id": "cam"}], "tracks": [{"image": "track.png"}]}
    env = make_env(write_track(tmp_path, blank(700, 700), config))
    for key_path, default in TINYCARLO_DEFAULTS.items():
        assert lookup(env.unwrapped.config, key_path) == default, key_path
    # and they act: spawn, camera size, speed, no steering rate limit, no cte
    observation, info = env.reset(seed=0)
    assert info["pose"] == (500, 500, 0)
    assert observation["cam"].shape == (480, 640, 3)
    assert "cte" not in info
    _, _, _, _, info = env.step(np.array([1.0], np.float32))
    turn = 500 * math.tan(math.radians(33)) / 160 / 30  # full lock at once [rad/step]
    assert info["pose"][2] == pytest.approx(turn)
    assert math.dist(info["pose"][:2], (500, 500)) == pytest.approx(500 / 30, rel=1e-3)
    assert env.unwrapped.car.front_axle == pytest.approx(
        (info["pose"][0] + 160 * math.cos(turn), info["pose"][1] + 160 * math.sin(turn))
    )


CAMERA = {"id": "cam", "resolution": [60, 80], "roi": [120, 160], "position": [0, 0]}
TRACK = {"image": "track.png", "spawns": [[300.0, 300.0, 0.5]]}


@pytest.mark.parametrize("camera_key", ["camera", "cameras"])
@pytest.mark.parametrize("camera_as_list", [False, True])
@pytest.mark.parametrize("track_key", ["track", "tracks"])
@pytest.mark.parametrize("track_as_list", [False, True])
def test_section_spellings(tmp_path, camera_key, camera_as_list, track_key, track_as_list):
    config = {
        camera_key: [CAMERA] if camera_as_list else CAMERA,
        track_key: [TRACK] if track_as_list else TRACK,
    }
    env = make_env(write_track(tmp_path, blank(), config))
    assert [c.id for c in env.unwrapped.config.cameras] == ["cam"]
    assert env.unwrapped.config.tracks[0].spawns == ((300.0, 300.0, 0.5),)
    observation, info = env.reset(seed=0)
    assert observation["cam"].shape == (60, 80, 3) and info["pose"] == (300.0, 300.0, 0.5)


def test_both_spellings_at_once_are_refused(tmp_path):
    with pytest.raises(ConfigError, match="given twice"):
        make_env(write_track(tmp_path, blank(), {"camera": CAMERA, "cameras": [CAMERA]}))


@pytest.mark.parametrize("track_type, kind", [(None, "image"), ("image", "image")])
def test_a_track_without_type_is_an_image(tmp_path, track_type, kind):
    track = dict(TRACK, **({"type": track_type} if track_type else {}))
    env = make_env(write_track(tmp_path, blank(), {"tracks": [track]}))
    assert env.unwrapped.config.kind == kind
    assert env.action_space.shape == (1,)  # tinycarlo's kinematic car


def test_type_procedural_is_carracings_track(tmp_path):
    env = make_env(write_track(tmp_path, None, {"cameras": [], "tracks": [{"type": "procedural"}]}))
    assert env.unwrapped.config.kind == "procedural"
    assert env.observation_space == spaces.Box(0, 255, (96, 96, 3), np.uint8)
    assert env.action_space.shape == (3,)


def test_folder_without_tracks_is_tinycarlos_black_plane(tmp_path):
    env = make_env(write_track(tmp_path, None, {"cameras": [CAMERA]}))
    assert env.unwrapped.config.kind == "image"
    observation, info = env.reset(seed=0)
    assert info["pose"] == (500, 500, 0)
    assert env.unwrapped.track.picture_size == (1000, 1000)
    assert not observation["cam"].any()


# -- images and colours -----------------------------------------------------------------------

# A car at SPAWN (wheelbase 100) has its camera (roi = resolution = [120, 160]) sample the
# track's pixel centres exactly: camera pixel [row, column] shows track pixel (x, y) =
# (369 - row, 220 + column).
SPAWN = (149.5, 299.5, 0.0)
EXACT_CAMERA = {"id": "cam", "resolution": [120, 160], "roi": [120, 160]}


def seen(frame: np.ndarray, x: int, y: int) -> tuple:
    """The camera pixel over track pixel (x, y), as an RGB tuple."""
    return tuple(int(c) for c in frame[369 - x, y - 220])


def blocks_image(kind: str) -> tuple[np.ndarray, dict]:
    """Two blocks ahead of SPAWN in the given pixel format; what the camera must show (RGB)."""
    if kind == "grey":
        image = np.full((600, 600), 40, np.uint8)  # dark grey ground: black
        image[240:290, 270:350] = 200  # light grey: white
        image[310:360, 270:350] = 100  # not above the threshold: black
        return image, {(310, 265): (255, 255, 255), (310, 335): (0, 0, 0)}
    image = blank()
    image[240:290, 270:350] = (30, 20, 230)  # BGR, nearly red
    image[310:360, 270:350] = (210, 180, 60)  # BGR: blue and green above 100
    if kind == "rgba":
        alpha = np.full((600, 600, 1), 255, np.uint8)
        alpha[240:290, 270:350] = 0  # a transparent red block is still red
        image = np.concatenate([image, alpha], axis=2)
    return image, {(310, 265): (255, 0, 0), (310, 335): (0, 255, 255)}


FORMATS = [("rgb", ".png"), ("rgba", ".png"), ("grey", ".png"), ("rgb", ".jpg")]


@pytest.mark.parametrize("kind, suffix", FORMATS)
def test_image_formats(tmp_path, kind, suffix):
    image, expected = blocks_image(kind)
    name = "track" + suffix
    params = [cv2.IMWRITE_JPEG_QUALITY, 90] if suffix == ".jpg" else []
    assert cv2.imwrite(str(tmp_path / name), image, params)
    config = {
        "car": {"wheelbase": 100},
        "cameras": [EXACT_CAMERA],
        "tracks": [{"image": name, "spawns": [list(SPAWN)]}],
    }
    observation, _ = make_env(write_track(tmp_path, None, config)).reset(seed=0)
    frame = observation["cam"]
    for (x, y), rgb in expected.items():
        assert seen(frame, x, y) == rgb, (x, y)
    # binarised: every channel is 0 or 255 (the camera samples pixel centres exactly) ...
    assert set(np.unique(frame)) <= {0, 255}
    if suffix == ".png":  # ... and, lossless, no colour but the blocks' and the ground's
        colours = set(map(tuple, frame.reshape(-1, 3).tolist()))
        assert colours == {(0, 0, 0), *expected.values()}


def test_binarisation_threshold_is_100_per_channel(tmp_path):
    image = blank()
    image[250:300, 270:320] = (100, 101, 0)  # BGR -> (0, 255, 0): green
    image[320:370, 270:320] = (101, 100, 255)  # BGR -> (255, 0, 255): magenta
    obstacles = [{"color": [0, 255, 0], "reward": -1}, {"color": [255, 0, 255], "reward": -2}]
    config = {
        "car": {"wheelbase": 100, "track_width": 20, "velocity": 300},
        "cameras": [EXACT_CAMERA],
        "reward_design": {"color_obstacles": obstacles},
        "tracks": [{"image": "track.png", "spawns": [list(SPAWN), [150, 275, 0], [150, 345, 0]]}],
    }
    env = make_env(write_track(tmp_path, image, config))
    observation, _ = env.reset(seed=0, options={"spawn": 0})
    assert seen(observation["cam"], 290, 275) == (0, 255, 0)
    assert seen(observation["cam"], 290, 345) == (255, 0, 255)
    for spawn, color, reward in [(1, "#00ff00", -1), (2, "#ff00ff", -2)]:
        env.reset(seed=0, options={"spawn": spawn})
        steps = [env.step(straight()) for _ in range(5)]
        assert {c for step in steps for c in step[4]["obstacles_hit"]} == {color}
        assert steps[-1][1] == reward


@pytest.mark.parametrize(
    "spec, fires", [([0, 0, 255], True), ("#ff0000", True), ([255, 0, 0], False)]
)
def test_yaml_lists_are_bgr_and_strings_rgb(tmp_path, spec, fires):
    image = blank()
    image[270:330, 300:340] = BGR["red"]  # cv2 writes BGR: this block is red
    config = {
        "car": {"wheelbase": 100, "velocity": 300},
        "cameras": [EXACT_CAMERA],
        "reward_design": {"color_obstacles": [{"color": spec, "reward": -1}]},
        "tracks": [{"image": "track.png", "spawns": [list(SPAWN)]}],
    }
    if not fires:  # blue, which no pixel has: refused, naming the list read the other way
        with pytest.raises(ConfigError, match=r"the image has \[0, 0, 255\]: a list is \[b, g"):
            make_env(write_track(tmp_path, image, config))
        return
    env = make_env(write_track(tmp_path, image, config))
    observation, _ = env.reset(seed=0)
    assert seen(observation["cam"], 320, 300) == (255, 0, 0)  # observations are RGB
    hits = [env.step(straight())[4]["obstacles_hit"] for _ in range(8)]
    assert ["#ff0000"] in hits
    assert env.unwrapped.config.reward_design.color_obstacles[0].color == Color.rgb(255, 0, 0)


# -- episodes -----------------------------------------------------------------------------------


@pytest.mark.parametrize("limit", [1, 7])
def test_step_limit_truncates_at_that_step(tmp_path, limit):
    env = make_env(write_track(tmp_path, blank(), {"sim": {"step_limit": limit}}))
    env.reset(seed=0)
    for step in range(1, limit + 1):
        _, _, terminated, truncated, _ = env.step(straight())
        assert not terminated
        assert truncated == (step == limit), step


def several_tracks(tmp_path):
    """Three images, each with a colour 100 px ahead of every spawn, and 2..4 spawns."""
    folder = tmp_path / "several"
    folder.mkdir()
    colours = ["red", "green", "blue"]
    tracks = []
    for n, colour in enumerate(colours):
        image = blank(400 + 100 * n, 600)
        spawns = [[100.0 + 40 * s, 150.0 + 50 * s, 0.0] for s in range(n + 2)]
        for x, y, _ in spawns:
            square(image, (x + 160 + 60, y), 30, BGR[colour])
        cv2.imwrite(str(folder / f"t{n}.png"), image)
        tracks.append({"image": f"t{n}.png", "spawns": spawns})
    camera = {"id": "cam", "resolution": [60, 80], "roi": [120, 160]}
    return write_track(folder, None, {"cameras": [camera], "tracks": tracks}), colours, tracks


def test_several_tracks_and_spawns(tmp_path):
    folder, colours, tracks = several_tracks(tmp_path)
    env = make_env(folder)
    counts = collections.Counter()
    env.reset(seed=1)
    for _ in range(150):
        observation, info = env.reset()
        track, spawn = info["track"], info["spawn"]
        counts[track, spawn] += 1
        assert list(info["pose"]) == tracks[track]["spawns"][spawn]
        assert color_mask(observation["cam"], BGR[colours[track]]).sum() > 20
    assert set(counts) == {(t, s) for t in range(3) for s in range(t + 2)}
    # the same seed, the same choice; other seeds, other choices
    chosen = {s: env.reset(seed=s)[1] for s in range(10)}
    again = {s: env.reset(seed=s)[1] for s in range(10)}
    picks = [(chosen[s]["track"], chosen[s]["spawn"]) for s in range(10)]
    assert picks == [(again[s]["track"], again[s]["spawn"]) for s in range(10)]
    assert len(set(picks)) > 3
    # options choose
    observation, info = env.reset(seed=0, options={"track": 2, "spawn": 3})
    assert (info["track"], info["spawn"]) == (2, 3)
    assert list(info["pose"]) == tracks[2]["spawns"][3]
    assert color_mask(observation["cam"], BGR["blue"]).sum() > 20


@pytest.mark.parametrize(
    "options, message",
    [
        ({"track": 3}, "track: got 3; expected a track index from 0 to 2"),
        ({"track": 0, "spawn": 2}, "spawn: got 2; expected a spawn index from 0 to 1"),
        ({"track": 1, "spawn": -1}, "spawn: got -1; expected a spawn index from 0 to 2"),
        ({"spawn": 0.5}, "spawn: got 0.5"),
    ],
)
def test_bad_track_or_spawn_index(tmp_path, options, message):
    folder, _, _ = several_tracks(tmp_path)
    with pytest.raises(ConfigError) as caught:
        make_env(folder).reset(seed=0, options=options)
    assert message in str(caught.value)


# -- the overview ---------------------------------------------------------------------------


@pytest.mark.parametrize("downscale", [1, 2, 1.5])
def test_overview(tmp_path, downscale):
    image = blank(400, 600)
    image[:, 560:] = BGR["white"]
    cameras = [
        {"id": "front", "resolution": [60, 80], "roi": [120, 160]},
        {"id": "back", "resolution": [30, 40], "roi": [60, 80], "yaw": 180},
    ]
    spawn = (300.0, 300.0, 0.0)
    config = {
        "sim": {"overview_downscale": downscale},
        "car": {"wheelbase": 100, "track_width": 60},
        "cameras": cameras,
        "tracks": [{"image": "track.png", "spawns": [list(spawn)]}],
    }
    env = make_env(write_track(tmp_path, image, config), render_mode="rgb_array")
    observation, _ = env.reset(seed=0)
    frame = env.render()
    assert frame.dtype == np.uint8
    assert frame.shape == (round(400 / downscale), round(600 / downscale), 3)

    def at(x, y):  # the frame pixel over track point (x, y)
        return tuple(frame[int(y / downscale), int(x / downscale)])

    assert at(350, 300) == CAR_COLOR  # the footprint's middle: rear axle + wheelbase / 2
    assert at(300 - 20, 300) != CAR_COLOR and at(350, 300 + 45) != CAR_COLOR
    assert at(580, 390) == (255, 255, 255)  # the track picture
    # each camera's window outline (drawn anti-aliased): the middle of the front camera's far
    # edge, and of the back camera's left edge (its far edge is under the car)
    for k, (x, y) in enumerate([(400 + 120, 300), (400 - 30, 300 - 40)]):
        row, column = round(y / downscale), round(x / downscale)
        near = frame[row - 2 : row + 3, column - 2 : column + 3]
        assert color_mask(near, ROI_COLORS[k][::-1], tolerance=60).any(), k
        assert not color_mask(near, ROI_COLORS[1 - k][::-1], tolerance=60).any(), k
    # the camera images inset along the top: the front camera sees the white band
    first = observation["front"]
    inset = frame[4 : 4 + first.shape[0], 4 : 4 + first.shape[1]]
    if downscale == 1:  # the inset is the camera image itself at this size
        np.testing.assert_array_equal(inset, first)
    # the car moves in the overview
    for _ in range(6):
        env.step(straight())
    moved = env.render()
    assert tuple(moved[int(300 / downscale), int((350 + 100) / downscale)]) == CAR_COLOR


def test_human_render_in_a_subprocess():
    script = f"""
import numpy as np, gymnasium as gym, tinyrace
env = gym.make({ENV_ID!r}, environment={str(EXAMPLES / "carolo_cup")!r}, render_mode="human",
               sim={{"render_realtime": False}})
env.reset(seed=0)
for _ in range(3):
    assert env.step(np.zeros(1, np.float32))[0]
assert env.render() is None
print(env.unwrapped._window.screen.get_size())
env.close()
"""
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy", "SDL_AUDIODRIVER": "dummy"}
    result = subprocess.run(
        [sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 0, result.stderr
    height, width = cv2.imread(str(EXAMPLES / "carolo_cup" / "carolo_cup.png")).shape[:2]
    assert result.stdout.strip().splitlines()[-1] == str((round(width / 2), round(height / 2)))


# -- the shipped examples ---------------------------------------------------------------------


@pytest.mark.parametrize("name", EXAMPLE_NAMES)
def test_example_track(name, monkeypatch):
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")  # check_env opens the human window too
    monkeypatch.setenv("SDL_AUDIODRIVER", "dummy")
    env = make_env(EXAMPLES / name)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped)
    assert [str(w.message) for w in caught] == []
    env.action_space.seed(0)
    observation, info = env.reset(seed=0)
    for _ in range(300):
        observation, reward, terminated, truncated, info = env.step(env.action_space.sample())
        assert env.observation_space.contains(observation)
        assert math.isfinite(reward)
        if terminated or truncated:
            observation, info = env.reset()
    assert 0 <= info["cte"] < 2000
    env.close()


# -- determinism and pickling -----------------------------------------------------------------


def rollout(env, actions, seed=None):
    """Everything the env returns, for comparison."""
    out = []
    if seed is not None:
        observation, info = env.reset(seed=seed)
        out.append((observation, info))
    for action in actions:
        observation, reward, terminated, truncated, info = env.step(action)
        out.append((observation, reward, terminated, truncated, info))
        if terminated or truncated:
            out.append(env.reset())
    return out


def assert_same(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        assert x[1:] == y[1:]
        assert x[0].keys() == y[0].keys()
        for key in x[0]:
            np.testing.assert_array_equal(x[0][key], y[0][key])


def test_determinism(tmp_path):
    actions = np.random.default_rng(5).uniform(-1, 1, (150, 1)).astype(np.float32)
    one = rollout(make_env(EXAMPLES / "formula_student"), actions, seed=11)
    two = rollout(make_env(EXAMPLES / "formula_student"), actions, seed=11)
    assert_same(one, two)
    assert any(step[4]["obstacles_hit"] for step in one if len(step) == 5)  # it met cones
    other = rollout(make_env(EXAMPLES / "formula_student"), actions, seed=12)
    assert any(a[-1] != b[-1] for a, b in zip(one, other, strict=True))


def test_pickle_mid_episode():
    actions = np.random.default_rng(6).uniform(-1, 1, (80, 1)).astype(np.float32)
    env = make_env(EXAMPLES / "segmented")
    rollout(env, actions[:30], seed=3)
    clone = pickle.loads(pickle.dumps(env))
    assert_same(rollout(env, actions[30:]), rollout(clone, actions[30:]))
