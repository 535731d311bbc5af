"""docs/training.md's RLlib examples, run as printed: PPO on CarRacing-v0 with two env
runners (each stepping a BatchVectorEnv of two envs), and PPO on the PettingZoo race (two
cars, one shared policy).

Run by .ci/run's train stage after ``pip install -e ".[train,rllib]"``. Each block runs as
the page prints it (the very text, found as .ci/readme_examples.py finds it), as a script
of its own in an empty folder, with this checkout's tinyrace; its printed returns are
checked. Ray starts its own processes: a block that hangs is killed with its process group.
"""

from __future__ import annotations

import ast
import importlib.util
import math
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import torch
from ray.rllib.algorithms.ppo.torch.default_ppo_torch_rl_module import DefaultPPOTorchRLModule
from ray.rllib.core.columns import Columns
from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig
from ray.rllib.core.rl_module.rl_module import RLModuleSpec

from tinyrace.rllib import make_env

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "training.md"
README = ROOT / "README.md"
TIMEOUT = 600  # [s] per block; each takes well under a minute on 2 cores
CONV_FILTERS = [[16, 8, 4], [32, 4, 2], [64, 3, 2]]  # the page's, for any camera size
ITERATION = re.compile(r"^iteration 1: (\d+) episodes, (return|returns) (.+)$", re.M)


def _page_blocks(page: Path = PAGE) -> list[str]:
    """The page's Python blocks that need rllib, as .ci/readme_examples.py reads them."""
    script = ROOT / ".ci" / "readme_examples.py"
    spec = importlib.util.spec_from_file_location("readme_examples", script)
    assert spec and spec.loader
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return [b.code for b in module.blocks(page) if b.kind == "python" and "rllib" in b.needs]


BLOCKS = _page_blocks()


def _run(code: str, folder: Path) -> str:
    """The block's output (stdout), run as a script; its stderr when it fails."""
    script = folder / "example.py"
    script.write_text(code, encoding="utf-8")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}  # this checkout's tinyrace, in every worker
    with subprocess.Popen(
        [sys.executable, str(script)],
        cwd=folder,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # Ray's processes too, killed together on a timeout
    ) as process:
        try:
            out, err = process.communicate(timeout=TIMEOUT)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            out, err = process.communicate()
            pytest.fail(f"timed out after {TIMEOUT} s:\n{out}\n{err[-3000:]}")
    assert process.returncode == 0, err[-4000:]
    print(out)  # the returns, in pytest's output with -s (CI's log: -rA)
    return out


def test_the_page_has_both_examples():
    assert len(BLOCKS) == 2, "docs/training.md: the CarRacing and the race examples"
    car, race = BLOCKS
    assert '"tinyrace/CarRacing-v0"' in car and "num_env_runners=2" in car
    assert 'gym_env_vectorize_mode="vector_entry_point"' in car  # BatchVectorEnvs in the runners
    assert "ParallelPettingZooEnv(" in race and "parallel_env(" in race
    assert 'policies={"shared"}' in race and '"num_agents": 2' in race
    for code in BLOCKS:
        assert f"conv_filters={CONV_FILTERS}" in code
        assert "for i in range(1):" in code  # one iteration each, as CI runs them


def test_the_readme_shows_both_examples_as_the_page_prints_them():
    assert _page_blocks(README) == BLOCKS  # the very text these tests run


def test_ppo_trains_one_iteration_on_carracing_with_two_env_runners(tmp_path: Path):
    out = _run(BLOCKS[0], tmp_path)
    found = ITERATION.search(out)
    assert found and found[2] == "return", out
    episodes, mean = int(found[1]), float(found[3])
    # 400 steps, 100-step episodes, 2 runners with two envs each: 4 episodes end
    assert episodes >= 2 and math.isfinite(mean), out
    # CarRacing's reward: -0.1 a step, +1000/N a tile; 100 steps cost 10 at most
    assert mean >= -10.0 - 1e-6, out


def test_ppo_trains_one_iteration_on_the_pettingzoo_race_with_a_shared_policy(tmp_path: Path):
    out = _run(BLOCKS[1], tmp_path)
    found = ITERATION.search(out)
    assert found and found[2] == "returns", out
    returns = ast.literal_eval(found[3])
    assert int(found[1]) >= 1, out
    assert sorted(returns) == ["car_0", "car_1"], out  # both cars drove, on one policy
    assert all(math.isfinite(value) for value in returns.values()), out


def test_the_pages_filters_take_a_120x160_camera_that_rllibs_defaults_do_not():
    """TinyRace-v0's one camera as a Box, through make_env: the default PPO module has no
    conv filters for 120x160; with the page's it builds and acts on FloatPixels' floats."""
    env = make_env({"id": "tinyrace/TinyRace-v0", "environment": "formula_student",
                    "observation": "box", "max_episode_steps": 5})  # fmt: skip
    space = env.observation_space
    assert isinstance(space, gym.spaces.Box)
    assert space.shape == (120, 160, 3) and space.dtype == np.float32
    spec = RLModuleSpec(
        module_class=DefaultPPOTorchRLModule,
        observation_space=space,
        action_space=env.action_space,
        model_config=DefaultModelConfig(),
    )
    with pytest.raises(ValueError, match="No default CNN configuration for obs shape"):
        spec.build()
    spec.model_config = DefaultModelConfig(conv_filters=CONV_FILTERS)
    module = spec.build()
    observation, _ = env.reset(seed=0)
    assert observation.dtype == np.float32 and 0.0 <= observation.min() <= observation.max() <= 1
    with torch.no_grad():
        out = module.forward_inference({Columns.OBS: torch.from_numpy(observation[None])})
    logits = out[Columns.ACTION_DIST_INPUTS]
    assert logits.shape == (1, 2 * env.action_space.shape[0])  # a Gaussian: means, log stds
    assert torch.isfinite(logits).all()
    env.close()


def test_rllibs_default_cnn_takes_float_pixels_not_tinyraces_uint8():
    """Why FloatPixels: CarRacing-v0's 96x96 camera has a default CNN, which fails on uint8."""
    plain = gym.make("tinyrace/CarRacing-v0", max_episode_steps=5)
    env = make_env({"max_episode_steps": 5})
    module = RLModuleSpec(
        module_class=DefaultPPOTorchRLModule,
        observation_space=env.observation_space,
        action_space=env.action_space,
        model_config=DefaultModelConfig(),  # RLlib's filters for 96x96
    ).build()
    pixels, _ = plain.reset(seed=0)
    with pytest.raises(RuntimeError, match=r"Input type \(unsigned char\)"), torch.no_grad():
        module.forward_inference({Columns.OBS: torch.from_numpy(pixels[None])})
    floats, _ = env.reset(seed=0)
    with torch.no_grad():
        out = module.forward_inference({Columns.OBS: torch.from_numpy(floats[None])})
    assert torch.isfinite(out[Columns.ACTION_DIST_INPUTS]).all()
