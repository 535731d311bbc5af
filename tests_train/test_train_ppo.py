"""``tinyrace train`` and docs/training.md's Stable-Baselines3 script: a few hundred PPO steps.

Run by .ci/run after ``pip install torch==2.13.0`` and ``pip install -e ".[train]"``; not
collected by the main test run (testpaths is ``tests``), so that run needs no torch.
"""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.policies import MultiInputActorCriticPolicy

from tinyrace import cli, train

ROOT = Path(__file__).resolve().parents[1]
EVALUATION = re.compile(r"evaluation: mean return (-?[\d.]+) ± ([\d.]+) over 1 episode")


@pytest.fixture
def here(tmp_path: Path, monkeypatch) -> Path:
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_tinyrace_train_saves_a_model_and_prints_its_evaluation(here: Path, capsys):
    argv = ["--timesteps", "256", "--envs", "2", "--eval-episodes", "1"]
    argv += ["--max-episode-steps", "60", "--out", "model.zip"]
    assert cli.main(["train", *argv]) == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    found = EVALUATION.search(out)
    assert found and math.isfinite(float(found[1])) and float(found[2]) == 0.0, out
    model = PPO.load(here / "model.zip")
    assert model.num_timesteps >= 256
    assert model.observation_space.shape == (12, 96, 96)  # 4 frames, channels first in SB3
    observation = np.zeros((1, 96, 96, 12), np.uint8)
    action, _ = model.predict(observation, deterministic=True)
    assert model.action_space.contains(action[0].astype(np.float32))


def test_training_changes_the_policy(here: Path):
    env = train.train_env(None, max_episode_steps=40)
    before = PPO("CnnPolicy", train.make_envs(env, 1, 0, subprocesses=False), seed=0)
    weights = [p.detach().clone() for p in before.policy.parameters()]
    model = train.train(env, 128, envs=1, seed=0, subprocesses=False)
    after = list(model.policy.parameters())
    assert all(a.shape == b.shape for a, b in zip(weights, after, strict=True))
    assert any(not torch.equal(a, b) for a, b in zip(weights, after, strict=True))


@pytest.mark.parametrize("name", ["formula_student", "sensors"])
def test_an_experiments_env_trains_with_its_own_policy(here: Path, name: str):
    """A camera dict (formula_student) and sensors with a nested dict (cones) both train."""
    env = train.train_env(name, max_episode_steps=20)
    model = train.train(env, 32, envs=1, subprocesses=False)
    assert isinstance(model.policy, MultiInputActorCriticPolicy)  # one network per key
    mean, std = train.evaluate(model, env, episodes=1, seed=0)
    assert math.isfinite(mean) and std == 0.0


def test_python_dash_m_tinyrace_train_is_the_command(here: Path):
    done = subprocess.run(
        [sys.executable, "-m", "tinyrace", "train", "--timesteps", "0"],
        env={**os.environ, "PYTHONPATH": str(ROOT)},  # this checkout's tinyrace
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2 and "argument --timesteps" in done.stderr, done.stderr


def test_the_training_pages_script_runs_as_printed(here: Path):
    """docs/training.md's SB3 block, saved as a file (SubprocVecEnv imports it again in its
    workers), with a shorter run: 2 rollouts of 32 steps in each of its 4 envs."""
    readme = (ROOT / "docs" / "training.md").read_text()
    block = next(
        b.split("```", 1)[0]
        for b in readme.split("```python\n")[1:]
        if "stable_baselines3" in b and "SubprocVecEnv" in b
    )
    short = block.replace("total_timesteps=200_000", "total_timesteps=256")
    short = short.replace("n_steps=512, batch_size=128", "n_steps=32, batch_size=64")
    assert short.count("256") == 1 and "n_steps=32" in short  # the run was shortened
    (here / "train_sb3.py").write_text(short)
    done = subprocess.run(
        [sys.executable, "train_sb3.py"], capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert PPO.load(here / "ppo_carracing.zip").num_timesteps >= 256
