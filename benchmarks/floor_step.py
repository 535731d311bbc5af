"""How fast a step of tinyrace/CarRacing-v0 could be without tinyrace's layers: its floor.

Usage::

    python benchmarks/floor_step.py              # 6 rounds of 800 steps each
    python benchmarks/floor_step.py --rounds 10 --steps 1000

Beside ``gym.make("tinyrace/CarRacing-v0")`` it steps a second env of the same seed with a
*lean* step: only what a step cannot do without, called straight on the env's parts. The
action's bounds, the car's controls and compiled tyre model, pymunk's ``cpSpaceStep`` (no
``Space.step`` wrapper), the new tiles and the reward, the car's state, and the chase view's
render (its ground warp in cv2, its compiled car and dashboard). Left out: gymnasium's
wrappers, ``TinyRaceEnv.step``'s parts (control, judge, snapshot, report), the episode's
and the world's steps with their facts, the reward terms' dicts and the info's.

It first proves that the lean step does the same work: 300 steps of both give the same
observations and rewards, bit for bit (else it stops, exit status 1). Then it times both in
alternating blocks (thread time per step; each block starts from a seeded reset, which is
not timed, so that no episode ends inside a block) and prints the best block of each, their
ratio, the lean step's parts (wall time, one more block), and what that ratio makes of a
speed-up over CarRacing-v3 given with ``--versus``.
cv2 runs on one thread, as in ``run.py``. The lean step reads private attributes: it is a
measurement, not an API, and the bit-for-bit check says when a change has made it stale.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

import cv2
import gymnasium as gym
import numpy as np
import tinyrace  # noqa: F401  (registers the env ids)
from pymunk._chipmunk import lib as chipmunk
from tinyrace.world.snapshot import Snapshot

ENV_ID = "tinyrace/CarRacing-v0"
SEED = 0
CHECKED_STEPS = 300
OBSERVATION = (96, 96)  # [px] CarRacing's state_pixels (w, h)
TIME_TERM = -0.1  # CarRacing's reward per step
TILES_PAID = 1000.0  # CarRacing's reward for visiting every tile


class LeanStep:
    """A step of ``env`` (just reset, continuous actions) with every layer taken out."""

    def __init__(self, env: gym.Env[Any, Any], parts: dict[str, int] | None = None) -> None:
        """``parts``: if given, nanoseconds per part of the step are added to it."""
        self.parts = parts
        core: Any = env.unwrapped
        episode = core.episode
        world = episode.world
        self.car, self.view = world.cars[0], core.sensors[0]  # the chase_view sensor
        self.layout, self.rng = core.layout, core.np_random
        self.progress = episode.rules[0][0]  # CarRacing's tile_touches rule of the car
        self.world, self.space = world, world.space._space
        contacts = world.contacts[0]
        self.touches, self.wheel_tiles = contacts.new_tile_touches, contacts.wheel_tiles
        self.dt, self.t, self.steps, self.score = core.dt, core.t, core.steps, core.score
        self.carried = sum(episode.carry[0].values())  # the reset's tiles, paid next step
        self.tile_reward = TILES_PAID / len(self.progress.visited)

    def __call__(self, action: np.ndarray) -> tuple[np.ndarray, float, dict[str, Any]]:
        parts, clock = self.parts, time.perf_counter_ns
        started = clock() if parts is not None else 0
        steer, gas, brake = action.tolist()
        if not (-1.0 <= steer <= 1.0 and 0.0 <= gas <= 1.0 and 0.0 <= brake <= 1.0):
            raise ValueError(f"action {action} is outside the space")
        car, progress = self.car, self.progress
        car.control(steer, gas, brake)
        car.apply_forces(self.dt, [bool(tiles) for tiles in self.wheel_tiles])
        if parts is not None:
            started = _add(parts, "action, controls, tyre model", started, clock())
        self.touches.clear()
        self.world._states = None  # the world's copy of the car's state is stale now
        chipmunk.cpSpaceStep(self.space, self.dt)
        if parts is not None:
            started = _add(parts, "cpSpaceStep (tile contacts included)", started, clock())
        carried, self.carried = self.carried, 0.0
        reward = TIME_TERM + carried
        for tile in self.touches:
            if not progress.visited[tile]:
                progress.visited[tile] = True
                progress.visited_count += 1
                progress.visit_order.append(tile)  # the pictures repaint it
                reward += self.tile_reward
        state = car.state()
        self.t += self.dt
        self.steps += 1
        self.score += reward - carried
        snapshot = Snapshot(self.t, self.steps, (state,), score=self.score)
        if parts is not None:
            started = _add(parts, "tiles, reward, the car's state", started, clock())
        frame = self.view.observe(snapshot, self.layout, self.rng)
        if parts is not None:
            started = _add(parts, "the chase view's render", started, clock())
        info = {"pose": state.pose, "speed": state.speed, "tiles_visited": progress.visited_count}
        return frame, reward, info


def _add(parts: dict[str, int], name: str, started: int, now: int) -> int:
    parts[name] = parts.get(name, 0) + now - started
    return now


def same_work(actions: list[np.ndarray]) -> bool:
    """Whether the lean step gives the env's observations and rewards, bit for bit."""
    env, other = gym.make(ENV_ID), gym.make(ENV_ID)
    env.reset(seed=SEED)
    other.reset(seed=SEED)
    lean = LeanStep(other)
    for index, action in enumerate(actions[:CHECKED_STEPS]):
        observation, reward, *_ = env.step(action)
        lean_observation, lean_reward, _ = lean(action)
        if reward != lean_reward or not np.array_equal(observation, lean_observation):
            print(f"step {index}: the lean step differs (reward {lean_reward!r} vs {reward!r})")
            return False
    return True


