"""tinyrace/CarRacing-v0 as a drop-in for CarRacing-v3: registration, ids, spaces, track, info,
the Gymnasium checker, determinism and pickling (issue #2, points 1-3, 6 and 10)."""

from __future__ import annotations

import json
import pickle
import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import tinyrace  # noqa: F401  (registers the ids)
from tinyrace.errors import ConfigError

PROCEDURAL_IDS = ["tinyrace/CarRacing-v0", "tinyrace/TinyRace-v0"]
GAS = np.array([0.0, 1.0, 0.0], np.float32)


def reference_tiles(env, seed: int) -> np.ndarray:
    """CarRacing-v3's road tiles after reset(seed): road_poly minus the pure red/white kerbs."""
    env.reset(seed=seed)
    kerb = {(255, 255, 255), (255, 0, 0)}
    return np.array(
        [vertices for vertices, colour in env.road_poly if tuple(map(int, colour)) not in kerb],
        dtype=float,
    )


# -- point 1: importing registers and does nothing else --------------------------------------
def test_import_registers_the_ids_and_does_nothing_else() -> None:
    script = (
        "import json, sys\n"
        "before = set(sys.modules)\n"
        "import tinyrace\n"
        "from gymnasium.envs.registration import registry\n"
        "print(json.dumps({'ids': sorted(k for k in registry if k.startswith('tinyrace/')),"
        " 'new': sorted(set(sys.modules) - before)}))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=60, check=True
    )
    result = json.loads(done.stdout)  # anything printed by the import would break this
    assert done.stdout.count("\n") == 1 and done.stderr == ""
    assert result["ids"] == ["tinyrace/CarRacing-v0", "tinyrace/TinyRace-v0"]
    loaded = {name.split(".")[0] for name in result["new"]}
    # entry points are strings: nothing heavy (or a window library) is imported yet
    assert not loaded & {"pygame", "pymunk", "cv2", "Box2D"}


# -- point 2: ids, kwargs, spaces, spec ------------------------------------------------------
@pytest.mark.parametrize("continuous", [True, False])
def test_carracing_kwargs_and_spaces_match_carracing_v3(continuous: bool) -> None:
    kwargs = dict(
        render_mode="rgb_array",
        verbose=False,
        lap_complete_percent=0.5,
        domain_randomize=True,
        continuous=continuous,
    )
    ours = gym.make("tinyrace/CarRacing-v0", **kwargs)
    reference = gym.make("CarRacing-v3", **kwargs)
    assert ours.observation_space == reference.observation_space
    assert ours.action_space == reference.action_space
    assert ours.render_mode == reference.render_mode == "rgb_array"
    assert ours.metadata["render_fps"] == reference.metadata["render_fps"] == 50
    assert set(reference.metadata["render_modes"]) <= set(ours.metadata["render_modes"])
    track = ours.unwrapped.config.tracks[0]
    assert track.lap_complete_percent == 0.5 and track.domain_randomize is True
    ours.close()
    reference.close()


@pytest.mark.parametrize("env_id", ["tinyrace/CarRacing-v0", "CarRacing-v3"])
def test_verbose_speaks_about_track_generation(env_id: str, capsys) -> None:
    gym.make(env_id).reset(seed=36)  # the first track attempt fails to close on this seed
    assert capsys.readouterr().out == ""
    gym.make(env_id, verbose=True).reset(seed=36)
    assert "track" in capsys.readouterr().out


def test_unknown_kwarg_is_refused_like_carracing_v3() -> None:
    with pytest.raises(TypeError):
        gym.make("CarRacing-v3", track_width=3)
    with pytest.raises(TypeError):
        gym.make("tinyrace/CarRacing-v0", track_width=3)


def test_spec_matches_carracing_v3() -> None:
    ours, reference = gym.spec("tinyrace/CarRacing-v0"), gym.spec("CarRacing-v3")
    assert ours.max_episode_steps == reference.max_episode_steps == 1000
    assert ours.reward_threshold == reference.reward_threshold == 900


