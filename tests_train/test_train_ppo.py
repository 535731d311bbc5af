"""``tinyrace train`` and docs/training.md's Stable-Baselines3 script: a few hundred PPO steps.

Run by .ci/run after ``pip install torch==2.13.0`` and ``pip install -e ".[train]"``; not
collected by the main test run (testpaths is ``tests``), so that run needs no torch.
"""

from __future__ import annotations

import math
import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.policies import MultiInputActorCriticPolicy

from tinyrace import cli, train

ROOT = Path(__file__).resolve().parents[1]
EVALUATION = re.compile(
    r"(untrained|trained) policy: +mean return (-?[\d.]+) ± ([\d.]+) over 1 episode"
)


@pytest.fixture
def here(tmp_path: Path, monkeypatch) -> Path:
    monkeypatch.chdir(tmp_path)
    return tmp_path


def evaluations(out: str) -> dict[str, float]:
    return {m[1]: float(m[2]) for m in EVALUATION.finditer(out)}


def test_tinyrace_train_on_pixels_saves_a_model_and_prints_both_evaluations(here: Path, capsys):
    argv = ["carracing", "--timesteps", "256", "--envs", "2", "--subprocesses"]
    argv += ["--max-episode-steps", "60", "--out", "model.zip"]
    assert cli.main(["train", *argv]) == 0, capsys.readouterr().err
    captured = capsys.readouterr()
    found = evaluations(captured.out)
    assert set(found) == {"untrained", "trained"}, captured.out
    assert all(math.isfinite(v) for v in found.values())
    assert "training: 100%" in captured.err and "256/256" in captured.err  # the bar
    model = PPO.load(here / "model.zip")
    assert model.num_timesteps >= 256
    assert model.observation_space.shape == (12, 96, 96)  # 4 frames, channels first in SB3
    observation = np.zeros((1, 96, 96, 12), np.uint8)
    action, _ = model.predict(observation, deterministic=True)
    assert model.action_space.contains(action[0].astype(np.float32))


def test_the_default_run_learns_to_drive(here: Path, capsys):
    """``tinyrace train`` as the README prints it: the trained policy's return is far above
    the untrained one's (f1tenth_lidar: the untrained car meets a wall at once)."""
    assert cli.main(["train"]) == 0, capsys.readouterr().err
    captured = capsys.readouterr()
    found = evaluations(captured.out)
    assert found["trained"] > found["untrained"] + 300, captured.out
    assert "mean of the last 20 episodes" in captured.err  # the bar's recent return
    assert PPO.load(here / "ppo_f1tenth_lidar.zip").num_timesteps >= 20_000


