"""Driving by hand: arrow keys in a pygame window (``tinyrace play``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from tinyrace.actions import BRAKE, GAS, LEFT, NOTHING, RIGHT
from tinyrace.cars.registry import model_of
from tinyrace.env import TinyRaceEnv
from tinyrace.validate import load_any

KEYS_HELP = "arrows: steer, gas (up), brake (down); R: reset; Esc: quit"


def play(target: str | None, seed: int | None) -> int:
    import pygame

    env = _env(target)
    print(f"tinyrace play: {KEYS_HELP}")
    env.reset(seed=seed)
    total = 0.0
    try:
        while True:
            keys, quit_requested, reset = _read_keys(pygame)
            if quit_requested:
                return 0
            if reset:
                env.reset()
                total = 0.0
                continue
            _, reward, terminated, truncated, info = env.step(_action(env, keys, pygame))
            total += reward
            if terminated or truncated:
                print(f"episode over ({info.get('termination', 'step limit')}): return {total:.1f}")
                env.reset()
                total = 0.0
    finally:
        env.close()


def _env(target: str | None) -> TinyRaceEnv:
    if target is None:
        return TinyRaceEnv(render_mode="human")
    return TinyRaceEnv(config=load_any(Path(target)), render_mode="human")


def _read_keys(pygame: Any) -> tuple[Any, bool, bool]:
    quit_requested = reset = False
    for event in pygame.event.get():
        if event.type == pygame.QUIT or (
            event.type == pygame.KEYDOWN and event.key == pygame.K_ESCAPE
        ):
            quit_requested = True
        if event.type == pygame.KEYDOWN and event.key == pygame.K_r:
            reset = True
    return pygame.key.get_pressed(), quit_requested, reset


def _action(env: TinyRaceEnv, keys: Any, pygame: Any) -> np.ndarray | int:
    steer = float(keys[pygame.K_RIGHT]) - float(keys[pygame.K_LEFT])
    kind = model_of(env.config).actions(env.config.car).kind
    if kind in ("angle_speed", "rate_accel"):  # the single-track car
        return _single_track_action(env, kind, steer, keys[pygame.K_UP], keys[pygame.K_DOWN])
    right = 1.0 if env.car_facts.steer_per_rad > 0 else -1.0  # the action's sign of a right turn
    if env.action_space.shape == (1,):
        return np.array([right * steer], np.float32)
    gas, brake = float(keys[pygame.K_UP]), 0.8 * float(keys[pygame.K_DOWN])
    if env.action_space.shape == (2,):  # the kinematic car with throttle: [steer, throttle]
        return np.array([right * steer, gas - float(keys[pygame.K_DOWN])], np.float32)
    if env.config.car.actions == "discrete":
        return (
            GAS
            if gas
            else BRAKE
            if brake
            else RIGHT
            if steer > 0
            else LEFT
            if steer < 0
            else NOTHING
        )
    return np.array([right * steer, gas, brake], np.float32)


def _single_track_action(
    env: TinyRaceEnv, kind: str, steer: float, up: Any, down: Any
) -> np.ndarray:
    """Right/left at full lock (or full steering rate); up: half the top speed (or full
    acceleration), down: a stop (or full braking), neither: the speed held (or coasting)."""
    facts, space = env.car_facts, env.action_space
    assert isinstance(space, spaces.Box)  # the single-track car's actions
    right = 1.0 if facts.steer_per_rad > 0 else -1.0  # the action's sign of a right turn
    if kind == "angle_speed":
        speed = facts.top_speed / 2 if up else 0.0 if down else env.car.speed
        action = np.array([steer * right * facts.steer_lock, speed], np.float32)
    else:
        high = np.asarray(space.high, np.float32)
        action = np.array([steer * right * high[0], (float(up) - float(down)) * high[1]])
    clipped: np.ndarray = np.clip(action.astype(np.float32), space.low, space.high)
    return clipped