def test_time_limit_truncates_at_1000_steps() -> None:
    env = gym.make("tinyrace/CarRacing-v0")
    env.reset(seed=0)
    idle = np.zeros(3, np.float32)
    ends = [env.step(idle)[2:4] for _ in range(1000)]
    assert ends[-1] == (False, True)
    assert not any(terminated or truncated for terminated, truncated in ends[:-1])


@pytest.mark.parametrize("seed", [0, 7])
def test_tinyrace_v0_defaults_to_the_same_procedural_track(seed: int) -> None:
    carracing, tinyrace_v0 = gym.make("tinyrace/CarRacing-v0"), gym.make("tinyrace/TinyRace-v0")
    obs_a, info_a = carracing.reset(seed=seed)
    obs_b, info_b = tinyrace_v0.reset(seed=seed)
    tiles = carracing.unwrapped.track.tiles
    np.testing.assert_array_equal(tiles, tinyrace_v0.unwrapped.track.tiles)
    assert carracing.action_space == tinyrace_v0.action_space
    np.testing.assert_array_equal(obs_a, obs_b)
    assert info_a == info_b


def test_config_takes_a_yaml_path_or_a_dict(tmp_path) -> None:
    config = {"track": {"type": "procedural", "half_width": 5.0, "lap_complete_percent": 0.5}}
    path = tmp_path / "narrow.yaml"
    path.write_text("track:\n  type: procedural\n  half_width: 5.0\n  lap_complete_percent: 0.5\n")
    from_dict = gym.make("tinyrace/TinyRace-v0", config=config)
    from_yaml = gym.make("tinyrace/TinyRace-v0", config=str(path))
    from_dict.reset(seed=3)
    from_yaml.reset(seed=3)
    tiles = from_dict.unwrapped.track.tiles
    np.testing.assert_array_equal(tiles, from_yaml.unwrapped.track.tiles)
    # tile i spans +-half_width across point i: its first two corners are 2 * 5 u apart
    np.testing.assert_allclose(np.linalg.norm(tiles[:, 0] - tiles[:, 1], axis=1), 10.0)
    assert from_yaml.unwrapped.config.tracks[0].lap_complete_percent == 0.5


def test_config_errors_name_the_key() -> None:
    with pytest.raises(ConfigError, match="half_width"):
        gym.make("tinyrace/TinyRace-v0", config={"track": {"type": "procedural", "half_width": -1}})


# -- point 3: the track, at env level ---------------------------------------------------------
@pytest.fixture(scope="module")
def carracing_v3():
    env = gym.make("CarRacing-v3")
    yield env.unwrapped
    env.close()


@pytest.mark.parametrize("seed", [0, 1, 36])  # 36: the first attempt fails in both
def test_env_track_tiles_equal_carracing_v3(carracing_v3, seed: int) -> None:
    env = gym.make("tinyrace/CarRacing-v0")
    env.reset(seed=seed)
    expected = reference_tiles(carracing_v3, seed)
    np.testing.assert_allclose(env.unwrapped.track.tiles, expected, rtol=0, atol=1e-6)


def test_track_exposes_centerline_tiles_and_kerbs() -> None:
    env = gym.make("tinyrace/CarRacing-v0")
    _, info = env.reset(seed=2)
    track = env.unwrapped.track
    n = len(track.tiles)
    assert track.centerline.shape == (n, 2) and track.tiles.shape == (n, 4, 2)
    assert track.kerbs.ndim == 3 and track.kerbs.shape[1:] == (4, 2) and len(track.kerbs) > 0
    # tile 0 first: the car starts on point 0, tile i ends at point i
    np.testing.assert_allclose(info["pose"][:2], track.centerline[0], atol=1e-9)
    middle = track.tiles[:, :2].mean(axis=1)  # mid-point of each tile's leading edge
    np.testing.assert_allclose(middle, track.centerline, atol=1e-9)
    assert info["tiles_total"] == n