def _default_ctrl_c() -> None:
    """In the trainer's process before it starts: SIGINT as a terminal's foreground job has
    it. A job a non-interactive shell starts with ``&`` (a CI script's) inherits SIGINT
    ignored, and Python then installs no KeyboardInterrupt handler: Ctrl-C would not reach
    the trainer the test means to interrupt."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def hung(process: subprocess.Popen[str]) -> str:
    """What a trainer that has not ended 120 s after Ctrl-C is doing: its threads' stacks
    (faulthandler, on SIGABRT) if it still runs, else the processes of its group that keep
    its stderr open; then the group is killed."""
    code = process.poll()
    listing = ["ps", "-s", str(process.pid), "-o", "pid,stat,etime,args"]  # its session's
    group = subprocess.run(listing, capture_output=True, text=True).stdout
    if code is None:
        os.kill(process.pid, signal.SIGABRT)  # faulthandler prints every thread's stack
        time.sleep(2)
    os.killpg(process.pid, signal.SIGKILL)
    _, err = process.communicate(timeout=30)
    state = "still running" if code is None else f"exited with {code}, its stderr still open"
    return f"120 s after Ctrl-C the trainer was {state}:\n{group}\nits stderr ends:\n{err[-6000:]}"


def stopped_trainer(stop: Callable[[subprocess.Popen[str]], None]) -> tuple[int, str]:
    """A trainer of 1,000,000 steps (2 envs, a worker process) stopped by ``stop`` 5 s into
    training: its exit status and stderr. A trainer that has not ended 120 s later fails."""
    command = [sys.executable, "-m", "tinyrace", "train", "--timesteps", "1000000"]
    process = subprocess.Popen(
        [*command, "--subprocesses", "--envs", "2", "--out", "partial.zip"],
        # faulthandler: a trainer that hangs after the signal is aborted and shows where it waits
        env={**os.environ, "PYTHONPATH": str(ROOT), "PYTHONFAULTHANDLER": "1"},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, as a terminal's foreground job
        preexec_fn=_default_ctrl_c,
    )
    try:
        assert process.stdout is not None
        for line in process.stdout:  # training starts after the untrained evaluation
            if line.startswith("untrained policy"):
                break
        time.sleep(5)
        stop(process)
        try:
            _, err = process.communicate(timeout=120)
        except subprocess.TimeoutExpired:
            pytest.fail(hung(process))
    finally:
        process.kill()
    return process.returncode, err


def test_ctrl_c_saves_the_policy_so_far_and_exits_130(here: Path):
    # Ctrl-C: the trainer and its workers
    code, err = stopped_trainer(lambda process: os.killpg(process.pid, signal.SIGINT))
    assert code == 130, err[-2000:]
    assert "interrupted after" in err and "saved partial.zip" in err
    assert "BrokenPipeError" not in err and "Traceback" not in err
    assert PPO.load(here / "partial.zip").num_timesteps < 1_000_000


@pytest.mark.parametrize("group", [False, True], ids=["the trainer", "its process group"])
def test_sigterm_saves_the_policy_so_far_and_exits_143(here: Path, group: bool):
    """A scheduler's SIGTERM (Slurm's at a job's time limit, to the whole group) stops the
    run as Ctrl-C does: the policy trained so far is saved."""

    def stop(process: subprocess.Popen[str]) -> None:
        if group:
            os.killpg(process.pid, signal.SIGTERM)
        else:
            process.terminate()

    code, err = stopped_trainer(stop)
    assert code == 143, err[-2000:]
    assert "interrupted by SIGTERM after" in err and "saved partial.zip" in err
    assert "Traceback" not in err
    assert PPO.load(here / "partial.zip").num_timesteps < 1_000_000


BREAKING = """
import gymnasium as gym

import tinyrace  # noqa: F401


class Breaks(gym.Wrapper):
    def __init__(self, **kwargs):
        super().__init__(gym.make("tinyrace/TinyRace-v0", **kwargs))
        self.steps = 0

    def step(self, action):
        self.steps += 1
        if self.steps == 50:
            raise FloatingPointError("the car blew up")
        return self.env.step(action)


def make_breaks(**kwargs):
    return Breaks(**kwargs)


# a function, not the wrapper class: gymnasium 1.2 (Ray's pin) checks a class entry point's
# metadata, which a Wrapper subclass only has on an instance
gym.register("Breaks-v0", entry_point=make_breaks)
"""


def test_a_worker_env_that_raises_ends_the_run_with_its_error(here: Path):
    """In a worker process (SubprocVecEnv): the run ends with the error, never hangs."""
    (here / "breaking.py").write_text(BREAKING)
    script = (
        "from tinyrace import train\n"
        "env = train.TrainEnv('breaking:Breaks-v0', train.train_env().kwargs, 'breaks')\n"
        "try:\n"
        "    train.train(env, 4000, envs=2, subprocesses=True)\n"
        "except train.EnvFailed as exc:\n"
        "    print('failed:', exc)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script],
        env={**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{here}"},
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert "failed: an env raised during training: FloatingPointError: the car blew up" in (
        done.stdout
    )


def test_training_changes_the_policy(here: Path):
    env = train.train_env("carracing", max_episode_steps=40)
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
    assert PPO.load(here / "ppo_carracing_script.zip").num_timesteps >= 256
