"""tinyrace.sb3.BatchVecEnv against SB3's own DummyVecEnv, SB3's wrappers on it, and the
id in SB3's SubprocVecEnv workers (forkserver and spawn).

Run by .ci/run's train stage (Stable-Baselines3 and torch installed).
"""

from __future__ import annotations

import functools
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.wrappers import TimeLimit
from stable_baselines3 import PPO
from stable_baselines3.common.env_checker import check_env
from stable_baselines3.common.env_util import make_vec_env as sb3_make_vec_env
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import (
    DummyVecEnv,
    SubprocVecEnv,
    VecFrameStack,
    VecMonitor,
    VecNormalize,
)

import tinyrace  # noqa: F401  (registers the ids)
from tinyrace.sb3 import BatchVecEnv, make_vec_env, split_infos
from tinyrace.vector import BatchVectorEnv

EPISODE = 25  # [steps] so that 60 steps cross two resets
MAKE = functools.partial(gym.make, "tinyrace/CarRacing-v0", max_episode_steps=EPISODE)


def same(a, b, where: str) -> None:
    """Equal values: arrays by dtype, shape and content, dicts key by key."""
    if isinstance(a, dict):
        assert set(a) == set(b), (where, set(a) ^ set(b))
        for key in a:
            same(a[key], b[key], f"{where}.{key}")
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, (where, a.dtype, b.dtype)
        assert np.array_equal(a, b), where
    else:
        assert a == b, (where, a, b)