# -- point 6: info every step -----------------------------------------------------------------
@pytest.mark.parametrize("env_id", PROCEDURAL_IDS)
def test_info_every_step(env_id: str) -> None:
    env = gym.make(env_id)
    _, info = env.reset(seed=4)
    infos = [info]
    for i in range(120):
        action = np.array([0.3 if i > 60 else 0.0, 1.0, 0.0], np.float32)
        _, _, terminated, _, info = env.step(action)
        assert not terminated
        infos.append(info)
        car = env.unwrapped.car
        assert info["pose"] == pytest.approx(car.pose)
        assert info["speed"] == pytest.approx(car.speed)
    for info in infos:
        x, y, heading = info["pose"]
        assert all(isinstance(v, float) for v in (x, y, heading, info["speed"]))
        assert 0 <= info["tiles_visited"] <= info["tiles_total"] == len(env.unwrapped.track.tiles)
        assert info["wheels_on_grass"] in range(5)
        assert "lap_finished" not in info  # only on termination, as in CarRacing-v3
    visited = [info["tiles_visited"] for info in infos]
    assert visited == sorted(visited) and visited[-1] > visited[0]
    assert infos[-1]["speed"] > 20
    assert infos[-1]["wheels_on_grass"] > 0  # steering right off the road at speed
    assert infos[0]["wheels_on_grass"] == 0


# -- point 10: checker, determinism, pickling -------------------------------------------------
@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [
        ("tinyrace/CarRacing-v0", {}),
        ("tinyrace/CarRacing-v0", {"continuous": False, "domain_randomize": True}),
        ("tinyrace/TinyRace-v0", {}),
    ],
)
def test_check_env_passes_without_warnings(env_id: str, kwargs: dict, monkeypatch) -> None:
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")  # the checker also opens the human mode
    monkeypatch.setenv("SDL_AUDIODRIVER", "dummy")
    env = gym.make(env_id, **kwargs)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped)
    assert [str(w.message) for w in caught] == []
    env.close()


def rollout(env_id: str, seed: int, steps: int, **kwargs) -> list:
    env = gym.make(env_id, **kwargs)
    env.action_space.seed(seed)
    observation, info = env.reset(seed=seed)
    trace = [(observation, 0.0, False, False, info)]
    for _ in range(steps):
        trace.append(env.step(env.action_space.sample()))
        if trace[-1][2] or trace[-1][3]:
            break
    return trace


@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [
        ("tinyrace/CarRacing-v0", {}),
        ("tinyrace/CarRacing-v0", {"continuous": False, "domain_randomize": True}),
        ("tinyrace/TinyRace-v0", {}),
    ],
)
def test_same_seed_same_rollout(env_id: str, kwargs: dict) -> None:
    first, second = rollout(env_id, 5, 200, **kwargs), rollout(env_id, 5, 200, **kwargs)
    assert len(first) == len(second) == 201
    for a, b in zip(first, second, strict=True):
        np.testing.assert_array_equal(a[0], b[0])
        assert a[1:] == b[1:]  # reward, terminated, truncated, info
    other = rollout(env_id, 6, 20, **kwargs)
    assert not np.array_equal(first[20][0], other[20][0])


@pytest.mark.parametrize("env_id", PROCEDURAL_IDS)
def test_pickle_mid_episode_continues_identically(env_id: str) -> None:
    env = gym.make(env_id, render_mode="rgb_array")
    env.reset(seed=8)
    for _ in range(40):
        env.step(GAS)
    clone = pickle.loads(pickle.dumps(env))
    rng = np.random.default_rng(0)
    for _ in range(60):
        action = np.array([rng.uniform(-1, 1), rng.uniform(0, 1), 0.0], np.float32)
        a, b = env.step(action), clone.step(action)
        np.testing.assert_array_equal(a[0], b[0])
        assert a[1:] == b[1:]
    np.testing.assert_array_equal(env.render(), clone.render())
    assert env.unwrapped.car is not clone.unwrapped.car
