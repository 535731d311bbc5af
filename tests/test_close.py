"""close(): callable twice, the env usable again afterwards, nothing left behind."""

from __future__ import annotations

import gc
import json
import os
import subprocess
import sys
import textwrap
import weakref
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.examples import TRACKS_DIR

ROOT = Path(__file__).resolve().parents[1]
TRACK = str(TRACKS_DIR / "carolo_cup")
MAKERS = {
    "procedural": lambda mode: gym.make("tinyrace/CarRacing-v0", render_mode=mode),
    "image": lambda mode: gym.make("tinyrace/TinyRace-v0", environment=TRACK, render_mode=mode),
}


@pytest.mark.parametrize("kind", list(MAKERS))
@pytest.mark.parametrize("mode", [None, "rgb_array", "state_pixels"])
def test_close_twice_then_reset_and_step_again(kind, mode):
    env = MAKERS[kind](mode)
    env.close()  # closing an env that never reset is fine too
    env.reset(seed=0)
    env.step(env.action_space.sample())
    env.close()
    env.close()
    observation, _ = env.reset(seed=0)
    assert env.observation_space.contains(observation)
    for _ in range(3):
        observation, reward, *_ = env.step(env.action_space.sample())
        assert env.observation_space.contains(observation)
        assert np.isfinite(reward)
    if mode is not None:
        assert isinstance(env.render(), np.ndarray)
    env.close()


HUMAN_SCRIPT = textwrap.dedent(
    """
    import json, sys
    import gymnasium as gym
    import pygame
    import tinyrace

    report = {}
    kinds = {"procedural": {"id": "tinyrace/CarRacing-v0"},
             "image": {"id": "tinyrace/TinyRace-v0", "environment": sys.argv[1],
                       "sim": {"render_realtime": False}}}
    for kind, kwargs in kinds.items():
        kwargs = dict(kwargs)
        env = gym.make(kwargs.pop("id"), render_mode="human", **kwargs)
        env.reset(seed=0)
        for _ in range(3):
            env.step(env.action_space.sample())
        shown = pygame.display.get_init() and pygame.display.get_surface() is not None
        env.close()
        after_close = pygame.display.get_init()
        env.close()
        env.reset(seed=1)                   # a closed env opens its window again
        env.step(env.action_space.sample())
        reopened = pygame.display.get_init()
        env.close()
        report[kind] = [shown, after_close, reopened, pygame.display.get_init()]
    print(json.dumps(report))
    """
)


def run_isolated(script: str, cwd: Path, *args: str) -> subprocess.CompletedProcess:
    """``script`` in a fresh interpreter: dummy SDL display, an empty cwd and HOME."""
    home = cwd / "home"
    home.mkdir()
    env = {
        **os.environ,
        "SDL_VIDEODRIVER": "dummy",
        "SDL_AUDIODRIVER": "dummy",
        "HOME": str(home),
        "PYTHONPATH": str(ROOT),
    }
    return subprocess.run(
        [sys.executable, "-c", script, *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def test_human_window_closes_and_reopens(tmp_path):
    done = run_isolated(HUMAN_SCRIPT, tmp_path, TRACK)
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout.strip().splitlines()[-1])
    for kind, (shown, after_close, reopened, at_end) in report.items():
        assert shown, f"{kind}: no window was opened"
        assert not after_close, f"{kind}: close() left pygame's display running"
        assert reopened, f"{kind}: reset after close() did not show the window again"
        assert not at_end, kind


RUN_SCRIPT = textwrap.dedent(
    """
    import sys
    import gymnasium as gym
    import tinyrace
    for kwargs in ({"id": "tinyrace/CarRacing-v0"},
                   {"id": "tinyrace/TinyRace-v0", "environment": sys.argv[1],
                    "sim": {"render_realtime": False}}):
        for mode in (None, "rgb_array", "state_pixels", "human"):
            args = dict(kwargs)
            env = gym.make(args.pop("id"), render_mode=mode, **args)
            env.reset(seed=0)
            for _ in range(5):
                env.step(env.action_space.sample())
            env.render() if mode else None
            env.close()
    print("ok")
    """
)


def test_nothing_is_written(tmp_path):
    """Running every render mode writes no file: not in the cwd, not in HOME."""
    done = run_isolated(RUN_SCRIPT, tmp_path, TRACK)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().endswith("ok")
    written = [p for p in tmp_path.rglob("*") if p != tmp_path / "home"]
    assert written == [], written


def space_counts(episode) -> tuple[int, int, int]:
    """(bodies, shapes beyond the track's sensors, constraints) of an episode's pymunk space.

    Procedural tracks differ in tile count per seed; an image track's obstacle cells are fixed.
    """
    bodies, shapes, constraints = episode.world.counts
    track = episode.track
    test = track.obstacle_test
    sensors = len(track.tiles) if track.tiles is not None else len(test.cells) if test else 0
    return bodies, shapes - sensors, constraints


@pytest.mark.parametrize("kind", list(MAKERS))
def test_resets_build_the_same_space_and_free_the_old_ones(kind):
    """50 resets (the soak test's check in small, see benchmarks/soak.py)."""
    env = MAKERS[kind](None)
    env.action_space.seed(0)
    counts, spaces = set(), []
    for seed in range(50):
        env.reset(seed=seed)
        episode = env.unwrapped.episode
        at_reset = episode.world.counts
        counts.add(space_counts(episode))
        spaces.append(weakref.ref(episode.world.space))
        for _ in range(5):
            env.step(env.action_space.sample())
        assert episode.world.counts == at_reset  # steps add and remove nothing
    assert len(counts) == 1, counts
    bodies, shapes, constraints = counts.pop()
    assert bodies == 1 and constraints == 0 and shapes >= 1  # the car, its shapes
    gc.collect()
    # one space alive: procedural tracks build one per reset and free the old ones, image
    # tracks keep one per track and swap only the car
    assert len({id(ref()) for ref in spaces if ref() is not None}) == 1
    env.close()