def block(env: gym.Env[Any, Any], lean: bool, actions: list[np.ndarray], warmup: int) -> float:
    """[µs] thread time per step over ``actions``, after a seeded reset and ``warmup`` steps."""
    env.reset(seed=SEED)
    step: Any = LeanStep(env) if lean else env.step
    for action in actions[:warmup]:
        step(action)
    started = time.thread_time()
    for action in actions[warmup:]:
        step(action)
    return (time.thread_time() - started) / (len(actions) - warmup) * 1e6


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=6, help="blocks of each step (6)")
    parser.add_argument("--steps", type=int, default=800, help="timed steps per block (800)")
    parser.add_argument(
        "--versus", type=float, default=None, help="a speed-up over CarRacing-v3 to rescale"
    )
    args = parser.parse_args()
    cv2.setNumThreads(1)
    gym.logger.min_level = gym.logger.ERROR
    warmup = 100  # a block's first steps include the zoom-in's patch renders: not timed
    space = gym.make(ENV_ID).action_space
    space.seed(SEED)
    actions = [space.sample() for _ in range(max(warmup + args.steps, CHECKED_STEPS))]
    if not same_work(actions):
        return 1
    print(f"same observations and rewards for {CHECKED_STEPS} steps: the lean step is valid")
    env = gym.make(ENV_ID)
    times: dict[str, list[float]] = {"env.step": [], "lean step": []}
    for round_ in range(args.rounds):
        order = [False, True] if round_ % 2 == 0 else [True, False]
        for lean in order:
            name = "lean step" if lean else "env.step"
            times[name].append(block(env, lean, actions[: warmup + args.steps], warmup))
    best = {name: min(values) for name, values in times.items()}
    for name, values in times.items():
        listed = " ".join(f"{value:.1f}" for value in values)
        print(f"{name:10s} best {best[name]:6.1f} us per step   (blocks: {listed})")
    ratio = best["lean step"] / best["env.step"]
    print(f"lean / env.step: {ratio:.2f} (the layers cost {1 - ratio:.0%} of a step)")
    parts: dict[str, int] = {}
    env.reset(seed=SEED)
    timed = LeanStep(env)
    for action in actions[:warmup]:
        timed(action)
    timed.parts = parts
    for action in actions[warmup : warmup + args.steps]:
        timed(action)
    print(f"the lean step's parts (wall time per step, {args.steps} steps after {warmup}):")
    for name, nanoseconds in parts.items():
        print(f"  {name:40s} {nanoseconds / args.steps / 1000:6.1f} us")
    if args.versus is not None:
        print(f"{args.versus:.1f}x CarRacing-v3 would become {args.versus / ratio:.1f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