@pytest.mark.parametrize(("workers", "parent_steps"), [(0, False), (2, False), (1, True)])
def test_steps_equal_sb3s_dummy_vec_env(workers, parent_steps):
    dummy = DummyVecEnv([MAKE] * 3)
    batch = BatchVecEnv(BatchVectorEnv([MAKE] * 3, workers=workers, parent_steps=parent_steps))
    for vec in (dummy, batch):
        vec.seed(11)
    same(dummy.reset(), batch.reset(), "reset")
    assert [set(i) for i in dummy.reset_infos] == [set(i) for i in batch.reset_infos]
    space = gym.spaces.Box(-1.0, 1.0, (3, 3), np.float32)
    space.seed(3)
    ends = 0
    for step in range(60):
        actions = np.clip(space.sample(), [-1, 0, 0], 1).astype(np.float32)
        a, b = dummy.step(actions), batch.step(actions)
        for name, x, y in zip(("obs", "rewards", "dones"), a[:3], b[:3], strict=True):
            same(x, y, f"step {step} {name}")
        for index, (x, y) in enumerate(zip(a[3], b[3], strict=True)):
            same(x, y, f"step {step} info {index}")
        ends += int(b[2].sum())
    assert ends == 3 * (60 // EPISODE)  # every env crossed its resets
    dummy.close()
    batch.close()


@pytest.mark.parametrize("parent_steps", [False, True])
def test_vec_env_api_with_indices(parent_steps):
    vec = make_vec_env(MAKE, 3, workers=2 - parent_steps, seed=0, parent_steps=parent_steps)
    assert (vec.venv._workers.parent is not None) is parent_steps
    vec.reset()
    assert vec.get_attr("spec", indices=[2])[0].id == "tinyrace/CarRacing-v0"
    vec.set_attr("marker", 5, indices=[0, 2])
    vec.set_attr("marker", 7, indices=1)
    assert vec.get_attr("marker") == [5, 7, 5]
    assert vec.env_method("get_wrapper_attr", "marker", indices=[2, 0]) == [5, 5]
    assert vec.env_is_wrapped(TimeLimit) == [True] * 3
    assert vec.env_is_wrapped(Monitor, indices=[1]) == [False]
    assert vec.get_images() == [None] * 3  # no render_mode
    vec.set_options({"randomize": False})
    vec.reset()
    vec.close()


def test_sb3_wrappers_and_ppo_run_on_it():
    vec = make_vec_env("tinyrace/CarRacing-v0", 2, workers=1, seed=0, max_episode_steps=20)
    wrapped = VecNormalize(VecFrameStack(VecMonitor(vec), 4), norm_reward=True)
    observations = wrapped.reset()
    assert observations.shape == (2, 96, 96, 12) and observations.dtype == np.float32
    episodes = []
    for _ in range(45):
        *_, infos = wrapped.step(np.tile([0.0, 0.5, 0.0], (2, 1)).astype(np.float32))
        episodes += [info["episode"]["l"] for info in infos if "episode" in info]
        assert all(
            info["terminal_observation"].shape == (96, 96, 12)
            for info in infos
            if "terminal_observation" in info
        )
    assert episodes == [20, 20, 20, 20]
    model = PPO(
        "CnnPolicy",
        VecFrameStack(make_vec_env(MAKE, 2, workers=2, seed=0), 4),
        n_steps=32,
        batch_size=32,
        n_epochs=1,
        seed=0,
    )
    model.learn(64)
    assert model.num_timesteps >= 64
    model.get_env().close()
    wrapped.close()


def test_sb3_env_checker_accepts_the_env():
    check_env(gym.make("tinyrace/CarRacing-v0"), warn=True)


def test_split_infos_keeps_masks():
    merged = {
        "a": np.array([1.5, 0.0]),
        "_a": np.array([True, False]),
        "d": {"x": np.array([1, 2]), "_x": np.array([True, True])},
        "_d": np.array([False, True]),
    }
    assert split_infos(merged, 2) == [{"a": 1.5}, {"d": {"x": 2}}]


@pytest.mark.parametrize("start_method", ["forkserver", "spawn"])
def test_the_id_works_in_sb3_subprocess_workers(start_method):
    """Workers that import nothing else make the env by the documented id, which imports
    tinyrace first (gymnasium's "module:id" form)."""
    vec = sb3_make_vec_env(
        "tinyrace:tinyrace/CarRacing-v0",
        n_envs=2,
        seed=0,
        vec_env_cls=SubprocVecEnv,
        vec_env_kwargs={"start_method": start_method},
    )
    observations = vec.reset()
    assert observations.shape == (2, 96, 96, 3)
    observations, rewards, _, infos = vec.step(np.zeros((2, 3), np.float32))
    assert rewards.shape == (2,) and "tiles_total" in infos[0]
    vec.close()


@pytest.mark.parametrize(
    ("kwargs", "said"),
    [
        ({"seed": "x"}, "seed: got 'x'; expected None or a whole number >= 0"),
        ({"seed": -1}, "seed: got -1"),
        ({"env_kwargs": [1, 2]}, "env_kwargs: got [1, 2]; expected a dict"),
        ({"env_kwargs": {"workers": 3}}, "'workers' is an argument of make_vec_env itself"),
        ({"env_id": 123}, "env_id: got 123; expected an env id"),
        ({"monitor_dir": "logs"}, "monitor_dir: not taken by tinyrace.sb3.make_vec_env: wrap"),
        ({"monitor_kwargs": {}}, "monitor_kwargs: not taken"),
        ({"vec_env_cls": SubprocVecEnv}, "vec_env_cls: not taken"),
        ({"vec_env_kwargs": {"start_method": "spawn"}}, "start method is context='spawn'"),
        ({"start_index": -1}, "start_index: got -1; expected a whole number >= 0"),
        ({"start_index": 1.5}, "start_index: got 1.5"),
        ({"wrapper_class": 3}, "wrapper_class: got 3; expected a wrapper class"),
        ({"wrapper_kwargs": [1]}, "wrapper_kwargs: got [1]; expected a dict"),
    ],
)
def test_make_vec_env_names_a_bad_argument_before_making_envs(kwargs, said, monkeypatch):
    made = []
    monkeypatch.setattr(BatchVectorEnv, "__init__", lambda *a, **k: made.append(a))
    arguments = {"env_id": "tinyrace/CarRacing-v0", "n_envs": 2, "workers": 1, **kwargs}
    with pytest.raises(ValueError) as caught:
        make_vec_env(**arguments)
    assert said in str(caught.value)
    assert made == []  # no env, no worker


@pytest.mark.parametrize("workers", [0, 1])
def test_make_vec_env_takes_sb3s_wrapper_class_and_start_index(workers):
    """As SB3's make_vec_env: each env wrapped in wrapper_class(env, **wrapper_kwargs), the
    envs seeded from seed whatever start_index; the env's keywords reach the env."""
    vec = make_vec_env(
        "tinyrace/CarRacing-v0",
        n_envs=2,
        workers=workers,
        seed=3,
        start_index=2,
        wrapper_class=gym.wrappers.GrayscaleObservation,
        wrapper_kwargs={"keep_dim": True},
        max_episode_steps=EPISODE,
    )
    sb3 = sb3_make_vec_env(
        "tinyrace/CarRacing-v0",
        n_envs=2,
        seed=3,
        start_index=2,
        wrapper_class=gym.wrappers.GrayscaleObservation,
        wrapper_kwargs={"keep_dim": True},
        env_kwargs={"max_episode_steps": EPISODE},
    )
    try:
        assert vec.observation_space == sb3.observation_space
        assert vec.observation_space.shape == (96, 96, 1)
        same(sb3.reset(), vec.reset(), "reset")
        for _ in range(EPISODE + 2):  # across the time limit's reset
            actions = np.tile(np.array([0.2, 0.5, 0.0], np.float32), (2, 1))
            expected, got = sb3.step(actions), vec.step(actions)
            same(expected[0], got[0], "observations")
            same(expected[1], got[1], "rewards")
            same(expected[2], got[2], "dones")
    finally:
        vec.close()
        sb3.close()


@pytest.fixture
def two() -> BatchVecEnv:
    vec = make_vec_env(MAKE, 2, workers=1)
    vec.reset()
    yield vec
    vec.close()


@pytest.mark.parametrize(
    ("options", "said"),
    [
        ({"reset_mask": np.array([True, False])}, "'reset_mask' is not an option here"),
        ([{}, {}, {"bogus": 1}], "got 3 dicts; expected None, a dict or a list of 2 dicts"),
        ([{}, 5], "got 5 among them"),
        ("x", "options: got 'x'"),
    ],
)
def test_set_options_names_what_reset_could_not_use(two, options, said):
    with pytest.raises(ValueError) as caught:
        two.set_options(options)
    assert said in str(caught.value)
    observations = two.reset()  # the options set before stay, and every env resets
    assert observations.shape == (2, 96, 96, 3) and observations.any(axis=(1, 2, 3)).all()


@pytest.mark.parametrize(
    "call",
    [
        lambda vec: vec.get_attr("spec", indices=[5]),
        lambda vec: vec.env_method("render", indices=[5]),
        lambda vec: vec.set_attr("foo", 1, indices=[5]),
        lambda vec: vec.env_is_wrapped(Monitor, indices=[0.5]),
    ],
)
def test_indices_outside_the_envs_are_named(two, call):
    with pytest.raises(ValueError, match=r"indices: got .*; expected env indices from -2 to 1"):
        call(two)


def test_negative_indices_count_from_the_end_as_in_sb3s_own_vec_envs(two):
    dummy = DummyVecEnv([MAKE] * 2)
    try:
        for indices in (-1, [-2, 1], None, 0):
            assert two.get_attr("spec", indices) == dummy.get_attr("spec", indices)
    finally:
        dummy.close()


# -- a saved model as a driver ------------------------------------------------------------------


@pytest.fixture(scope="module")
def pixel_model(tmp_path_factory) -> Path:
    """A PPO CNN trained for one rollout on 4 stacked CarRacing frames, as tinyrace train
    trains pixels."""
    envs = VecFrameStack(make_vec_env("tinyrace/CarRacing-v0", n_envs=2, seed=0, workers=0), 4)
    model = PPO("CnnPolicy", envs, n_steps=32, batch_size=64, n_epochs=1, seed=0)
    model.learn(64)
    envs.close()
    path = tmp_path_factory.mktemp("model") / "pixels.zip"
    model.save(path)
    return path


def test_a_model_driver_acts_as_the_model_does_through_sb3s_frame_stack(pixel_model: Path):
    """ModelDriver on one env, fed one observation at a time, takes the actions the model
    takes through SB3's VecFrameStack (zeros before the first frame, the newest last)."""
    from tinyrace.sb3 import ModelDriver

    model = PPO.load(pixel_model, device="cpu")
    envs = VecFrameStack(make_vec_env("tinyrace/CarRacing-v0", n_envs=1, seed=7, workers=0), 4)
    observations = envs.reset()
    expected = []
    for _ in range(30):
        action, _ = model.predict(observations, deterministic=True)
        expected.append(action[0])
        observations, _, dones, _ = envs.step(action)
        assert not dones[0]
    envs.close()
    env = gym.make("tinyrace/CarRacing-v0")
    observation, info = env.reset(seed=7)
    driver = ModelDriver(str(pixel_model))
    driver.reset(env)
    got = []
    for _ in range(30):
        action = driver.act(observation, info)
        got.append(action)
        observation, _, _, _, info = env.step(action)
    env.close()
    assert np.array_equal(np.array(expected), np.array(got))


def test_a_model_driver_runs_an_experiment_and_names_a_mismatch(
    pixel_model: Path, tmp_path: Path, capsys, monkeypatch
):
    from tinyrace import cli

    monkeypatch.chdir(tmp_path)
    experiment = (
        "env: {}\nepisodes: 1\nmax_steps: 20\noutput: {video: false}\n"
        f"driver: tinyrace.sb3:ModelDriver\ndriver_args: {{model: {pixel_model}}}\n"
    )
    (tmp_path / "e.yaml").write_text(experiment)
    assert cli.main(["run", "e.yaml", "--quiet"]) == 0, capsys.readouterr().err
    (tmp_path / "bad.yaml").write_text(
        experiment.replace("env: {}", "env: {environment: f1tenth_loop}")
    )
    assert cli.main(["run", "bad.yaml", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "the model was trained on observations (12, 96, 96)" in err
    assert cli.main(["run", "carracing", "--model", str(pixel_model), "--episodes", "1",
                     "--no-video", "--quiet"]) == 0  # fmt: skip
    assert cli.main(["run", "f1tenth_lidar", "--model", str(pixel_model), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"<command line>: --model: got {str(pixel_model)!r}" in err  # not the experiment
    assert "the model was trained on observations (12, 96, 96)" in err
    (tmp_path / "none.yaml").write_text(experiment.replace(str(pixel_model), "missing.zip"))
    assert cli.main(["run", "none.yaml", "--quiet"]) == 2
    assert "driver_args.model: got 'missing.zip'; expected the path of a saved model" in (
        capsys.readouterr().err
    )
