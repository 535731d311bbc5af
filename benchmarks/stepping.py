"""Timing loops shared by the benchmarks: seeded random actions, interleaved rounds."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

SEED = 0
ACTION_BLOCK = 4096  # pre-drawn actions, cycled


@dataclass
class Timing:
    """Steps taken (env-steps for batches) and wall time spent, summed over rounds."""

    steps: int = 0
    seconds: float = 0.0  # [s] wall time, resets included
    resets: int = 0  # episodes ended and reset inside the timed loop
    reset_seconds: float = 0.0  # [s] of ``seconds`` spent in those resets
    rounds: list[float] = field(default_factory=list)  # [steps/s] of each round
    cpu_seconds: float = 0.0  # [s] this process's CPU time (the machine's load left out)

    @property
    def rate(self) -> float:
        """[steps/s] as a training loop sees it: resets included."""
        return self.steps / self.seconds if self.seconds else 0.0

    @property
    def step_rate(self) -> float:
        """[steps/s] of the steps alone."""
        stepping = self.seconds - self.reset_seconds
        return self.steps / stepping if stepping > 0 else 0.0

    @property
    def cpu_rate(self) -> float:
        """[steps per CPU second] of this process, resets included."""
        return self.steps / self.cpu_seconds if self.cpu_seconds else 0.0

    def add(self, other: Timing) -> None:
        self.steps += other.steps
        self.seconds += other.seconds
        self.cpu_seconds += other.cpu_seconds
        self.resets += other.resets
        self.reset_seconds += other.reset_seconds
        self.rounds.append(other.rate)

    def as_dict(self) -> dict[str, Any]:
        rates = {"steps_per_s": self.rate, "step_only_per_s": self.step_rate}
        return {**asdict(self), **rates, "steps_per_cpu_s": self.cpu_rate}


class Stepper:
    """Steps an env, a vector env or an EnvPool batch with pre-drawn seeded random actions.

    ``batch`` envs advance per call; ``auto_reset`` envs reset themselves, others are
    reset here when an episode ends; ``add_batch_axis`` wraps single actions for EnvPool.
    """

    def __init__(
        self, env: Any, *, batch: int = 1, auto_reset: bool = False, add_batch_axis: bool = False
    ):
        self.env, self.batch, self.auto_reset = env, batch, auto_reset
        env.action_space.seed(SEED)
        actions = [env.action_space.sample() for _ in range(ACTION_BLOCK)]
        self.actions = [a[None] for a in actions] if add_batch_axis else actions
        self.index = 0
        if add_batch_axis:
            env.reset()  # EnvPool is seeded when made
        else:
            env.reset(seed=SEED)

    def run(self, seconds: float) -> Timing:
        """Step for ``seconds`` (at least one step); the observation is produced every step."""
        env, actions, n = self.env, self.actions, len(self.actions)
        steps = resets = 0
        reset_seconds = 0.0
        cpu = time.process_time()
        start = time.perf_counter()
        end = start + seconds
        while True:
            _, _, terminated, truncated, _ = env.step(actions[self.index % n])
            self.index += 1
            steps += 1
            if not self.auto_reset and (terminated or truncated):
                began = time.perf_counter()
                env.reset()
                reset_seconds += time.perf_counter() - began
                resets += 1
            now = time.perf_counter()
            if now >= end:
                break
        cpu = time.process_time() - cpu
        return Timing(steps * self.batch, now - start, resets, reset_seconds, cpu_seconds=cpu)

    def take(self, steps: int) -> None:
        """``steps`` calls, untimed."""
        for _ in range(steps):
            self.run(0.0)  # a zero budget still takes one step

    def close(self) -> None:
        self.env.close()


def interleave(
    steppers: dict[str, Stepper], seconds: float, rounds: int, warmup: float
) -> dict[str, Timing]:
    """Warm each stepper up, then time them in ``rounds``, rotating who goes first."""
    for stepper in steppers.values():
        stepper.run(warmup)
    totals = {name: Timing() for name in steppers}
    names = list(steppers)
    for round_index in range(rounds):
        shift = round_index % max(len(names), 1)
        for name in names[shift:] + names[:shift]:
            totals[name].add(steppers[name].run(seconds / rounds))
    return totals


def time_resets(envs: dict[str, gym.Env], seeds: range) -> dict[str, dict[str, Any]]:
    """Seeded reset times [ms] of each env, alternating envs for every seed."""
    for env in envs.values():
        env.reset(seed=SEED)  # warm-up (and the env checker's first-reset checks)
    times: dict[str, list[float]] = {name: [] for name in envs}
    for seed in seeds:
        for name, env in envs.items():
            start = time.perf_counter()
            env.reset(seed=seed)
            times[name].append((time.perf_counter() - start) * 1e3)
    return {
        name: {"mean_ms": float(np.mean(t)), "median_ms": float(np.median(t)), "all_ms": t}
        for name, t in times.items()
    }


def unavailable(error: BaseException) -> str:
    """``unavailable: <error>`` on one line."""
    message = " ".join(line.strip() for line in str(error).splitlines())
    return f"unavailable: {type(error).__name__}: {message}".rstrip(": ")


@contextmanager
def quiet_gym_warnings() -> Iterator[None]:
    """Gymnasium's checkers warn once per env (e.g. float32 casts); keep the output readable."""
    level = gym.logger.min_level
    gym.logger.min_level = gym.logger.ERROR
    try:
        yield
    finally:
        gym.logger.min_level = level
