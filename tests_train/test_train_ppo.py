"""docs/training.md's example: a few hundred PPO steps on tinyrace/CarRacing-v0.

Run by .ci/run after ``pip install -e ".[train]"``; not collected by the main test run
(testpaths is ``tests``), so that run needs no torch.
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import torch
from stable_baselines3 import PPO

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "train_ppo.py"
SMALL = {"n_steps": 64, "batch_size": 64, "n_epochs": 1}  # two updates in 256 steps of 2 envs


def load_example():
    spec = importlib.util.spec_from_file_location("train_ppo", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_ppo_trains_on_tinyrace_saves_and_evaluates(tmp_path: Path):
    example = load_example()
    untrained = PPO("CnnPolicy", example.make_envs(1, 0, subprocesses=False), seed=0, **SMALL)
    before = [p.detach().clone() for p in untrained.policy.parameters()]
    model = example.train(256, n_envs=2, subprocesses=False, **SMALL)
    assert model.num_timesteps >= 256
    after = list(model.policy.parameters())
    assert all(a.shape == b.shape for a, b in zip(before, after, strict=True))
    assert any(not torch.equal(a, b) for a, b in zip(before, after, strict=True))  # learned

    envs = example.make_envs(1, 5, subprocesses=False)
    observation = envs.reset()
    assert observation.shape == (1, 96, 96, 12) and observation.dtype == np.uint8
    action, _ = model.predict(observation, deterministic=True)
    assert envs.action_space.contains(action[0].astype(np.float32))
    model.save(tmp_path / "ppo.zip")
    again, _ = PPO.load(tmp_path / "ppo.zip").predict(observation, deterministic=True)
    np.testing.assert_array_equal(action, again)
    envs.close()

    mean, std = example.evaluate(model, episodes=1, max_episode_steps=50)
    assert math.isfinite(mean) and std == 0.0
