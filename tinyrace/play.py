"""Driving by hand: arrow keys in a pygame window (``tinyrace play``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from tinyrace.actions import BRAKE, GAS, LEFT, NOTHING, RIGHT
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
    if env.action_space.shape == (1,):
        return np.array([steer], np.float32)
    gas, brake = float(keys[pygame.K_UP]), 0.8 * float(keys[pygame.K_DOWN])
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
    return np.array([steer, gas, brake], np.float32)
