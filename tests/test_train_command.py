"""``tinyrace train`` without torch: its arguments, its env, its policy, and the message that
names the train extra. Training itself is tested in tests_train/ (CI's train stage)."""

from __future__ import annotations

import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces

import tinyrace  # noqa: F401  (registers the ids)
from tinyrace import cli, train
from tinyrace.errors import ConfigError
from tinyrace.examples import shipped_track
from tinyrace.train import envs


@pytest.fixture
def here(tmp_path: Path, monkeypatch) -> Path:
    monkeypatch.chdir(tmp_path)
    return tmp_path


@pytest.mark.parametrize("module", ["torch", "stable_baselines3"])
def test_without_the_extra_it_names_the_pip_command(here: Path, capsys, monkeypatch, module):
    monkeypatch.setitem(sys.modules, module, None)  # import fails as if not installed
    assert cli.main(["train", "--timesteps", "10"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("tinyrace: error: tinyrace train needs ")
    assert module.replace("_", "-") in err and 'pip install ".[train]"' in err
    assert "\n" not in err and not list(here.iterdir())  # one line, no model file


def test_a_mistyped_env_is_refused_before_training(here: Path, capsys):
    assert cli.main(["train", "formula_studnt"]) == 2
    err = capsys.readouterr().err
    assert "did you mean 'formula_student'?" in err and err.count("\n") == 1


@pytest.mark.parametrize(
    ("out", "said"),
    [
        ("model.pt", "ending in .zip"),
        ("taken.zip", "exists"),
        ("taken.zip/model.zip", "expected a path in folders: 'taken.zip' is a file"),
    ],
)
def test_out_is_checked_before_training(here: Path, capsys, out: str, said: str):
    (here / "taken.zip").write_text("a model")
    assert cli.main(["train", "--out", out]) == 2
    assert said in capsys.readouterr().err
    assert (here / "taken.zip").read_text() == "a model"


def test_the_default_env_is_f1tenth_lidar_and_a_name_is_an_experiments_env():
    default = train.train_env(None)
    assert default == train.train_env("f1tenth_lidar") and default.name == "f1tenth_lidar"
    made = gym.make(default.env_id, **default.kwargs)
    try:  # small vectors, no pixels: what learns in minutes
        space = made.observation_space
        assert isinstance(space, spaces.Dict) and set(space.spaces) == {"lidar", "state"}
        assert not train.has_images(space) and train.policy_for(space) == "MultiInputPolicy"
    finally:
        made.close()
    env = train.train_env("formula_student")
    assert env.env_id == "tinyrace/TinyRace-v0" and env.name == "formula_student"
    assert Path(env.kwargs["config"]) == shipped_track("formula_student") / "track.yaml"
    track = train.train_env(shipped_track("segmented"), max_episode_steps=9)
    assert track.name == "segmented" and track.kwargs["max_episode_steps"] == 9


def test_an_experiment_with_problems_is_one_config_error(tmp_path: Path):
    (tmp_path / "exp.yaml").write_text("episodes: 0\nenv: {sim: {fps: fast}}\n")
    with pytest.raises(ConfigError) as caught:
        train.train_env(tmp_path / "exp.yaml")
    assert [p.path for p in caught.value.problems] == ["episodes", "env.sim.fps"]


def test_the_policy_fits_the_observation():
    image = spaces.Box(0, 255, (96, 96, 3), np.uint8)
    assert train.policy_for(image) == "CnnPolicy"
    assert train.policy_for(spaces.Dict({"front": image})) == "MultiInputPolicy"
    assert train.policy_for(spaces.Box(-1, 1, (4,), np.float32)) == "MlpPolicy"


@pytest.mark.parametrize(("timesteps", "envs"), [(256, 2), (10, 4), (10**6, 8)])
def test_a_short_run_gets_a_short_rollout(timesteps: int, envs: int):
    settings = train.ppo_settings(timesteps, envs)
    assert train.MIN_STEPS <= settings["n_steps"] <= 512
    assert settings["n_steps"] * envs >= min(timesteps, train.MIN_STEPS * envs)
    assert settings["batch_size"] <= settings["n_steps"] * envs


def test_nested_dict_observations_are_flattened_per_key():
    """The sensors experiment's ``cones`` entry is a dict: SB3 takes no nested dicts."""
    env = train._make(**_kwargs(train.train_env("sensors")))
    try:
        space = env.observation_space
        assert isinstance(space, spaces.Dict)
        assert all(isinstance(s, spaces.Box) for s in space.spaces.values())
        observation, _ = env.reset(seed=0)
        assert space.contains(observation)
        assert observation["cones"].ndim == 1 and observation["lidar"].shape == (1080,)
    finally:
        env.close()
    plain = train._make(**_kwargs(train.train_env(None)))
    assert isinstance(plain, envs.Reporting) and not isinstance(plain, envs.FlatEntries)
    plain.close()


def test_help_shows_every_default(capsys):
    with pytest.raises(SystemExit):
        cli.main(["train", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for default in ("default: f1tenth_lidar", "default: 20000", "default: 8", "default: 0",
                    "default: 1", "default: ppo_<name>.zip", "default: the experiment's",
                    "default: all in this process", "default: refuse"):  # fmt: skip
        assert default in text, default


class _Breaks(gym.Wrapper):
    """An env whose step raises at its third step."""

    def __init__(self, env):
        super().__init__(env)
        self.steps = 0

    def step(self, action):
        self.steps += 1
        if self.steps == 3:
            raise FloatingPointError("the car blew up")
        return self.env.step(action)


def test_an_env_error_is_reported_not_raised_and_ends_the_episode():
    env = envs.Reporting(_Breaks(gym.make("tinyrace/TinyRace-v0", **train.train_env().kwargs)))
    try:
        env.reset(seed=0)
        for _ in range(2):
            env.step(env.action_space.sample())
        observation, reward, terminated, _, info = env.step(env.action_space.sample())
        assert terminated and reward == 0.0 and env.observation_space.contains(observation)
        assert info[envs.FAILED] == "FloatingPointError: the car blew up"
        with pytest.raises(train.EnvFailed, match="FloatingPointError: the car blew up"):
            train.raise_failure([{}, info])
        train.raise_failure([{}, {"x": 1}])  # no report: nothing raised
    finally:
        env.close()


def _kwargs(env: train.TrainEnv) -> dict:
    return {"env_id": env.env_id, "kwargs": env.kwargs}


# -- hostile input, sixth round ----------------------------------------------------------------


def test_force_never_replaces_a_file_that_is_no_model(here: Path, capsys):
    """An experiment called e.zip, or a link to the experiment, named as --out with --force:
    a model is a zip archive, and train replaces only models."""
    experiment = "env: {environment: f1tenth_loop}\nepisodes: 1\n"
    (here / "e.zip").write_text(experiment)
    (here / "exp.yaml").write_text(experiment)
    (here / "m.zip").symlink_to(here / "exp.yaml")
    for out in ("e.zip", "m.zip"):
        assert cli.main(["train", "exp.yaml", "--out", out, "--force"]) == 2
        assert "this file is no zip archive" in capsys.readouterr().err
    assert (here / "e.zip").read_text() == (here / "exp.yaml").read_text() == experiment
    (here / "model.zip").write_bytes(_zip_bytes())
    assert train.model_file("model.zip", force=True) == Path("model.zip")


def _zip_bytes() -> bytes:
    import io
    import zipfile

    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        archive.writestr("data", "{}")
    return buffer.getvalue()


def test_out_through_a_dangling_link_or_into_proc_is_refused_before_training(here: Path):
    (here / "dangling.zip").symlink_to(here / "missing" / "x.zip")
    with pytest.raises(ConfigError) as caught:
        train.model_file("dangling.zip", force=True)
    assert "a link to" in caught.value.problems[0].allowed
    assert "which is missing" in caught.value.problems[0].allowed
    if Path("/proc/self").is_dir():  # Linux: root may write in /proc by its permissions
        with pytest.raises(ConfigError) as caught:
            train.model_file("/proc/m.zip", force=False)
        assert "expected a folder where a file can be made: '/proc'" in str(caught.value)


def test_an_env_whose_episodes_never_end_is_refused_unless_given_a_limit(tmp_path: Path):
    (tmp_path / "exp.yaml").write_text(
        "env: {environment: f1tenth_loop, cameras: [], sensors: [{id: s, type: state}], "
        "sim: {step_limit: null}}\nmax_steps: null\n"
    )
    with pytest.raises(ConfigError) as caught:
        train.train_env(tmp_path / "exp.yaml")
    assert "no step limit" in caught.value.problems[0].allowed
    assert "--max-episode-steps" in caught.value.problems[0].allowed
    limited = train.train_env(tmp_path / "exp.yaml", max_episode_steps=20)
    assert limited.kwargs["max_episode_steps"] == 20


@pytest.mark.parametrize(
    ("camera", "observation", "said"),
    [
        ("[8, 8]", "box", "'observation' is 8 x 8 px"),
        ("[200, 1]", "box", "'observation' is 1 x 200 px"),
        ("[8, 8]", "dict", "'c' is 8 x 8 px"),
    ],
)
def test_a_picture_smaller_than_the_cnn_takes_is_refused(tmp_path, camera, observation, said):
    (tmp_path / "exp.yaml").write_text(
        f"env: {{environment: formula_student, observation: {observation}, "
        f"cameras: [{{id: c, resolution: {camera}}}]}}\nmax_steps: 50\n"
    )
    with pytest.raises(ConfigError) as caught:
        train.train_env(tmp_path / "exp.yaml")
    assert said in caught.value.problems[0].allowed
    assert "at least 36 x 36 px" in caught.value.problems[0].allowed
    (tmp_path / "exp.yaml").write_text(
        "env: {environment: formula_student, observation: box, "
        "cameras: [{id: c, resolution: [36, 36]}]}\nmax_steps: 50\n"
    )
    assert train.train_env(tmp_path / "exp.yaml").name == "exp"


@pytest.mark.parametrize(
    ("timesteps", "envs"), [(2000, 8), (3000, 8), (32, 2), (20_000, 8), (1000, 7), (999, 3)]
)
def test_minibatches_split_the_rollout_evenly(timesteps: int, envs: int):
    settings = train.ppo_settings(timesteps, envs)
    rollout = settings["n_steps"] * envs
    assert rollout % settings["batch_size"] == 0 and settings["batch_size"] <= 256
    trained = train.trained_steps(timesteps, envs)
    assert trained % rollout == 0 and timesteps <= trained < timesteps + rollout


@pytest.mark.parametrize("seed", ["1_0", "١", "１", "4294967296", "-1", " "])
def test_train_seeds_are_ascii_digits_within_numpys_range(here: Path, capsys, seed: str):
    assert cli.main(["train", "--seed", seed]) == 2
    assert "argument --seed: got" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("option", "value"), [("--seed", "1_0"), ("--seed", "١"), ("--episodes", "１")]
)
def test_run_counts_are_ascii_digits(capsys, option: str, value: str):
    assert cli.main(["run", option, value]) == 2
    assert f"argument {option}: got {value!r}" in capsys.readouterr().err


def test_a_model_file_in_a_track_folder_needs_force(here: Path):
    """As tinyrace run's run folders: a track folder is the user's data."""
    folder = here / "my_track"
    folder.mkdir()
    (folder / "track.yaml").write_text("track: {type: procedural}\n")
    with pytest.raises(ConfigError) as caught:
        train.model_file(str(folder / "sub" / "m.zip"), force=False)
    assert f"expected a file outside the track folder {str(folder)!r}" in str(caught.value)
    assert train.model_file(str(folder / "m.zip"), force=True) == folder / "m.zip"
